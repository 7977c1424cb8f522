//! Tests of the checks of `secure`: what may enter a configuration, and what a secure one refuses.
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
            format!("{{ mode: 'peer', connect: {{ endpoints: ['tls/10.0.0.1:7447'] }}, {TLS} }}"),
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

/// The client's TLS settings of a file that connects to a router.
const CLIENT_FILE: &str = "{ mode: 'client', connect: { endpoints: ['tls/10.0.0.1:7447'] }, \
    transport: { link: { tls: { root_ca_certificate: '/c/ca.pem', connect_private_key: \
    '/c/echo.key', connect_certificate: '/c/echo.pem', enable_mtls: true, \
    verify_name_on_connect: true, close_link_on_expiration: true } } } }";

/// A router's file, as `pipeline/deploy/tls/router.json5` sets it up.
const ROUTER_FILE: &str = "{ mode: 'router', listen: { endpoints: ['tls/10.0.0.1:7447'] }, \
    transport: { link: { tls: { root_ca_certificate: '/c/ca.pem', listen_private_key: \
    '/c/router.key', listen_certificate: '/c/router.pem', enable_mtls: true, \
    close_link_on_expiration: true } } }, access_control: { enabled: true, \
    default_permission: 'deny' } }";

fn args_with(f: &std::path::Path) -> ZenohArgs {
    ZenohArgs {
        config: Some(f.to_path_buf()),
        ..ZenohArgs::default()
    }
}

/// Every option of an endpoint outside the allow-list is refused, from `-e`, `-l` and the
/// file, over a TLS file and over none (an endpoint's options override the file's TLS
/// settings, and could make a TLS link of a plain configuration): the error names the flag,
/// the endpoint and the option. The options the allow-list takes are accepted.
#[test]
fn endpoint_options_outside_the_allow_list_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let client = file(d, "client.json5", CLIENT_FILE);
    let router = file(d, "router.json5", ROUTER_FILE);
    let ep = |opts: &str| format!("tls/127.0.0.1:17449{opts}");
    let refused_options = [
        (
            "#verify_name_on_connect=false",
            "#verify_name_on_connect",
            "router's name",
        ),
        ("#enable_mtls=false", "#enable_mtls", "no certificate"),
        (
            "#root_ca_certificate=/tmp/other-ca.pem",
            "#root_ca_certificate",
            "authority",
        ),
        (
            "#root_ca_certificate_file=/tmp/ca.pem",
            "#root_ca_certificate_file",
            "authority",
        ),
        (
            "#root_ca_certificate_raw=x",
            "#root_ca_certificate_raw",
            "authority",
        ),
        (
            "#root_ca_certificate_base64=eA==",
            "#root_ca_certificate_base64",
            "authority",
        ),
        (
            "#connect_certificate_file=/tmp/x.pem",
            "#connect_certificate_file",
            "presents",
        ),
        (
            "#connect_private_key_file=/tmp/x.key",
            "#connect_private_key_file",
            "presents",
        ),
        (
            "#listen_certificate_file=/tmp/x.pem",
            "#listen_certificate_file",
            "presents",
        ),
        (
            "#listen_private_key_raw=x",
            "#listen_private_key_raw",
            "presents",
        ),
        (
            "#close_link_on_expiration=false",
            "#close_link_on_expiration",
            "expired",
        ),
        (
            "#tls_handshake_timeout_ms=600000",
            "#tls_handshake_timeout_ms",
            "only",
        ),
        (
            "#Verify_Name_On_Connect=false",
            "#Verify_Name_On_Connect",
            "only",
        ),
        (
            "#so_rcvbuf=65536;verify_name_on_connect=false",
            "#verify_name_on_connect",
            "name",
        ),
        ("?foo=1", "?foo", "may carry only ?prio, ?rel"),
        ("?prio=1-7#enable_mtls=false", "#enable_mtls", "certificate"),
    ];
    for (opts, option, why) in refused_options {
        let e = ep(opts);
        let cases = [
            (
                ZenohArgs {
                    connect: vec![e.clone()],
                    ..args_with(&client)
                },
                format!("--connect {e}"),
            ),
            (
                ZenohArgs {
                    connect: vec![e.clone()],
                    ..ZenohArgs::default()
                },
                format!("--connect {e}"),
            ),
            (
                ZenohArgs {
                    listen: vec![e.clone()],
                    ..args_with(&router)
                },
                format!("--listen {e}"),
            ),
            (
                ZenohArgs {
                    listen: vec![e.clone()],
                    mode: Some(super::super::Mode::Router),
                    ..ZenohArgs::default()
                },
                format!("--listen {e}"),
            ),
        ];
        for (a, what) in cases {
            let err = a.to_config().unwrap_err();
            assert!(
                matches!(&err, ConfigError::EndpointOption { option: o, .. } if o == option),
                "{a:?}: {err:?}"
            );
            let err = err.to_string();
            let want = format!("{what}: endpoint option {option} is not allowed");
            assert!(err.contains(&want), "{want:?} in {err}");
            assert!(err.contains(why), "{why:?} in {err}");
        }
        // the same endpoint in a file, to connect to and to listen on
        let name = format!("ep{}.json5", opts.len());
        let f = file(
            d,
            &name,
            &CLIENT_FILE.replace("tls/10.0.0.1:7447", &e.replace('\'', "")),
        );
        let err = args_with(&f).to_config().unwrap_err().to_string();
        let want = format!("{name}: connect endpoint {e}: endpoint option {option}");
        assert!(err.contains(&want), "{want:?} in {err}");
        let f = file(
            d,
            &name,
            &ROUTER_FILE.replace("tls/10.0.0.1:7447", &e.replace('\'', "")),
        );
        let err = args_with(&f).to_config().unwrap_err().to_string();
        let want = format!("{name}: listen endpoint {e}: endpoint option {option}");
        assert!(err.contains(&want), "{want:?} in {err}");
    }
    // what the allow-list takes, over the TLS files and over none
    let allowed = "tls/10.0.0.1:7447?prio=1-7;rel=1#so_rcvbuf=65536;so_sndbuf=65536;iface=lo;\
                   bind=10.0.0.2:0;dscp=8";
    for a in [
        ZenohArgs {
            connect: vec![allowed.into()],
            ..args_with(&client)
        },
        ZenohArgs {
            listen: vec![allowed.into()],
            ..args_with(&router)
        },
        ZenohArgs {
            connect: vec!["tcp/127.0.0.1:7447#so_rcvbuf=65536".into()],
            ..ZenohArgs::default()
        },
    ] {
        a.to_config().unwrap_or_else(|e| panic!("{a:?}: {e}"));
    }
}

/// A secure configuration's TLS, access-control and admin-space settings are taken only as
/// the allow-list says: a TLS listener requires mutual TLS and closes expired links, no client
/// skips the router's name or keeps expired links, a CA is given, access control denies by
/// default, the admin space takes no writes. Each refusal names the file and the setting.
#[test]
fn secure_settings_outside_the_allow_list_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let router_acl = ", access_control: { enabled: true, default_permission: 'deny' } }";
    for (name, text, want) in [
        (
            "router-no-mtls.json5",
            ROUTER_FILE.replace("enable_mtls: true", "enable_mtls: false"),
            "router-no-mtls.json5: transport.link.tls.enable_mtls false: must be true on a \
             process that listens on TLS: a TLS listener without mutual TLS opens sessions for \
             clients that present no certificate",
        ),
        (
            "router-mtls-unset.json5",
            ROUTER_FILE.replace("enable_mtls: true,", ""),
            "transport.link.tls.enable_mtls not set: must be true",
        ),
        (
            "router-keeps-expired.json5",
            ROUTER_FILE.replace(
                "close_link_on_expiration: true",
                "close_link_on_expiration: false",
            ),
            "transport.link.tls.close_link_on_expiration false: must be true",
        ),
        (
            "router-expiry-unset.json5",
            ROUTER_FILE.replace(", close_link_on_expiration: true", ""),
            "transport.link.tls.close_link_on_expiration not set: must be true",
        ),
        (
            "router-no-ca.json5",
            ROUTER_FILE.replace("root_ca_certificate: '/c/ca.pem', ", ""),
            "router-no-ca.json5: transport.link.tls.root_ca_certificate not set: the TLS link \
             trusts only the deployment's certificate authority",
        ),
        (
            "router-allow.json5",
            ROUTER_FILE.replace("default_permission: 'deny'", "default_permission: 'allow'"),
            "router-allow.json5: access_control.default_permission \"allow\": must be \"deny\"",
        ),
        (
            "router-admin-write.json5",
            ROUTER_FILE.replace(
                router_acl,
                ", access_control: { enabled: true, default_permission: 'deny' }, adminspace: \
                 { enabled: true, permissions: { read: true, write: true } } }",
            ),
            "router-admin-write.json5: adminspace.permissions.write true",
        ),
        (
            "client-noverify.json5",
            CLIENT_FILE.replace(
                "verify_name_on_connect: true",
                "verify_name_on_connect: false",
            ),
            "client-noverify.json5: transport.link.tls.verify_name_on_connect false",
        ),
        (
            "client-keeps-expired.json5",
            CLIENT_FILE.replace(
                "close_link_on_expiration: true",
                "close_link_on_expiration: false",
            ),
            "client-keeps-expired.json5: transport.link.tls.close_link_on_expiration false",
        ),
        (
            "client-no-ca.json5",
            CLIENT_FILE.replace("root_ca_certificate: '/c/ca.pem', ", ""),
            "client-no-ca.json5: transport.link.tls.root_ca_certificate not set",
        ),
    ] {
        assert!(
            text != ROUTER_FILE && text != CLIENT_FILE,
            "{name}: no change"
        );
        let p = file(d, name, &text);
        let e = args_with(&p).to_config().unwrap_err();
        assert!(matches!(e, ConfigError::Downgrade { .. }), "{name}: {e:?}");
        let e = e.to_string();
        assert!(e.contains(want), "{want:?} in {e}");
    }
    // what the allow-list takes: the files as they are; a client that leaves out mutual TLS
    // and the expiry (it then presents no certificate, and the router refuses it); the admin
    // space read-only
    for (name, text) in [
        ("router.json5", ROUTER_FILE.to_string()),
        ("client.json5", CLIENT_FILE.to_string()),
        (
            "client-plain-defaults.json5",
            CLIENT_FILE
                .replace("enable_mtls: true, ", "")
                .replace(", close_link_on_expiration: true", ""),
        ),
        (
            "router-ca-base64.json5",
            ROUTER_FILE.replace(
                "root_ca_certificate: '/c/ca.pem'",
                "root_ca_certificate_base64: 'eA=='",
            ),
        ),
        (
            "router-admin-read.json5",
            ROUTER_FILE.replace(
                router_acl,
                ", access_control: { enabled: true, default_permission: 'deny' }, adminspace: \
                 { enabled: true, permissions: { read: true, write: false } } }",
            ),
        ),
    ] {
        let p = file(d, name, &text);
        args_with(&p)
            .to_config()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

/// The allow-list names every setting of this Zenoh's `transport.link.tls`, so that one a
/// later Zenoh adds is refused (as not known) until it is looked at and listed.
#[test]
fn the_allow_list_knows_every_tls_setting_of_this_zenoh() {
    let all = Config::default().get_json("transport/link/tls").unwrap();
    let all: serde_json::Map<String, serde_json::Value> = serde_json::from_str(&all).unwrap();
    assert!(all.len() >= 10, "{all:?}");
    for k in all.keys() {
        assert!(
            allow::knows_tls_setting(k),
            "transport.link.tls.{k} is not in the allow-list"
        );
    }
    let acl = Config::default().get_json("access_control").unwrap();
    let acl: serde_json::Map<String, serde_json::Value> = serde_json::from_str(&acl).unwrap();
    for k in acl.keys() {
        assert!(
            allow::knows_acl_setting(k),
            "access_control.{k} is not in the allow-list"
        );
    }
}
