"""The radar chain on a short mission: the recording's IQ, and processing that detects every
landmark the plan looks at."""

import numpy as np
import pytest

import cellsar
from conftest import ROOT

SMALL_SCENE = ROOT / "tests" / "data" / "small-scene.toml"


@pytest.fixture(scope="module")
def short_run():
    mission = cellsar.Mission.default(30.0, horizon_s=20.0)
    plan = cellsar.plan(mission, resolution="paper")
    recording = cellsar.radar.simulate(mission, plan, SMALL_SCENE)
    return mission, plan, recording, cellsar.radar.process(recording)


def test_recording(short_run):
    mission, _, recording, _ = short_run
    assert len(recording.iq) == len(recording.apertures) == 2
    for iq, ap in zip(recording.iq, recording.apertures):
        assert iq.dtype == np.complex64
        assert iq.shape == (ap["looks"] * ap["pulses_per_look"], recording.samples_per_pulse)
        assert np.isfinite(iq).all() and np.abs(iq).max() > 0
    truth = recording.truth
    assert set(truth.dtype.names) >= {"id", "x_m", "y_m", "rcs_m2", "landmark"}
    landmarks = truth[truth["landmark"] >= 0]
    assert len(landmarks) == len(mission.landmarks)
    # a fixed mission is flown at altitude_m, pulse by pulse
    pulses = recording.pulses
    assert len(pulses) == sum(iq.shape[0] for iq in recording.iq)
    assert (pulses["z_m"] == mission.params["altitude_m"]).all()
    assert (pulses["vz_mps"] == 0.0).all()
    assert recording.iq[0] is recording.iq[0] or np.shares_memory(recording.iq[0], recording.iq[0])


def test_processing_detects_the_landmarks(short_run):
    mission, _, recording, result = short_run
    assert len(result.images) == 2
    for image, x, y, ap in zip(result.images, result.x_m, result.y_m, recording.apertures):
        assert image.ndim == 2 and image.shape == (len(y), len(x))
        assert image.dtype == np.float32
        # the image is centred on its aperture's landmark
        assert x[len(x) // 2] == pytest.approx(ap["centre_m"][0], abs=1.0)
        assert y[len(y) // 2] == pytest.approx(ap["centre_m"][1], abs=1.0)
    det = result.detections
    assert set(det.dtype.names) == {"aperture", "x_m", "y_m", "snr_db", "pixels", "truth_id", "error_m"}
    for k, lm in enumerate(mission.landmarks[:2]):
        mine = det[det["aperture"] == k]
        assert len(mine) >= 1
        best = mine[np.argmax(mine["snr_db"])]
        assert np.hypot(best["x_m"] - lm["x_m"], best["y_m"] - lm["y_m"]) < 2.0
    metrics = result.metrics
    assert metrics["pd"] == 1.0
    assert [a["landmark_detected"] for a in metrics["apertures"]] == [True, True]


def test_radar_errors(short_run):
    mission, plan, recording, _ = short_run
    with pytest.raises(cellsar.RadarError, match="fft_size"):
        cellsar.radar.simulate(mission, plan, {"radar": {"fft_size": -3}})
    with pytest.raises(cellsar.RadarError, match="nope.toml"):
        cellsar.radar.simulate(mission, plan, ROOT / "nope.toml")
    with pytest.raises(ValueError, match="another mission"):
        cellsar.radar.simulate(cellsar.Mission.default(60.0), plan, SMALL_SCENE)


def test_ground_clutter_is_synthesised_with_the_objects(short_run):
    """`[clutter]` reaches the recording as `cellsar-radar-sim simulate` synthesises it: the
    same objects and noise plus the ground's scatterers, which are not part of the truth;
    repeatable for one seed, another ground for another."""
    import tomllib

    mission, plan, recording, _ = short_run
    with open(SMALL_SCENE, "rb") as f:
        scene = tomllib.load(f)
    off = cellsar.radar.simulate(mission, plan, scene)
    for a, b in zip(off.iq, recording.iq):
        np.testing.assert_array_equal(a, b)
    clutter = {"enabled": True, "terrain": "farmland", "scatterers_per_cell": 1.0, "half_width_m": 20.0}
    on = cellsar.radar.simulate(mission, plan, {**scene, "clutter": clutter})
    again = cellsar.radar.simulate(mission, plan, {**scene, "clutter": clutter})
    other = cellsar.radar.simulate(mission, plan, {**scene, "clutter": {**clutter, "seed": 12}})
    assert len(on.truth) == len(off.truth)
    for k in range(len(on.iq)):
        ground = on.iq[k] - off.iq[k]
        # the ground adds power in every aperture (speckle: not one sample in a thousand is 0)
        assert np.mean(np.abs(ground) ** 2) > 0
        assert np.count_nonzero(ground) > 0.999 * ground.size
        np.testing.assert_array_equal(on.iq[k], again.iq[k])
        assert not np.array_equal(on.iq[k], other.iq[k])
