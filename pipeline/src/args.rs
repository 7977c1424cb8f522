//! Command-line flags shared by several binaries and services (clap), for the libraries'
//! parameters that have no flags of their own.

use radar_sim::limits::{self, IqLimits};

/// The `--max-iq-gib` / `--max-aperture-gib` flags.
#[derive(clap::Args, Debug, Clone, Copy, PartialEq)]
pub struct IqLimitArgs {
    /// Refuse a run whose IQ (all apertures: pulses × samples per pulse × 8 bytes) exceeds
    /// this many GiB; checked before anything is simulated.
    #[arg(long, value_name = "GIB", default_value_t = limits::DEFAULT_MAX_IQ_GIB)]
    pub max_iq_gib: f64,
    /// Refuse a run in which one aperture (its IQ, plus its look images with
    /// `processing.save_complex`) would take more than this many GiB of memory.
    #[arg(long, value_name = "GIB", default_value_t = limits::DEFAULT_MAX_APERTURE_GIB)]
    pub max_aperture_gib: f64,
}

impl Default for IqLimitArgs {
    fn default() -> Self {
        Self {
            max_iq_gib: limits::DEFAULT_MAX_IQ_GIB,
            max_aperture_gib: limits::DEFAULT_MAX_APERTURE_GIB,
        }
    }
}

impl IqLimitArgs {
    /// The limits; the error names the bad flag.
    pub fn limits(&self) -> radar_sim::Result<IqLimits> {
        IqLimits::from_gib(self.max_iq_gib, self.max_aperture_gib)
    }
}

/// Refuses best-effort options that the plan would ignore (the library's rule,
/// [`planner::PlanOptions::check_best_effort`]), naming them by their command-line flags:
/// "--strict-resolution applies to --resolution general only, not to paper".
pub fn check_best_effort_flags(options: &planner::PlanOptions) -> anyhow::Result<()> {
    options
        .check_best_effort()
        .map_err(|e| anyhow::anyhow!(e.describe(planner::OptionName::flag)))
}

/// The clap value parser of a string-valued enum of the maths crates (which do not depend on
/// clap): the enum's own names (strum's `VARIANTS`) become clap's possible values, so a bad
/// value is refused with the flag's name and the list of valid values, and `--help` lists them.
pub fn enum_parser<E>() -> impl clap::builder::TypedValueParser<Value = E>
where
    E: strum::VariantNames + std::str::FromStr + Clone + Send + Sync + 'static,
    E::Err: std::error::Error + Send + Sync + 'static,
{
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(E::VARIANTS.iter().copied())
        .try_map(|name| name.parse::<E>())
}

/// The clap value parser of a flag that names a role ([`crate::protocol::Role`]), restricted to
/// `roles`: their names (as on the wire) are clap's possible values, so another name, or a
/// role the flag does not take, is refused with the flag's name and the list, and `--help`
/// lists them.
pub fn role_parser(
    roles: &'static [crate::protocol::Role],
) -> impl clap::builder::TypedValueParser<Value = crate::protocol::Role> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(roles.iter().map(|r| r.as_str()))
        .try_map(|name| name.parse::<crate::protocol::Role>())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use planner::evaluate::ResolutionMode;
    use planner::Scheme;

    #[derive(Parser, Debug)]
    struct Flags {
        #[arg(long, default_value = "exact", value_parser = enum_parser::<Scheme>())]
        scheme: Scheme,
        #[arg(long, default_value = "paper", value_parser = enum_parser::<ResolutionMode>())]
        resolution: ResolutionMode,
    }

    #[test]
    fn every_name_parses_and_a_bad_one_names_the_flag_and_the_values() {
        let f = Flags::try_parse_from(["x"]).unwrap();
        assert_eq!(
            (f.scheme, f.resolution),
            (Scheme::Exact, ResolutionMode::Paper)
        );
        for s in Scheme::ALL {
            let f = Flags::try_parse_from(["x", "--scheme", s.name()]).unwrap();
            assert_eq!(f.scheme, s);
        }
        for r in ResolutionMode::ALL {
            let f = Flags::try_parse_from(["x", "--resolution", r.name()]).unwrap();
            assert_eq!(f.resolution, r);
        }
        let e = Flags::try_parse_from(["x", "--scheme", "fast"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("--scheme"), "{e}");
        assert!(e.contains("exact, paper, baseline, baseline-exact"), "{e}");
        let e = Flags::try_parse_from(["x", "--resolution", "Paper"])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--resolution") && e.contains("paper, general"),
            "{e}"
        );
    }

    #[derive(Parser, Debug)]
    struct RoleFlags {
        #[arg(long, value_parser = role_parser(&crate::protocol::Role::CHILDREN))]
        external: Vec<crate::protocol::Role>,
    }

    /// Every role the flag takes parses to itself; a role it does not take and a name that
    /// is no role are refused naming the flag and the roles it takes.
    #[test]
    fn a_role_flag_takes_its_roles_only() {
        use crate::protocol::Role;
        for r in Role::CHILDREN {
            let f = RoleFlags::try_parse_from(["x", "--external", r.as_str()]).unwrap();
            assert_eq!(f.external, [r]);
        }
        for bad in ["launcher", "router", "Echo", "forge"] {
            let e = RoleFlags::try_parse_from(["x", "--external", bad])
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("--external") && e.contains("planner, echo, processor, bridge"),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn best_effort_flags_are_refused_with_the_paper_resolution() {
        use planner::evaluate::ResolutionMode::{General, Paper};
        let check = |resolution, strict_resolution, max_extra_energy_pct| {
            check_best_effort_flags(&planner::PlanOptions {
                resolution,
                strict_resolution,
                max_extra_energy_pct,
                ..Default::default()
            })
        };
        assert!(check(General, true, None).is_ok());
        assert!(check(General, false, Some(5.0)).is_ok());
        assert!(check(Paper, false, None).is_ok());
        let e = check(Paper, true, Some(5.0)).unwrap_err().to_string();
        assert!(
            e.contains("--strict-resolution and --max-extra-energy-pct") && e.contains("paper"),
            "{e}"
        );
        let e = check(Paper, false, Some(5.0)).unwrap_err().to_string();
        assert!(e.starts_with("--max-extra-energy-pct applies"), "{e}");
    }
}
