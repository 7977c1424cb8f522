//! The planner's options ([`PlanOptions`], [`Scheme`]) and the run's deadline.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use crate::evaluate::{Dynamics, ResolutionMode};
use crate::socp::SocpSettings;
use crate::Trajectory;

use super::{PlanError, Scheme};

/// Default of [`PlanOptions::resolution_weight_j_per_m`], J/m.
pub const DEFAULT_RESOLUTION_WEIGHT_J_PER_M: f64 = 100.0;

/// The resolution requirement of the `exact` scheme unless a request says otherwise, through
/// every interface (the library's [`PlanOptions::default`], `cellsar-planner plan`,
/// `cellsar run`, a plan request on the wire, the Python package, the FMU's initial plan): the
/// general bistatic cell, as a best effort where the geometry does not allow it in every
/// landmark slot (top-level docs/user-guide.md, "Resolution"). The comparison schemes default
/// to [`ResolutionMode::Paper`] ([`Scheme::default_resolution`]), and `reproduce` keeps the
/// paper's resolution, as the paper's figures do.
pub const DEFAULT_RESOLUTION: ResolutionMode = ResolutionMode::General;

/// The vehicle model of the schemes a user flies (`exact`, its best effort and trade-off,
/// `baseline-exact`) unless a request says otherwise, through every interface: a multirotor's
/// acceleration limit (mission `max_accel_mps2`, from its start velocity on). The comparison
/// schemes `paper` and `baseline`, and `reproduce`, keep the paper's model
/// ([`Scheme::default_dynamics`]).
pub const DEFAULT_DYNAMICS: Dynamics = Dynamics::Vehicle;

/// An option of a plan, for messages: each interface names it its own way ([`OptionName::field`]
/// in the library, the Python package and on the wire; [`OptionName::flag`] on the command
/// line).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OptionName {
    /// [`PlanOptions::scheme`].
    Scheme,
    /// [`PlanOptions::resolution`].
    Resolution,
    /// [`PlanOptions::strict_resolution`].
    StrictResolution,
    /// [`PlanOptions::max_extra_energy_pct`].
    MaxExtraEnergyPct,
}

impl OptionName {
    /// The field's name: `strict_resolution`, ...
    pub fn field(self) -> &'static str {
        match self {
            OptionName::Scheme => "scheme",
            OptionName::Resolution => "resolution",
            OptionName::StrictResolution => "strict_resolution",
            OptionName::MaxExtraEnergyPct => "max_extra_energy_pct",
        }
    }

    /// The command-line flag: `--strict-resolution`, ...
    pub fn flag(self) -> &'static str {
        match self {
            OptionName::Scheme => "--scheme",
            OptionName::Resolution => "--resolution",
            OptionName::StrictResolution => "--strict-resolution",
            OptionName::MaxExtraEnergyPct => "--max-extra-energy-pct",
        }
    }
}

/// Best-effort options ([`PlanOptions::strict_resolution`],
/// [`PlanOptions::max_extra_energy_pct`]) given to a plan that would ignore them: one under the
/// paper's resolution, or of a scheme other than `exact`; or both together on a plan they apply
/// to, where they exclude each other (a strict plan has no energy cap, and the cap would be
/// ignored). Its message names the options by
/// their fields; [`OptionConflict::describe`] names them another way (the command line's
/// flags), with the same words.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", self.describe(OptionName::field))]
pub struct OptionConflict {
    /// The best-effort options given, in the order of [`PlanOptions`]'s fields.
    pub given: Vec<OptionName>,
    /// The plan's resolution requirement.
    pub resolution: ResolutionMode,
    /// The plan's scheme.
    pub scheme: Scheme,
}

impl OptionConflict {
    /// The message with each option named by `name`: "strict_resolution applies to resolution
    /// general only, not to paper" ([`OptionName::field`]), "--strict-resolution applies to
    /// --resolution general only, not to paper" ([`OptionName::flag`]).
    pub fn describe(&self, name: impl Fn(OptionName) -> &'static str) -> String {
        let given = self
            .given
            .iter()
            .map(|&o| name(o))
            .collect::<Vec<_>>()
            .join(" and ");
        let applies = if self.given.len() > 1 {
            "apply"
        } else {
            "applies"
        };
        if self.resolution == ResolutionMode::Paper {
            format!(
                "{given} {applies} to {} general only, not to {}",
                name(OptionName::Resolution),
                self.resolution
            )
        } else if !self.scheme.spec().own_rules {
            format!(
                "{given} {applies} to {} exact only, not to {}",
                name(OptionName::Scheme),
                self.scheme
            )
        } else {
            format!("{given} exclude each other: a strict plan has no energy cap")
        }
    }
}

/// Options of a planning run.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanOptions {
    /// The scheme.
    pub scheme: Scheme,
    /// Largest number of SCA/BCD iterations.
    pub max_iterations: usize,
    /// Stop when the relative change of the objective is below this.
    pub tolerance: f64,
    /// Start from this trajectory instead of the built-in guidance start.
    pub init: Option<Trajectory>,
    /// Settings of the cone-program solver for the comparison schemes (`paper`, `baseline`,
    /// `baseline-exact`).
    pub socp: SocpSettings,
    /// Settings of the cone-program solver for the `exact` scheme, its coarse start and its
    /// repair. Its default skips Clarabel's iterative refinement (about twice as fast, the same
    /// energies); the comparison schemes keep the refinement because their flat or
    /// solver-dependent objectives land on other local optima without it (`baseline-exact`
    /// up to 1.2 % longer).
    pub exact_socp: SocpSettings,
    /// Smallest factor on the proven centre-error bound that the exact scheme tries after
    /// successful steps (1 = always use the proven bound).
    pub min_kappa_scale: f64,
    /// For the exact-geometry schemes without a given start: first solve the mission on slots
    /// about 2 s long and start from that solution (fewer, larger steps make the SCA converge
    /// in far fewer iterations; the fine solve then only polishes). When false, the coarse grid
    /// only provides a feasible start.
    pub coarse: bool,
    /// Try longer steps along each accepted SCA step of the exact scheme (2× and 4×, kept when
    /// still feasible and better). Off gives the plain SCA sequence.
    pub over_relaxation: bool,
    /// Resolution requirement of the exact-geometry schemes (the paper's schemes always use the
    /// paper's, as printed). Default: [`DEFAULT_RESOLUTION`], the general cell as a best effort;
    /// [`PlanOptions::for_scheme`] gives each scheme its own default.
    pub resolution: ResolutionMode,
    /// Wall-time limit of the whole run, s (`None`: none). The coarse levels are skipped once it
    /// has passed; the iterations stop at the first check after it with
    /// [`TerminationReason::TimeLimit`](super::TerminationReason::TimeLimit) and return the last
    /// accepted iterate (feasible on the
    /// exact geometry for the exact-geometry schemes); a phase I that has not found a feasible
    /// start by then fails with [`PlanError::TimeLimit`]. A check comes before every cone
    /// program, so the run ends within about one program's time (~0.1 s at 600 slots) after it.
    pub time_limit_s: Option<f64>,
    /// When a given start ([`PlanOptions::init`]) cannot be repaired, plan from the built-in
    /// start instead (saying so in
    /// [`PlanResult::init_replaced`](super::PlanResult::init_replaced)); when false, fail with
    /// phase I's error.
    pub replace_unrepairable_init: bool,
    /// Under [`ResolutionMode::General`] with the `exact` scheme: refuse a mission whose cell
    /// cannot be held within d_min in every landmark slot ([`PlanError::Infeasible`], naming
    /// the first slot) instead of planning the best effort. The best effort minimises the
    /// resolution deficit ([`crate::shortfall`]) and, at that deficit, the energy, with every
    /// other constraint hard.
    pub strict_resolution: bool,
    /// Best effort only: the plan may use at most this many percent more energy than the
    /// least-energy plan (the `paper` resolution plan); `None`: no cap (the best-resolved plan).
    pub max_extra_energy_pct: Option<f64>,
    /// Best effort only: the energy one metre of resolution deficit is worth, J/m. Large values
    /// make the objective lexicographic (deficit first, then energy).
    pub resolution_weight_j_per_m: f64,
    /// The vehicle model: [`Dynamics::Vehicle`] keeps the acceleration between consecutive slots
    /// within `max_accel_mps2`, from the mission's start velocity on (the exact-geometry schemes
    /// only); [`Dynamics::Paper`] lets the velocity jump, as the paper does.
    /// [`PlanOptions::for_scheme`] gives each scheme its default ([`Scheme::default_dynamics`]).
    pub dynamics: Dynamics,
    /// Plan an altitude per slot for a mission with `altitude = "free"` (the `exact` scheme,
    /// jointly, and `paper`, by the paper's alternation; the plan's [`PlanResult::altitudes_m`](super::PlanResult::altitudes_m)). Off (the
    /// default), such a mission is refused ([`PlanError::AltitudeConflict`]): a caller that flies
    /// the plan's track at one altitude leaves it off. Fixed missions ignore it.
    pub altitude_profile: bool,
}

impl PlanOptions {
    /// The default options with the paper's resolution: the least-energy plan (the paper's
    /// criterion, what `--resolution paper` plans).
    pub fn least_energy() -> Self {
        Self {
            resolution: ResolutionMode::Paper,
            ..Self::default()
        }
    }

    /// The default options with `scheme` and its default resolution
    /// ([`Scheme::default_resolution`]): what a request that names only the scheme plans with.
    pub fn for_scheme(scheme: Scheme) -> Self {
        Self {
            scheme,
            resolution: scheme.default_resolution(),
            dynamics: scheme.default_dynamics(),
            ..Self::default()
        }
    }

    /// Refuses the best-effort options ([`PlanOptions::strict_resolution`],
    /// [`PlanOptions::max_extra_energy_pct`]) where the plan would ignore them: under the
    /// paper's resolution, or with a scheme other than `exact`, and the two together (a strict
    /// plan would ignore the cap). Part of
    /// [`PlanOptions::validate`]; every interface checks its options with it before planning.
    pub fn check_best_effort(&self) -> Result<(), OptionConflict> {
        let mut given = Vec::new();
        if self.strict_resolution {
            given.push(OptionName::StrictResolution);
        }
        if self.max_extra_energy_pct.is_some() {
            given.push(OptionName::MaxExtraEnergyPct);
        }
        let applies = self.resolution == ResolutionMode::General && self.scheme.spec().own_rules;
        if given.is_empty() || (applies && given.len() == 1) {
            return Ok(());
        }
        Err(OptionConflict {
            given,
            resolution: self.resolution,
            scheme: self.scheme,
        })
    }

    /// Checks the numeric options (the error names the first bad one), then the best-effort
    /// options ([`PlanOptions::check_best_effort`]).
    pub fn validate(&self) -> Result<(), PlanError> {
        let bad = |field, value, reason| {
            Err(PlanError::InvalidOption {
                field,
                value,
                reason,
            })
        };
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return bad("tolerance", self.tolerance, "must be a finite number > 0");
        }
        if !(self.min_kappa_scale.is_finite()
            && self.min_kappa_scale > 0.0
            && self.min_kappa_scale <= 1.0)
        {
            return bad(
                "min_kappa_scale",
                self.min_kappa_scale,
                "must lie in (0, 1]",
            );
        }
        if let Some(pct) = self.max_extra_energy_pct {
            if !(pct.is_finite() && pct >= 0.0) {
                return bad(
                    "max_extra_energy_pct",
                    pct,
                    "must be a finite percentage >= 0",
                );
            }
        }
        if !(self.resolution_weight_j_per_m.is_finite() && self.resolution_weight_j_per_m > 0.0) {
            return bad(
                "resolution_weight_j_per_m",
                self.resolution_weight_j_per_m,
                "must be a finite number > 0",
            );
        }
        if let Some(limit) = self.time_limit_s {
            if !(limit.is_finite() && limit > 0.0) {
                return bad(
                    "time_limit_s",
                    limit,
                    "must be a finite number of seconds > 0",
                );
            }
        }
        if !self.scheme.supports(self.dynamics) {
            return Err(PlanError::DynamicsConflict {
                scheme: self.scheme,
                dynamics: self.dynamics,
            });
        }
        self.check_best_effort()?;
        Ok(())
    }

    /// The cone-program settings of this run's scheme.
    pub fn scheme_socp(&self) -> SocpSettings {
        if self.scheme.spec().tuned_socp {
            self.exact_socp
        } else {
            self.socp
        }
    }
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            scheme: Scheme::Exact,
            max_iterations: 200,
            tolerance: 1e-4,
            init: None,
            socp: SocpSettings::default(),
            exact_socp: SocpSettings::exact_geometry(),
            min_kappa_scale: 1.0 / 16.0,
            coarse: true,
            over_relaxation: true,
            resolution: DEFAULT_RESOLUTION,
            time_limit_s: None,
            replace_unrepairable_init: true,
            strict_resolution: false,
            max_extra_energy_pct: None,
            resolution_weight_j_per_m: DEFAULT_RESOLUTION_WEIGHT_J_PER_M,
            dynamics: DEFAULT_DYNAMICS,
            altitude_profile: false,
        }
    }
}

/// When a planning run must stop: [`PlanOptions::time_limit_s`] after it started, or as soon as
/// its stop flag (if any, see [`plan_with_stop`](super::plan_with_stop)) is set.
#[derive(Debug, Clone, Copy)]
pub(super) struct Deadline<'a> {
    pub(super) at: Option<Instant>,
    /// The limit, s (for messages; infinite without one).
    pub(super) limit_s: f64,
    /// Set from outside (another thread, a signal handler) to stop the run early.
    pub(super) stop: Option<&'a AtomicBool>,
}

impl<'a> Deadline<'a> {
    /// `limit_s` after `started` (a limit too large to represent is no limit), or when `stop` is
    /// set.
    pub(super) fn after(
        started: Instant,
        limit_s: Option<f64>,
        stop: Option<&'a AtomicBool>,
    ) -> Self {
        let at = limit_s
            .and_then(|s| Duration::try_from_secs_f64(s).ok())
            .and_then(|d| started.checked_add(d));
        Self {
            at,
            limit_s: limit_s.unwrap_or(f64::INFINITY),
            stop,
        }
    }

    /// Whether it has passed (or the stop flag is set).
    pub(super) fn passed(self) -> bool {
        self.stop.is_some_and(|s| s.load(Ordering::Relaxed))
            || self.at.is_some_and(|at| Instant::now() >= at)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn the_default_is_the_general_best_effort_and_the_comparison_schemes_keep_the_paper() {
        let o = PlanOptions::default();
        assert_eq!(o.resolution, ResolutionMode::General);
        assert_eq!(o.resolution, DEFAULT_RESOLUTION);
        assert!(!o.strict_resolution && o.max_extra_energy_pct.is_none());
        assert_eq!(PlanOptions::for_scheme(Scheme::Exact), o);
        for s in [Scheme::Paper, Scheme::Baseline, Scheme::BaselineExact] {
            let o = PlanOptions::for_scheme(s);
            assert_eq!((o.scheme, o.resolution), (s, ResolutionMode::Paper));
            assert!(o.validate().is_ok());
        }
    }

    #[test]
    fn best_effort_options_are_refused_where_they_would_be_ignored() {
        let general = PlanOptions::default();
        let strict = PlanOptions {
            strict_resolution: true,
            ..general.clone()
        };
        let capped = PlanOptions {
            max_extra_energy_pct: Some(5.0),
            ..general.clone()
        };
        assert!(strict.validate().is_ok() && capped.validate().is_ok());
        let paper = |o: &PlanOptions| PlanOptions {
            resolution: ResolutionMode::Paper,
            ..o.clone()
        };
        assert!(paper(&general).validate().is_ok());
        let both = PlanOptions {
            strict_resolution: true,
            ..paper(&capped)
        };
        let e = both.check_best_effort().unwrap_err();
        assert_eq!(
            e.to_string(),
            "strict_resolution and max_extra_energy_pct apply to resolution general only, not to paper"
        );
        assert_eq!(
            e.describe(OptionName::flag),
            "--strict-resolution and --max-extra-energy-pct apply to --resolution general only, not to paper"
        );
        assert_eq!(both.validate(), Err(PlanError::OptionConflict(e)));
        // both together where they apply: a strict plan would ignore the cap
        let strict_capped = PlanOptions {
            strict_resolution: true,
            ..capped.clone()
        };
        let e = strict_capped.validate().unwrap_err();
        assert_eq!(
            e.to_string(),
            "strict_resolution and max_extra_energy_pct exclude each other: a strict plan has no energy cap"
        );
        // a comparison scheme ignores them under the general resolution too
        let baseline = PlanOptions {
            scheme: Scheme::BaselineExact,
            ..capped
        };
        assert_eq!(
            baseline.validate().unwrap_err().to_string(),
            "max_extra_energy_pct applies to scheme exact only, not to baseline-exact"
        );
    }
}
