//! UAV tracks (3-D positions at any time), the pulse plan along a track, and the apertures of a
//! mission (one per landmark window, split into coherent looks of T_d).

use serde::{Deserialize, Serialize};

use crate::error::{RadarError, Result};
use crate::waveform::{Numerology, C_MPS};

/// A UAV track: position, velocity and heading at any time.
pub trait Track: Sync {
    /// Position (x, y, z), m, at time `t_s`.
    fn position_m(&self, t_s: f64) -> [f64; 3];
    /// Velocity (x, y, z), m/s, at time `t_s`.
    fn velocity_mps(&self, t_s: f64) -> [f64; 3];
    /// Unit heading (x, y) at time `t_s` (kept through hover).
    fn heading(&self, t_s: f64) -> [f64; 2];
}

/// A straight track at constant velocity (tests and benchmarks).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinearTrack {
    /// Position at t = 0, m.
    pub start_m: [f64; 3],
    /// Constant velocity, m/s (horizontal part non-zero).
    pub velocity_mps: [f64; 3],
}

impl LinearTrack {
    /// A right-looking UAV at altitude H flying `heading_deg` (from +x, counter-clockwise) at
    /// `speed_mps` whose sensing centre (H tan η right of the track) passes `target_m` at
    /// time `t_mid_s`.
    pub fn through(
        params: &planner::Params,
        target_m: [f64; 2],
        heading_deg: f64,
        speed_mps: f64,
        t_mid_s: f64,
    ) -> Self {
        let a = heading_deg.to_radians();
        let h = [a.cos(), a.sin()];
        let right = [h[1], -h[0]];
        let off = params.centre_offset_m();
        let at_mid = [target_m[0] - off * right[0], target_m[1] - off * right[1]];
        Self {
            start_m: [
                at_mid[0] - h[0] * speed_mps * t_mid_s,
                at_mid[1] - h[1] * speed_mps * t_mid_s,
                params.altitude_m,
            ],
            velocity_mps: [h[0] * speed_mps, h[1] * speed_mps, 0.0],
        }
    }
}

impl Track for LinearTrack {
    fn position_m(&self, t_s: f64) -> [f64; 3] {
        [
            self.start_m[0] + self.velocity_mps[0] * t_s,
            self.start_m[1] + self.velocity_mps[1] * t_s,
            self.start_m[2] + self.velocity_mps[2] * t_s,
        ]
    }
    fn velocity_mps(&self, _t_s: f64) -> [f64; 3] {
        self.velocity_mps
    }
    fn heading(&self, _t_s: f64) -> [f64; 2] {
        let v = self.velocity_mps;
        let n = v[0].hypot(v[1]);
        if n > 0.0 {
            [v[0] / n, v[1] / n]
        } else {
            [1.0, 0.0]
        }
    }
}

/// The planner's trajectory flown at altitude H, or at a planned altitude per slot H_t (a
/// mission with `altitude = "free"`): linear between slot positions, the altitude too.
#[derive(Debug, Clone)]
pub struct PlannedTrack {
    traj: planner::Trajectory,
    /// The altitude at t = 0 (the mission's `altitude_m`), m; the whole track's when
    /// `altitudes_m` is `None`.
    altitude_m: f64,
    /// H_t of slots 1..=N (at t = t δ), m.
    altitudes_m: Option<Vec<f64>>,
    headings_rad: Vec<f64>,
}

impl PlannedTrack {
    /// Wraps a planner trajectory flown at `altitude_m`.
    pub fn new(traj: planner::Trajectory, altitude_m: f64) -> Self {
        let headings_rad = traj.headings_rad();
        Self {
            traj,
            altitude_m,
            altitudes_m: None,
            headings_rad,
        }
    }

    /// Wraps a planner trajectory flown from `start_altitude_m` at t = 0 through the altitude
    /// `altitudes_m[t − 1]` at the end of slot t (a plan's
    /// [`PlanResult::altitudes_m`](planner::PlanResult::altitudes_m)), linear in between like
    /// the horizontal position; the vertical velocity is that slot's climb rate.
    ///
    /// One altitude per slot, each finite and > 0 ([`RadarError::Config`] naming
    /// `altitudes_m` otherwise).
    pub fn with_altitudes(
        traj: planner::Trajectory,
        start_altitude_m: f64,
        altitudes_m: Vec<f64>,
    ) -> Result<Self> {
        if altitudes_m.len() != traj.slots() {
            return Err(RadarError::config(
                "altitudes_m",
                format!(
                    "{} altitudes for a trajectory of {} slots",
                    altitudes_m.len(),
                    traj.slots()
                ),
            ));
        }
        if let Some((i, h)) = std::iter::once(start_altitude_m)
            .chain(altitudes_m.iter().copied())
            .enumerate()
            .find(|(_, h)| !(h.is_finite() && *h > 0.0))
        {
            return Err(RadarError::config(
                "altitudes_m",
                format!("slot {i}: altitude {h} m is not a finite number > 0"),
            ));
        }
        let mut track = Self::new(traj, start_altitude_m);
        track.altitudes_m = Some(altitudes_m);
        Ok(track)
    }

    /// The wrapped trajectory.
    pub fn trajectory(&self) -> &planner::Trajectory {
        &self.traj
    }

    /// The planned altitude per slot, when the track follows one.
    pub fn altitudes_m(&self) -> Option<&[f64]> {
        self.altitudes_m.as_deref()
    }

    fn slot_of(&self, t_s: f64) -> usize {
        let n = self.traj.slots().max(1);
        ((t_s / self.traj.slot_s).ceil().max(1.0) as usize).min(n)
    }

    /// The altitude at the end of slot `t` (t = 0: the start), m.
    fn altitude_after(&self, profile: &[f64], t: usize) -> f64 {
        match t {
            0 => self.altitude_m,
            _ => profile.get(t - 1).copied().unwrap_or(self.altitude_m),
        }
    }

    /// The altitude at `t_s`, m: as [`planner::Trajectory::position_at`] interpolates.
    fn altitude_at(&self, t_s: f64) -> f64 {
        let Some(profile) = self.altitudes_m.as_deref() else {
            return self.altitude_m;
        };
        let n = profile.len();
        if n == 0 || !t_s.is_finite() || t_s <= 0.0 {
            return self.altitude_m;
        }
        let x = t_s / self.traj.slot_s;
        if x >= n as f64 {
            return self.altitude_after(profile, n);
        }
        let t = x.floor() as usize;
        let f = x - t as f64;
        let a = self.altitude_after(profile, t);
        let b = self.altitude_after(profile, t + 1);
        a + (b - a) * f
    }

    /// The climb rate of the slot holding `t_s` (as [`planner::Trajectory::velocity_at`]), m/s.
    fn climb_at(&self, t_s: f64) -> f64 {
        let Some(profile) = self.altitudes_m.as_deref() else {
            return 0.0;
        };
        if profile.is_empty() {
            return 0.0;
        }
        let t = ((t_s / self.traj.slot_s).ceil() as usize).clamp(1, profile.len());
        (self.altitude_after(profile, t) - self.altitude_after(profile, t - 1)) / self.traj.slot_s
    }
}

impl Track for PlannedTrack {
    fn position_m(&self, t_s: f64) -> [f64; 3] {
        let p = self.traj.position_at(t_s);
        [p[0], p[1], self.altitude_at(t_s)]
    }
    fn velocity_mps(&self, t_s: f64) -> [f64; 3] {
        let v = self.traj.velocity_at(t_s);
        [v[0], v[1], self.climb_at(t_s)]
    }
    fn heading(&self, t_s: f64) -> [f64; 2] {
        let a = self
            .headings_rad
            .get(self.slot_of(t_s) - 1)
            .copied()
            .unwrap_or(0.0);
        [a.cos(), a.sin()]
    }
}

/// Everything the processor must know about one recorded pulse.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PulseMeta {
    /// Global pulse index in the recording.
    pub index: usize,
    /// Aperture this pulse belongs to.
    pub aperture: usize,
    /// Look (coherent sub-aperture) within the aperture.
    pub look: usize,
    /// Reference (centre) time of the pulse, s.
    pub t_s: f64,
    /// Index of the first BS symbol used as this pulse.
    pub symbol: u64,
    /// UAV position at `t_s` (navigation), m.
    pub pos_m: [f64; 3],
    /// UAV velocity at `t_s`, m/s.
    pub vel_mps: [f64; 3],
    /// UAV unit heading at `t_s`.
    pub heading: [f64; 2],
    /// Receiver window delay D: the FFT window of symbol m starts D samples after the symbol's
    /// useful part leaves the BS (the UE's sync to the direct path, floor(R_d f_s / c)).
    pub window_delay_samples: i64,
}

/// Distance between two 3-D points, m.
pub fn dist3(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// One aperture: the pulses of one landmark window, split into looks of `look_s`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Aperture {
    /// 0-based aperture index.
    pub index: usize,
    /// The landmark sensed in this window, if any.
    pub landmark: Option<usize>,
    /// Image centre (the landmark), m.
    pub centre_m: [f64; 2],
    /// Window start, s.
    pub t_start_s: f64,
    /// Window end, s.
    pub t_end_s: f64,
    /// Coherent look length, s.
    pub look_s: f64,
    /// Number of looks.
    pub looks: usize,
    /// Pulses per look.
    pub pulses_per_look: usize,
    /// Global index of the first pulse.
    pub first_pulse: usize,
}

impl Aperture {
    /// Total pulses (saturating: the IQ budget refuses such an aperture by its size).
    pub fn pulses(&self) -> usize {
        self.looks.saturating_mul(self.pulses_per_look)
    }
}

/// Splits the windows `(centre, landmark, t_start, t_end)` into apertures of whole looks.
pub fn plan_apertures(
    windows: &[([f64; 2], Option<usize>, f64, f64)],
    look_s: f64,
    prf_hz: f64,
) -> Result<Vec<Aperture>> {
    let pulses_per_look = (look_s * prf_hz).round() as usize;
    if pulses_per_look < 2 {
        return Err(RadarError::config(
            "processing.look_s",
            format!("a look of {look_s} s at {prf_hz} Hz holds fewer than 2 pulses"),
        ));
    }
    let mut out = Vec::new();
    let mut first = 0;
    for (i, &(centre, lm, t0, t1)) in windows.iter().enumerate() {
        let looks = ((t1 - t0) / look_s + 1e-9).floor() as usize;
        if looks == 0 {
            return Err(RadarError::Mismatch(format!(
                "window {i} ({t0} s, {t1} s] is shorter than one look of {look_s} s: empty aperture"
            )));
        }
        // centre the looks in the window
        let used = looks as f64 * look_s;
        let start = t0 + 0.5 * ((t1 - t0) - used);
        out.push(Aperture {
            index: i,
            landmark: lm,
            centre_m: centre,
            t_start_s: start,
            t_end_s: start + used,
            look_s,
            looks,
            pulses_per_look,
            first_pulse: first,
        });
        first += looks * pulses_per_look;
    }
    Ok(out)
}

/// The pulses of `ap` along `track`: look l, pulse i at t = t_start + l T + (i + ½)/PRF (under
/// NR: at the centre of the pulse slot's symbols of that PRF period, see
/// [`Numerology::pulse_symbol`]).
pub fn plan_pulses(
    track: &dyn Track,
    num: &Numerology,
    bs_m: [f64; 3],
    ap: &Aperture,
    prf_hz: f64,
) -> Vec<PulseMeta> {
    let fs = num.sample_rate_hz();
    let mut out = Vec::with_capacity(ap.pulses());
    for l in 0..ap.looks {
        for i in 0..ap.pulses_per_look {
            let t = ap.t_start_s + l as f64 * ap.look_s + (i as f64 + 0.5) / prf_hz;
            let (symbol, t) = num.pulse_symbol(t);
            let pos = track.position_m(t);
            let rd = dist3(pos, bs_m);
            out.push(PulseMeta {
                index: ap.first_pulse + out.len(),
                aperture: ap.index,
                look: l,
                t_s: t,
                symbol,
                pos_m: pos,
                vel_mps: track.velocity_mps(t),
                heading: track.heading(t),
                window_delay_samples: (rd * fs / C_MPS).floor() as i64,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn apertures_are_whole_looks_centred_in_windows() {
        let w = [
            ([0.0, 0.0], Some(0), 0.0, 10.0),
            ([0.0, 30.0], Some(1), 10.0, 20.5),
        ];
        let a = plan_apertures(&w, 1.0, 100.0).unwrap();
        assert_eq!(a[0].looks, 10);
        assert_eq!(a[1].looks, 10);
        assert!((a[1].t_start_s - 10.25).abs() < 1e-12);
        assert_eq!(a[1].first_pulse, 1000);
        let e = plan_apertures(&[([0.0, 0.0], None, 0.0, 0.5)], 1.0, 100.0).unwrap_err();
        assert!(e.to_string().contains("empty aperture"), "{e}");
    }

    #[test]
    fn planned_track_interpolates() {
        let traj = planner::Trajectory {
            slot_s: 0.5,
            start_m: [0.0, 0.0],
            pos_m: vec![[0.0, 10.0], [0.0, 20.0]],
        };
        let t = PlannedTrack::new(traj, 1000.0);
        assert_eq!(t.position_m(0.25), [0.0, 5.0, 1000.0]);
        assert_eq!(t.velocity_mps(0.7), [0.0, 20.0, 0.0]);
        let h = t.heading(0.7);
        assert!(h[0].abs() < 1e-12 && (h[1] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn planned_track_follows_the_altitude_profile() {
        let traj = planner::Trajectory {
            slot_s: 0.5,
            start_m: [0.0, 0.0],
            pos_m: vec![[0.0, 10.0], [0.0, 20.0], [5.0, 20.0]],
        };
        let t = PlannedTrack::with_altitudes(traj.clone(), 1000.0, vec![1010.0, 1010.0, 990.0])
            .unwrap();
        assert_eq!(t.position_m(0.0), [0.0, 0.0, 1000.0]);
        assert_eq!(t.position_m(0.25), [0.0, 5.0, 1005.0]);
        assert_eq!(t.position_m(0.75), [0.0, 15.0, 1010.0]);
        assert_eq!(t.position_m(1.25), [2.5, 20.0, 1000.0]);
        assert_eq!(t.position_m(9.0), [5.0, 20.0, 990.0]);
        assert_eq!(t.velocity_mps(0.1), [0.0, 20.0, 20.0]);
        assert_eq!(t.velocity_mps(0.7), [0.0, 20.0, 0.0]);
        assert_eq!(t.velocity_mps(1.2), [10.0, 0.0, -40.0]);
        // a constant profile at the start altitude is today's track, bit for bit
        let flat = PlannedTrack::with_altitudes(traj.clone(), 1000.0, vec![1000.0; 3]).unwrap();
        let fixed = PlannedTrack::new(traj.clone(), 1000.0);
        for i in 0..=400 {
            let ts = -0.1 + i as f64 * 0.005;
            assert_eq!(flat.position_m(ts), fixed.position_m(ts), "{ts}");
            assert_eq!(flat.velocity_mps(ts), fixed.velocity_mps(ts), "{ts}");
            assert_eq!(flat.heading(ts), fixed.heading(ts), "{ts}");
        }
        let e = PlannedTrack::with_altitudes(traj.clone(), 1000.0, vec![1000.0; 2]).unwrap_err();
        assert!(e.to_string().contains("altitudes_m"), "{e}");
        let e =
            PlannedTrack::with_altitudes(traj, 1000.0, vec![1000.0, f64::NAN, 1.0]).unwrap_err();
        assert!(e.to_string().contains("slot 2"), "{e}");
    }
}
