//! Flights that meet their mission by construction, shared by the integration tests of the
//! energy bound and of the best effort: a random flight within the speed and acceleration
//! limits, and a mission whose landmarks are the flight's own sensing centres.

use planner::{evaluate, LandmarkWindow, LandmarksSpec, Mission, Params, Trajectory};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// A flight of `n` slots from `start_m` at the start velocity `v0`, its slot-average velocities
/// changing by less than a_max δ/2 into the first slot (what constant acceleration from v₀ gives)
/// and a_max δ after, its speeds within [v_lo, v_hi].
pub fn random_flight(
    p: &Params,
    n: usize,
    v0: [f64; 2],
    (v_lo, v_hi): (f64, f64),
    rng: &mut ChaCha8Rng,
) -> Trajectory {
    let delta = p.slot_s;
    let a = 0.98 * p.max_accel_mps2;
    let mut v = v0;
    let mut q = p.start_m;
    let mut pos = Vec::with_capacity(n);
    for t in 1..=n {
        let step = if t == 1 { 0.5 * a * delta } else { a * delta };
        let (r, phi) = (
            step * rng.gen::<f64>().sqrt(),
            rng.gen_range(0.0..std::f64::consts::TAU),
        );
        let w = [v[0] + r * phi.cos(), v[1] + r * phi.sin()];
        let speed = w[0].hypot(w[1]);
        if (v_lo..=v_hi).contains(&speed) {
            v = w;
        }
        q = [q[0] + v[0] * delta, q[1] + v[1] * delta];
        pos.push(q);
    }
    Trajectory {
        slot_s: delta,
        start_m: p.start_m,
        pos_m: pos,
    }
}

/// A mission whose landmarks are `flight`'s own sensing centres: one window of `hold` slots
/// every `every` slots, the landmark at the centre of the window's middle slot (the flight then
/// has it in view wherever its centre stays within r_s).
pub fn mission_of(p: &Params, flight: &Trajectory, every: usize, hold: usize) -> Mission {
    let n = flight.slots();
    let mut probe_p = p.clone();
    probe_p.horizon_s = n as f64 * p.slot_s;
    let probe = Mission::new(
        "probe",
        probe_p.clone(),
        &LandmarksSpec {
            points: Some(vec![LandmarkWindow {
                x_m: 0.0,
                y_m: 0.0,
                from_s: 0.0,
                to_s: p.slot_s,
            }]),
            ..Default::default()
        },
    )
    .unwrap();
    let centres: Vec<[f64; 2]> = evaluate(&probe, flight)
        .slots
        .iter()
        .map(|s| s.centre_m)
        .collect();
    let mut points = Vec::new();
    let mut start = every / 2;
    while start + hold <= n {
        let mid = start + hold / 2;
        let c = centres[mid];
        points.push(LandmarkWindow {
            x_m: c[0],
            y_m: c[1],
            from_s: start as f64 * p.slot_s,
            to_s: (start + hold) as f64 * p.slot_s,
        });
        start += every;
    }
    Mission::new(
        "constructed",
        probe_p,
        &LandmarksSpec {
            points: Some(points),
            ..Default::default()
        },
    )
    .unwrap()
}
