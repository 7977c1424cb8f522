//! The allow-lists of the checks in [`super`]: the options an endpoint may carry, and what a
//! configuration that enables TLS or access control may set in `transport.link.tls`,
//! `access_control` and `adminspace`. Anything not listed is refused, so that a setting a
//! later Zenoh adds is looked at before it is taken.

use zenoh::config::EndPoint;
use zenoh::Config;

/// Options an endpoint may carry after `?` (Zenoh's link metadata): the priorities and the
/// reliability the link carries. Neither changes whom the link trusts.
pub const ALLOWED_ENDPOINT_METADATA: [&str; 2] = ["prio", "rel"];

/// Options an endpoint may carry after `#` (the link's own configuration): socket buffer
/// sizes, the interface or address to bind and the DSCP of its packets. Every TLS setting
/// (`verify_name_on_connect`, `enable_mtls`, `root_ca_certificate_file`, the certificates and
/// keys, `close_link_on_expiration`, `tls_handshake_timeout_ms`) is left out: an endpoint's
/// options override the file's `transport.link.tls`, where they are checked.
pub const ALLOWED_ENDPOINT_CONFIG: [&str; 5] = ["so_rcvbuf", "so_sndbuf", "iface", "bind", "dscp"];

/// The first option of `endpoint` that is not allowed, written as it appears (`?name` or
/// `#name`), with the reason it is refused; `None` when every option is allowed, or when Zenoh
/// cannot read the endpoint (Zenoh then refuses it itself, naming it).
pub(super) fn refused_endpoint_option(endpoint: &str) -> Option<(String, String)> {
    let ep: EndPoint = endpoint.parse().ok()?;
    let allowed = format!(
        "an endpoint may carry only {} and {}; TLS settings belong in the -c file's \
         transport.link.tls, where they are checked",
        ALLOWED_ENDPOINT_METADATA
            .map(|o| format!("?{o}"))
            .join(", "),
        ALLOWED_ENDPOINT_CONFIG.map(|o| format!("#{o}")).join(", "),
    );
    let metadata = ep.metadata();
    if let Some((k, _)) = metadata
        .iter()
        .find(|(k, _)| !ALLOWED_ENDPOINT_METADATA.contains(k))
    {
        return Some((format!("?{k}"), allowed));
    }
    let config = ep.config();
    let (k, _) = config
        .iter()
        .find(|(k, _)| !ALLOWED_ENDPOINT_CONFIG.contains(k))?;
    let why = option_risk(k).map_or(String::new(), |r| format!("{r}; "));
    Some((format!("#{k}"), format!("{why}{allowed}")))
}

/// What an endpoint option of the TLS link would do, for the message.
fn option_risk(option: &str) -> Option<&'static str> {
    Some(match option {
        "verify_name_on_connect" => {
            "it can turn off the client's check of the router's name, which then accepts any \
             certificate its CA signed, another role's included"
        }
        "enable_mtls" => {
            "it can turn off mutual TLS, and a listener then opens sessions for clients that \
             present no certificate"
        }
        "close_link_on_expiration" => "it can keep links open after their certificate expired",
        o if o.starts_with("root_ca_certificate") => {
            "it replaces the certificate authority the link trusts"
        }
        o if o.starts_with("listen_") || o.starts_with("connect_") => {
            "it replaces the certificate or key the link presents"
        }
        _ => return None,
    })
}

/// What a secure configuration may give one setting of `transport.link.tls`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum TlsRule {
    /// Any value (a file, a base64 text, a buffer size).
    Any,
    /// Never `false`; left out, Zenoh's default is `true`.
    NotFalse,
    /// `true` on a process that listens on TLS (left out, Zenoh's default is `false`); a
    /// process that only connects may leave it out or give either value.
    TrueOnListener,
    /// `true` on a process that listens on TLS, and never `false` on one that connects.
    TrueOnListenerNotFalse,
}

/// Every setting of Zenoh's `transport.link.tls` (zenoh-config 1.10), with what a secure
/// configuration may give it and why.
const TLS_SETTINGS: [(&str, TlsRule, &str); 15] = [
    ("root_ca_certificate", TlsRule::Any, ""),
    ("root_ca_certificate_base64", TlsRule::Any, ""),
    ("listen_private_key", TlsRule::Any, ""),
    ("listen_private_key_base64", TlsRule::Any, ""),
    ("listen_certificate", TlsRule::Any, ""),
    ("listen_certificate_base64", TlsRule::Any, ""),
    ("connect_private_key", TlsRule::Any, ""),
    ("connect_private_key_base64", TlsRule::Any, ""),
    ("connect_certificate", TlsRule::Any, ""),
    ("connect_certificate_base64", TlsRule::Any, ""),
    ("so_sndbuf", TlsRule::Any, ""),
    ("so_rcvbuf", TlsRule::Any, ""),
    (
        "enable_mtls",
        TlsRule::TrueOnListener,
        "a TLS listener without mutual TLS opens sessions for clients that present no \
         certificate",
    ),
    (
        "verify_name_on_connect",
        TlsRule::NotFalse,
        "a client that does not check the router's name accepts any certificate its roots \
         signed, another role's or a public one",
    ),
    (
        "close_link_on_expiration",
        TlsRule::TrueOnListenerNotFalse,
        "a link would stay open after the certificate it was opened with expired",
    ),
];

/// The settings of `access_control` (zenoh-config 1.10).
const ACL_SETTINGS: [&str; 5] = [
    "enabled",
    "default_permission",
    "rules",
    "subjects",
    "policies",
];

/// Whether `key` is a setting of `transport.link.tls` that the allow-list names.
pub(super) fn knows_tls_setting(key: &str) -> bool {
    TLS_SETTINGS.iter().any(|(s, ..)| *s == key)
}

/// Whether `key` is a setting of `access_control` that the allow-list names.
pub(super) fn knows_acl_setting(key: &str) -> bool {
    ACL_SETTINGS.contains(&key)
}

fn get(config: &Config, key: &str) -> Option<serde_json::Value> {
    config
        .get_json(key)
        .ok()
        .and_then(|s| serde_json::from_str::<serde_json::Value>(&s).ok())
        .filter(|v| !v.is_null())
}

/// Whether `config` sets `key` (to anything but null).
fn is_given(config: &Config, key: &str) -> bool {
    get(config, key).is_some()
}

/// The first setting of `config` (a secure configuration, `listens`: whether it listens on TLS;
/// `tls_endpoints`: whether it has a `tls/` endpoint at all) that the allow-lists refuse, as
/// `(setting as written in the file, reason)`.
pub(super) fn refused_setting(
    config: &Config,
    listens: bool,
    tls_endpoints: bool,
) -> Option<(String, String)> {
    refused_tls_setting(config, listens, tls_endpoints)
        .or_else(|| refused_acl_setting(config))
        .or_else(|| refused_adminspace_setting(config))
}

fn refused_tls_setting(
    config: &Config,
    listens: bool,
    tls_endpoints: bool,
) -> Option<(String, String)> {
    const BASE: &str = "transport/link/tls";
    let name = |k: &str| format!("transport.link.tls.{k}");
    // a setting this list does not know (a later Zenoh's): refused until looked at
    if let Some(serde_json::Value::Object(all)) = get(config, BASE) {
        if let Some((k, _)) = all
            .iter()
            .find(|(k, v)| !v.is_null() && !knows_tls_setting(k))
        {
            return Some((
                name(k),
                "a TLS setting that cellsar does not know, which may change whom the link \
                 trusts (bridge::zconfig's allow-list names those it takes)"
                    .into(),
            ));
        }
    }
    for (key, rule, why) in TLS_SETTINGS {
        let value = get(config, &format!("{BASE}/{key}"));
        let is_false = value == Some(serde_json::Value::Bool(false));
        let is_true = value == Some(serde_json::Value::Bool(true));
        let refused = match rule {
            TlsRule::Any => None,
            TlsRule::NotFalse => is_false.then(|| format!("{} false", name(key))),
            TlsRule::TrueOnListener | TlsRule::TrueOnListenerNotFalse if listens && !is_true => {
                Some(format!(
                    "{} {}: must be true on a process that listens on TLS",
                    name(key),
                    if is_false { "false" } else { "not set" }
                ))
            }
            TlsRule::TrueOnListenerNotFalse => is_false.then(|| format!("{} false", name(key))),
            TlsRule::TrueOnListener => None,
        };
        if let Some(what) = refused {
            return Some((what, why.into()));
        }
    }
    let has_ca = ["root_ca_certificate", "root_ca_certificate_base64"]
        .iter()
        .any(|k| is_given(config, &format!("{BASE}/{k}")));
    if tls_endpoints && !has_ca {
        return Some((
            format!("{} not set", name("root_ca_certificate")),
            "the TLS link trusts only the deployment's certificate authority, which the \
             configuration must give"
                .into(),
        ));
    }
    None
}

fn refused_acl_setting(config: &Config) -> Option<(String, String)> {
    if let Some(serde_json::Value::Object(all)) = get(config, "access_control") {
        if let Some((k, _)) = all
            .iter()
            .find(|(k, v)| !v.is_null() && !knows_acl_setting(k))
        {
            return Some((
                format!("access_control.{k}"),
                "an access-control setting that cellsar does not know (bridge::zconfig's \
                 allow-list names those it takes)"
                    .into(),
            ));
        }
    }
    let enabled = get(config, "access_control/enabled") == Some(serde_json::Value::Bool(true));
    let default = get(config, "access_control/default_permission");
    if enabled && default.as_ref().and_then(|v| v.as_str()) != Some("deny") {
        return Some((
            format!(
                "access_control.default_permission {}",
                default.map_or("not set".to_string(), |v| v.to_string())
            ),
            "must be \"deny\": with \"allow\", every message that no rule names goes through, \
             for a certificate of any name"
                .into(),
        ));
    }
    None
}

fn refused_adminspace_setting(config: &Config) -> Option<(String, String)> {
    let on = |k: &str| get(config, k) == Some(serde_json::Value::Bool(true));
    (on("adminspace/enabled") && on("adminspace/permissions/write")).then(|| {
        (
            "adminspace.permissions.write true".to_string(),
            "a peer could change this process's configuration at run time through the admin \
             space"
                .to_string(),
        )
    })
}
