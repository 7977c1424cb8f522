"""The default mission's planned trajectory beside the SAR image of its first landmark's
aperture, with the detections marked.

    pip install ./python matplotlib
    python python/examples/trajectory_and_image.py --scene radar-sim/scenes/default.toml

The radar chain covers the first `--horizon-s` seconds of the mission (20 s: two landmarks);
the whole 300 s mission takes minutes and gigabytes of IQ.
"""

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import cellsar  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=None, help="scene file (default: the default scene)")
    parser.add_argument("--horizon-s", type=float, default=20.0, help="mission length for the radar")
    parser.add_argument("--out", default="trajectory_and_image.png", help="the figure (PNG)")
    args = parser.parse_args()

    full = cellsar.plan(cellsar.Mission.default(30.0))
    short_mission = cellsar.Mission.default(30.0, horizon_s=args.horizon_s)
    short = cellsar.plan(short_mission)
    result = cellsar.radar.process(cellsar.radar.simulate(short_mission, short, args.scene))

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 5))
    landmarks = np.array([[w["x_m"], w["y_m"]] for w in full.mission.landmarks])
    left.plot(full.x_m, full.y_m, "-", lw=1.2, label="UAV")
    left.plot(full.xc_m, full.yc_m, ".", ms=2, label="sensing centre")
    left.plot(landmarks[:, 0], landmarks[:, 1], "k^", ms=5, label="landmarks")
    left.set_aspect("equal")
    left.set_xlabel("x (m)")
    left.set_ylabel("y (m)")
    left.set_title(f"{full.summary['mission']}: {full.summary['energy_j'] / 1e3:.2f} kJ")
    left.legend(loc="best", fontsize=8)

    image, x, y = result.images[0], result.x_m[0], result.y_m[0]
    db = 10 * np.log10(np.maximum(image / image.max(), 1e-6))
    extent = [x[0], x[-1], y[0], y[-1]]
    shown = right.imshow(db, origin="lower", extent=extent, vmin=-40, vmax=0, cmap="gray")
    det = result.detections[result.detections["aperture"] == 0]
    right.plot(det["x_m"], det["y_m"], "r+", ms=12, label="detections")
    right.set_xlabel("x (m)")
    right.set_ylabel("y (m)")
    right.set_title("aperture 0: multilook image (dB)")
    right.legend(loc="upper right", fontsize=8)
    fig.colorbar(shown, ax=right, shrink=0.8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}; metrics: pd = {result.metrics['pd']}")


if __name__ == "__main__":
    main()
