//! Trajectories: the start q_0 and one waypoint q_t per slot; straight, constant-speed flight
//! within each slot (the model of the paper: the heading of slot t is that of q_t − q_{t−1}).

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::geometry::{heading_rad, Length, Point2, Vector2};

/// A trajectory that cannot be read or does not fit its mission.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrajectoryError {
    /// The file could not be read.
    #[error("cannot read trajectory {path}: {error}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error (in the message).
        error: std::io::Error,
    },
    /// A malformed CSV file; names the line and column.
    #[error("trajectory {path}, {location}: {reason}")]
    Format {
        /// The file.
        path: String,
        /// e.g. `line 4, column y_m`.
        location: String,
        /// What is wrong.
        reason: String,
    },
}

/// A planned or given trajectory. Points are `[f64; 2]` so that files and messages keep their
/// format; the methods below do the vector maths in nalgebra ([`crate::geometry`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    /// Slot length δ, s.
    pub slot_s: f64,
    /// Start position q_0, m.
    pub start_m: [f64; 2],
    /// Waypoints q_1..q_{T_w}, m (`pos_m[t-1]` is q_t).
    pub pos_m: Vec<[f64; 2]>,
}

impl Trajectory {
    /// Number of slots T_w.
    pub fn slots(&self) -> usize {
        self.pos_m.len()
    }

    /// Duration T = T_w δ, s.
    pub fn duration_s(&self) -> f64 {
        self.slots() as f64 * self.slot_s
    }

    /// q_t for t = 0..=T_w (q_0 is the start). Clamped to the ends.
    pub fn q(&self, t: usize) -> [f64; 2] {
        if t == 0 {
            self.start_m
        } else {
            self.pos_m
                .get(t - 1)
                .or(self.pos_m.last())
                .copied()
                .unwrap_or(self.start_m)
        }
    }

    /// Displacement q_t − q_{t−1} of slot t (1-based), m.
    pub fn step_m(&self, t: usize) -> [f64; 2] {
        (Point2::from(self.q(t)) - Point2::from(self.q(t.saturating_sub(1)))).into()
    }

    /// True velocity of slot t, (q_t − q_{t−1}) / δ, m/s.
    pub fn velocity_mps(&self, t: usize) -> [f64; 2] {
        (Vector2::from(self.step_m(t)) * (1.0 / self.slot_s)).into()
    }

    /// True speed of slot t, m/s.
    pub fn speed_mps(&self, t: usize) -> f64 {
        Vector2::from(self.velocity_mps(t)).length()
    }

    /// True headings of slots 1..=T_w, rad. A slot without motion keeps the previous heading
    /// (the antenna is fixed to the airframe, which keeps its yaw in hover); before the first
    /// motion the first defined heading is used, and 0 if the UAV never moves.
    pub fn headings_rad(&self) -> Vec<f64> {
        let raw: Vec<Option<f64>> = (1..=self.slots())
            .map(|t| heading_rad(self.q(t - 1), self.q(t)))
            .collect();
        let first = raw.iter().flatten().next().copied().unwrap_or(0.0);
        let mut last = first;
        raw.into_iter()
            .map(|h| {
                if let Some(h) = h {
                    last = h;
                }
                last
            })
            .collect()
    }

    /// Position at time `time_s` (linear within a slot; clamped to [0, T]).
    pub fn position_at(&self, time_s: f64) -> [f64; 2] {
        let n = self.slots();
        if n == 0 || !time_s.is_finite() || time_s <= 0.0 {
            return self.start_m;
        }
        let x = time_s / self.slot_s;
        if x >= n as f64 {
            return self.q(n);
        }
        let t = x.floor() as usize; // slot t+1 runs from q_t to q_{t+1}
        let f = x - t as f64;
        let a = Point2::from(self.q(t));
        let b = Point2::from(self.q(t + 1));
        (a + (b - a) * f).into()
    }

    /// Velocity at time `time_s`: that of the slot containing it (m/s).
    pub fn velocity_at(&self, time_s: f64) -> [f64; 2] {
        let n = self.slots();
        if n == 0 {
            return [0.0, 0.0];
        }
        let t = ((time_s / self.slot_s).ceil() as usize).clamp(1, n);
        self.velocity_mps(t)
    }

    /// Total path length Σ ‖q_t − q_{t−1}‖, m.
    pub fn length_m(&self) -> f64 {
        (1..=self.slots())
            .map(|t| Vector2::from(self.step_m(t)).length())
            .sum()
    }

    /// Reads a CSV file with at least the columns `t_s,x_m,y_m`, one row per slot, optionally with
    /// the start as a row at t = 0. `start_m` is used when no t = 0 row is present. An altitude
    /// column `z_m` (as `trajectory.csv` has) must hold the mission's `altitude_m` in every row:
    /// a 2-D track is flown at that altitude, so a file made for another altitude, or with a
    /// varying one, is refused rather than flown at the wrong height.
    pub fn from_csv_path(
        path: &Path,
        slot_s: f64,
        slots: usize,
        start_m: [f64; 2],
        altitude_m: f64,
    ) -> Result<Self, TrajectoryError> {
        let (text, shown) = Self::read_bounded(path)?;
        Self::from_csv_str(&text, &shown, slot_s, slots, start_m, altitude_m)
    }

    /// Parses CSV text (see [`Trajectory::from_csv_path`]); `name` is used in error messages.
    pub fn from_csv_str(
        text: &str,
        name: &str,
        slot_s: f64,
        slots: usize,
        start_m: [f64; 2],
        altitude_m: f64,
    ) -> Result<Self, TrajectoryError> {
        Self::parse_csv(text, name, (slot_s, slots, start_m), altitude_m, false).map(|(tr, _)| tr)
    }

    /// Reads a trajectory of a mission with `altitude = "free"` (a plan's `trajectory.csv`):
    /// like [`Trajectory::from_csv_path`], but the `z_m` column may vary and is returned, one
    /// altitude per slot (the t = 0 row's, when present, must be the start altitude
    /// `altitude_m`); without a `z_m` column every slot is at `altitude_m`.
    pub fn from_csv_path_with_altitudes(
        path: &Path,
        slot_s: f64,
        slots: usize,
        start_m: [f64; 2],
        altitude_m: f64,
    ) -> Result<(Self, Vec<f64>), TrajectoryError> {
        let (text, shown) = Self::read_bounded(path)?;
        Self::from_csv_str_with_altitudes(&text, &shown, slot_s, slots, start_m, altitude_m)
    }

    /// Parses CSV text (see [`Trajectory::from_csv_path_with_altitudes`]).
    pub fn from_csv_str_with_altitudes(
        text: &str,
        name: &str,
        slot_s: f64,
        slots: usize,
        start_m: [f64; 2],
        altitude_m: f64,
    ) -> Result<(Self, Vec<f64>), TrajectoryError> {
        Self::parse_csv(text, name, (slot_s, slots, start_m), altitude_m, true)
    }

    /// The text of the file at `path` (at most [`crate::files::MAX_INPUT_FILE_BYTES`]) and the
    /// path as error messages name it.
    fn read_bounded(path: &Path) -> Result<(String, String), TrajectoryError> {
        let shown = path.display().to_string();
        let text = crate::files::read_text_bounded(path, crate::files::MAX_INPUT_FILE_BYTES)
            .map_err(|error| TrajectoryError::Io {
                path: shown.clone(),
                error,
            })?;
        Ok((text, shown))
    }

    /// The reader of both: with `varying`, the `z_m` column is returned per slot (the t = 0
    /// row's must be `altitude_m`); without, it must hold `altitude_m` in every row.
    fn parse_csv(
        text: &str,
        name: &str,
        (slot_s, slots, start_m): (f64, usize, [f64; 2]),
        altitude_m: f64,
        varying: bool,
    ) -> Result<(Self, Vec<f64>), TrajectoryError> {
        let err = |location: String, reason: String| TrajectoryError::Format {
            path: name.to_string(),
            location,
            reason,
        };
        let mut rd = csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .flexible(true)
            .from_reader(text.as_bytes());
        let cols = rd
            .headers()
            .map_err(|e| err("header".into(), e.to_string()))?
            .clone();
        if cols.iter().all(str::is_empty) {
            return Err(err("line 1".into(), "empty file".into()));
        }
        let col = |name: &str| {
            cols.iter()
                .position(|c| c == name)
                .ok_or_else(|| err("header".into(), format!("missing column `{name}`")))
        };
        let (ct, cx, cy) = (col("t_s")?, col("x_m")?, col("y_m")?);
        // an altitude column (`trajectory.csv`'s z_m) must hold the mission's altitude: a 2-D
        // track cannot carry a varying one, and dropping it would fly another trajectory
        let cz = cols.iter().position(|c| c == "z_m");
        let mut first_z: Option<f64> = None;
        let altitude_tol_m = 1e-6 * altitude_m.abs().max(1.0);
        let mut start = start_m;
        let mut pos = Vec::with_capacity(slots);
        let mut altitudes = Vec::with_capacity(slots);
        for record in rd.records() {
            let fields = record.map_err(|e| {
                let line = e.position().map_or(0, |p| line_of(text, p));
                err(format!("line {line}"), e.to_string())
            })?;
            if fields.iter().all(str::is_empty) {
                continue;
            }
            let line = fields.position().map_or(0, |p| line_of(text, p));
            let get = |c: usize, n: &str| -> Result<f64, TrajectoryError> {
                let s = fields.get(c).ok_or_else(|| {
                    err(format!("line {line}, column {n}"), "missing value".into())
                })?;
                let v: f64 = s.parse().map_err(|_| {
                    err(
                        format!("line {line}, column {n}"),
                        format!("`{s}` is not a number"),
                    )
                })?;
                if !v.is_finite() {
                    return Err(err(
                        format!("line {line}, column {n}"),
                        format!("{v} is not finite"),
                    ));
                }
                Ok(v)
            };
            let (t, x, y) = (get(ct, "t_s")?, get(cx, "x_m")?, get(cy, "y_m")?);
            let start_row = t.abs() < 1e-9 && pos.is_empty();
            let z = cz.map(|c| get(c, "z_m")).transpose()?;
            if varying {
                if let (Some(z), true) = (z, start_row) {
                    if (z - altitude_m).abs() > altitude_tol_m {
                        return Err(err(
                            format!("line {line}, column z_m"),
                            format!(
                                "start altitude {z} m, but the mission starts at altitude_m = \
                                 {altitude_m} m"
                            ),
                        ));
                    }
                }
                if !start_row {
                    altitudes.push(z.unwrap_or(altitude_m));
                }
            } else if let Some(z) = z {
                match first_z {
                    None if (z - altitude_m).abs() > altitude_tol_m => {
                        return Err(err(
                            format!("line {line}, column z_m"),
                            format!(
                                "altitude {z} m, but the mission flies at altitude_m = \
                                 {altitude_m} m: the track was made for another altitude"
                            ),
                        ))
                    }
                    None => first_z = Some(z),
                    Some(z0) if z != z0 => {
                        return Err(err(
                            format!("line {line}, column z_m"),
                            format!(
                                "altitude {z} m differs from the first row's {z0} m: a \
                                 trajectory with a varying altitude (altitude = \"free\") is \
                                 not read as a 2-D track"
                            ),
                        ))
                    }
                    Some(_) => {}
                }
            }
            if start_row {
                start = [x, y];
                continue;
            }
            let expected = (pos.len() + 1) as f64 * slot_s;
            if (t - expected).abs() > 1e-6 * expected.max(1.0) {
                return Err(err(
                    format!("line {line}, column t_s"),
                    format!(
                        "expected t_s = {expected} (slot {}), found {t}",
                        pos.len() + 1
                    ),
                ));
            }
            pos.push([x, y]);
        }
        if pos.len() != slots {
            return Err(err(
                "rows".into(),
                format!(
                    "{} slot rows, but the mission has {slots} slots of {slot_s} s",
                    pos.len()
                ),
            ));
        }
        Ok((
            Self {
                slot_s,
                start_m: start,
                pos_m: pos,
            },
            altitudes,
        ))
    }
}

/// The 1-based line of `text` that holds the record at `position` (csv's own line count and
/// byte offset include the comment and blank lines before the record: skip them).
fn line_of(text: &str, position: &csv::Position) -> usize {
    let start = usize::try_from(position.byte()).unwrap_or(usize::MAX);
    let first = text
        .as_bytes()
        .iter()
        .take(start)
        .filter(|&&b| b == b'\n')
        .count();
    let skipped = text
        .lines()
        .skip(first)
        .take_while(|l| l.trim().is_empty() || l.starts_with('#'))
        .count();
    1 + first + skipped
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line() -> Trajectory {
        Trajectory {
            slot_s: 0.5,
            start_m: [0.0, 0.0],
            pos_m: (1..=4).map(|t| [t as f64 * 5.0, 0.0]).collect(),
        }
    }

    #[test]
    fn speeds_and_interpolation() {
        let tr = line();
        assert_eq!(tr.speed_mps(1), 10.0);
        assert_eq!(tr.position_at(0.25), [2.5, 0.0]);
        assert_eq!(tr.position_at(2.0), [20.0, 0.0]);
        assert_eq!(tr.position_at(99.0), [20.0, 0.0]);
        assert_eq!(tr.length_m(), 20.0);
    }

    #[test]
    fn hover_keeps_heading() {
        let tr = Trajectory {
            slot_s: 1.0,
            start_m: [0.0, 0.0],
            pos_m: vec![[0.0, 0.0], [0.0, 1.0], [0.0, 1.0], [1.0, 1.0]],
        };
        let h = tr.headings_rad();
        let half_pi = std::f64::consts::FRAC_PI_2;
        assert_eq!(h, vec![half_pi, half_pi, half_pi, 0.0]);
    }

    #[test]
    fn csv_round_trip_and_errors() {
        let text = "t_s,x_m,y_m\n0,1,2\n0.5,3,4\n1.0,5,6\n";
        let tr = Trajectory::from_csv_str(text, "x.csv", 0.5, 2, [0.0, 0.0], 1000.0).unwrap();
        assert_eq!(tr.start_m, [1.0, 2.0]);
        assert_eq!(tr.pos_m, vec![[3.0, 4.0], [5.0, 6.0]]);
        let e = Trajectory::from_csv_str(text, "x.csv", 0.5, 3, [0.0, 0.0], 1000.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("3 slots"), "{e}");
        let bad = "t_s,x_m,y_m\n0.5,3,oops\n";
        let e = Trajectory::from_csv_str(bad, "x.csv", 0.5, 1, [0.0, 0.0], 1000.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2, column y_m"), "{e}");
        // comments and blank lines keep the line numbers of the file
        let commented = "# a plan\nt_s,x_m,y_m\n\n0.5,3,4\n# note\n1.5,5,6\n";
        let e = Trajectory::from_csv_str(commented, "x.csv", 0.5, 2, [0.0, 0.0], 1000.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 6, column t_s"), "{e}");
        let e = Trajectory::from_csv_str("", "x.csv", 0.5, 1, [0.0, 0.0], 1000.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("empty file"), "{e}");
    }

    #[test]
    fn a_constant_altitude_column_is_read_and_a_varying_one_refused() {
        let flat = "t_s,x_m,y_m,z_m\n0,1,2,1000\n0.5,3,4,1000\n1.0,5,6,1000\n";
        let tr = Trajectory::from_csv_str(flat, "x.csv", 0.5, 2, [0.0, 0.0], 1000.0).unwrap();
        assert_eq!(tr.pos_m, vec![[3.0, 4.0], [5.0, 6.0]]);
        let climbing = flat.replace("5,6,1000", "5,6,1001.5");
        let e = Trajectory::from_csv_str(&climbing, "x.csv", 0.5, 2, [0.0, 0.0], 1000.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 4, column z_m") && e.contains("altitude = \"free\""),
            "{e}"
        );
        // a constant altitude other than the mission's: made for another mission
        let e = Trajectory::from_csv_str(flat, "x.csv", 0.5, 2, [0.0, 0.0], 1200.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2, column z_m") && e.contains("altitude_m = 1200 m"),
            "{e}"
        );
        // within the reader's tolerance (1e-6 relative) it is the same altitude
        let near = flat.replace(",1000\n", ",1000.0005\n");
        Trajectory::from_csv_str(&near, "x.csv", 0.5, 2, [0.0, 0.0], 1000.0).unwrap();
    }

    #[test]
    fn a_varying_altitude_column_is_read_as_a_profile() {
        let climbing = "t_s,x_m,y_m,z_m\n0,1,2,1000\n0.5,3,4,1001\n1.0,5,6,1001.5\n";
        let read = |text: &str, z0: f64| {
            Trajectory::from_csv_str_with_altitudes(text, "x.csv", 0.5, 2, [0.0, 0.0], z0)
        };
        let (tr, z) = read(climbing, 1000.0).unwrap();
        assert_eq!(tr.pos_m, vec![[3.0, 4.0], [5.0, 6.0]]);
        assert_eq!((tr.start_m, z), ([1.0, 2.0], vec![1001.0, 1001.5]));
        // the start row at another altitude than the mission's start
        let e = read(climbing, 900.0).unwrap_err().to_string();
        assert!(e.contains("line 2, column z_m") && e.contains("900"), "{e}");
        // no altitude column: the mission's altitude in every slot
        let (_, z) = read("t_s,x_m,y_m\n0.5,3,4\n1.0,5,6\n", 800.0).unwrap();
        assert_eq!(z, vec![800.0, 800.0]);
    }
}
