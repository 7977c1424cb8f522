//! Hosts emulated with Linux network namespaces (two namespaces joined by a veth pair, or one
//! with multicast on its loopback for the tests of multicast scouting), the deployment
//! configurations of `pipeline/deploy/` adapted to them, the certificates of a secure
//! deployment (`cellsar certs`), and what a hostile peer (`cellsar-bridge-bench forge`) logs.
//!
//! Needs `ip` (iproute2) and the right to create network namespaces (root or CAP_NET_ADMIN):
//! [`unavailable`] says why they cannot be made; the tests that need them are run by
//! [`crate::trials`], which shows them as ignored there.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use crate::pipeline::{exe, Service};
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
