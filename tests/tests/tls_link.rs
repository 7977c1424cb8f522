//! The patched TLS link (`third_party/zenoh-link-tls`, `PATCHED.md`): under traffic both
//! ways at once, whom it trusts, and that it is the link Zenoh resolves.
//!
//! zenoh-link-tls 1.10.2 lets the task that reads a link and the task that writes it use one
//! rustls connection at the same time; rustls allows neither, and the process crashes
//! (SIGSEGV) after seconds to minutes of traffic both ways. `third_party/zenoh-link-tls` is
//! that crate with the stream locked per poll. Two sessions over mutual TLS on loopback, each
//! publishing frames as fast as the link takes them while it receives the other's: both run
//! to the end and exit normally, every frame they took intact (checksums verified).
//!
//! The published crate's client also trusts the public Web PKI roots besides the configured
//! CA; the patched one trusts the configured CA only. A router certificate that chains to a
//! public-looking root which is not the deployment's CA is refused, and no binary carries the
//! Web PKI roots. Cargo.lock must resolve zenoh-link-tls to the vendored crate, at the version
//! of zenoh itself: a zenoh upgrade leaves the `[patch]` unused (a warning only), and the
//! crash and the public roots would come back silently.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use bridge::{NetError, ZenohArgs, ZenohNode};
use harness::transport::{bench_exe, free_port, s, Proc};

/// Seconds of traffic both ways.
const DUPLEX_S: u64 = 20;

/// The configuration of one side: `a` listens with the server certificate, `b` connects; each
/// presents its own client certificate of the test CA.
fn config(dir: &Path, certs: &Path, me: &str, port: u16) -> String {
    let listen = if me == "a" {
        vec![format!("tls/127.0.0.1:{port}")]
    } else {
        vec![]
    };
    let connect = if me == "b" {
        vec![format!("tls/127.0.0.1:{port}")]
    } else {
        vec![]
    };
    let p = |f: &str| serde_json::Value::String(certs.join(f).display().to_string());
    let text = format!(
        "{{ mode: 'peer', listen: {{ endpoints: {} }}, connect: {{ endpoints: {} }}, \
         scouting: {{ multicast: {{ enabled: false }} }}, transport: {{ link: {{ tls: {{ \
         root_ca_certificate: {}, listen_private_key: {}, listen_certificate: {}, \
         connect_private_key: {}, connect_certificate: {}, enable_mtls: true, \
         verify_name_on_connect: true, close_link_on_expiration: true }} }} }} }}",
        serde_json::json!(listen),
        serde_json::json!(connect),
        p("ca.pem"),
        p("router.key"),
        p("router.pem"),
        p(&format!("{me}.key")),
        p(&format!("{me}.pem")),
    );
    let path = dir.join(format!("{me}.json5"));
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

#[test]
fn a_tls_link_carrying_frames_both_ways_at_once_survives() {
    let dir = tempfile::tempdir().unwrap();
    let certs = dir.path().join("certs");
    pipeline::certs::make_certs(&pipeline::certs::CertsArgs {
        out: certs.clone(),
        roles: vec![pipeline::certs::ROUTER_ROLE],
        extra_names: vec![s("a"), s("b")],
        hosts: vec![s("127.0.0.1")],
        days: 1,
        force: true,
    })
    .unwrap();
    let port = free_port();
    let duplex = |me: &str, other: &str| -> Proc {
        let args = [
            s("z-duplex"),
            s("--send-key"),
            format!("duplex/{me}"),
            s("--recv-key"),
            format!("duplex/{other}"),
            s("--duration-s"),
            DUPLEX_S.to_string(),
            s("-c"),
            config(dir.path(), &certs, me, port),
        ];
        Proc::spawn(me, &bench_exe(), &args, dir.path(), "warn")
    };
    let mut a = duplex("a", "b");
    let mut b = duplex("b", "a");
    for p in [&a, &b] {
        p.ready();
    }
    let timeout = Duration::from_secs(DUPLEX_S + 40);
    for p in [&mut a, &mut b] {
        let st = p.wait(timeout);
        assert!(
            st.success(),
            "{} ended {st:?} (signal {:?}) after traffic both ways over TLS:\n{}",
            p.name,
            st.signal(),
            p.stderr_tail()
        );
        let r: serde_json::Value = serde_json::from_str(&p.line(Duration::from_secs(1))).unwrap();
        eprintln!("{}: {r}", p.name);
        for k in ["sent", "received"] {
            assert!(r[k].as_u64().unwrap() > 100, "{}: {k}: {r}", p.name);
        }
        for k in ["send_errors", "malformed"] {
            assert_eq!(r[k], 0, "{}: {r}", p.name);
        }
    }
}

/// The deployment's certificates (`cellsar certs`) in `dir`: its CA, the router's server
/// certificate for 127.0.0.1 and the planner's client certificate.
fn deployment_certs(dir: &Path) -> PathBuf {
    let certs = dir.join("deployment");
    pipeline::certs::make_certs(&pipeline::certs::CertsArgs {
        out: certs.clone(),
        roles: vec![
            pipeline::certs::ROUTER_ROLE,
            pipeline::protocol::Role::Planner,
        ],
        extra_names: vec![],
        hosts: vec![s("127.0.0.1")],
        days: 1,
        force: true,
    })
    .unwrap();
    certs
}

/// A root that looks like a public certificate authority's (a self-signed CA of an
/// organisation's name, with no path-length limit, as the Web PKI roots have), made with the
/// crate `cellsar certs` uses, and a server certificate it signed for 127.0.0.1 with the
/// router's common name and key usage: `public/ca.pem`, `public/router.pem`,
/// `public/router.key`.
fn public_looking_root(dir: &Path) -> PathBuf {
    use rcgen::{
        BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer,
        KeyPair, KeyUsagePurpose,
    };
    let out = dir.join("public");
    std::fs::create_dir_all(&out).unwrap();
    let ca_key = KeyPair::generate().unwrap();
    let mut ca = CertificateParams::default();
    ca.distinguished_name.push(DnType::CountryName, "US");
    ca.distinguished_name
        .push(DnType::OrganizationName, "Public Trust Services");
    ca.distinguished_name
        .push(DnType::CommonName, "Public Trust Root CA X1");
    ca.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    ca.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    let ca_cert = ca.self_signed(&ca_key).unwrap();
    let mut leaf = CertificateParams::new(vec![s("127.0.0.1")]).unwrap();
    leaf.distinguished_name.push(DnType::CommonName, "router");
    leaf.key_usages = vec![KeyUsagePurpose::DigitalSignature];
    leaf.extended_key_usages = vec![ExtendedKeyUsagePurpose::ServerAuth];
    let leaf_key = KeyPair::generate().unwrap();
    let leaf_cert = leaf.signed_by(&leaf_key, &Issuer::new(ca, ca_key)).unwrap();
    std::fs::write(out.join("ca.pem"), ca_cert.pem()).unwrap();
    std::fs::write(out.join("router.pem"), leaf_cert.pem()).unwrap();
    std::fs::write(out.join("router.key"), leaf_key.serialize_pem()).unwrap();
    out
}

/// Writes `text` to `dir/name` and builds its configuration as every process does (`-c`).
fn config_of(dir: &Path, name: &str, text: &str) -> bridge::zenoh::Config {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    ZenohArgs {
        config: Some(path),
        ..ZenohArgs::default()
    }
    .to_config()
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn json_path(p: PathBuf) -> String {
    serde_json::Value::String(p.display().to_string()).to_string()
}

/// A router on loopback that presents a server certificate for 127.0.0.1 signed by a
/// public-looking root that is not the deployment's CA (and checks its clients against the
/// deployment's CA). A client of the deployment (its CA, the planner's certificate) refuses it:
/// its session does not open. The same client trusting that root instead opens one, so the
/// refusal is the trust's, not a broken certificate's.
#[test]
fn a_router_certificate_of_a_public_looking_root_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let deployment = deployment_certs(d);
    let public = public_looking_root(d);
    let port = free_port();
    let router = config_of(
        d,
        "router.json5",
        &format!(
            "{{ mode: 'router', listen: {{ endpoints: ['tls/127.0.0.1:{port}'] }}, \
             scouting: {{ multicast: {{ enabled: false }} }}, transport: {{ link: {{ tls: {{ \
             root_ca_certificate: {}, listen_private_key: {}, listen_certificate: {}, \
             enable_mtls: true, close_link_on_expiration: true }} }} }} }}",
            json_path(deployment.join("ca.pem")),
            json_path(public.join("router.key")),
            json_path(public.join("router.pem")),
        ),
    );
    let _router = ZenohNode::open(router, "router", "public-root").unwrap();
    let client = |name: &str, ca: PathBuf| {
        config_of(
            d,
            name,
            &format!(
                "{{ mode: 'client', connect: {{ endpoints: ['tls/127.0.0.1:{port}'], \
                 timeout_ms: 5000, exit_on_failure: true }}, scouting: {{ multicast: {{ \
                 enabled: false }} }}, transport: {{ link: {{ tls: {{ root_ca_certificate: {}, \
                 connect_private_key: {}, connect_certificate: {}, enable_mtls: true, \
                 verify_name_on_connect: true, close_link_on_expiration: true }} }} }} }}",
                json_path(ca),
                json_path(deployment.join("planner.key")),
                json_path(deployment.join("planner.pem")),
            ),
        )
    };
    let stop = AtomicBool::new(false);
    let limit = Some(Duration::from_secs(60));
    let refused = ZenohNode::open_within(
        client("deployment-client.json5", deployment.join("ca.pem")),
        "planner",
        "deployment",
        &stop,
        limit,
    );
    assert!(
        matches!(refused, Err(NetError::Open { .. })),
        "a client of the deployment opened a session with a router of another root: {:?}",
        refused.map(|n| n.is_some())
    );
    let trusting = ZenohNode::open_within(
        client("public-client.json5", public.join("ca.pem")),
        "planner",
        "public",
        &stop,
        limit,
    )
    .unwrap_or_else(|e| panic!("a client that trusts the public-looking root: {e}"))
    .unwrap();
    trusting.close().unwrap();
}

/// No binary carries the public Web PKI roots (the published zenoh-link-tls compiles
/// webpki-roots' store into every binary that links it): none of three roots' names of that
/// store appears in any of the four binaries.
#[test]
fn no_binary_carries_the_web_pki_roots() {
    for exe in [
        "cellsar",
        "cellsar-planner",
        "cellsar-radar-sim",
        "cellsar-bridge",
    ] {
        let bytes = std::fs::read(harness::bin(exe)).unwrap();
        for root in [
            "ISRG Root X1",
            "DigiCert Global Root G2",
            "USERTrust RSA Certification Authority",
        ] {
            assert!(
                !bytes.windows(root.len()).any(|w| w == root.as_bytes()),
                "{exe} carries the Web PKI root {root:?}"
            );
        }
    }
}

/// The packages of Cargo.lock named `name`, as (version, source; `None` for a path).
fn locked(lock: &str, name: &str) -> Vec<(String, Option<String>)> {
    lock.split("[[package]]")
        .filter_map(|block| {
            let field = |k: &str| {
                block.lines().find_map(|l| {
                    l.strip_prefix(&format!("{k} = \""))
                        .and_then(|v| v.strip_suffix('"'))
                        .map(str::to_string)
                })
            };
            (field("name")? == name)
                .then(|| (field("version").unwrap_or_default(), field("source")))
        })
        .collect()
}

/// The `[patch]` of zenoh-link-tls is in force: Cargo.lock resolves zenoh-link-tls once, to
/// the vendored crate (a path, no registry source), at the vendored version, which is zenoh's
/// own; no patch is left unused, and webpki-roots is in no build. Fails on a zenoh upgrade,
/// telling to reconsider the patch.
#[test]
fn the_vendored_tls_link_is_the_one_zenoh_resolves() {
    let root = harness::root();
    let lock = std::fs::read_to_string(root.join("Cargo.lock")).unwrap();
    let manifest =
        std::fs::read_to_string(root.join("third_party/zenoh-link-tls/Cargo.toml")).unwrap();
    let vendored = manifest
        .split("[package]")
        .nth(1)
        .and_then(|p| p.lines().find_map(|l| l.strip_prefix("version = \"")))
        .and_then(|v| v.strip_suffix('"'))
        .expect("the vendored crate's version");
    let reconsider = format!(
        "reconsider the patch of zenoh-link-tls (third_party/zenoh-link-tls/PATCHED.md): drop \
         it if this zenoh's link no longer shares one rustls connection between its reading and \
         writing tasks and trusts only the configured CA, else vendor this zenoh's \
         zenoh-link-tls with the same changes; the vendored crate is {vendored}"
    );
    let zenoh = locked(&lock, "zenoh");
    assert_eq!(zenoh.len(), 1, "{zenoh:?}");
    assert_eq!(
        zenoh[0].0, vendored,
        "zenoh is {}: {reconsider}",
        zenoh[0].0
    );
    assert_eq!(
        locked(&lock, "zenoh-link-tls"),
        vec![(vendored.to_string(), None)],
        "zenoh-link-tls is not resolved to the vendored crate alone: {reconsider}"
    );
    assert!(
        !lock.contains("[[patch.unused]]"),
        "Cargo.lock lists an unused patch: {reconsider}"
    );
    assert_eq!(
        locked(&lock, "webpki-roots"),
        vec![],
        "webpki-roots is in a build"
    );
    let workspace = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
    assert!(
        workspace.contains(
            "[patch.crates-io]\nzenoh-link-tls = { path = \"third_party/zenoh-link-tls\" }"
        ),
        "the workspace's Cargo.toml no longer patches zenoh-link-tls: {reconsider}"
    );
}
