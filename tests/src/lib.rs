//! The one harness of cellsar's system tests: where the binaries and the repository are, free
//! ports, bounded waits, signals, the Python environment of the Python client tests, and (in
//! [`pipeline`] and [`transport`]) the launcher, service and frame-tool processes with their
//! fixtures. Every child a helper starts is stopped and reaped when its guard drops.
//!
//! The binaries are those of the `pipeline` crate (`cellsar`, `cellsar-planner`,
//! `cellsar-radar-sim`, `cellsar-bridge`), the fmu crate's `package-fmu` and this crate's
//! `cellsar-bridge-bench`, found next
//! to the test executable: `cargo test --workspace` builds them all before any test runs
//! (alone, `cargo test -p cellsar-tests` needs `cargo build -p pipeline --bins` first).

#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

pub mod memory;
pub mod netns;
pub mod pipeline;
pub mod transport;
pub mod trials;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

pub use nix::sys::signal::Signal;

/// The repository root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate lies in the repository root")
        .to_path_buf()
}

/// The target directory of this build (`target/`, or `$CARGO_TARGET_DIR`).
pub fn target_dir() -> PathBuf {
    profile_dir()
        .parent()
        .expect("target/<profile> has a parent")
        .to_path_buf()
}

/// `target/<profile>`: two levels above the test executable (`target/<profile>/deps/test-…`).
pub fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test executable's path");
    exe.parent()
        .and_then(Path::parent)
        .expect("the test executable lies in target/<profile>/deps")
        .to_path_buf()
}

/// The path of a workspace binary built in this profile; panics naming the build command when
/// it is missing.
pub fn bin(name: &str) -> PathBuf {
    let p = profile_dir().join(name);
    assert!(
        p.is_file(),
        "{} not built: run the tests with `cargo test --workspace`, or build the binaries first \
         (`cargo build -p pipeline --bins`)",
        p.display()
    );
    p
}

/// A TCP port on loopback that was free a moment ago.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("binding a loopback port")
        .port()
}

/// Waits until `cond` holds (polling every 20 ms) or panics after `timeout`.
pub fn wait_until(what: &str, timeout: Duration, mut cond: impl FnMut() -> bool) {
    let deadline = Instant::now() + timeout;
    while !cond() {
        assert!(
            Instant::now() < deadline,
            "timed out after {timeout:?} waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Sends `sig` to process `pid`; a process that is already gone is not an error.
pub fn signal(pid: u32, sig: Signal) {
    let Ok(pid) = i32::try_from(pid) else { return };
    let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), sig);
}

/// Whether a process with this pid exists and is not a zombie.
pub fn running(pid: u32) -> bool {
    // /proc directly: kill(pid, 0) succeeds on a zombie, and nix has no call for a process state
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .map(|s| !s.contains(") Z "))
        .unwrap_or(false)
}

/// The Python interpreter of the Python tests: `$CELLSAR_PYTHON` if set, else a virtual
/// environment in `target/py-venv` with `.ci/requirements.txt` installed, made on first use
/// (and again when the requirements change; one process at a time, under a file lock).
pub fn python() -> PathBuf {
    static PYTHON: OnceLock<PathBuf> = OnceLock::new();
    PYTHON.get_or_init(provision_python).clone()
}

fn provision_python() -> PathBuf {
    if let Some(p) = std::env::var_os("CELLSAR_PYTHON") {
        return PathBuf::from(p);
    }
    let requirements = root().join(".ci/requirements.txt");
    let wanted = std::fs::read_to_string(&requirements)
        .unwrap_or_else(|e| panic!("{}: {e}", requirements.display()));
    let target = target_dir();
    let venv = target.join("py-venv");
    let python = venv.join("bin").join("python");
    let stamp = venv.join("requirements.installed");
    let lock = std::fs::File::create(target.join("py-venv.lock")).expect("py-venv.lock");
    lock.lock().expect("locking py-venv.lock");
    if python.is_file() && std::fs::read_to_string(&stamp).ok().as_deref() == Some(&wanted) {
        return python;
    }
    eprintln!(
        "provisioning the Python test environment {} from {}",
        venv.display(),
        requirements.display()
    );
    run(Command::new("python3").args(["-m", "venv"]).arg(&venv));
    run(Command::new(&python)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "-r",
        ])
        .arg(&requirements));
    std::fs::write(&stamp, &wanted).expect("writing the requirements stamp");
    python
}

/// Runs `cmd` to completion; panics naming it when it cannot start or fails.
pub fn run(cmd: &mut Command) {
    let status = cmd
        .status()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"));
    assert!(status.success(), "{cmd:?} failed: {status}");
}

/// `pip install ./python` into the test environment ([`python`]), with its console scripts, with
/// maturin (from the environment) as the build backend, in the debug profile and in
/// `target/python-package` (the package is its own workspace), so that a rebuild after a change
/// is incremental; pip reinstalls the wheel every time (a few seconds when nothing changed).
pub fn install_python_package() {
    let python = python();
    let venv_bin = python
        .parent()
        .expect("the venv's bin directory")
        .to_path_buf();
    let path = std::env::var_os("PATH").unwrap_or_default();
    let mut paths = vec![venv_bin];
    paths.extend(std::env::split_paths(&path));
    run(Command::new(&python)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "--no-build-isolation",
            "--force-reinstall",
            "--no-deps",
        ])
        .arg(root().join("python"))
        .env("PATH", std::env::join_paths(paths).expect("PATH"))
        .env("CARGO_TARGET_DIR", target_dir().join("python-package"))
        .env("MATURIN_PEP517_ARGS", "--profile dev"));
}

/// Runs `pytest -q DIR` in the test environment ([`python`]) from the repository root, with
/// `env` set; panics when a test fails.
pub fn pytest(dir: &Path, env: &[(&str, &Path)]) {
    let mut cmd = Command::new(python());
    cmd.args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(dir)
        .current_dir(root());
    for (k, v) in env {
        cmd.env(k, v);
    }
    run(&mut cmd);
}
