//! The schemes and the table of what the planner knows of each ([`SchemeSpec`]): one row per
//! scheme in place of a match in every module. A scheme's iterations are a step of the executor
//! ([`super::executor`]), run by its rules in [`super::table`].

use serde::{Deserialize, Serialize};

use crate::evaluate::{Dynamics, ResolutionMode};
use crate::schemes::exact::ExactObjective;
use crate::schemes::paper::PaperObjective;

use super::options::{DEFAULT_DYNAMICS, DEFAULT_RESOLUTION};

/// Which planner to run. Its names (`exact`, `paper`, `baseline`, `baseline-exact`) are the
/// same in serde, [`std::str::FromStr`], [`std::fmt::Display`] and `VARIANTS` (strum).
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    strum::EnumString,
    strum::Display,
    strum::IntoStaticStr,
    strum::VariantNames,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum Scheme {
    /// SCA on the exact geometry; every iterate feasible on it (the default).
    Exact,
    /// The paper's Algorithm 1 as printed: SCA + BCD between (p5) and (p6).
    Paper,
    /// The paper's baseline: least flight distance under the paper's convexification.
    Baseline,
    /// Least flight distance on the exact geometry (a baseline that is truly feasible).
    BaselineExact,
}

impl Scheme {
    /// All schemes.
    pub const ALL: [Scheme; 4] = [
        Scheme::Exact,
        Scheme::Paper,
        Scheme::Baseline,
        Scheme::BaselineExact,
    ];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        self.into()
    }

    /// The vehicle model of this scheme unless a request names one: [`DEFAULT_DYNAMICS`] for the
    /// exact-geometry schemes, the paper's model for `paper` and `baseline` (which can only use
    /// it).
    pub fn default_dynamics(self) -> Dynamics {
        self.spec().default_dynamics
    }

    /// Whether the scheme can plan under `dynamics` (`paper` and `baseline` have the paper's
    /// model only).
    pub fn supports(self, dynamics: Dynamics) -> bool {
        self.spec().exact_geometry || dynamics == Dynamics::Paper
    }

    /// The resolution requirement of this scheme unless a request names one:
    /// [`DEFAULT_RESOLUTION`] for `exact`, the paper's for the comparison schemes (which
    /// reproduce the paper; `paper` and `baseline` can only use it).
    pub fn default_resolution(self) -> ResolutionMode {
        self.spec().default_resolution
    }

    /// Its row of [`SCHEMES`].
    pub(crate) fn spec(self) -> &'static SchemeSpec {
        match self {
            Scheme::Exact => &SCHEMES[0],
            Scheme::Paper => &SCHEMES[1],
            Scheme::Baseline => &SCHEMES[2],
            Scheme::BaselineExact => &SCHEMES[3],
        }
    }
}

/// How a scheme iterates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Family {
    /// Sequential convex programming on the exact geometry (`schemes::exact`): every iterate
    /// feasible there, from a feasible start (phase I).
    ExactGeometry,
    /// The paper's Algorithm 1: block-coordinate descent between (p5) and (p6) as printed.
    PaperBcd,
}

/// How a scheme plans the altitude of every slot (a mission with `altitude = "free"` and
/// [`super::PlanOptions::altitude_profile`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FreeAltitude {
    /// The track and the altitudes jointly, by the exact SCA ([`super::altitude`]).
    Joint,
    /// The paper's alternation between the altitudes and the track ([`super::alternating`]).
    Alternating,
}

/// What the planner knows of a scheme: its row of [`SCHEMES`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SchemeSpec {
    pub scheme: Scheme,
    /// What it minimises: the energy (J) or the flight distance (m).
    pub objective: ExactObjective,
    pub family: Family,
    /// Whether it keeps the exact geometry's constraints (and can therefore plan under the
    /// general resolution and [`Dynamics::Vehicle`]).
    pub exact_geometry: bool,
    /// The `exact` scheme's own rules: phase I's whole-slot merit and trust region, the 20 s
    /// coarse level and an optimised coarse start, the best effort under the general
    /// resolution. The comparison schemes keep the earlier rules, so that their starts and the
    /// results compared with the paper do not change.
    pub own_rules: bool,
    pub default_resolution: ResolutionMode,
    pub default_dynamics: Dynamics,
    /// How it plans per-slot altitudes (`None`: at the fixed altitude only).
    pub free_altitude: Option<FreeAltitude>,
    /// Whether it solves with [`super::PlanOptions::exact_socp`] (tuned for the exact
    /// geometry) rather than [`super::PlanOptions::socp`].
    pub tuned_socp: bool,
}

impl SchemeSpec {
    /// The objective of Algorithm 1's (p5) for a BCD scheme.
    pub fn paper_objective(&self) -> PaperObjective {
        match self.objective {
            ExactObjective::Energy => PaperObjective::Energy,
            ExactObjective::Distance => PaperObjective::Distance,
        }
    }
}

/// The scheme table, in the order of [`Scheme::ALL`].
pub(crate) const SCHEMES: [SchemeSpec; 4] = [
    SchemeSpec {
        scheme: Scheme::Exact,
        objective: ExactObjective::Energy,
        family: Family::ExactGeometry,
        exact_geometry: true,
        own_rules: true,
        default_resolution: DEFAULT_RESOLUTION,
        default_dynamics: DEFAULT_DYNAMICS,
        free_altitude: Some(FreeAltitude::Joint),
        tuned_socp: true,
    },
    SchemeSpec {
        scheme: Scheme::Paper,
        objective: ExactObjective::Energy,
        family: Family::PaperBcd,
        exact_geometry: false,
        own_rules: false,
        default_resolution: ResolutionMode::Paper,
        default_dynamics: Dynamics::Paper,
        free_altitude: Some(FreeAltitude::Alternating),
        tuned_socp: false,
    },
    SchemeSpec {
        scheme: Scheme::Baseline,
        objective: ExactObjective::Distance,
        family: Family::PaperBcd,
        exact_geometry: false,
        own_rules: false,
        default_resolution: ResolutionMode::Paper,
        default_dynamics: Dynamics::Paper,
        free_altitude: None,
        tuned_socp: false,
    },
    SchemeSpec {
        scheme: Scheme::BaselineExact,
        objective: ExactObjective::Distance,
        family: Family::ExactGeometry,
        exact_geometry: true,
        own_rules: false,
        default_resolution: ResolutionMode::Paper,
        default_dynamics: DEFAULT_DYNAMICS,
        free_altitude: None,
        tuned_socp: false,
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_has_one_row_per_scheme_in_the_order_of_all() {
        assert_eq!(SCHEMES.len(), Scheme::ALL.len());
        for (row, scheme) in SCHEMES.iter().zip(Scheme::ALL) {
            assert_eq!(row.scheme, scheme);
            assert_eq!(scheme.spec().scheme, scheme);
        }
    }
}
