"""The radar chain: ``simulate`` what the UAV records along a plan, ``process`` it into SAR
images, detections and metrics (the steps of ``cellsar-radar-sim simulate`` and ``process``,
in memory)::

    recording = cellsar.radar.simulate(mission, plan, "radar-sim/scenes/default.toml")
    result = cellsar.radar.process(recording)
    image, x_m, y_m = result.images[0], result.x_m[0], result.y_m[0]

Both run with the GIL released.
"""

from ._cellsar import radar as _radar

Recording = _radar.Recording
Result = _radar.Result
simulate = _radar.simulate
process = _radar.process
check_scene = _radar.check_scene

__all__ = ["Recording", "Result", "simulate", "process", "check_scene"]
