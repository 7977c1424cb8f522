//! Zenoh configuration from the command line, following the zenoh examples' conventions.
//!
//! Every cellsar binary flattens [`ZenohArgs`] into its clap parser:
//!
//! ```text
//! -m, --mode <peer|client|router>   session mode [default: peer]
//! -e, --connect <ENDPOINT>          endpoints to connect to (repeatable)
//! -l, --listen <ENDPOINT>           endpoints to listen on (repeatable)
//! -c, --config <FILE>               a Zenoh configuration file (JSON5)
//!     --multicast-scouting          find and be found by peers on the local network
//!     --no-multicast-scouting       no multicast scouting (the default; overrides a file)
//!     --zenoh-max-message-bytes <BYTES>
//!                                   largest message Zenoh reassembles [default: 64 MiB + 64 KiB]
//! ```
//!
//! Without `--config`, the session is an embedded peer that listens on the loopback interface
//! only (`tcp/127.0.0.1:0`) and needs no router. With `--config`, the file is the base and the
//! flags given on the command line override it.
//!
//! Multicast scouting is off unless `--multicast-scouting` is given or a `--config` file sets
//! `scouting.multicast.enabled` itself (Zenoh's own default is on): a process joins only the
//! peers and routers it is told about (module `scouting`).
//!
//! Every endpoint (of `-e`, `-l` or the file) may carry only the options of an allow-list
//! ([`ALLOWED_ENDPOINT_METADATA`], [`ALLOWED_ENDPOINT_CONFIG`]; [`ConfigError::EndpointOption`]
//! names the option). Once a `--config` file enables TLS or access control, nothing may
//! downgrade it: a non-`tls/` endpoint, multicast scouting, a client that does not check the
//! router's name, one that connects to a name a public CA may certify, a TLS listener without
//! mutual TLS, access control that allows by default, and any TLS or access-control setting
//! not on the allow-list are refused, naming the flag or the file's setting (module `secure`,
//! [`ConfigError::Downgrade`]).
//!
//! Every configuration built here bounds what a peer can make this process allocate: Zenoh
//! reassembles a fragmented message in memory before anyone sees it, up to
//! `transport/link/rx/max_message_size` (1 GiB by Zenoh's default). It is set to
//! [`DEFAULT_MAX_MESSAGE_BYTES`], room for the largest message this crate decodes, unless
//! `--zenoh-max-message-bytes` says otherwise (at most [`MAX_MAX_MESSAGE_BYTES`], 256 MiB +
//! 64 KiB) or a `--config` file sets a value of its own.

use std::path::PathBuf;

use zenoh::Config;

use crate::envelope::{HEADER_LEN, MAX_BODY_BYTES};
use crate::frame::{DEFAULT_MAX_FRAME_BYTES, MAX_FRAME_HARD_LIMIT, WIRE_PREFIX_LEN};
use crate::zenoh_error::ZenohError;

mod describe;
mod error;
mod scouting;
mod secure;

pub use describe::{describe, effective_endpoints, effective_mode, waiting_client_json5};
pub use error::ConfigError;
pub use scouting::MULTICAST_SCOUTING_KEY;
pub use secure::{
    is_private_name, what_secures, ALLOWED_ENDPOINT_CONFIG, ALLOWED_ENDPOINT_METADATA,
    PRIVATE_DNS_SUFFIXES,
};

/// The Zenoh session mode.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Peer: talks to other peers directly (and to routers).
    Peer,
    /// Client: talks only through a router.
    Client,
    /// Router: routes for clients and peers.
    Router,
}

impl Mode {
    /// The mode as Zenoh and the `-m` flag spell it.
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Peer => "peer",
            Mode::Client => "client",
            Mode::Router => "router",
        }
    }
}

/// The listen endpoint used when neither `--listen` nor `--config` is given.
pub const DEFAULT_LISTEN: &str = "tcp/127.0.0.1:0";

/// Zenoh's configuration key of the largest message it reassembles from fragments.
pub const MAX_MESSAGE_SIZE_KEY: &str = "transport/link/rx/max_message_size";

/// Default of `--zenoh-max-message-bytes` (64 MiB + 64 KiB): room for the largest message
/// this crate decodes by default, with its headers: a body of [`MAX_BODY_BYTES`] (64 MiB, the
/// plan message's limit) or a frame of [`DEFAULT_MAX_FRAME_BYTES`] (64 MiB; the services'
/// frames default to 4 MiB, `frame::SERVICE_MAX_FRAME_BYTES`). A process that takes frames
/// above 64 MiB (`--max-frame-bytes`) needs a larger value:
/// [`ZenohArgs::with_room_for`].
pub const DEFAULT_MAX_MESSAGE_BYTES: usize = (64 << 20) + (64 << 10);

/// Smallest `--zenoh-max-message-bytes` accepted (64 KiB: one Zenoh batch).
pub const MIN_MAX_MESSAGE_BYTES: usize = 64 << 10;

/// Largest `--zenoh-max-message-bytes` accepted: 256 MiB + 64 KiB, four times the default.
/// Zenoh keeps a reassembly buffer for each priority and reliability of each link (16 per
/// session), each up to this size, so a peer can make a process hold many times it; Zenoh's
/// own 1 GiB would let one session claim more memory than the hosts have. 256 MiB is room
/// for frames four times the largest this crate decodes by default ([`DEFAULT_MAX_FRAME_BYTES`])
/// and far above any frame a mission needs (a frame need hold only one pulse; the services'
/// frames default to 4 MiB). Frames above 256 MiB (up to [`MAX_FRAME_HARD_LIMIT`]) still
/// travel over iceoryx2 on one host, but not over Zenoh.
pub const MAX_MAX_MESSAGE_BYTES: usize = (256 << 20) + (64 << 10);

const _: () = assert!(DEFAULT_MAX_MESSAGE_BYTES >= MAX_BODY_BYTES + HEADER_LEN);
const _: () = assert!(DEFAULT_MAX_MESSAGE_BYTES >= DEFAULT_MAX_FRAME_BYTES + WIRE_PREFIX_LEN);
const _: () = assert!(MIN_MAX_MESSAGE_BYTES <= DEFAULT_MAX_MESSAGE_BYTES);
const _: () = assert!(DEFAULT_MAX_MESSAGE_BYTES <= MAX_MAX_MESSAGE_BYTES);
const _: () = assert!(MAX_MAX_MESSAGE_BYTES <= MAX_FRAME_HARD_LIMIT + WIRE_PREFIX_LEN);

/// Zenoh flags shared by every cellsar binary (flatten with `#[command(flatten)]`).
#[derive(clap::Args, Clone, Debug, Default, PartialEq, Eq)]
pub struct ZenohArgs {
    /// A Zenoh configuration file (JSON5); the other flags override it.
    #[arg(id = "zenoh_config", short = 'c', long = "config", value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// The Zenoh session mode [default: peer].
    #[arg(id = "zenoh_mode", short = 'm', long = "mode", value_enum)]
    pub mode: Option<Mode>,
    /// Endpoints to connect to, e.g. tcp/192.168.1.2:7447 (repeatable).
    #[arg(
        id = "zenoh_connect",
        short = 'e',
        long = "connect",
        value_name = "ENDPOINT"
    )]
    pub connect: Vec<String>,
    /// Endpoints to listen on, e.g. tcp/127.0.0.1:7447 (repeatable).
    #[arg(
        id = "zenoh_listen",
        short = 'l',
        long = "listen",
        value_name = "ENDPOINT"
    )]
    pub listen: Vec<String>,
    /// Find and be found by Zenoh peers and routers on the local network by multicast
    /// scouting, and connect to them [default: off, unless the --config file turns it on].
    #[arg(
        id = "zenoh_multicast_scouting",
        long = "multicast-scouting",
        conflicts_with = "zenoh_no_multicast_scouting"
    )]
    pub multicast_scouting: bool,
    /// No multicast scouting (the default), also where the --config file turns it on.
    #[arg(id = "zenoh_no_multicast_scouting", long = "no-multicast-scouting")]
    pub no_multicast_scouting: bool,
    /// Largest message Zenoh reassembles from its fragments, in bytes; larger ones are
    /// dropped before they are allocated [default: 67174400 (64 MiB + 64 KiB), or the
    /// --config file's own value; at most 268500992 (256 MiB + 64 KiB)]. Raise it with
    /// --max-frame-bytes above 64 MiB.
    #[arg(
        id = "zenoh_max_message_bytes",
        long = "zenoh-max-message-bytes",
        value_name = "BYTES"
    )]
    pub max_message_bytes: Option<usize>,
}

impl ZenohArgs {
    /// Args for an isolated session: peer, no multicast scouting, the given listen and
    /// connect endpoints (tests and local pipelines).
    pub fn isolated(listen: &[String], connect: &[String]) -> Self {
        ZenohArgs {
            config: None,
            mode: Some(Mode::Peer),
            connect: connect.to_vec(),
            listen: listen.to_vec(),
            multicast_scouting: false,
            no_multicast_scouting: true,
            max_message_bytes: None,
        }
    }

    /// The same flags with room for messages of `bytes` bytes: `--zenoh-max-message-bytes`
    /// raised to `bytes` if it (or its default) is smaller. For a process that takes frames
    /// of `--max-frame-bytes` N: `with_room_for(N + frame::WIRE_PREFIX_LEN)`. Above
    /// [`MAX_MAX_MESSAGE_BYTES`], [`to_config`](Self::to_config) refuses the result.
    #[must_use]
    pub fn with_room_for(mut self, bytes: usize) -> Self {
        let now = self.max_message_bytes.unwrap_or(DEFAULT_MAX_MESSAGE_BYTES);
        if bytes > now {
            self.max_message_bytes = Some(bytes);
        }
        self
    }

    /// The flags as command-line arguments (to pass them on to a child process).
    pub fn to_cli_args(&self) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(c) = &self.config {
            v.push("--config".to_string());
            v.push(c.display().to_string());
        }
        if let Some(m) = self.mode {
            v.push("--mode".to_string());
            v.push(m.as_str().to_string());
        }
        for e in &self.connect {
            v.push("--connect".to_string());
            v.push(e.clone());
        }
        for l in &self.listen {
            v.push("--listen".to_string());
            v.push(l.clone());
        }
        if self.multicast_scouting {
            v.push("--multicast-scouting".to_string());
        }
        if self.no_multicast_scouting {
            v.push("--no-multicast-scouting".to_string());
        }
        if let Some(n) = self.max_message_bytes {
            v.push("--zenoh-max-message-bytes".to_string());
            v.push(n.to_string());
        }
        v
    }

    /// Builds the Zenoh configuration.
    pub fn to_config(&self) -> Result<Config, ConfigError> {
        let mut config = match &self.config {
            Some(path) => Config::from_file(path).map_err(|e| ConfigError::File {
                path: path.clone(),
                source: e.into(),
            })?,
            None => Config::default(),
        };
        // what the file enables (TLS, access control) no flag may take away
        let secured = self.config.as_ref().and(what_secures(&config));
        let mode = self.mode.or(if self.config.is_none() {
            Some(Mode::Peer)
        } else {
            None
        });
        if let Some(m) = mode {
            insert(&mut config, "mode", &json_str(m.as_str()), "--mode")?;
        }
        check_endpoints("--connect", &self.connect)?;
        check_endpoints("--listen", &self.listen)?;
        if !self.connect.is_empty() {
            insert(
                &mut config,
                "connect/endpoints",
                &json_list(&self.connect),
                "--connect",
            )?;
        }
        if !self.listen.is_empty() {
            insert(
                &mut config,
                "listen/endpoints",
                &json_list(&self.listen),
                "--listen",
            )?;
        } else if self.config.is_none() && mode != Some(Mode::Client) {
            insert(
                &mut config,
                "listen/endpoints",
                &json_list(&[DEFAULT_LISTEN.to_string()]),
                "default listen endpoint",
            )?;
        }
        if let Some((value, what)) = scouting::setting(
            self.multicast_scouting,
            self.no_multicast_scouting,
            self.config.as_deref(),
        )? {
            insert(&mut config, MULTICAST_SCOUTING_KEY, value, what)?;
        }
        if let Some(n) = self.max_message_size(&config)? {
            insert(
                &mut config,
                MAX_MESSAGE_SIZE_KEY,
                &n.to_string(),
                "--zenoh-max-message-bytes",
            )?;
        }
        secure::check(self, &config, secured)?;
        Ok(config)
    }

    /// What the `--config` file enables of TLS and access control, in words (`None`: no file,
    /// or a file that enables neither); an error when the file cannot be read.
    pub fn secured_by(&self) -> Result<Option<&'static str>, ConfigError> {
        match &self.config {
            Some(path) => Config::from_file(path)
                .map(|c| what_secures(&c))
                .map_err(|e| ConfigError::File {
                    path: path.clone(),
                    source: e.into(),
                }),
            None => Ok(None),
        }
    }

    /// The largest message to set in `config`: the flag's (checked), else the default unless
    /// a `--config` file set a value of its own (one that differs from Zenoh's default);
    /// `None` keeps the file's.
    fn max_message_size(&self, config: &Config) -> Result<Option<usize>, ConfigError> {
        if let Some(n) = self.max_message_bytes {
            if !(MIN_MAX_MESSAGE_BYTES..=MAX_MAX_MESSAGE_BYTES).contains(&n) {
                return Err(ConfigError::OutOfRange {
                    flag: "--zenoh-max-message-bytes",
                    value: n.to_string(),
                    reason: format!(
                        "must be in {MIN_MAX_MESSAGE_BYTES}..={MAX_MAX_MESSAGE_BYTES} bytes"
                    ),
                });
            }
            return Ok(Some(n));
        }
        let zenoh_default = Config::default().get_json(MAX_MESSAGE_SIZE_KEY).ok();
        let own =
            self.config.is_some() && config.get_json(MAX_MESSAGE_SIZE_KEY).ok() != zenoh_default;
        Ok((!own).then_some(DEFAULT_MAX_MESSAGE_BYTES))
    }
}

fn json_str(s: &str) -> String {
    serde_json::Value::String(s.to_string()).to_string()
}

fn json_list(v: &[String]) -> String {
    serde_json::Value::Array(
        v.iter()
            .map(|s| serde_json::Value::String(s.clone()))
            .collect(),
    )
    .to_string()
}

fn insert(
    config: &mut Config,
    key: &'static str,
    value: &str,
    what: &'static str,
) -> Result<(), ConfigError> {
    config
        .insert_json5(key, value)
        .map_err(|e| ConfigError::Setting {
            what,
            key,
            value: value.to_string(),
            source: e.into(),
        })
}

/// Checks each endpoint of `flag` on its own, so that the error names the bad one.
fn check_endpoints(flag: &'static str, endpoints: &[String]) -> Result<(), ConfigError> {
    for e in endpoints {
        e.parse::<zenoh::config::EndPoint>()
            .map_err(|err| ConfigError::Flag {
                flag,
                value: e.clone(),
                source: ZenohError::new(err),
            })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(clap::Parser, Debug)]
    struct Cli {
        #[command(flatten)]
        zenoh: ZenohArgs,
        #[command(flatten)]
        iox: crate::iox::IoxArgs,
    }

    #[test]
    fn zenoh_and_iox_flags_fit_in_one_parser() {
        use clap::CommandFactory;
        Cli::command().debug_assert();
        let cli = Cli::try_parse_from([
            "x",
            "-c",
            "z.json5",
            "--iox-config",
            "i.toml",
            "--iox-prefix",
            "p_",
        ])
        .unwrap();
        assert_eq!(
            cli.zenoh.config.as_deref(),
            Some(std::path::Path::new("z.json5"))
        );
        assert_eq!(cli.iox.prefix.as_deref(), Some("p_"));
        let back =
            Cli::try_parse_from(std::iter::once("x".to_string()).chain(cli.iox.to_cli_args()))
                .unwrap();
        assert_eq!(back.iox, cli.iox);
    }

    #[test]
    fn parses_the_example_flags() {
        let cli = Cli::try_parse_from([
            "x",
            "-m",
            "client",
            "-e",
            "tcp/127.0.0.1:7447",
            "-e",
            "tcp/127.0.0.1:7448",
            "--no-multicast-scouting",
        ])
        .unwrap();
        assert_eq!(cli.zenoh.mode, Some(Mode::Client));
        assert_eq!(cli.zenoh.connect.len(), 2);
        let c = cli.zenoh.to_config().unwrap();
        assert_eq!(c.get_json("mode").unwrap(), "\"client\"");
        assert!(c.get_json("connect/endpoints").unwrap().contains("7448"));
        assert_eq!(c.get_json("scouting/multicast/enabled").unwrap(), "false");
        // client mode: no default listener
        assert_eq!(
            c.get_json("listen/endpoints").unwrap(),
            cli_default_listen()
        );
        let back =
            Cli::try_parse_from(std::iter::once("x".to_string()).chain(cli.zenoh.to_cli_args()))
                .unwrap();
        assert_eq!(back.zenoh, cli.zenoh);
    }

    fn cli_default_listen() -> String {
        Config::default().get_json("listen/endpoints").unwrap()
    }

    #[test]
    fn default_is_a_loopback_peer() {
        let c = ZenohArgs::default().to_config().unwrap();
        assert_eq!(c.get_json("mode").unwrap(), "\"peer\"");
        assert!(c
            .get_json("listen/endpoints")
            .unwrap()
            .contains("tcp/127.0.0.1:0"));
    }

    /// What a person sees of a bad flag or file (the error and its cause, printed as the
    /// binaries print it): one line naming the flag or file, without Zenoh's Debug output
    /// or source paths.
    #[test]
    fn zenoh_messages_lose_debug_output_and_source_paths() {
        use cellsar_error::error_chain;
        let a = ZenohArgs {
            connect: vec!["tcp/127.0.0.1:7447".into(), "garbage".into()],
            ..Default::default()
        };
        let e = error_chain(&a.to_config().unwrap_err());
        assert!(
            e.starts_with("invalid Zenoh configuration: --connect garbage: "),
            "{e}"
        );
        for noise in [".rs:", "Message {", "registry", "\n", "Json5Err"] {
            assert!(!e.contains(noise), "{noise:?} in {e}");
        }
        // a file with a bad endpoint and a file that does not parse: one clean line each
        let dir = tempfile::tempdir().unwrap();
        for (name, text) in [
            (
                "ep.json5",
                "{ mode: 'peer', listen: { endpoints: ['garbage'] } }",
            ),
            ("syntax.json5", "{ mode: 'peer', bogus: 1 "),
            ("mode.json5", "{ mode: 'nonsense' }"),
        ] {
            let p = dir.path().join(name);
            std::fs::write(&p, text).unwrap();
            let a = ZenohArgs {
                config: Some(p),
                ..Default::default()
            };
            let e = error_chain(&a.to_config().unwrap_err());
            assert!(e.contains(name), "{e}");
            for noise in [".rs:", "Message {", "\n"] {
                assert!(!e.contains(noise), "{noise:?} in {e}");
            }
        }
    }

    #[test]
    fn bad_endpoint_and_file_are_named() {
        let a = ZenohArgs {
            listen: vec!["nonsense".into()],
            ..Default::default()
        };
        let e = a.to_config().unwrap_err();
        assert!(e.to_string().contains("--listen"), "{e}");
        let a = ZenohArgs {
            config: Some("/nonexistent/zenoh.json5".into()),
            ..Default::default()
        };
        let e = a.to_config().unwrap_err();
        assert!(e.to_string().contains("/nonexistent/zenoh.json5"), "{e}");
    }

    /// Zenoh reassembles at most 64 MiB + 64 KiB by default (not its own 1 GiB); the flag
    /// sets it within bounds (at most 256 MiB + 64 KiB: 1 GiB is refused), and passes on to a
    /// child; a file's own value is kept.
    #[test]
    fn the_largest_message_is_bounded() {
        let size = |a: &ZenohArgs| -> usize {
            a.to_config()
                .unwrap()
                .get_json(MAX_MESSAGE_SIZE_KEY)
                .unwrap()
                .parse()
                .unwrap()
        };
        assert_eq!(size(&ZenohArgs::default()), DEFAULT_MAX_MESSAGE_BYTES);
        assert_eq!(
            size(&ZenohArgs::isolated(&[], &[])),
            DEFAULT_MAX_MESSAGE_BYTES
        );
        let a = ZenohArgs {
            max_message_bytes: Some(1 << 20),
            ..Default::default()
        };
        assert_eq!(size(&a), 1 << 20);
        let back =
            Cli::try_parse_from(std::iter::once("x".to_string()).chain(a.to_cli_args())).unwrap();
        assert_eq!(back.zenoh, a);
        // room for larger frames, never less than the default
        assert_eq!(
            size(&ZenohArgs::default().with_room_for(200 << 20)),
            200 << 20
        );
        assert_eq!(
            size(&ZenohArgs::default().with_room_for(1 << 20)),
            DEFAULT_MAX_MESSAGE_BYTES
        );
        for bad in [0, 1000, MAX_MAX_MESSAGE_BYTES + 1, 1 << 30, usize::MAX] {
            let a = ZenohArgs {
                max_message_bytes: Some(bad),
                ..Default::default()
            };
            let e = a.to_config().unwrap_err().to_string();
            assert!(e.contains("--zenoh-max-message-bytes"), "{e}");
        }
        let dir = tempfile::tempdir().unwrap();
        let own = dir.path().join("own.json5");
        std::fs::write(
            &own,
            "{ transport: { link: { rx: { max_message_size: 2097152 } } } }",
        )
        .unwrap();
        let plain = dir.path().join("plain.json5");
        std::fs::write(&plain, "{ mode: 'peer' }").unwrap();
        let file = |p: &std::path::Path, flag: Option<usize>| ZenohArgs {
            config: Some(p.to_path_buf()),
            max_message_bytes: flag,
            ..Default::default()
        };
        assert_eq!(size(&file(&own, None)), 2 << 20);
        assert_eq!(size(&file(&own, Some(3 << 20))), 3 << 20);
        assert_eq!(size(&file(&plain, None)), DEFAULT_MAX_MESSAGE_BYTES);
    }

    #[test]
    fn config_file_is_the_base() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("z.json5");
        std::fs::write(
            &p,
            "{ mode: 'router', listen: { endpoints: ['tcp/127.0.0.1:17447'] } }",
        )
        .unwrap();
        let a = ZenohArgs {
            config: Some(p.clone()),
            ..Default::default()
        };
        let c = a.to_config().unwrap();
        assert_eq!(c.get_json("mode").unwrap(), "\"router\"");
        assert!(c.get_json("listen/endpoints").unwrap().contains("17447"));
        let a = ZenohArgs {
            config: Some(p),
            mode: Some(Mode::Peer),
            ..Default::default()
        };
        assert_eq!(a.to_config().unwrap().get_json("mode").unwrap(), "\"peer\"");
    }
}
