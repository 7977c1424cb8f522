//! Whether a session uses Zenoh's multicast scouting: off unless asked for.
//!
//! Zenoh's own default is on: a process then answers and sends multicast scouting messages on
//! the local network and connects to every peer or router it finds, so anyone on that network
//! can join it. Every cellsar process has it off unless `--multicast-scouting` is given or a
//! `--config` file sets `scouting.multicast.enabled` itself; `--no-multicast-scouting` turns it
//! off over the file's value.

use std::path::Path;

use super::error::ConfigError;
use crate::zenoh_error::ZenohError;

/// Zenoh's configuration key of multicast scouting.
pub const MULTICAST_SCOUTING_KEY: &str = "scouting/multicast/enabled";

/// The multicast scouting setting to write into a configuration (`"true"` or `"false"`, with
/// what asked for it), or `None` to keep the `--config` file's own value.
pub(super) fn setting(
    on: bool,
    off: bool,
    file: Option<&Path>,
) -> Result<Option<(&'static str, &'static str)>, ConfigError> {
    if on {
        return Ok(Some(("true", "--multicast-scouting")));
    }
    if off {
        return Ok(Some(("false", "--no-multicast-scouting")));
    }
    match file {
        Some(f) if file_sets_scouting(f)? => Ok(None),
        _ => Ok(Some(("false", "the default: multicast scouting off"))),
    }
}

/// Whether the configuration file `path` sets `scouting.multicast.enabled` itself. Read as
/// Zenoh reads it (JSON5 for `.json`/`.json5`, YAML for `.yaml`/`.yml`, the same crates), since
/// Zenoh's parsed configuration cannot tell a value the file set from its own default.
fn file_sets_scouting(path: &Path) -> Result<bool, ConfigError> {
    let bad = |source: ZenohError| ConfigError::File {
        path: path.to_path_buf(),
        source,
    };
    let text = std::fs::read_to_string(path).map_err(|e| bad(ZenohError::new(e)))?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    let value: serde_json::Value = match ext {
        "yaml" | "yml" => serde_yaml::from_str(&text).map_err(|e| bad(ZenohError::new(e)))?,
        _ => json5::from_str(&text).map_err(|e| bad(ZenohError::new(e)))?,
    };
    Ok(value
        .pointer("/scouting/multicast/enabled")
        .is_some_and(|v| !v.is_null()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::zconfig::ZenohArgs;
    use clap::Parser;

    #[derive(clap::Parser, Debug)]
    struct Cli {
        #[command(flatten)]
        zenoh: ZenohArgs,
    }

    fn scouting(a: &ZenohArgs) -> String {
        a.to_config()
            .unwrap()
            .get_json(MULTICAST_SCOUTING_KEY)
            .unwrap()
    }

    fn parse(args: &[&str]) -> Result<ZenohArgs, clap::Error> {
        Cli::try_parse_from(std::iter::once("x").chain(args.iter().copied())).map(|c| c.zenoh)
    }

    /// Off by default (Zenoh's own default is on), in every mode; on only when asked for.
    #[test]
    fn multicast_scouting_is_off_unless_asked_for() {
        // Zenoh leaves it unset (null), which it takes as on
        assert_ne!(
            zenoh::Config::default()
                .get_json(MULTICAST_SCOUTING_KEY)
                .unwrap(),
            "false",
            "Zenoh's own default changed: revisit the documentation"
        );
        for args in [
            &[][..],
            &["-m", "client"],
            &["-m", "router", "-l", "tcp/127.0.0.1:7447"],
            &["-e", "tcp/127.0.0.1:7447"],
            &["--no-multicast-scouting"],
        ] {
            assert_eq!(scouting(&parse(args).unwrap()), "false", "{args:?}");
        }
        for args in [
            &["--multicast-scouting"][..],
            &["-m", "client", "--multicast-scouting"],
        ] {
            let a = parse(args).unwrap();
            assert_eq!(scouting(&a), "true", "{args:?}");
            // passed on to a child as given
            let back = parse(
                &a.to_cli_args()
                    .iter()
                    .map(String::as_str)
                    .collect::<Vec<_>>(),
            )
            .unwrap();
            assert_eq!(back, a);
        }
        let e = parse(&["--multicast-scouting", "--no-multicast-scouting"]).unwrap_err();
        assert!(e.to_string().contains("--multicast-scouting"), "{e}");
    }

    /// A configuration file decides when it sets `scouting.multicast.enabled` (JSON5 or YAML);
    /// a file that does not gets it off; the flags override the file.
    #[test]
    fn a_configuration_file_decides_when_it_sets_it() {
        let dir = tempfile::tempdir().unwrap();
        let file = |name: &str, text: &str| {
            let p = dir.path().join(name);
            std::fs::write(&p, text).unwrap();
            p
        };
        let with = |p: &std::path::Path, on: bool, off: bool| ZenohArgs {
            config: Some(p.to_path_buf()),
            multicast_scouting: on,
            no_multicast_scouting: off,
            ..ZenohArgs::default()
        };
        let on = file(
            "on.json5",
            "{ mode: 'peer', scouting: { multicast: { enabled: true } } }",
        );
        let on_yaml = file(
            "on.yaml",
            "mode: peer\nscouting:\n  multicast:\n    enabled: true\n",
        );
        let off = file(
            "off.json",
            r#"{ "scouting": { "multicast": { "enabled": false } } }"#,
        );
        let unset = file(
            "unset.json5",
            "{ mode: 'peer', scouting: { multicast: { address: '224.0.0.224:17446' } } }",
        );
        assert_eq!(scouting(&with(&on, false, false)), "true");
        assert_eq!(scouting(&with(&on_yaml, false, false)), "true");
        assert_eq!(scouting(&with(&off, false, false)), "false");
        assert_eq!(scouting(&with(&unset, false, false)), "false");
        assert_eq!(scouting(&with(&on, false, true)), "false");
        assert_eq!(scouting(&with(&off, true, false)), "true");
        assert_eq!(scouting(&with(&unset, true, false)), "true");
        // the deployment's configurations set it off themselves
        let deploy = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../pipeline/deploy");
        for f in [
            "router.json5",
            "client.json5",
            "tls/router.json5",
            "tls/echo.json5",
        ] {
            assert!(file_sets_scouting(&deploy.join(f)).unwrap(), "{f}");
            assert_eq!(
                scouting(&with(&deploy.join(f), false, false)),
                "false",
                "{f}"
            );
        }
    }
}
