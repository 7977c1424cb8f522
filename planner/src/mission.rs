//! Missions: validated parameters plus a resolved landmark schedule, read from TOML or JSON.
//!
//! ```toml
//! name = "paper default, 30 m"      # optional
//! [params]                           # any subset of `Params`, the default parameters otherwise
//! bandwidth_hz = 150e6
//! [landmarks]
//! preset = "default"                 # or: points = [{ x_m = 0, y_m = 0, from_s = 0, to_s = 10 }]
//! spacing_m = 30
//! ```

use std::borrow::Cow;
use std::path::Path;

use serde::{Deserialize, Serialize};

mod start;
use start::StartSearch;

use crate::landmarks::{LandmarksSpec, Preset, Schedule, ScheduleError};
use crate::params::{ParamError, Params, ParamsOverride};

/// A mission that cannot be read or built. Every variant names the file, field or slot.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MissionError {
    /// The file could not be read.
    #[error("cannot read mission file {path}: {error}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error (in the message).
        error: std::io::Error,
    },
    /// The file is not valid TOML/JSON or has unknown or mistyped fields.
    #[error("mission file {path}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// The parser's message (it names the line and field).
        message: String,
    },
    /// A parameter is out of range.
    #[error(transparent)]
    Param(#[from] ParamError),
    /// The landmark table is invalid.
    #[error(transparent)]
    Schedule(#[from] ScheduleError),
}

/// The on-disk structure of a mission file (TOML or JSON).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionFile {
    /// Free-form name used in reports.
    pub name: Option<String>,
    /// Overrides of the the default parameters.
    #[serde(default)]
    pub params: ParamsOverride,
    /// The landmark schedule.
    pub landmarks: LandmarksSpec,
}

impl MissionFile {
    /// Parses TOML text.
    pub fn from_toml_str(text: &str) -> Result<Self, String> {
        toml::from_str(text).map_err(|e| e.to_string())
    }

    /// Parses JSON text.
    pub fn from_json_str(text: &str) -> Result<Self, String> {
        serde_json::from_str(text).map_err(|e| e.to_string())
    }

    /// Serialises to TOML.
    pub fn to_toml_string(&self) -> Result<String, String> {
        toml::to_string_pretty(self).map_err(|e| e.to_string())
    }
}

/// A validated mission: parameters that passed [`Params::validate`] and a schedule with one
/// optional landmark per slot. The planner only accepts this type.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Mission {
    name: String,
    params: Params,
    schedule: Schedule,
    /// [`Mission::start_velocity_mps`] once computed (its search costs ~9 000 cell evaluations;
    /// the evaluator asks for it on every call).
    #[serde(skip)]
    start_velocity: start::Cache,
}

impl Mission {
    /// Validates `params` and resolves `landmarks` into a schedule.
    pub fn new(
        name: impl Into<String>,
        params: Params,
        landmarks: &LandmarksSpec,
    ) -> Result<Self, MissionError> {
        params.validate()?;
        let schedule = Schedule::from_spec(landmarks, params.slots(), params.slot_s)?;
        Ok(Self {
            name: name.into(),
            params,
            schedule,
            start_velocity: start::Cache::default(),
        })
    }

    /// Builds a mission from its file structure. A `staircase` or `square` preset without an
    /// explicit `horizon_s` gets the paper's 600 s.
    pub fn from_file_struct(file: &MissionFile) -> Result<Self, MissionError> {
        let mut params = Params::default();
        if let (Some(preset), None) = (file.landmarks.preset, file.params.horizon_s) {
            params.horizon_s = preset.natural_horizon_s();
        }
        params.apply(&file.params);
        let name = file
            .name
            .clone()
            .unwrap_or_else(|| match file.landmarks.preset {
                Some(p) => format!(
                    "{} ({} m)",
                    p.name(),
                    file.landmarks.spacing_m.unwrap_or(p.default_spacing_m())
                ),
                None => "explicit landmarks".to_string(),
            });
        Self::new(name, params, &file.landmarks)
    }

    /// Reads a mission file: `.json` as JSON, anything else as TOML.
    pub fn from_path(path: &Path) -> Result<Self, MissionError> {
        let shown = path.display().to_string();
        let text = crate::files::read_text_bounded(path, crate::files::MAX_INPUT_FILE_BYTES)
            .map_err(|error| MissionError::Io {
                path: shown.clone(),
                error,
            })?;
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        let file = if is_json {
            MissionFile::from_json_str(&text)
        } else {
            MissionFile::from_toml_str(&text)
        }
        .map_err(|message| MissionError::Parse {
            path: shown,
            message,
        })?;
        Self::from_file_struct(&file)
    }

    /// The paper's preset mission with the given spacing (and the default parameters otherwise).
    pub fn preset(preset: Preset, spacing_m: f64) -> Result<Self, MissionError> {
        Self::from_file_struct(&MissionFile {
            name: None,
            params: ParamsOverride::default(),
            landmarks: LandmarksSpec {
                preset: Some(preset),
                spacing_m: Some(spacing_m),
                ..Default::default()
            },
        })
    }

    /// The same mission with changed parameters (re-validated, schedule rebuilt from its windows).
    pub fn with_params(&self, params: Params) -> Result<Self, MissionError> {
        params.validate()?;
        let schedule = Schedule::from_windows(
            self.schedule.landmarks.clone(),
            params.slots(),
            params.slot_s,
        )?;
        Ok(Self {
            name: self.name.clone(),
            params,
            schedule,
            start_velocity: start::Cache::default(),
        })
    }

    /// The same mission on a grid of slots `factor` times longer (for a coarse first solve):
    /// coarse slot k senses the landmark of the fine slot that ends at the same time, the start
    /// velocity is the mission's, and a jerk limit is divided by `factor` (so that the coarse
    /// track, interpolated to the fine slots, keeps the fine limit). `None` when `factor` is 0
    /// or does not divide the number of slots.
    pub fn coarsened(&self, factor: usize) -> Option<Self> {
        let n = self.slots();
        if factor == 0 || !n.is_multiple_of(factor) {
            return None;
        }
        let mut params = self.params.clone();
        // the start velocity of the mission itself, whatever the coarse grid's first slot senses
        params.start_velocity_mps = Some(self.start_velocity_mps());
        params.slot_s *= factor as f64;
        // the jerk limit over the fine slot: a coarse track whose slot accelerations change by at
        // most j δ (its jerk within j δ/Δ over its slots Δ) gives, with the velocity
        // interpolated linearly between its slot middles, fine slot accelerations that change by
        // at most j δ from one fine slot to the next (constant between the coarse middles)
        params.max_jerk_mps3 = params.max_jerk_mps3.map(|j| j / factor as f64);
        let slot_landmark = (1..=n / factor)
            .map(|k| self.schedule.slot_landmark[k * factor - 1])
            .collect();
        Some(Self {
            name: format!("{} (coarse x{factor})", self.name),
            params,
            schedule: Schedule {
                landmarks: self.schedule.landmarks.clone(),
                slot_landmark,
            },
            start_velocity: start::Cache::default(),
        })
    }

    /// The velocity at the start, (v_x, v_y) m/s: [`Params::start_velocity_mps`] when the
    /// mission states one, else a rule of the mission alone (not of any plan), so that a user can
    /// state the same value:
    ///
    /// - at rest when the UAV can reach the azimuth speed V_min from rest by the first landmark
    ///   slot t₀ at the acceleration limit (a_max (t₀ − ½) δ ≥ V_min: slot t₀'s average velocity is
    ///   that of its middle; no landmark: at rest);
    /// - otherwise (the paper's missions, whose first window opens at t = 0: from rest the first
    ///   slot could reach only a_max δ/2 ≈ 1.4 m/s of the 7.07 m/s required) already flying, as
    ///   the paper's model assumes, at the least-power speed within [V_min, V_m] with the first
    ///   landmark on the sensing side: heading h with J h pointing from q₀ to the landmark
    ///   (J the rotation by −90°, so the landmark lies H tan η away, where the sensing centre is);
    ///   where flying straight on at that velocity leaves the resolution cell of the first slot
    ///   wider than d_min, the velocity nearest to it (speed within [V_min, V_m], heading within a
    ///   quarter turn; the search is `mission::start::StartSearch`) that keeps the landmark in
    ///   view there with the cell ([`crate::geometry::ResolutionCell::worst_width_m`]) within
    ///   d_min, when one exists. The
    ///   first slot's velocity can differ from the start velocity by only a_max δ/2, so a start
    ///   velocity that cannot resolve it would leave that slot unresolved in every flyable plan.
    ///
    /// `summary.json` reports the value used (`start_velocity_mps`).
    pub fn start_velocity_mps(&self) -> [f64; 2] {
        *self
            .start_velocity
            .0
            .get_or_init(|| self.start_velocity_rule())
    }

    /// [`Mission::start_velocity_mps`], computed.
    fn start_velocity_rule(&self) -> [f64; 2] {
        let p = &self.params;
        if let Some(v) = p.start_velocity_mps {
            return v;
        }
        if p.has_margins() {
            // the rule of the limits the plan is made against, so that the mission and the
            // mission planned ([`Mission::planned`]) start alike
            return self.planned().start_velocity_mps();
        }
        let Some((t0, g)) = (1..=self.slots()).find_map(|t| self.target_m(t).map(|g| (t, g)))
        else {
            return [0.0, 0.0];
        };
        let v_min = p.min_speed_mps();
        if p.max_accel_mps2 * crate::evaluate::start_to_slot_middle_s(p, t0) >= v_min
            || v_min > p.max_speed_mps
        {
            return [0.0, 0.0];
        }
        let model = crate::power::PowerModel::new(p);
        let (speed, _) = model.min_power_in(v_min.min(p.max_speed_mps), p.max_speed_mps);
        let to = nalgebra::Vector2::new(g[0] - p.start_m[0], g[1] - p.start_m[1]);
        let Some(u) = to.try_normalize(1e-9) else {
            return [0.0, 0.0];
        };
        // J h = u with J (x, y) = (y, −x): h = (−u_y, u_x)
        let sensing_side = u.x.atan2(-u.y);
        let preferred = crate::geometry::heading_unit(sensing_side) * speed;
        let search = StartSearch {
            mission: self,
            t0,
            landmark_m: g,
            preferred_mps: preferred,
            speed_range_mps: (v_min, p.max_speed_mps),
            centre_heading_rad: sensing_side,
        };
        let v = search.nearest_resolving().unwrap_or(preferred);
        [v.x, v.y]
    }

    /// The mission a plan is made for: this one with each limit less its margin
    /// ([`Params::planning_limits`]: `d_min_m`, `max_accel_mps2`, `max_jerk_mps3`), or this one
    /// itself when it sets no margin. Same name, schedule and start velocity
    /// ([`Mission::start_velocity_mps`] follows the rule on the tightened limits for both).
    pub fn planned(&self) -> Cow<'_, Mission> {
        if !self.params.has_margins() {
            return Cow::Borrowed(self);
        }
        Cow::Owned(Self {
            name: self.name.clone(),
            params: self.params.planning_limits(),
            schedule: self.schedule.clone(),
            start_velocity: start::Cache::default(),
        })
    }

    /// The mission's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The validated parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The landmark schedule.
    pub fn schedule(&self) -> &Schedule {
        &self.schedule
    }

    /// Number of slots T_w.
    pub fn slots(&self) -> usize {
        self.schedule.slot_landmark.len()
    }

    /// The landmark sensed in slot `t` (1-based), if any.
    pub fn target_m(&self, t: usize) -> Option<[f64; 2]> {
        self.schedule.target_m(t)
    }

    /// This mission as a file structure with explicit windows (round-trips through TOML/JSON).
    pub fn to_file_struct(&self) -> MissionFile {
        let p = &self.params;
        let d = Params::default();
        let mut o = ParamsOverride::default();
        macro_rules! diff {
            ($($f:ident),*) => { $( if p.$f != d.$f { o.$f = Some(p.$f); } )* };
        }
        diff!(
            bandwidth_hz,
            wavelength_m,
            integration_time_s,
            observation_angle_rad,
            d_min_m,
            altitude_m,
            max_speed_mps,
            slot_s,
            horizon_s,
            start_m,
            bs_m,
            bs_height_m,
            sensing_radius_m,
            blade_power_w,
            tip_speed_mps,
            induced_power_w,
            induced_velocity_mps,
            rotor_solidity,
            rotor_disc_area_m2,
            air_density_kgpm3,
            fuselage_drag_ratio,
            uav_mass_kg,
            max_accel_mps2,
            resolution_margin_pct,
            accel_margin_pct,
            jerk_margin_pct
        );
        o.max_jerk_mps3 = p.max_jerk_mps3;
        o.start_accel_mps2 = p.start_accel_mps2;
        o.start_velocity_mps = p.start_velocity_mps;
        if p.altitude != d.altitude {
            o.altitude = Some(p.altitude);
        }
        o.min_altitude_m = p.min_altitude_m;
        o.max_altitude_m = p.max_altitude_m;
        if p.max_climb_mps != d.max_climb_mps {
            o.max_climb_mps = Some(p.max_climb_mps);
        }
        if p.max_descent_mps != d.max_descent_mps {
            o.max_descent_mps = Some(p.max_descent_mps);
        }
        MissionFile {
            name: Some(self.name.clone()),
            params: o,
            landmarks: LandmarksSpec {
                points: Some(self.schedule.landmarks.clone()),
                ..Default::default()
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_preset_mission() {
        let f = MissionFile::from_toml_str(
            "[params]\nbandwidth_hz = 50e6\n[landmarks]\npreset = \"default\"\nspacing_m = 200\n",
        )
        .unwrap();
        let m = Mission::from_file_struct(&f).unwrap();
        assert_eq!(m.params().bandwidth_hz, 50e6);
        assert_eq!(m.slots(), 600);
        assert_eq!(m.target_m(21), Some([0.0, 200.0]));
    }

    #[test]
    fn staircase_gets_600_s() {
        let m = Mission::preset(Preset::Staircase, 30.0).unwrap();
        assert_eq!(m.slots(), 1200);
        assert_eq!(m.target_m(1200), Some([30.0 * 30.0, 29.0 * 30.0]));
    }

    #[test]
    fn unknown_field_is_rejected_with_its_name() {
        let e = MissionFile::from_toml_str(
            "[params]\nbandwith_hz = 1\n[landmarks]\npreset=\"default\"",
        )
        .unwrap_err();
        assert!(e.contains("bandwith_hz"), "{e}");
    }

    #[test]
    fn bad_param_names_field() {
        let f = MissionFile::from_toml_str(
            "[params]\nmax_speed_mps = -3\n[landmarks]\npreset = \"default\"\n",
        )
        .unwrap();
        let e = Mission::from_file_struct(&f).unwrap_err().to_string();
        assert!(e.contains("max_speed_mps"), "{e}");
    }

    /// Every shipped mission lies within the physical envelope (`params::bounds`).
    #[test]
    fn shipped_missions_validate() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../missions");
        let mut n = 0;
        for e in std::fs::read_dir(&dir).unwrap() {
            let path = e.unwrap().path();
            if path.extension().is_some_and(|x| x == "toml") {
                Mission::from_path(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                n += 1;
            }
        }
        assert!(n >= 9, "{n} missions in {}", dir.display());
    }

    /// A mission with margins is planned against its tightened limits from the start velocity
    /// of the rule on those limits, which the mission itself reports too; its file form keeps
    /// the margins and the jerk limit.
    #[test]
    fn margins_plan_the_tightened_limits_from_one_start() {
        let text = "[params]\nresolution_margin_pct = 10\naccel_margin_pct = 20\n\
                    max_jerk_mps3 = 10\njerk_margin_pct = 50\n\
                    [landmarks]\npreset = \"default\"\nspacing_m = 30\n";
        let m = Mission::from_file_struct(&MissionFile::from_toml_str(text).unwrap()).unwrap();
        let planned = m.planned();
        let (p, t) = (m.params(), planned.params());
        assert_eq!((p.d_min_m, p.max_jerk_mps3), (20.0, Some(10.0)));
        assert!((t.d_min_m - 18.0).abs() < 1e-12);
        assert!((t.max_accel_mps2 - 0.8 * p.max_accel_mps2).abs() < 1e-12);
        assert_eq!(t.max_jerk_mps3, Some(5.0));
        assert_eq!(planned.schedule(), m.schedule());
        assert_eq!(m.start_velocity_mps(), planned.start_velocity_mps());
        // the rule of a mission that states the tightened limits itself
        let mut tight = t.clone();
        tight.d_min_m = 18.0;
        let stated = m.with_params(tight).unwrap();
        assert_eq!(m.start_velocity_mps(), stated.start_velocity_mps());
        assert!(matches!(stated.planned(), Cow::Borrowed(_)));
        // the file form round-trips the margins and the limit
        let back = Mission::from_file_struct(&m.to_file_struct()).unwrap();
        assert_eq!(back.params(), m.params());
    }

    #[test]
    fn json_and_toml_round_trip() {
        let m = Mission::preset(Preset::Square, 100.0).unwrap();
        let f = m.to_file_struct();
        let t = f.to_toml_string().unwrap();
        let back = Mission::from_file_struct(&MissionFile::from_toml_str(&t).unwrap()).unwrap();
        assert_eq!(back.schedule(), m.schedule());
        assert_eq!(back.params(), m.params());
        let j = serde_json::to_string(&f).unwrap();
        let back = Mission::from_file_struct(&MissionFile::from_json_str(&j).unwrap()).unwrap();
        assert_eq!(back.params(), m.params());
    }
}
