//! A configuration that enables TLS or access control, and the settings that would silently
//! downgrade it: refused before a session opens.
//!
//! Once a `--config` file enables TLS (TLS settings or a `tls/` endpoint) or access control,
//! every endpoint must be `tls/` (a `-e`/`-l` flag or an endpoint of the file, Zenoh's default
//! listener included), multicast scouting stays off, the client checks the router's name
//! (`verify_name_on_connect`), and a `tls/` endpoint it connects to names a host that no
//! public certificate authority may certify ([`is_private_name`]): Zenoh's TLS client (1.x)
//! trusts the public Web PKI roots besides the configured CA, so the router's name is what
//! keeps a publicly trusted certificate out.

use std::net::{IpAddr, Ipv4Addr, Ipv6Addr};

use zenoh::Config;

use super::error::ConfigError;
use super::{effective_endpoints, effective_mode, ZenohArgs, MULTICAST_SCOUTING_KEY};

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

/// Checks the final configuration `config` of `args`, whose file enables TLS or access
/// control (`why`): what would downgrade it is refused, naming the flag or the file.
pub(super) fn check(args: &ZenohArgs, config: &Config, why: &str) -> Result<(), ConfigError> {
    let file = args
        .config
        .as_ref()
        .map(|f| format!("-c {}", f.display()))
        .unwrap_or_default();
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
            let Some(rest) = ep.strip_prefix("tls/") else {
                return Err(refuse(
                    source,
                    "not a tls/ endpoint: it would carry the session without TLS".into(),
                ));
            };
            if which == "connect" {
                let address = rest.split(['?', '#']).next().unwrap_or(rest);
                let host = address.rsplit_once(':').map_or(address, |(h, _)| h);
                if !is_private_name(host) {
                    return Err(refuse(
                        source,
                        format!(
                            "{host} is a name a public certificate authority may certify, and \
                             Zenoh's TLS client trusts the public Web PKI roots besides the \
                             deployment's CA; connect to the router by a private address \
                             (10/8, 172.16/12, 192.168/16, loopback) or a name under .internal"
                        ),
                    ));
                }
            }
        }
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
    if config
        .get_json("transport/link/tls/verify_name_on_connect")
        .ok()
        .as_deref()
        == Some("false")
    {
        return Err(refuse(
            format!("{file}: transport.link.tls.verify_name_on_connect false"),
            "a client that does not check the router's name accepts any certificate its \
             roots signed, another role's or a public one"
                .into(),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn private_names_are_those_no_public_ca_may_certify() {
        for ok in [
            "10.0.0.1",
            "172.16.5.4",
            "172.31.255.255",
            "192.168.1.10",
            "100.64.0.1",
            "127.0.0.1",
            "169.254.1.1",
            "[::1]",
            "::1",
            "[fd00::1]",
            "fe80::1",
            "::ffff:10.1.2.3",
            "localhost",
            "router.cellsar.internal",
            "ROUTER.Internal.",
            "a.test",
            "box.local",
            "nas.home.arpa",
        ] {
            assert!(is_private_name(ok), "{ok}");
        }
        for public in [
            "8.8.8.8",
            "172.32.0.1",
            "100.128.0.1",
            "192.169.1.1",
            "[2001:db8::1]",
            "2a00::1",
            "::ffff:8.8.8.8",
            "example.com",
            "internal.example.com",
            "router.internal.com",
            "localhost.example",
            "mytest",
            "",
        ] {
            assert!(!is_private_name(public), "{public}");
        }
    }

    fn file(dir: &std::path::Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    const TLS: &str = "transport: { link: { tls: { root_ca_certificate: '/c/ca.pem', \
        connect_private_key: '/c/echo.key', connect_certificate: '/c/echo.pem', \
        enable_mtls: true, verify_name_on_connect: true } } }";

    /// A configuration with TLS or access control is taken as it is; every flag or setting
    /// that would downgrade it is refused, naming the flag or the file's setting; the same
    /// flags over a plain file are accepted (the refusals are the TLS's).
    #[test]
    fn nothing_downgrades_a_secure_configuration() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let client = file(
            d,
            "client.json5",
            &format!(
                "{{ mode: 'client', connect: {{ endpoints: ['tls/10.0.0.1:7447'] }}, \
                 scouting: {{ multicast: {{ enabled: false }} }}, {TLS} }}"
            ),
        );
        let plain = file(
            d,
            "plain.json5",
            "{ mode: 'client', connect: { endpoints: ['tcp/10.0.0.1:7447'] } }",
        );
        let with = |f: &std::path::Path| ZenohArgs {
            config: Some(f.to_path_buf()),
            ..ZenohArgs::default()
        };
        with(&client).to_config().unwrap();
        assert_eq!(with(&client).secured_by().unwrap(), Some("TLS settings"));
        assert_eq!(with(&plain).secured_by().unwrap(), None);
        let ok_flags = [
            ZenohArgs {
                connect: vec!["tls/192.168.1.10:7447".into()],
                ..with(&client)
            },
            ZenohArgs {
                connect: vec!["tls/router.cellsar.internal:7447".into()],
                no_multicast_scouting: true,
                ..with(&client)
            },
        ];
        for a in ok_flags {
            a.to_config().unwrap_or_else(|e| panic!("{a:?}: {e}"));
        }
        let refused: Vec<(ZenohArgs, String)> = vec![
            (
                ZenohArgs {
                    connect: vec!["tcp/10.0.0.1:7447".into()],
                    ..with(&client)
                },
                "--connect tcp/10.0.0.1:7447: not a tls/ endpoint".into(),
            ),
            (
                ZenohArgs {
                    connect: vec!["unixsock-stream//tmp/z.sock".into()],
                    ..with(&client)
                },
                "--connect unixsock-stream//tmp/z.sock".into(),
            ),
            (
                ZenohArgs {
                    listen: vec!["tcp/127.0.0.1:0".into()],
                    mode: Some(super::super::Mode::Peer),
                    ..with(&client)
                },
                "--listen tcp/127.0.0.1:0: not a tls/ endpoint".into(),
            ),
            (
                ZenohArgs {
                    mode: Some(super::super::Mode::Peer),
                    ..with(&client)
                },
                "-m peer: Zenoh's default listen endpoint of mode peer, tcp/".into(),
            ),
            (
                ZenohArgs {
                    multicast_scouting: true,
                    ..with(&client)
                },
                "--multicast-scouting: multicast scouting".into(),
            ),
            (
                ZenohArgs {
                    connect: vec!["tls/203.0.113.7:7447".into()],
                    ..with(&client)
                },
                "--connect tls/203.0.113.7:7447: 203.0.113.7 is a name a public".into(),
            ),
            (
                ZenohArgs {
                    connect: vec!["tls/router.example.com:7447".into()],
                    ..with(&client)
                },
                "router.example.com is a name a public certificate authority may certify".into(),
            ),
        ];
        for (a, want) in refused {
            let e = a.to_config().unwrap_err();
            assert!(matches!(e, ConfigError::Downgrade { .. }), "{e:?}");
            let e = e.to_string();
            assert!(e.contains(&want), "{want:?} in {e}");
            assert!(e.contains("the configuration enables TLS settings"), "{e}");
            // the same flags over a plain file: accepted
            let over_plain = ZenohArgs {
                config: Some(plain.clone()),
                ..a
            };
            over_plain
                .to_config()
                .unwrap_or_else(|e| panic!("{over_plain:?}: {e}"));
        }
        // settings of the file itself
        for (name, text, want) in [
            (
                "acl-tcp.json5",
                "{ mode: 'router', listen: { endpoints: ['tcp/10.0.0.1:7447'] }, \
                 access_control: { enabled: true, default_permission: 'deny' } }"
                    .to_string(),
                "acl-tcp.json5: listen endpoint tcp/10.0.0.1:7447: not a tls/ endpoint: it \
                 would carry the session without TLS (the configuration enables access control)",
            ),
            (
                "mixed.json5",
                "{ mode: 'router', listen: { endpoints: ['tls/10.0.0.1:7447', \
                 'tcp/10.0.0.1:7448'] } }"
                    .to_string(),
                "mixed.json5: listen endpoint tcp/10.0.0.1:7448",
            ),
            (
                "peer-default.json5",
                format!(
                    "{{ mode: 'peer', connect: {{ endpoints: ['tls/10.0.0.1:7447'] }}, {TLS} }}"
                ),
                "peer-default.json5: Zenoh's default listen endpoint of mode peer, tcp/",
            ),
            (
                "router-default.json5",
                format!("{{ mode: 'router', {TLS} }}"),
                "router-default.json5: Zenoh's default listen endpoint of mode router, tcp/",
            ),
            (
                "public-connect.json5",
                format!(
                    "{{ mode: 'client', connect: {{ endpoints: ['tls/router.example.com:7447'] }}, \
                     {TLS} }}"
                ),
                "public-connect.json5: connect endpoint tls/router.example.com:7447: \
                 router.example.com is a name a public certificate authority may certify",
            ),
            (
                "scouting.json5",
                format!(
                    "{{ mode: 'client', connect: {{ endpoints: ['tls/10.0.0.1:7447'] }}, \
                     scouting: {{ multicast: {{ enabled: true }} }}, {TLS} }}"
                ),
                "scouting.json5: scouting.multicast.enabled",
            ),
            (
                "noverify.json5",
                format!(
                    "{{ mode: 'client', connect: {{ endpoints: ['tls/10.0.0.1:7447'] }}, {} }}",
                    TLS.replace(
                        "verify_name_on_connect: true",
                        "verify_name_on_connect: false"
                    )
                ),
                "noverify.json5: transport.link.tls.verify_name_on_connect false",
            ),
        ] {
            let p = file(d, name, &text);
            let e = with(&p).to_config().unwrap_err().to_string();
            assert!(e.contains(want), "{want:?} in {e}");
        }
        // --no-multicast-scouting over a file that scouts: off, accepted
        let p = d.join("scouting.json5");
        ZenohArgs {
            no_multicast_scouting: true,
            ..with(&p)
        }
        .to_config()
        .unwrap();
    }

    /// The shipped configurations of the secure deployment are accepted as they are, and
    /// refuse a plain endpoint given over them.
    #[test]
    fn the_shipped_tls_configurations_are_secure_and_keep_so() {
        let deploy = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../pipeline/deploy");
        for role in [
            "router",
            "planner",
            "echo",
            "processor",
            "bridge",
            "launcher",
        ] {
            let f = deploy.join(format!("tls/{role}.json5"));
            let a = ZenohArgs {
                config: Some(f.clone()),
                ..ZenohArgs::default()
            };
            assert!(a.secured_by().unwrap().is_some(), "{role}");
            a.to_config().unwrap_or_else(|e| panic!("{role}: {e}"));
            let (flag, plain) = if role == "router" {
                (
                    "--listen",
                    ZenohArgs {
                        listen: vec!["tcp/0.0.0.0:7447".into()],
                        ..a
                    },
                )
            } else {
                (
                    "--connect",
                    ZenohArgs {
                        connect: vec!["tcp/192.168.1.10:7447".into()],
                        ..a
                    },
                )
            };
            let e = plain.to_config().unwrap_err().to_string();
            assert!(e.contains(flag), "{role}: {e}");
        }
        // the plain ones enable neither
        for f in ["router.json5", "client.json5"] {
            let a = ZenohArgs {
                config: Some(deploy.join(f)),
                ..ZenohArgs::default()
            };
            assert_eq!(a.secured_by().unwrap(), None, "{f}");
        }
    }
}
