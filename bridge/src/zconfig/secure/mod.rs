//! What may enter a Zenoh configuration: the options of every endpoint, and, once a
//! configuration enables TLS or access control, every setting that would silently downgrade
//! it. Refused before a session opens, naming the flag or the file and its setting. This is
//! the one place every configuration of every process passes ([`ZenohArgs::to_config`]: `-e`,
//! `-l`, `-c`, the launcher's `--child-config` files, the router's flags).
//!
//! Every endpoint (of a flag or of the file, whatever the file enables) may carry only the
//! options of the allow-list ([`ALLOWED_ENDPOINT_METADATA`] after `?`,
//! [`ALLOWED_ENDPOINT_CONFIG`] after `#`): an endpoint's options override the file's
//! `transport.link.tls`, so `tls/…#verify_name_on_connect=false` or `#enable_mtls=false`
//! would otherwise undo what the file sets.
//!
//! Once a `--config` file enables TLS (TLS settings or a `tls/` endpoint) or access control,
//! every endpoint must be `tls/` (a `-e`/`-l` flag or an endpoint of the file, Zenoh's default
//! listener included), multicast scouting stays off, a `tls/` endpoint it connects to names a
//! host that no public certificate authority may certify ([`is_private_name`]), and every
//! setting of `transport.link.tls`, `access_control` and `adminspace` is one the allow-list
//! (module `allow`) takes: the client checks the router's name, a TLS listener requires
//! mutual TLS and closes links whose certificate expired, a CA is given, access control
//! denies by default, and the admin space takes no writes.

use std::net::{IpAddr, Ipv4Addr, Ipv6Addr};

use zenoh::Config;

use super::error::ConfigError;
use super::{effective_endpoints, effective_mode, ZenohArgs, MULTICAST_SCOUTING_KEY};

mod allow;

pub use allow::{ALLOWED_ENDPOINT_CONFIG, ALLOWED_ENDPOINT_METADATA};

/// Names under which no public certificate authority may issue a certificate: top-level
/// names that are never delegated in the public DNS (`internal`, reserved for private use;
/// RFC 6761's `localhost`, `test`, `invalid`; RFC 6762's `local`; RFC 8375's `home.arpa`).
pub const PRIVATE_DNS_SUFFIXES: [&str; 6] = [
    "internal",
    "localhost",
    "test",
    "invalid",
    "local",
    "home.arpa",
];

/// Whether `host` (a DNS name or an IP address, IPv6 with or without brackets) is a name no
/// public certificate authority may certify (the CA/Browser Forum's requirements forbid
/// certificates for internal names and reserved addresses): an address of a private range
/// (10/8, 172.16/12, 192.168/16, 100.64/10), loopback or link-local (IPv6: `::1`, `fc00::/7`,
/// `fe80::/10`), or a DNS name under one of [`PRIVATE_DNS_SUFFIXES`].
pub fn is_private_name(host: &str) -> bool {
    let bare = host
        .strip_prefix('[')
        .and_then(|h| h.strip_suffix(']'))
        .unwrap_or(host);
    if let Ok(ip) = bare.parse::<IpAddr>() {
        return match ip {
            IpAddr::V4(v4) => private_v4(v4),
            IpAddr::V6(v6) => private_v6(v6),
        };
    }
    let name = bare.trim_end_matches('.').to_ascii_lowercase();
    !name.is_empty()
        && PRIVATE_DNS_SUFFIXES
            .iter()
            .any(|s| name == *s || name.ends_with(&format!(".{s}")))
}

fn private_v4(ip: Ipv4Addr) -> bool {
    let [a, b, ..] = ip.octets();
    ip.is_private()
        || ip.is_loopback()
        || ip.is_link_local()
        || (a == 100 && (64..128).contains(&b))
}

fn private_v6(ip: Ipv6Addr) -> bool {
    if let Some(v4) = ip.to_ipv4_mapped() {
        return private_v4(v4);
    }
    let first = ip.segments()[0];
    ip.is_loopback() || (first & 0xfe00) == 0xfc00 || (first & 0xffc0) == 0xfe80
}

/// The TLS settings whose presence enables TLS in a configuration.
const TLS_SETTINGS: [&str; 7] = [
    "root_ca_certificate",
    "root_ca_certificate_base64",
    "listen_certificate",
    "listen_certificate_base64",
    "connect_certificate",
    "connect_certificate_base64",
    "enable_mtls",
];

fn is_set(config: &Config, key: &str) -> bool {
    config
        .get_json(key)
        .ok()
        .is_some_and(|v| v != "null" && v != "false")
}

/// What in `config` (a configuration file as read) enables TLS or access control, in words;
/// `None` when nothing does.
pub fn what_secures(config: &Config) -> Option<&'static str> {
    if is_set(config, "access_control/enabled") {
        return Some("access control");
    }
    if TLS_SETTINGS
        .iter()
        .any(|s| is_set(config, &format!("transport/link/tls/{s}")))
    {
        return Some("TLS settings");
    }
    let tls_endpoint = ["connect", "listen"].iter().any(|which| {
        config
            .get_json(&format!("{which}/endpoints"))
            .is_ok_and(|v| v.contains("\"tls/"))
    });
    tls_endpoint.then_some("a tls/ endpoint")
}

/// Checks the final configuration `config` of `args`: the options of every endpoint against
/// the allow-list ([`ALLOWED_ENDPOINT_METADATA`], [`ALLOWED_ENDPOINT_CONFIG`]), whatever the
/// file; and, where its file enables TLS or access control (`secured`: what does, in words),
/// what would downgrade it. Refused naming the flag or the file and its setting.
pub(super) fn check(
    args: &ZenohArgs,
    config: &Config,
    secured: Option<&str>,
) -> Result<(), ConfigError> {
    let file = args
        .config
        .as_ref()
        .map(|f| format!("-c {}", f.display()))
        .unwrap_or_default();
    let why = secured.unwrap_or_default();
    let refuse = |what: String, reason: String| ConfigError::Downgrade {
        what,
        reason: format!("{reason} (the configuration enables {why})"),
    };
    let mode = effective_mode(config);
    // the listen endpoints are Zenoh's defaults for the mode where nothing sets them
    let default_listen = Config::default().get_json("listen/endpoints").ok();
    let zenoh_default = config.get_json("listen/endpoints").ok() == default_listen;
    let mode_source = match args.mode {
        Some(m) => format!("-m {}", m.as_str()),
        None => file.clone(),
    };
    let (mut listens, mut tls_endpoints) = (false, false);
    for (which, flag, given) in [
        ("connect", "--connect", &args.connect),
        ("listen", "--listen", &args.listen),
    ] {
        for ep in effective_endpoints(config, which, &mode) {
            let source = if !given.is_empty() {
                format!("{flag} {ep}")
            } else if which == "listen" && zenoh_default {
                format!("{mode_source}: Zenoh's default listen endpoint of mode {mode}, {ep}")
            } else {
                format!("{file}: {which} endpoint {ep}")
            };
            if let Some((option, reason)) = allow::refused_endpoint_option(&ep) {
                return Err(ConfigError::EndpointOption {
                    what: source,
                    option,
                    reason,
                });
            }
            if secured.is_none() {
                continue;
            }
            let Some(rest) = ep.strip_prefix("tls/") else {
                return Err(refuse(
                    source,
                    "not a tls/ endpoint: it would carry the session without TLS".into(),
                ));
            };
            tls_endpoints = true;
            listens |= which == "listen";
            if which == "connect" {
                let address = rest.split(['?', '#']).next().unwrap_or(rest);
                let host = address.rsplit_once(':').map_or(address, |(h, _)| h);
                if !is_private_name(host) {
                    return Err(refuse(
                        source,
                        format!(
                            "{host} is a name a public certificate authority may certify, and \
                             a TLS link that trusts the public Web PKI roots (the published \
                             zenoh-link-tls does; cellsar's does not) would accept a public \
                             certificate for it; connect to the router by a private address \
                             (10/8, 172.16/12, 192.168/16, loopback) or a name under .internal"
                        ),
                    ));
                }
            }
        }
    }
    if secured.is_none() {
        return Ok(());
    }
    if config.get_json(MULTICAST_SCOUTING_KEY).ok().as_deref() == Some("true") {
        let what = if args.multicast_scouting {
            "--multicast-scouting".to_string()
        } else {
            format!("{file}: scouting.multicast.enabled")
        };
        return Err(refuse(
            what,
            "multicast scouting would find and join peers outside the deployment".into(),
        ));
    }
    if let Some((setting, reason)) = allow::refused_setting(config, listens, tls_endpoints) {
        return Err(refuse(format!("{file}: {setting}"), reason));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
