//! Hosts emulated with Linux network namespaces (two namespaces joined by a veth pair, or one
//! with multicast on its loopback for the tests of multicast scouting), the deployment
//! configurations of `pipeline/deploy/` adapted to them, the certificates of a secure
//! deployment (`cellsar certs`), its router, processor and hostile peers (`cellsar-bridge-bench
//! forge`, and what they log), clients of its router that try once to open a session
//! ([`client`]), and a run of it under forgers whose services' peak memory is bounded
//! ([`launch_over_tls`]).
//!
//! Needs `ip` (iproute2) and the right to create network namespaces (root or CAP_NET_ADMIN):
//! [`unavailable`] says why they cannot be made; the tests that need them are run by
//! [`crate::trials`], which shows them as ignored there.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use crate::memory::{peak_bound, Baseline};
use crate::pipeline::{echo_args, exe, scene, shm_files, Launch, Service};
use crate::root;

/// The namespaces of a test, deleted (with their veth ends) on drop.
pub struct Netns {
    names: Vec<String>,
}

impl Drop for Netns {
    fn drop(&mut self) {
        for n in &self.names {
            let _ = Command::new("ip").args(["netns", "del", n]).status();
        }
    }
}

/// Two namespaces and the addresses in them.
pub struct TwoHosts {
    /// Deletes the namespaces on drop.
    pub guard: Netns,
    /// Namespace A (the router's).
    pub a: String,
    /// Namespace B.
    pub b: String,
    /// The address of A.
    pub ip_a: String,
    /// The address of B.
    pub ip_b: String,
}

impl TwoHosts {
    /// `ip netns exec A`: the prefix of a command run on host A.
    pub fn in_a(&self) -> [&str; 4] {
        ["ip", "netns", "exec", self.a.as_str()]
    }

    /// `ip netns exec B`.
    pub fn in_b(&self) -> [&str; 4] {
        ["ip", "netns", "exec", self.b.as_str()]
    }
}

/// Runs `ip ARGS`, panicking with its error output when it fails.
pub fn ip(args: &[&str]) {
    let o = Command::new("ip").args(args).output().expect("running ip");
    assert!(
        o.status.success(),
        "ip {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Why network namespaces cannot be made here (no `ip`, or no permission to run
/// `ip netns add`), found by making and deleting one; `None` where they can. Any other failure
/// of the probe is left to the tests, which then fail saying why.
pub fn unavailable() -> Option<String> {
    let name = format!("csprobe{}", std::process::id());
    let o = match Command::new("ip").args(["netns", "add", &name]).output() {
        Ok(o) => o,
        Err(e) => return Some(format!("cannot run `ip` ({e}); install iproute2")),
    };
    if o.status.success() {
        let _ = Command::new("ip").args(["netns", "del", &name]).status();
        return None;
    }
    let err = String::from_utf8_lossy(&o.stderr).trim().to_string();
    (err.contains("Permission denied") || err.contains("Operation not permitted")).then(|| {
        format!("`ip netns add` is not permitted here ({err}); run as root or with CAP_NET_ADMIN")
    })
}

/// Two namespaces joined by veth, addresses 10.X.Y.1 (A) and 10.X.Y.2 (B); panics where
/// namespaces cannot be made (the tests that call it are [`crate::trials::Needs::Netns`],
/// ignored there). Names are unique per process and call, so tests of one binary may run in
/// parallel.
pub fn two_namespaces() -> TwoHosts {
    static NEXT: AtomicU32 = AtomicU32::new(0);
    let pid = std::process::id();
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let (a, b) = (format!("csa{pid}x{n}"), format!("csb{pid}x{n}"));
    ip(&["netns", "add", &a]);
    let guard = Netns {
        names: vec![a.clone(), b.clone()],
    };
    ip(&["netns", "add", &b]);
    // interface names: at most 15 characters
    let (va, vb) = (format!("cva{pid}x{n}"), format!("cvb{pid}x{n}"));
    ip(&["link", "add", &va, "type", "veth", "peer", "name", &vb]);
    ip(&["link", "set", &va, "netns", &a]);
    ip(&["link", "set", &vb, "netns", &b]);
    let net = format!("10.{}.{}", 100 + pid % 100, (pid / 100) % 250);
    let (ip_a, ip_b) = (format!("{net}.1"), format!("{net}.2"));
    ip(&["-n", &a, "addr", "add", &format!("{ip_a}/24"), "dev", &va]);
    ip(&["-n", &b, "addr", "add", &format!("{ip_b}/24"), "dev", &vb]);
    for (ns, v) in [(&a, &va), (&b, &vb)] {
        ip(&["-n", ns, "link", "set", v, "up"]);
        ip(&["-n", ns, "link", "set", "lo", "up"]);
    }
    TwoHosts {
        guard,
        a,
        b,
        ip_a,
        ip_b,
    }
}

/// One namespace whose only interface is its loopback, with multicast on it (a route for
/// 224.0.0.0/4), so that Zenoh's multicast scouting works inside it and reaches nothing
/// outside: a host of its own for the tests of scouting. Panics as [`two_namespaces`].
pub fn multicast_host() -> (Netns, String) {
    static NEXT: AtomicU32 = AtomicU32::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    let name = format!("csm{}x{n}", std::process::id());
    ip(&["netns", "add", &name]);
    let guard = Netns {
        names: vec![name.clone()],
    };
    ip(&["-n", &name, "link", "set", "lo", "up"]);
    ip(&["-n", &name, "link", "set", "lo", "multicast", "on"]);
    ip(&["-n", &name, "route", "add", "224.0.0.0/4", "dev", "lo"]);
    (guard, name)
}

/// The example router address of the configurations in `pipeline/deploy/`.
pub const EXAMPLE_ROUTER: &str = "192.168.1.10";
/// The example certificate directory of the configurations in `pipeline/deploy/tls/`.
pub const EXAMPLE_CERTS: &str = "/etc/cellsar/certs/";

/// A deployment config of `pipeline/deploy/` (`name` relative to it, e.g. `router.json5` or
/// `tls/echo.json5`) written into `dir` with the router address replaced by `router` and,
/// when given, the certificate directory by `certs`; its path.
pub fn config(dir: &Path, name: &str, router: &str, certs: Option<&Path>) -> String {
    let text = std::fs::read_to_string(root().join("pipeline/deploy").join(name)).unwrap();
    assert!(
        text.contains(EXAMPLE_ROUTER),
        "{name} lost its example address"
    );
    let mut text = text.replace(EXAMPLE_ROUTER, router);
    if let Some(c) = certs {
        assert!(
            text.contains(EXAMPLE_CERTS),
            "{name} lost its example certificate directory"
        );
        text = text.replace(EXAMPLE_CERTS, &format!("{}/", c.display()));
    }
    let p = dir.join(name.replace('/', "-"));
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

// ---- the secure deployment (`pipeline/deploy/tls/`) and its hostile peers ----

/// `cellsar certs --out DIR --host HOST` (every default role); the directory.
pub fn make_certs(dir: &Path, name: &str, host: &str) -> PathBuf {
    make_certs_with(dir, name, host, &[])
}

/// [`make_certs`] with client certificates of `extra` common names that are no role too
/// (signed by the same CA; `--extra-name`).
pub fn make_certs_with(dir: &Path, name: &str, host: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let mut c = Command::new(exe());
    c.args(["certs", "--out"]).arg(&out).args(["--host", host]);
    for n in extra {
        c.args(["--extra-name", n]);
    }
    let o = c.output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let roles = pipeline::certs::DEFAULT_ROLES.map(|r| r.as_str());
    for n in roles.iter().chain(extra) {
        assert!(out.join(format!("{n}.pem")).is_file(), "{n}");
    }
    out
}

/// The `forge progress` reports in a forger's log, oldest first.
pub fn forge_progress(log: &str) -> Vec<serde_json::Value> {
    log.lines()
        .filter_map(|l| l.split_once("forge progress ").map(|(_, j)| j))
        .map(|j| serde_json::from_str(j).unwrap())
        .collect()
}

/// A progress report of forger `s` made after this call (waits for it, bounded): what it
/// did and received up to now.
pub fn next_progress(s: &Service) -> serde_json::Value {
    let before = forge_progress(&s.log_text()).len();
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        if let Some(r) = forge_progress(&s.log_text()).into_iter().nth(before) {
            return r;
        }
        assert!(
            Instant::now() < deadline,
            "{}: no progress report within 30 s:\n{}",
            s.name,
            s.log_text()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The Zenoh id a forger logged.
pub fn forge_zid(log: &str) -> String {
    log.lines()
        .find_map(|l| {
            l.split_once("forge zid ")
                .map(|(_, z)| z.trim().to_string())
        })
        .unwrap_or_else(|| panic!("no zid logged:\n{log}"))
}

// ---- clients of the secure deployment's router ----

/// A client of the TLS router with `tls` settings (none: plain TCP), started in namespace B
/// as a planner service that tries once to connect and exits when it cannot.
pub fn client(hosts: &TwoHosts, dir: &Path, name: &str, tls: Option<&str>) -> Service {
    client_logging(hosts, dir, name, tls, "info")
}

/// [`client`] with `RUST_LOG=rust_log`.
pub fn client_logging(
    hosts: &TwoHosts,
    dir: &Path,
    name: &str,
    tls: Option<&str>,
    rust_log: &str,
) -> Service {
    let (proto, tls) = match tls {
        Some(t) => (
            "tls",
            format!("transport: {{ link: {{ tls: {{ {t} }} }} }},"),
        ),
        None => ("tcp", String::new()),
    };
    let cfg = dir.join(format!("{name}.json5"));
    std::fs::write(
        &cfg,
        format!(
            "{{ mode: 'client', connect: {{ endpoints: ['{proto}/{}:7447'], timeout_ms: 5000, \
             exit_on_failure: true }}, scouting: {{ multicast: {{ enabled: false }} }}, {tls} }}",
            hosts.ip_a
        ),
    )
    .unwrap();
    let [ip, netns, exec, b] = hosts.in_b();
    let log = format!("RUST_LOG={rust_log}");
    Service::start_in(
        &[ip, netns, exec, b, "env", &log],
        name,
        dir,
        &["planner".into(), "-c".into(), cfg.display().to_string()],
    )
}

/// Waits (bounded) for `s` to exit; its status.
pub fn exit_within(s: &mut Service, timeout: Duration) -> std::process::ExitStatus {
    let deadline = Instant::now() + timeout;
    loop {
        if let Some(st) = s.child.try_wait().unwrap() {
            return st;
        }
        assert!(
            Instant::now() < deadline,
            "{} still running after {timeout:?}:\n{}",
            s.name,
            s.log_text()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

// ---- the processes of the secure deployment, and a run under forgers ----

/// What the router logs of its access control: every decision (trace), so that a test sees
/// what the router denied.
pub const ACL_LOG: &str = "RUST_LOG=info,zenoh::net::routing::interceptor::access_control=trace";

/// The router of `pipeline/deploy/tls/router.json5`, in namespace A.
pub fn start_router(hosts: &TwoHosts, dir: &Path, certs: &Path) -> Service {
    start_router_as(hosts, dir, certs, "router", "router")
}

/// The router of `pipeline/deploy/tls/router.json5` in namespace A, presenting `certs`'s
/// certificate and key of `role` (the router's own: `router`), logging to `name`.
pub fn start_router_as(
    hosts: &TwoHosts,
    dir: &Path,
    certs: &Path,
    role: &str,
    name: &str,
) -> Service {
    let cfg = config(dir, "tls/router.json5", &hosts.ip_a, Some(certs));
    let text = std::fs::read_to_string(&cfg).unwrap();
    for ext in ["pem", "key"] {
        assert!(text.contains(&format!("router.{ext}")), "{cfg}");
    }
    let text = text
        .replace("router.pem", &format!("{role}.pem"))
        .replace("router.key", &format!("{role}.key"));
    let cfg_as = dir.join(format!("{name}.json5"));
    std::fs::write(&cfg_as, text).unwrap();
    let [ip, netns, exec, a] = hosts.in_a();
    let mut router = Service::start_in(
        &[ip, netns, exec, a, "env", ACL_LOG],
        name,
        dir,
        &["router".into(), "-c".into(), cfg_as.display().to_string()],
    );
    wait_for_log(&mut router, "router running", Duration::from_secs(30));
    router
}

/// Waits until `s`'s log contains `text` (panics, with the log, past `timeout` or when `s`
/// exits first).
pub fn wait_for_log(s: &mut Service, text: &str, timeout: Duration) {
    let deadline = Instant::now() + timeout;
    loop {
        if s.log_text().contains(text) {
            return;
        }
        if let Some(st) = s.child.try_wait().unwrap() {
            panic!(
                "{} exited ({st}) before {text:?}:\n{}",
                s.name,
                s.log_text()
            );
        }
        assert!(
            Instant::now() < deadline,
            "{}: no {text:?} within {timeout:?}:\n{}",
            s.name,
            s.log_text()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The processor of the deployment in namespace B, with its role's configuration `cfg`.
pub fn start_processor(hosts: &TwoHosts, dir: &Path, cfg: &str) -> Service {
    let args = [
        "process",
        "--frames",
        "zenoh",
        "--scene",
        &scene().display().to_string(),
        "--resend-after-s",
        "2",
        "-c",
        cfg,
    ]
    .map(String::from);
    Service::start_in(&hosts.in_b(), "processor", dir, &args)
}

/// `cellsar-bridge-bench forge` in namespace B for 600 s with the client configuration `cfg`
/// and the flags `extra`, logging to `name`; on the mesh (READY) before it returns, so that it
/// is there before the run plans.
pub fn start_forger(
    hosts: &TwoHosts,
    dir: &Path,
    name: &str,
    cfg: &str,
    extra: &[&str],
) -> Service {
    let args: Vec<String> = ["forge", "--duration-s", "600", "-c", cfg]
        .iter()
        .chain(extra)
        .map(|a| a.to_string())
        .collect();
    let s = Service::start_exe_in(
        &hosts.in_b(),
        &crate::bin("cellsar-bridge-bench"),
        name,
        dir,
        &args,
    );
    s.wait_for_log("READY", Duration::from_secs(60));
    s
}

/// Seconds the forgers work against the planned mission before the echo starts: the window
/// in which each service's peak memory is measured (as the hostile suite on the private mesh
/// does, `tests/tests/hostile.rs`).
pub const FORGE_S: u64 = 15;

/// The largest encoded plan in play (the run's, about 30 KB, and the forgers' smaller ones):
/// the plan size of the memory bound ([`peak_bound`]).
pub const PLAN_BYTES: u64 = 64 * 1024;

/// A run of the secure deployment whose echo starts late ([`launch_over_tls`]).
pub struct Run {
    /// The launcher.
    pub l: Launch,
    /// The echo, started by hand in namespace A once the window is over.
    pub echo: Service,
    /// The launcher's `network` event.
    pub net: serde_json::Value,
    /// The mission's id.
    pub id: String,
}

impl Run {
    /// Waits for the launcher to exit; its status. Stops the echo and removes the
    /// iceoryx2 segments it left after the launcher's clean-up.
    pub fn finish(&mut self) -> std::process::ExitStatus {
        let st = self.l.finish(Duration::from_secs(240));
        let echo = self.echo.stop(Duration::from_secs(20));
        let iox: Vec<&str> = self.net["iox"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        if let Some(w) = iox.windows(2).find(|w| w[0] == "--iox-prefix") {
            for f in shm_files(w[1]) {
                let _ = std::fs::remove_file(format!("/dev/shm/{f}"));
            }
        }
        assert!(echo.success(), "echo: {echo:?}\n{}", self.echo.log_text());
        st
    }
}

/// The launcher in namespace A (`role(r)`: role r's configuration) with the planner and the
/// bridge as children, each with its role's configuration; the processor (in B, `processor`)
/// and the echo external. Once the mission is planned and the bridge started, `forgers` (given
/// the mission id) starts what forgers are still to start, and the peak resident memory of
/// the router, the launcher, the planner, the bridge and the processor is measured for
/// [`FORGE_S`] s under the forgers and asserted within the hostile suite's bound
/// ([`peak_bound`] of [`PLAN_BYTES`]); then the echo starts (by hand, in A, with the echo's
/// configuration) and the run goes on.
pub fn launch_over_tls(
    hosts: &TwoHosts,
    dir: &Path,
    h: f64,
    role: &dyn Fn(&str) -> String,
    services: [&Service; 2],
    forgers: &mut dyn FnMut(&str) -> Vec<Service>,
) -> (Run, Vec<Service>) {
    let child_config = |r: &str| format!("{r}={}", role(r));
    let (planner, bridge) = (child_config("planner"), child_config("bridge"));
    let launcher = role("launcher");
    let mut l = Launch::start_in(
        &hosts.in_a(),
        dir,
        h,
        &[
            "--transport",
            "zenoh",
            "--external",
            "processor",
            "--external",
            "echo",
            "-c",
            &launcher,
            "--child-config",
            &planner,
            "--child-config",
            &bridge,
        ],
    );
    let net = l.event("network", Duration::from_secs(60));
    let planned = l.event("planned", Duration::from_secs(120));
    let id = planned["mission_id"].as_str().unwrap().to_string();
    // the bridge up (alive: its session open), so that its start is not counted
    l.wait_for("the bridge alive", Duration::from_secs(60), |e| {
        e["event"] == "alive" && e["role"] == "bridge" && e["alive"] == true
    });
    let [router, processor] = services;
    let measured = [
        ("router", router.child.id()),
        ("processor", processor.child.id()),
        ("launcher", l.child.id()),
        ("planner", l.pid("planner")),
        ("bridge", l.pid("bridge")),
    ]
    .map(|(name, pid)| (name, Baseline::take(pid)));
    let started = forgers(&id);
    std::thread::sleep(Duration::from_secs(FORGE_S));
    for (name, b) in &measured {
        b.assert_peak_within(
            peak_bound(PLAN_BYTES),
            &format!("the {name} under forgers over TLS ({FORGE_S} s)"),
        );
    }
    // the echo now, with its role's configuration instead of the launcher's
    let mut ea = echo_args(&net);
    match ea.iter().position(|a| a == "--config") {
        Some(i) => ea[i + 1] = role("echo"),
        None => ea.extend(["--config".to_string(), role("echo")]),
    }
    let echo = Service::start_in(&hosts.in_a(), "echo", dir, &ea);
    (Run { l, echo, net, id }, started)
}

/// The last status the launcher got from the processor: its counters.
pub fn processor_counters(l: &Launch) -> serde_json::Value {
    l.named("status")
        .into_iter()
        .rev()
        .find(|e| e["role"] == "processor")
        .map(|e| e["counters"].clone())
        .unwrap_or_else(|| panic!("no processor status:\n{:#?}", l.named("status")))
}
