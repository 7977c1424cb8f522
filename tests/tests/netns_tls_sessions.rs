//! Who may open a session with the secure deployment's router (`pipeline/deploy/tls/`), and
//! which routers a client accepts, emulated with two network namespaces joined by a veth pair:
//!
//! - A client without a certificate, one with a certificate of another CA, and a plain-TCP
//!   client cannot open a session with the router; the same client with a certificate of the
//!   deployment can (so the refusals are the certificates', not a broken set-up).
//! - A client refuses a router that presents a role's certificate or a router certificate of
//!   another CA, and accepts the deployment's router.
//!
//! Needs `ip` (iproute2) and the right to create network namespaces (root or CAP_NET_ADMIN);
//! where they cannot be made the tests show as ignored, saying why (`harness::trials`).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::time::Duration;

use harness::netns::{
    client, client_logging, exit_within, make_certs, start_router, start_router_as, two_namespaces,
    wait_for_log,
};
use harness::trials::Test;

/// What a client logs of its connections: why a handshake failed (debug).
const TLS_LOG: &str = "info,zenoh::net::runtime::orchestrator=debug,zenoh_link_tls=debug";

fn strangers_cannot_open_a_session_with_the_tls_router() {
    let hosts = two_namespaces();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let certs = make_certs(d, "certs", &hosts.ip_a);
    let other = make_certs(d, "other-ca", &hosts.ip_a);
    let router = start_router(&hosts, d, &certs);
    let ca = format!("root_ca_certificate: '{}'", certs.join("ca.pem").display());
    let with_cert = |dir: &Path, role: &str| {
        format!(
            "{ca}, enable_mtls: true, connect_private_key: '{}', connect_certificate: '{}'",
            dir.join(format!("{role}.key")).display(),
            dir.join(format!("{role}.pem")).display()
        )
    };
    // the deployment's own certificate: the session opens and the service is ready
    let mut good = client(&hosts, d, "good", Some(&with_cert(&certs, "planner")));
    wait_for_log(&mut good, "plan service ready", Duration::from_secs(30));
    assert_eq!(good.stop(Duration::from_secs(20)).code(), Some(0));
    // no certificate, another CA's certificate, plain TCP: refused, the service exits 1
    let mut refused = vec![
        client(&hosts, d, "no-cert", Some(&ca)),
        client(&hosts, d, "other-ca", Some(&with_cert(&other, "planner"))),
        client(&hosts, d, "plain-tcp", None),
    ];
    for s in &mut refused {
        let st = exit_within(s, Duration::from_secs(60));
        assert_eq!(st.code(), Some(1), "{}: {st}\n{}", s.name, s.log_text());
        assert!(
            !s.log_text().contains("plan service ready"),
            "{}:\n{}",
            s.name,
            s.log_text()
        );
    }
    // each for the reason of its own, as the router saw it
    let log = router.log_text();
    for why in [
        "peer sent no certificates",
        "invalid peer certificate",
        "corrupt message",
    ] {
        assert!(log.contains(why), "{why}:\n{log}");
    }
}

/// A client with the deployment's CA and a valid planner certificate refuses a router that
/// presents a role's certificate (the processor's: signed by the same CA, but a client
/// certificate naming no host) and one that presents a router certificate of another CA for
/// the same address; it accepts the deployment's router (so the refusals are the router
/// certificates', not a broken set-up).
fn clients_refuse_a_router_that_is_not_the_deployments() {
    let hosts = two_namespaces();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let certs = make_certs(d, "certs", &hosts.ip_a);
    let other = make_certs(d, "other-ca", &hosts.ip_a);
    let tls = format!(
        "root_ca_certificate: '{}', enable_mtls: true, verify_name_on_connect: true, \
         connect_private_key: '{}', connect_certificate: '{}'",
        certs.join("ca.pem").display(),
        certs.join("planner.key").display(),
        certs.join("planner.pem").display()
    );
    for (name, router_certs, role, why) in [
        (
            "role-cert",
            &certs,
            "processor",
            "invalid peer certificate: certificate does not allow extended key usage for \
             server authentication",
        ),
        (
            "other-ca",
            &other,
            "router",
            "invalid peer certificate: BadSignature",
        ),
    ] {
        let router_name = format!("router-{name}");
        let mut router = start_router_as(&hosts, d, router_certs, role, &router_name);
        let mut c = client_logging(&hosts, d, &format!("client-of-{name}"), Some(&tls), TLS_LOG);
        let st = exit_within(&mut c, Duration::from_secs(60));
        let log = c.log_text();
        assert_eq!(st.code(), Some(1), "{name}: {st}\n{log}");
        assert!(!log.contains("plan service ready"), "{name}:\n{log}");
        // for the reason of its own, as the client saw it
        assert!(log.contains(why), "{name}: {why:?}:\n{log}");
        // the router saw the client give up the handshake (it does not know why: the
        // client's verdict on the router's certificate)
        assert!(
            !router.log_text().contains("invalid peer certificate"),
            "{name}: the router refused the client, not the other way round:\n{}",
            router.log_text()
        );
        assert_eq!(
            router.stop(Duration::from_secs(20)).code(),
            Some(0),
            "{name}"
        );
    }
    // the deployment's own router: the same client opens its session
    let _router = start_router(&hosts, d, &certs);
    let mut good = client(&hosts, d, "client-of-router", Some(&tls));
    wait_for_log(&mut good, "plan service ready", Duration::from_secs(30));
    assert_eq!(good.stop(Duration::from_secs(20)).code(), Some(0));
}

fn main() {
    harness::trials::main(&[
        Test::netns(
            "strangers_cannot_open_a_session_with_the_tls_router",
            strangers_cannot_open_a_session_with_the_tls_router,
        ),
        Test::netns(
            "clients_refuse_a_router_that_is_not_the_deployments",
            clients_refuse_a_router_that_is_not_the_deployments,
        ),
    ]);
}
