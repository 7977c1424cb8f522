//! Every Zenoh configuration shipped in `pipeline/deploy/` (the router's, the clients', and the
//! mutual-TLS deployment's) is one Zenoh reads, and bounds the largest message a peer may send
//! to cellsar's own limit (`bridge::zconfig::DEFAULT_MAX_MESSAGE_BYTES`), not Zenoh's 1 GiB,
//! both as cellsar reads it (`-c FILE`) and as the file states it (for `zenohd -c FILE`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use harness::root;

#[test]
fn every_shipped_configuration_bounds_the_message_size() {
    let dir = root().join("pipeline/deploy");
    let mut files: Vec<_> = ["", "tls"]
        .iter()
        .flat_map(|sub| std::fs::read_dir(dir.join(sub)).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json5"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 8, "{files:?}");
    let want = bridge::zconfig::DEFAULT_MAX_MESSAGE_BYTES.to_string();
    for f in &files {
        let args = bridge::ZenohArgs {
            config: Some(f.clone()),
            ..Default::default()
        };
        let config = args
            .to_config()
            .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let got = config
            .get_json(bridge::zconfig::MAX_MESSAGE_SIZE_KEY)
            .unwrap();
        assert_eq!(got, want, "{}", f.display());
        // the file itself states it (zenohd reads it as it is)
        let text = std::fs::read_to_string(f).unwrap();
        assert!(
            text.contains(&format!("max_message_size: {want}")),
            "{} does not state max_message_size",
            f.display()
        );
    }
}

/// `cellsar ARGS`, which must refuse before anything starts: exit 2, its error output naming
/// `named`.
fn refused<S: AsRef<std::ffi::OsStr> + std::fmt::Debug>(args: &[S], named: &str) {
    let o = std::process::Command::new(harness::pipeline::exe())
        .args(args)
        .env("RUST_LOG", "warn")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {}\n{err}", o.status);
    assert!(err.contains(named), "{args:?}: {named:?} in\n{err}");
}

/// With a shipped TLS configuration no flag turns the deployment into a plain one: a
/// non-tls/ endpoint (-e, -l), --multicast-scouting, a peer launcher, and a child the
/// launcher starts without its own --child-config are refused before anything starts
/// (exit 2, the flag named); each process as `cellsar` runs it.
#[test]
fn no_flag_downgrades_the_tls_deployment() {
    let deploy = root().join("pipeline/deploy/tls");
    let cfg = |r: &str| deploy.join(format!("{r}.json5")).display().to_string();
    let scene = harness::pipeline::scene().display().to_string();
    let mission = harness::pipeline::mission().display().to_string();
    let (processor, planner, router, bridge) = (
        cfg("processor"),
        cfg("planner"),
        cfg("router"),
        cfg("bridge"),
    );
    refused(
        &[
            "process",
            "--scene",
            &scene,
            "-c",
            &processor,
            "-e",
            "tcp/192.168.1.10:7447",
        ],
        "--connect tcp/192.168.1.10:7447: not a tls/ endpoint",
    );
    refused(
        &["planner", "-c", &planner, "--multicast-scouting"],
        "--multicast-scouting: multicast scouting",
    );
    refused(
        &["router", "-c", &router, "-l", "tcp/0.0.0.0:7447"],
        "--listen tcp/0.0.0.0:7447: not a tls/ endpoint",
    );
    refused(
        &[
            "bridge",
            "--service",
            "x",
            "-c",
            &bridge,
            "-e",
            "tcp/192.168.1.10:7447",
        ],
        "--connect tcp/192.168.1.10:7447",
    );
    refused(
        &["planner", "-c", &planner, "-e", "tls/203.0.113.7:7447"],
        "203.0.113.7 is a name a public certificate authority may certify",
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out_s = out.display().to_string();
    let (launcher, echo) = (cfg("launcher"), cfg("echo"));
    let planner_cc = format!("planner={planner}");
    let echo_cc = format!("echo={echo}");
    let run = |extra: &[&str]| -> Vec<String> {
        [
            "run",
            &mission,
            "--scene",
            &scene,
            "--out",
            &out_s,
            "--transport",
            "zenoh",
            "--external",
            "processor",
            "-c",
            &launcher,
        ]
        .iter()
        .chain(extra)
        .map(|s| s.to_string())
        .collect()
    };
    // the bridge without its own configuration
    let a = run(&["--child-config", &planner_cc, "--child-config", &echo_cc]);
    refused(&a, "--child-config bridge=FILE missing");
    // every child its own, but the launcher's flags add a plain endpoint or scouting
    let bridge_cc = format!("bridge={bridge}");
    let all = [
        "--child-config",
        &planner_cc,
        "--child-config",
        &echo_cc,
        "--child-config",
        &bridge_cc,
    ];
    for (flag, named) in [
        (
            &["-e", "tcp/192.168.1.10:7447"][..],
            "--connect tcp/192.168.1.10:7447",
        ),
        (&["--multicast-scouting"], "--multicast-scouting"),
        (
            &["-m", "peer"],
            "-m peer: Zenoh's default listen endpoint of mode peer",
        ),
    ] {
        let mut extra: Vec<&str> = all.to_vec();
        extra.extend(flag);
        refused(&run(&extra), named);
    }
    // a child's configuration that is plain
    let plain = root()
        .join("pipeline/deploy/client.json5")
        .display()
        .to_string();
    let plain_cc = format!("echo={plain}");
    let a = run(&[
        "--child-config",
        &planner_cc,
        "--child-config",
        &plain_cc,
        "--child-config",
        &bridge_cc,
    ]);
    refused(&a, "enables neither TLS nor access control");
    assert!(!out.exists(), "a refused run created its output directory");
}

/// An endpoint option that could weaken TLS is refused wherever an endpoint enters, each process
/// as `cellsar` runs it (exit 2, the flag or file, the endpoint and the option named): on `-e`
/// over a role's file and over none, on the router's `-l`, in a `-c` file and in a
/// `--child-config` file of `cellsar run`.
#[test]
fn no_endpoint_option_weakens_the_tls_deployment() {
    let deploy = root().join("pipeline/deploy/tls");
    let cfg = |r: &str| deploy.join(format!("{r}.json5")).display().to_string();
    let (planner, router) = (cfg("planner"), cfg("router"));
    let noverify = "tls/127.0.0.1:17449#verify_name_on_connect=false";
    let named = |flag: &str, ep: &str, option: &str| {
        format!("{flag} {ep}: endpoint option {option} is not allowed")
    };
    refused(
        &["planner", "-c", &planner, "-e", noverify],
        &named("--connect", noverify, "#verify_name_on_connect"),
    );
    refused(
        &["planner", "-e", noverify],
        &named("--connect", noverify, "#verify_name_on_connect"),
    );
    let no_mtls = "tls/127.0.0.1:17449#enable_mtls=false";
    refused(
        &["router", "-c", &router, "-l", no_mtls],
        &named("--listen", no_mtls, "#enable_mtls"),
    );
    refused(
        &["router", "-l", no_mtls],
        &named("--listen", no_mtls, "#enable_mtls"),
    );
    let other_ca = "tls/127.0.0.1:17449#root_ca_certificate=/tmp/other-ca.pem";
    refused(
        &["planner", "-c", &planner, "-e", other_ca],
        &named("--connect", other_ca, "#root_ca_certificate"),
    );
    // the same endpoint in a role's file: as -c of the service, and as --child-config of a run
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(&planner)
        .unwrap()
        .replace("tls/192.168.1.10:7447", noverify);
    let file = dir.path().join("planner-noverify.json5");
    std::fs::write(&file, text).unwrap();
    let file = file.display().to_string();
    let in_file = format!(
        "-c {file}: connect endpoint {noverify}: endpoint option #verify_name_on_connect is not \
         allowed"
    );
    refused(&["planner", "-c", &file], &in_file);
    let out = dir.path().join("out").display().to_string();
    let (scene, mission) = (
        harness::pipeline::scene().display().to_string(),
        harness::pipeline::mission().display().to_string(),
    );
    let child = format!("planner={file}");
    refused(
        &[
            "run",
            &mission,
            "--scene",
            &scene,
            "--out",
            &out,
            "--transport",
            "zenoh",
            "--external",
            "processor",
            "-c",
            &cfg("launcher"),
            "--child-config",
            &child,
        ],
        &format!("{file}: connect endpoint {noverify}: endpoint option #verify_name_on_connect"),
    );
}

/// Every configuration of the mutual-TLS deployment, as Zenoh reads it, requires client
/// certificates, checks the router's name, and closes a link when its certificate expires
/// (the promises of `docs/deployment.md`, "Secure deployment across hosts").
#[test]
fn every_tls_configuration_requires_certificates_and_closes_expired_links() {
    let dir = root().join("pipeline/deploy/tls");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let f = e.unwrap().path();
        if f.extension().is_none_or(|e| e != "json5") {
            continue;
        }
        let config = bridge::ZenohArgs {
            config: Some(f.clone()),
            ..Default::default()
        }
        .to_config()
        .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        for key in ["enable_mtls", "close_link_on_expiration"] {
            let got = config
                .get_json(&format!("transport/link/tls/{key}"))
                .unwrap();
            assert_eq!(got, "true", "{}: {key}", f.display());
        }
        if !f.ends_with("router.json5") {
            let got = config
                .get_json("transport/link/tls/verify_name_on_connect")
                .unwrap();
            assert_eq!(got, "true", "{}: verify_name_on_connect", f.display());
        }
        n += 1;
    }
    assert_eq!(n, 6, "the router's and five roles' configurations");
}

/// `cellsar certs` refuses, before it writes anything, a router name a public certificate
/// authority may certify and a role that is no role: exit 2, the flag named, no file made.
#[test]
fn certs_refuses_a_public_router_name_and_an_unknown_role() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("certs");
    let out_s = out.display().to_string();
    refused(
        &["certs", "--out", &out_s, "--host", "router.example.com"],
        "--host \"router.example.com\": a public certificate authority may certify this name",
    );
    refused(
        &["certs", "--out", &out_s, "--role", "nosuch"],
        "invalid value 'nosuch' for '--role <ROLE>'",
    );
    assert!(!out.exists(), "{} was made", out.display());
}
