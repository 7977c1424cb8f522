//! Landmark schedules: the paper's presets and explicit windows, resolved to one landmark per slot.
//!
//! Slot t (1-based) covers the time ((t−1)δ, tδ] and senses the landmark whose window
//! (from_s, to_s] holds tδ. A slot that no window holds carries no sensing constraint.

use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::params::bounds::{MAX_COORDINATE_M, MAX_LANDMARKS};

/// How long each preset landmark is held, s (20 slots of 0.5 s).
pub const PRESET_HOLD_S: f64 = 10.0;

/// The paper's landmark layouts (Section IV, figures 5–12).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// 15 landmarks up the y axis from the origin, then 15 along x at y = 14 s (figures 5–7, 12).
    Default,
    /// Two street blocks on a diagonal: up 15, right 15, up 15, right 15 (figure 8, T = 600 s).
    Staircase,
    /// A closed square loop of 60 landmarks, 15 per side (figure 9, T = 600 s).
    Square,
    /// The `default` layout with each gap drawn uniformly from [0, spacing_m] (figure 11).
    Random,
}

impl Preset {
    /// All presets, in the order above.
    pub const ALL: [Preset; 4] = [
        Preset::Default,
        Preset::Staircase,
        Preset::Square,
        Preset::Random,
    ];

    /// The name used in mission files.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Default => "default",
            Preset::Staircase => "staircase",
            Preset::Square => "square",
            Preset::Random => "random",
        }
    }

    /// The horizon the paper uses with this layout, s.
    pub fn natural_horizon_s(self) -> f64 {
        match self {
            Preset::Default | Preset::Random => 300.0,
            Preset::Staircase | Preset::Square => 600.0,
        }
    }

    /// The spacing the paper uses with this layout, m (for `random`: the largest gap).
    pub fn default_spacing_m(self) -> f64 {
        match self {
            Preset::Default => 30.0,
            Preset::Staircase => 30.0,
            Preset::Square => 100.0,
            Preset::Random => 100.0,
        }
    }

    /// The landmark positions of this layout, in sensing order.
    pub fn positions(self, spacing_m: f64, seed: u64) -> Vec<[f64; 2]> {
        let s = spacing_m;
        match self {
            Preset::Default => {
                let mut v: Vec<[f64; 2]> = (0..15).map(|k| [0.0, k as f64 * s]).collect();
                v.extend((1..=15).map(|j| [j as f64 * s, 14.0 * s]));
                v
            }
            Preset::Staircase => {
                let mut v: Vec<[f64; 2]> = (0..15).map(|k| [0.0, k as f64 * s]).collect();
                v.extend((1..=15).map(|j| [j as f64 * s, 14.0 * s]));
                v.extend((1..=15).map(|j| [15.0 * s, (14 + j) as f64 * s]));
                v.extend((1..=15).map(|j| [(15 + j) as f64 * s, 29.0 * s]));
                v
            }
            Preset::Square => {
                // Perimeter of the square with corners (0,0), (0,15s), (15s,15s), (15s,0),
                // walked from the origin up, right, down, left; 60 points 1 spacing apart.
                (0..60)
                    .map(|k| {
                        let side = k / 15;
                        let a = (k % 15) as f64 * s;
                        let l = 15.0 * s;
                        match side {
                            0 => [0.0, a],
                            1 => [a, l],
                            2 => [l, l - a],
                            _ => [l - a, 0.0],
                        }
                    })
                    .collect()
            }
            Preset::Random => {
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
                let mut v = Vec::with_capacity(30);
                let mut p = [0.0, 0.0];
                v.push(p);
                for _ in 1..15 {
                    p[1] += rng.gen_range(0.0..=s);
                    v.push(p);
                }
                for _ in 0..15 {
                    p[0] += rng.gen_range(0.0..=s);
                    v.push(p);
                }
                v
            }
        }
    }
}

/// One landmark with its sensing window (from_s, to_s].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LandmarkWindow {
    /// Ground x, m.
    pub x_m: f64,
    /// Ground y, m.
    pub y_m: f64,
    /// Window start (exclusive), s.
    pub from_s: f64,
    /// Window end (inclusive), s.
    pub to_s: f64,
}

impl LandmarkWindow {
    /// Position (x, y), m.
    pub fn pos_m(&self) -> [f64; 2] {
        [self.x_m, self.y_m]
    }
}

/// The `[landmarks]` table of a mission file.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LandmarksSpec {
    /// A paper layout; exclusive with `points`.
    pub preset: Option<Preset>,
    /// Spacing of a preset, m (for `random`: the largest gap). Default: the paper's for that preset.
    pub spacing_m: Option<f64>,
    /// Seed of the `random` preset.
    pub seed: Option<u64>,
    /// How long each preset landmark is held, s (default 10).
    pub hold_s: Option<f64>,
    /// Explicit landmarks with windows; exclusive with `preset`.
    pub points: Option<Vec<LandmarkWindow>>,
}

/// A schedule that cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ScheduleError {
    /// The `[landmarks]` table is malformed; `field` names the bad entry.
    #[error("landmarks.{field}: {reason}")]
    Invalid {
        /// The offending entry, e.g. `points[3].to_s`.
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// Two windows claim the same slot.
    #[error(
        "slot {slot} (t = {t_s} s) lies in the windows of landmarks {first} and {second}: contradictory windows"
    )]
    Overlap {
        /// 1-based slot.
        slot: usize,
        /// End time of the slot, s.
        t_s: f64,
        /// 0-based index of the first landmark.
        first: usize,
        /// 0-based index of the second landmark.
        second: usize,
    },
}

/// The resolved schedule: the landmarks and, for each slot t = 1..T_w, which one it senses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Schedule {
    /// All landmarks with their windows.
    pub landmarks: Vec<LandmarkWindow>,
    /// `slot_landmark[t-1]` is the 0-based landmark index sensed in slot t, if any.
    pub slot_landmark: Vec<Option<usize>>,
}

impl Schedule {
    /// The landmark position sensed in slot `t` (1-based), if any.
    pub fn target_m(&self, t: usize) -> Option<[f64; 2]> {
        let idx = (*self.slot_landmark.get(t.checked_sub(1)?)?)?;
        self.landmarks.get(idx).map(LandmarkWindow::pos_m)
    }

    /// Per-slot targets (index 0 is slot 1).
    pub fn targets_m(&self) -> Vec<Option<[f64; 2]>> {
        (1..=self.slot_landmark.len())
            .map(|t| self.target_m(t))
            .collect()
    }

    /// Builds the schedule for `slots` slots of `slot_s` seconds from explicit windows.
    pub fn from_windows(
        landmarks: Vec<LandmarkWindow>,
        slots: usize,
        slot_s: f64,
    ) -> Result<Self, ScheduleError> {
        let horizon_s = slots as f64 * slot_s;
        let eps = 1e-9 * horizon_s.max(1.0);
        if landmarks.len() > MAX_LANDMARKS {
            return Err(ScheduleError::Invalid {
                field: "points".into(),
                reason: format!(
                    "{} landmarks, more than the {MAX_LANDMARKS} a mission may have",
                    landmarks.len()
                ),
            });
        }
        for (i, w) in landmarks.iter().enumerate() {
            for (name, v) in [
                ("x_m", w.x_m),
                ("y_m", w.y_m),
                ("from_s", w.from_s),
                ("to_s", w.to_s),
            ] {
                if !v.is_finite() {
                    return Err(ScheduleError::Invalid {
                        field: format!("points[{i}].{name}"),
                        reason: format!("{v} is not a finite number"),
                    });
                }
            }
            for (name, v) in [("x_m", w.x_m), ("y_m", w.y_m)] {
                if v.abs() > MAX_COORDINATE_M {
                    return Err(ScheduleError::Invalid {
                        field: format!("points[{i}].{name}"),
                        reason: format!(
                            "{v} m is farther than {MAX_COORDINATE_M} m from the origin (the \
                             largest LTE cell radius)"
                        ),
                    });
                }
            }
            if w.to_s <= w.from_s {
                return Err(ScheduleError::Invalid {
                    field: format!("points[{i}].to_s"),
                    reason: format!(
                        "window ({}, {}] s is empty: to_s must exceed from_s",
                        w.from_s, w.to_s
                    ),
                });
            }
            if w.from_s < -eps {
                return Err(ScheduleError::Invalid {
                    field: format!("points[{i}].from_s"),
                    reason: format!("{} s is before the mission starts (0 s)", w.from_s),
                });
            }
            if w.to_s > horizon_s + eps {
                return Err(ScheduleError::Invalid {
                    field: format!("points[{i}].to_s"),
                    reason: format!(
                        "{} s is after the end of the horizon ({horizon_s} s)",
                        w.to_s
                    ),
                });
            }
        }
        // Each window visits only the slots near its own (one either side of the rounding),
        // and none after the first slot found claimed twice (an overlap there or later cannot
        // be the first): the work is the slots plus the landmarks, not their product. Windows
        // are taken in order, so a slot's first claimant is its lowest landmark and its second
        // the next.
        let mut slot_landmark: Vec<Option<usize>> = vec![None; slots];
        let mut holds = vec![false; landmarks.len()];
        let mut overlap: Option<(usize, usize, usize)> = None;
        for (i, w) in landmarks.iter().enumerate() {
            let from_t = ((w.from_s - eps) / slot_s).floor().max(1.0) as usize - 1;
            let to_t = (((w.to_s + eps) / slot_s).ceil() + 1.0).min(slots as f64) as usize;
            let end = overlap.map_or(to_t, |(t0, ..)| to_t.min(t0 + 1));
            let near = slot_landmark.iter_mut().enumerate().take(end).skip(from_t);
            for (t0, slot) in near {
                let t_s = (t0 + 1) as f64 * slot_s;
                if !(w.from_s < t_s - eps && t_s <= w.to_s + eps) {
                    continue;
                }
                holds[i] = true;
                match *slot {
                    None => *slot = Some(i),
                    Some(first) => {
                        if overlap.is_none_or(|(t, ..)| t0 < t) {
                            overlap = Some((t0, first, i));
                        }
                        break;
                    }
                }
            }
        }
        if let Some((t0, first, second)) = overlap {
            return Err(ScheduleError::Overlap {
                slot: t0 + 1,
                t_s: (t0 + 1) as f64 * slot_s,
                first,
                second,
            });
        }
        for (i, w) in landmarks.iter().enumerate() {
            if !holds[i] {
                return Err(ScheduleError::Invalid {
                    field: format!("points[{i}]"),
                    reason: format!(
                        "window ({}, {}] s holds no slot end (slots are {slot_s} s long)",
                        w.from_s, w.to_s
                    ),
                });
            }
        }
        Ok(Self {
            landmarks,
            slot_landmark,
        })
    }

    /// Builds the schedule of a spec. A preset's landmarks are held `hold_s` each, back to back
    /// from t = 0; those whose windows begin after the horizon are dropped.
    pub fn from_spec(
        spec: &LandmarksSpec,
        slots: usize,
        slot_s: f64,
    ) -> Result<Self, ScheduleError> {
        match (&spec.preset, &spec.points) {
            (Some(_), Some(_)) => Err(ScheduleError::Invalid {
                field: "preset".into(),
                reason: "give either `preset` or `points`, not both".into(),
            }),
            (None, None) => Err(ScheduleError::Invalid {
                field: "preset".into(),
                reason: "give either `preset = \"default\"|\"staircase\"|\"square\"|\"random\"` or `points = [...]`".into(),
            }),
            (None, Some(points)) => {
                for name in ["spacing_m", "seed", "hold_s"] {
                    let set = match name {
                        "spacing_m" => spec.spacing_m.is_some(),
                        "seed" => spec.seed.is_some(),
                        _ => spec.hold_s.is_some(),
                    };
                    if set {
                        return Err(ScheduleError::Invalid {
                            field: name.into(),
                            reason: "only applies to a preset, not to explicit `points`".into(),
                        });
                    }
                }
                Self::from_windows(points.clone(), slots, slot_s)
            }
            (Some(preset), None) => {
                let spacing = spec.spacing_m.unwrap_or(preset.default_spacing_m());
                if !(spacing.is_finite() && spacing >= 0.0) {
                    return Err(ScheduleError::Invalid {
                        field: "spacing_m".into(),
                        reason: format!("{spacing} must be a finite number >= 0"),
                    });
                }
                let hold = spec.hold_s.unwrap_or(PRESET_HOLD_S);
                if !(hold.is_finite() && hold > 0.0) {
                    return Err(ScheduleError::Invalid {
                        field: "hold_s".into(),
                        reason: format!("{hold} must be a finite number > 0"),
                    });
                }
                let horizon_s = slots as f64 * slot_s;
                let positions = preset.positions(spacing, spec.seed.unwrap_or(0));
                let extent = positions
                    .iter()
                    .flatten()
                    .fold(0.0_f64, |m, v| m.max(v.abs()));
                if extent > MAX_COORDINATE_M {
                    return Err(ScheduleError::Invalid {
                        field: "spacing_m".into(),
                        reason: format!(
                            "{spacing} m places landmarks {extent} m from the origin, farther \
                             than {MAX_COORDINATE_M} m (the largest LTE cell radius)"
                        ),
                    });
                }
                let windows = positions
                    .into_iter()
                    .enumerate()
                    .map(|(k, p)| LandmarkWindow {
                        x_m: p[0],
                        y_m: p[1],
                        from_s: k as f64 * hold,
                        to_s: ((k + 1) as f64 * hold).min(horizon_s),
                    })
                    .filter(|w| w.from_s < w.to_s - 1e-9 * horizon_s.max(1.0))
                    .collect();
                Self::from_windows(windows, slots, slot_s)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_preset_matches_spec() {
        let p = Preset::Default.positions(30.0, 0);
        assert_eq!(p.len(), 30);
        assert_eq!(p[0], [0.0, 0.0]);
        assert_eq!(p[14], [0.0, 420.0]);
        assert_eq!(p[15], [30.0, 420.0]);
        assert_eq!(p[29], [450.0, 420.0]);
    }

    #[test]
    fn default_schedule_windows() {
        let spec = LandmarksSpec {
            preset: Some(Preset::Default),
            spacing_m: Some(200.0),
            ..Default::default()
        };
        let s = Schedule::from_spec(&spec, 600, 0.5).unwrap();
        // slot 1 (t = 0.5 s) .. slot 20 (t = 10 s) sense landmark 0; slot 21 senses landmark 1
        assert_eq!(s.slot_landmark[0], Some(0));
        assert_eq!(s.slot_landmark[19], Some(0));
        assert_eq!(s.slot_landmark[20], Some(1));
        assert_eq!(s.slot_landmark[599], Some(29));
        assert_eq!(s.target_m(600), Some([15.0 * 200.0, 14.0 * 200.0]));
    }

    #[test]
    fn square_is_a_closed_loop() {
        let p = Preset::Square.positions(100.0, 0);
        assert_eq!(p.len(), 60);
        for w in p.windows(2) {
            let d = ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt();
            assert!((d - 100.0).abs() < 1e-9);
        }
        let d = (p[59][0].powi(2) + p[59][1].powi(2)).sqrt();
        assert!((d - 100.0).abs() < 1e-9);
    }

    #[test]
    fn random_gaps_lie_in_range_and_depend_on_seed() {
        let a = Preset::Random.positions(100.0, 1);
        let b = Preset::Random.positions(100.0, 2);
        assert_ne!(a, b);
        for w in a.windows(2) {
            let d = (w[1][0] - w[0][0]) + (w[1][1] - w[0][1]);
            assert!((0.0..=100.0).contains(&d));
        }
    }

    #[test]
    fn explicit_windows_and_gaps() {
        let w = vec![
            LandmarkWindow {
                x_m: 1.0,
                y_m: 2.0,
                from_s: 0.0,
                to_s: 1.0,
            },
            LandmarkWindow {
                x_m: 3.0,
                y_m: 4.0,
                from_s: 2.0,
                to_s: 3.0,
            },
        ];
        let s = Schedule::from_windows(w, 6, 0.5).unwrap();
        assert_eq!(
            s.slot_landmark,
            vec![Some(0), Some(0), None, None, Some(1), Some(1)]
        );
    }

    #[test]
    fn overlapping_windows_are_contradictory() {
        let w = vec![
            LandmarkWindow {
                x_m: 0.0,
                y_m: 0.0,
                from_s: 0.0,
                to_s: 2.0,
            },
            LandmarkWindow {
                x_m: 0.0,
                y_m: 0.0,
                from_s: 1.0,
                to_s: 3.0,
            },
        ];
        let e = Schedule::from_windows(w, 6, 0.5).unwrap_err();
        assert!(matches!(e, ScheduleError::Overlap { slot: 3, .. }), "{e}");
    }

    /// Many landmarks, far landmarks and a preset spread beyond the operating area are refused
    /// by name; the largest allowed schedule (every landmark's window over every slot, the most
    /// landmarks) is resolved without visiting each slot once per landmark, and names the
    /// first slot two windows claim with its two lowest landmarks.
    #[test]
    fn landmark_counts_and_positions_are_bounded() {
        let w = |x_m: f64, from_s: f64, to_s: f64| LandmarkWindow {
            x_m,
            y_m: 0.0,
            from_s,
            to_s,
        };
        let many = vec![w(0.0, 0.0, 1.0); MAX_LANDMARKS + 1];
        let e = Schedule::from_windows(many, 2, 0.5)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "landmarks.points: 10001 landmarks, more than the 10000 a mission may have"
        );
        let e = Schedule::from_windows(vec![w(-100_001.0, 0.0, 1.0)], 2, 0.5)
            .unwrap_err()
            .to_string();
        assert!(e.contains("points[0].x_m") && e.contains("100000"), "{e}");
        let spec = LandmarksSpec {
            preset: Some(Preset::Staircase),
            spacing_m: Some(4000.0),
            ..Default::default()
        };
        let e = Schedule::from_spec(&spec, 1200, 0.5)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("landmarks.spacing_m") && e.contains("120000"),
            "{e}"
        );
        let slots = crate::params::MAX_SLOTS;
        let all = vec![w(0.0, 0.0, slots as f64 * 0.5); MAX_LANDMARKS];
        let started = std::time::Instant::now();
        let e = Schedule::from_windows(all, slots, 0.5).unwrap_err();
        assert!(
            matches!(
                e,
                ScheduleError::Overlap {
                    slot: 1,
                    first: 0,
                    second: 1,
                    ..
                }
            ),
            "{e}"
        );
        // the overlap found late: windows that each start one slot earlier
        let late: Vec<_> = (0..100)
            .map(|k| w(0.0, (99 - k) as f64 * 0.5, 100.0))
            .collect();
        let e = Schedule::from_windows(late, 200, 0.5).unwrap_err();
        assert!(
            matches!(
                e,
                ScheduleError::Overlap {
                    slot: 2,
                    first: 98,
                    second: 99,
                    ..
                }
            ),
            "{e}"
        );
        assert!(
            started.elapsed().as_secs_f64() < 5.0,
            "{:?}",
            started.elapsed()
        );
    }

    #[test]
    fn bad_windows_name_the_field() {
        let w = vec![LandmarkWindow {
            x_m: 0.0,
            y_m: f64::NAN,
            from_s: 0.0,
            to_s: 2.0,
        }];
        let e = Schedule::from_windows(w, 6, 0.5).unwrap_err().to_string();
        assert!(e.contains("points[0].y_m"), "{e}");
        let w = vec![LandmarkWindow {
            x_m: 0.0,
            y_m: 0.0,
            from_s: 0.0,
            to_s: 20.0,
        }];
        let e = Schedule::from_windows(w, 6, 0.5).unwrap_err().to_string();
        assert!(e.contains("points[0].to_s"), "{e}");
    }
}
