//! The error of a flag or file that makes no valid Zenoh configuration ([`ConfigError`]).

use std::path::PathBuf;

use crate::zenoh_error::ZenohError;

/// A flag or file that does not make a valid Zenoh configuration. The message names the flag
/// and its value (`--connect garbage`), the file, or the setting; Zenoh's reason is the
/// [`source`](std::error::Error::source) ([`ZenohError`]: one line, without Zenoh's source
/// locations), so that printing the chain (`cellsar_error::error_chain`) shows each once.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// A flag's value that Zenoh refuses (an endpoint of `--connect` or `--listen`).
    #[error("invalid Zenoh configuration: {flag} {value}")]
    Flag {
        /// The flag.
        flag: &'static str,
        /// Its value.
        value: String,
        /// Why Zenoh refuses it.
        #[source]
        source: ZenohError,
    },
    /// The configuration file (`--config`) cannot be read or is no valid Zenoh configuration.
    #[error("invalid Zenoh configuration: --config {}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// Why Zenoh refuses it.
        #[source]
        source: ZenohError,
    },
    /// A flag's value outside the range this crate accepts.
    #[error("invalid Zenoh configuration: {flag} {value}: {reason}")]
    OutOfRange {
        /// The flag.
        flag: &'static str,
        /// Its value.
        value: String,
        /// The range.
        reason: String,
    },
    /// A setting that the flags make (on top of a `--config` file) and that Zenoh refuses.
    #[error("invalid Zenoh configuration: {what} ({key} = {value})")]
    Setting {
        /// The flag (or default) that makes the setting.
        what: &'static str,
        /// The configuration key.
        key: &'static str,
        /// The value (JSON5).
        value: String,
        /// Why Zenoh refuses it.
        #[source]
        source: ZenohError,
    },
    /// An option of an endpoint (after its `?` or `#`) that is not on the allow-list
    /// (`zconfig::ALLOWED_ENDPOINT_OPTIONS`): one that could change whom a link trusts or
    /// what it accepts (`#verify_name_on_connect=false`, `#enable_mtls=false`,
    /// `#root_ca_certificate_file=...`), or one this crate does not know.
    #[error(
        "invalid Zenoh configuration: {what}: endpoint option {option} is not allowed: {reason}"
    )]
    EndpointOption {
        /// The flag and its endpoint, or the file and its endpoint.
        what: String,
        /// The option, as written (`#verify_name_on_connect`).
        option: String,
        /// Why it is refused, and what is allowed.
        reason: String,
    },
    /// A flag or setting that would silently downgrade a configuration that enables TLS or
    /// access control (a plain endpoint, multicast scouting, no check of the router's name).
    #[error("invalid Zenoh configuration: {what}: {reason}")]
    Downgrade {
        /// The flag and its value, or the file and its setting.
        what: String,
        /// Why it is refused.
        reason: String,
    },
}
