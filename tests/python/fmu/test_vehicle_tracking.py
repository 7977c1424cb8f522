"""Co-simulation: a tilt-limited point-mass vehicle follows the planner FMU's set-points over the
default mission, and can do so within a stated error only when the plan respects the vehicle's
acceleration limit (`dynamics = vehicle`).

The vehicle. A point mass in the horizontal plane whose acceleration is clipped to
A = g tan 30 deg (a multirotor tilts its thrust to accelerate; 30 deg is ArduPilot's default
lean-angle limit, the default of the FMU's `max_accel_mps2`), integrated exactly for an
acceleration held over each step of H = 0.125 s (a quarter of the default slot: the slot
middles, where the feed-forward changes, lie on the step grid). Its controller commands

    a = a_ff + kp (s - p) + kd (v_s - v),   clipped to |a| <= A,

a feed-forward acceleration plus a critically damped PD loop (omega = 2 rad/s) around a smooth
reference (s, v_s) that it builds from the FMU's outputs alone.

The reference. The plan is a polyline: the FMU's position r(t) (`x_m`, `y_m`) is linear within
each slot of length delta, with the slot's velocity v_k (`speed_mps`, `heading_rad`); its
`commanded_accel_*` output is a_k = (v_k - v_{k-1}) / delta, and a_1 = (v_1 - v_0) / (delta / 2)
from the start velocity v_0, the velocity at t = 0, half a slot before slot 1's middle. No
vehicle can follow the velocity
steps at the slot ends, but one that accelerates with a_{k+1} from the middle of slot k to the
middle of slot k+1 flies the quadratic spline s whose velocity v_s is v_k at every slot middle,
linear in between. That spline meets r at every slot middle, and between two middles
s - r = a_{k+1} d^2 / 2, d the time to the nearer middle (at most delta/2). So

    |s(t) - r(t)| <= max_k |a_k| delta^2 / 8,

and a vehicle on s needs |a_ff| = |a_{k+1}| only. To know a_{k+1} half a slot early, the master
runs the planner FMU delta/2 + H/2 ahead of the vehicle (a set-point preview, as trajectory
set-points with a feed-forward acceleration give a flight controller) and buffers its outputs:
the accelerations come from the FMU now, r(t) from the buffer.

The bound. Under `dynamics = vehicle` every |a_k| <= A (1 + 1e-6) (asserted, on the FMU's
output), so the feed-forward is never clipped; the vehicle, started on s (with the plan's start
velocity v_0 at q_0 + a_1 delta^2/8: s accelerates with a_1 from t = 0 to slot 1's middle and
meets r there), stays on s up to rounding (the feed-forward changes only
at slot middles, which lie on the step grid, so the held acceleration is exact), and

    max_t |p(t) - r(t)| <= A delta^2 / 8 = 0.177 m   (delta = 0.5 s),

asserted with 1e-6 relative slack for the planner's tolerance on A and 1e-6 m for rounding.
Under `dynamics = paper` the same mission's plan commands up to about 41.5 m/s^2; the clipped
vehicle falls behind and stays far outside the bound (asserted: more than 10 times it), so the
test fails if the FMU did not apply the limits.

Each dynamics is flown with the FMU's default plan (the general resolution cell as a best
effort: under `paper` it commands up to about 41.5 m/s^2 and the vehicle ends up tens of metres
off, asserted > 10 times the bound) and with the least-energy plan (`resolution = paper`: under
`paper` it exceeds A in a few slots only, up to about 6.9 m/s^2, and the error exceeds the bound
by about 30 %, asserted > the bound). FMI 3.0. The best effort takes most of the run time: about
6 s per plan in the debug build the test suite packages, the least-energy plan under 0.5 s.
"""

import math

import pytest

from conftest import Fmu

G_MPS2 = 9.80665
A_MAX_MPS2 = G_MPS2 * math.tan(math.radians(30.0))
H_S = 0.125
OMEGA_RPS = 2.0
KP, KD = OMEGA_RPS ** 2, 2.0 * OMEGA_RPS
OUTPUTS = ["x_m", "y_m", "speed_mps", "heading_rad", "commanded_accel_x_mps2",
           "commanded_accel_y_mps2", "commanded_accel_mps2"]


def fly(dynamics, resolution):
    """Runs the co-simulation of the plan for `dynamics` and `resolution` (the FMU's parameters);
    returns a dict of what was measured."""
    f = Fmu("fmi3", name=f"tracking-{dynamics}-{resolution}")
    assert f.instantiate()
    f.init(strings={"dynamics": dynamics, "resolution": resolution})
    delta = f.get("slot_s")
    horizon = f.get("horizon_s")
    assert f.get("max_accel_mps2") == pytest.approx(A_MAX_MPS2, rel=1e-12)
    vrs = [f.vr(n) for n in OUTPUTS]
    # the FMU steps by H/2 and runs `lead` of its steps ahead of the vehicle
    half = H_S / 2
    lead = round((delta / 2 + H_S / 2) / half)
    assert math.isclose(lead * half, delta / 2 + H_S / 2)
    samples = []  # (x, y, vx, vy, ax, ay, |a|) at FMU times i * half

    def sample():
        x, y, speed, heading, ax, ay, a = f.fmu.getFloat64(vrs)
        samples.append((x, y, speed * math.cos(heading), speed * math.sin(heading), ax, ay, a))

    sample()
    steps = round(horizon / half)
    for i in range(lead):
        f.step(half, t=i * half)
        sample()

    def reference(j):
        """(s, v_s, a_ff, r) at vehicle time t = j H, each (x, y), from the buffer and the
        preview."""
        t = j * H_S
        lam = t + lead * half
        r = samples[2 * j][:2]
        _, _, vx, vy, ax, ay, _ = samples[2 * j + lead]
        slot_end = math.ceil(lam / delta - 1e-9) * delta
        mid_next = slot_end - delta / 2  # middle of the slot the preview is in
        d = min(t - (mid_next - delta), mid_next - t)
        s = (r[0] + ax * d * d / 2, r[1] + ay * d * d / 2)
        v_s = (vx - ax * (mid_next - t), vy - ay * (mid_next - t))
        return s, v_s, (ax, ay), r

    s, v_s, _, _ = reference(0)
    (px, py), (vx, vy) = s, v_s
    worst_m = worst_spline_m = 0.0
    clipped = 0
    j = 0
    while 2 * j + lead <= steps:
        s, v_s, a_ff, r = reference(j)
        worst_m = max(worst_m, math.hypot(px - r[0], py - r[1]))
        worst_spline_m = max(worst_spline_m, math.hypot(px - s[0], py - s[1]))
        if 2 * j + lead == steps:
            break
        ax = a_ff[0] + KP * (s[0] - px) + KD * (v_s[0] - vx)
        ay = a_ff[1] + KP * (s[1] - py) + KD * (v_s[1] - vy)
        norm = math.hypot(ax, ay)
        if norm > A_MAX_MPS2:
            ax, ay = ax * A_MAX_MPS2 / norm, ay * A_MAX_MPS2 / norm
            clipped += norm > A_MAX_MPS2 * (1 + 1e-6)
        px, py = px + vx * H_S + ax * H_S * H_S / 2, py + vy * H_S + ay * H_S * H_S / 2
        vx, vy = vx + ax * H_S, vy + ay * H_S
        # two FMU steps per vehicle step keep it `lead` half-steps ahead
        for _ in range(2):
            if len(samples) <= steps:
                f.step(half, t=(len(samples) - 1) * half)
                sample()
        j += 1
    f.fmu.terminate()
    f.free()
    peak = max(s[6] for s in samples)
    return {"delta": delta, "worst_m": worst_m, "worst_spline_m": worst_spline_m,
            "peak_accel_mps2": peak, "clipped_steps": clipped, "flown_s": j * H_S,
            "horizon_s": horizon}


def bound_m(delta):
    """A delta^2 / 8: the spline's largest distance from the plan's polyline (module docstring)."""
    return A_MAX_MPS2 * delta * delta / 8


RESOLUTIONS = ["general", "paper"]


@pytest.mark.parametrize("resolution", RESOLUTIONS)
def test_a_tilt_limited_vehicle_tracks_the_vehicle_plan_within_the_bound(resolution):
    m = fly("vehicle", resolution)
    bound = bound_m(m["delta"])
    assert m["flown_s"] >= m["horizon_s"] - m["delta"], m
    assert m["peak_accel_mps2"] <= A_MAX_MPS2 * (1 + 1e-6), m
    assert m["clipped_steps"] == 0, m
    assert m["worst_spline_m"] <= 1e-6, m
    assert m["worst_m"] <= bound * (1 + 1e-6) + 1e-6, m
    print(f"vehicle, resolution {resolution}: tracking error {m['worst_m']:.4f} m "
          f"(bound {bound:.4f} m), peak commanded acceleration {m['peak_accel_mps2']:.4f} m/s2")


@pytest.mark.parametrize("resolution,factor", [("general", 10.0), ("paper", 1.0)])
def test_the_same_vehicle_cannot_track_the_paper_plan(resolution, factor):
    m = fly("paper", resolution)
    bound = bound_m(m["delta"])
    assert m["flown_s"] >= m["horizon_s"] - m["delta"], m
    assert m["peak_accel_mps2"] > A_MAX_MPS2 * (1 + 1e-6), m
    assert m["clipped_steps"] > 0, m
    assert m["worst_m"] > factor * bound, m
    print(f"paper, resolution {resolution}: tracking error {m['worst_m']:.4f} m "
          f"(bound {bound:.4f} m), peak commanded acceleration {m['peak_accel_mps2']:.2f} m/s2")
