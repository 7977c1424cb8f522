//! The jerk limit's checks and the margins: the limits the planner plans against
//! ([`Params::planning_limits`]).

use super::{bounds, ParamError, Params};

impl Params {
    /// Whether the mission sets a margin the planner applies: `resolution_margin_pct`,
    /// `accel_margin_pct`, or `jerk_margin_pct` with a jerk limit.
    pub fn has_margins(&self) -> bool {
        self.resolution_margin_pct > 0.0
            || self.accel_margin_pct > 0.0
            || (self.jerk_margin_pct > 0.0 && self.max_jerk_mps3.is_some())
    }

    /// The parameters a plan is made against: `d_min_m`, `max_accel_mps2` and `max_jerk_mps3`
    /// each less its margin (d_min (1 − `resolution_margin_pct`/100), and so on), the margins
    /// 0, so that tightening twice changes nothing. The plan is judged against the limits
    /// themselves ([`crate::evaluate()`] of the mission), and keeps the margins' room there.
    /// Without margins, the parameters unchanged.
    pub fn planning_limits(&self) -> Params {
        let keep = |pct: f64| 1.0 - pct / 100.0;
        let mut p = self.clone();
        if self.resolution_margin_pct > 0.0 {
            p.d_min_m = self.d_min_m * keep(self.resolution_margin_pct);
        }
        if self.accel_margin_pct > 0.0 {
            p.max_accel_mps2 = self.max_accel_mps2 * keep(self.accel_margin_pct);
        }
        if self.jerk_margin_pct > 0.0 {
            p.max_jerk_mps3 = self.max_jerk_mps3.map(|j| j * keep(self.jerk_margin_pct));
        }
        p.resolution_margin_pct = 0.0;
        p.accel_margin_pct = 0.0;
        p.jerk_margin_pct = 0.0;
        p
    }
}

/// Checks `max_jerk_mps3` when set: a finite number > 0 and at most [`bounds::MAX_JERK_MPS3`];
/// and `start_accel_mps2` when set: finite components, its magnitude at most `max_accel_mps2`.
pub(super) fn validate_jerk(p: &Params) -> Result<(), ParamError> {
    if let Some(a) = p.start_accel_mps2 {
        let bad = |value: f64, reason: String| ParamError::Invalid {
            field: "start_accel_mps2",
            value,
            reason,
        };
        if let Some(v) = a.into_iter().find(|v| !v.is_finite()) {
            return Err(bad(v, "components must be finite numbers".into()));
        }
        let magnitude = a[0].hypot(a[1]);
        if magnitude > p.max_accel_mps2 {
            return Err(bad(
                magnitude,
                format!(
                    "its magnitude must not exceed max_accel_mps2 = {} m/s²",
                    super::short(p.max_accel_mps2)
                ),
            ));
        }
    }
    let Some(value) = p.max_jerk_mps3 else {
        return Ok(());
    };
    let bad = |reason: &str| ParamError::Invalid {
        field: "max_jerk_mps3",
        value,
        reason: reason.to_string(),
    };
    if !value.is_finite() {
        return Err(bad(
            "must be a finite number (leave it out for no jerk limit)",
        ));
    }
    if value <= 0.0 {
        return Err(bad("must be > 0 (leave it out for no jerk limit)"));
    }
    if value > bounds::MAX_JERK_MPS3 {
        return Err(bounds::above(
            "max_jerk_mps3",
            value,
            bounds::MAX_JERK_MPS3,
            bounds::JERK_WHY,
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bad jerk limits and margins are refused by name, with the value and the bound.
    #[test]
    fn bad_jerk_limits_and_margins_name_their_field() {
        for (jerk, what) in [
            (f64::NAN, "finite"),
            (f64::INFINITY, "finite"),
            (0.0, "> 0"),
            (-5.0, "> 0"),
            (500.5, "at most 500"),
        ] {
            let p = Params {
                max_jerk_mps3: Some(jerk),
                ..Params::default()
            };
            let msg = p
                .validate()
                .map_or_else(|e| e.to_string(), |()| String::new());
            assert!(
                msg.starts_with("parameter `max_jerk_mps3`") && msg.contains(what),
                "{jerk}: {msg}"
            );
        }
        for name in [
            "resolution_margin_pct",
            "accel_margin_pct",
            "jerk_margin_pct",
        ] {
            for (value, what) in [(-1.0, ">= 0"), (50.5, "at most 50"), (f64::NAN, "finite")] {
                let mut p = Params::default();
                assert!(p.set_by_name(name, value).is_ok());
                let msg = p
                    .validate()
                    .map_or_else(|e| e.to_string(), |()| String::new());
                assert!(
                    msg.starts_with(&format!("parameter `{name}`")) && msg.contains(what),
                    "{name} = {value}: {msg}"
                );
            }
        }
        for (a, what) in [([f64::NAN, 0.0], "finite"), ([6.0, 0.0], "max_accel_mps2")] {
            let p = Params {
                start_accel_mps2: Some(a),
                ..Params::default()
            };
            let msg = p
                .validate()
                .map_or_else(|e| e.to_string(), |()| String::new());
            assert!(
                msg.starts_with("parameter `start_accel_mps2`") && msg.contains(what),
                "{msg}"
            );
        }
        let fine = Params {
            max_jerk_mps3: Some(500.0),
            jerk_margin_pct: 50.0,
            ..Params::default()
        };
        assert!(fine.validate().is_ok());
    }

    /// The planning limits: each limit less its margin, margins 0, idempotent; without
    /// margins the parameters themselves.
    #[test]
    fn planning_limits_tighten_each_limit_by_its_margin() {
        let p = Params::default();
        assert!(!p.has_margins());
        assert_eq!(p.planning_limits(), p);
        let m = Params {
            resolution_margin_pct: 5.0,
            accel_margin_pct: 10.0,
            jerk_margin_pct: 20.0,
            max_jerk_mps3: Some(10.0),
            ..Params::default()
        };
        assert!(m.has_margins());
        let t = m.planning_limits();
        assert!((t.d_min_m - 19.0).abs() < 1e-12);
        assert!((t.max_accel_mps2 - 0.9 * p.max_accel_mps2).abs() < 1e-12);
        assert!((t.max_jerk_mps3.unwrap_or(0.0) - 8.0).abs() < 1e-12);
        assert!(!t.has_margins());
        assert_eq!(t.planning_limits(), t);
        // the azimuth speed follows d_min
        assert!((t.min_speed_mps() - p.min_speed_mps() / 0.95).abs() < 1e-12);
        // a jerk margin without a jerk limit is none
        let no_limit = Params {
            jerk_margin_pct: 20.0,
            ..Params::default()
        };
        assert!(!no_limit.has_margins());
    }
}
