//! The run's iceoryx2 frame-service files in `/dev/shm` (docs/deployment.md, "Single host"):
//! they are removed when the run ends, however it ends, and what a run killed with `-9` as a
//! whole leaves behind is removed by the next run.
//!
//! Each test reads the run's own prefix (`cs<pid>x<random>_`) from its `network` event and
//! checks that files with it exist while frames flow (so that their absence afterwards means
//! something): SIGINT, a run that times out and one that fails, each once frames flowed, and a
//! run killed as a whole. A `kill -9` of each child, with the run ending normally, is in
//! `tests/tests/reliability.rs` (`kill9_*`); a complete run, SIGINT before the children start
//! and while waiting for the planner, and runs that fail before any frame flowed are in
//! `tests/tests/system.rs`. A run started by another test binary at the moment this file's
//! killed run is checked would remove its files first; `cargo test` runs test binaries one
//! after the other.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::{Duration, Instant};

use harness::pipeline::*;
use harness::{running, signal, Signal};

/// 6 apertures of the small scene.
const H: f64 = 60.0;

/// The tests of this file one at a time: a run that starts removes the files of runs whose
/// launcher is dead, those a test killed on purpose too.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The run's iceoryx2 prefix, from its `network` event.
fn run_prefix(l: &mut Launch) -> String {
    let net = l.event("network", Duration::from_secs(60));
    let iox: Vec<String> = serde_json::from_value(net["iox"].clone()).unwrap();
    let i = iox.iter().position(|a| a == "--iox-prefix").unwrap();
    let prefix = iox[i + 1].clone();
    assert!(
        prefix.starts_with(&format!("cs{}x", l.child.id())),
        "{prefix}"
    );
    prefix
}

/// Waits for the first aperture of `l`; the frame files with `prefix` then (at least one).
fn frames_flow(l: &mut Launch, prefix: &str) -> Vec<String> {
    l.wait_for("the first aperture", Duration::from_secs(120), |e| {
        e["event"] == "aperture" && e["done"] == 1
    });
    let files = shm_files(prefix);
    assert!(
        !files.is_empty(),
        "no frame files with {prefix} while imaging"
    );
    files
}

/// Waits (bounded) until none of `pids` runs.
fn all_gone(pids: &[(String, u32)]) {
    let deadline = Instant::now() + Duration::from_secs(30);
    while pids.iter().any(|(_, p)| running(*p)) {
        assert!(Instant::now() < deadline, "still running: {pids:?}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// SIGINT to the launcher while the echo, which made the frame service, is frozen: the
/// launcher stops its children (the echo only with SIGKILL, so it cleans up nothing), exits
/// 130 and leaves no frame file.
#[test]
fn sigint_to_the_launcher_with_a_frozen_echo_leaves_no_frame_files() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut l = Launch::start(dir.path(), H, &["--window", "1"]);
    let prefix = run_prefix(&mut l);
    let files = frames_flow(&mut l, &prefix);
    // frozen at once: with one aperture in flight at a time the mission cannot end now
    signal(l.pid("echo"), Signal::SIGSTOP);
    assert!(l.child.try_wait().unwrap().is_none(), "the run ended first");
    signal(l.child.id(), Signal::SIGINT);
    let st = l.finish(Duration::from_secs(60));
    assert_eq!(st.code(), Some(130), "{}", l.stderr_tail());
    let stopped = l.named("child_stopped");
    assert!(
        stopped
            .iter()
            .any(|e| e["role"] == "echo" && e["status"].as_str().unwrap().contains("killed")),
        "the echo was not killed: {stopped:?}"
    );
    let left = shm_files(&prefix);
    assert!(left.is_empty(), "left: {left:?} (while imaging: {files:?})");
}

/// The launcher and every child killed with `-9` at once mid-mission (nothing of the run can
/// clean up): the frame files stay, and the next run removes them when it starts, then its
/// own when it ends.
#[test]
fn a_run_killed_as_a_whole_is_cleaned_up_by_the_next_run() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let reference = reference(H);
    let dir = tempfile::tempdir().unwrap();
    let mut l = Launch::start(dir.path(), H, &["--window", "1"]);
    let prefix = run_prefix(&mut l);
    frames_flow(&mut l, &prefix);
    signal(l.pid("echo"), Signal::SIGSTOP);
    let mut pids: Vec<(String, u32)> = ["planner", "echo", "processor"]
        .iter()
        .map(|r| (r.to_string(), l.pid(r)))
        .collect();
    pids.push(("launcher".into(), l.child.id()));
    for (_, p) in &pids {
        signal(*p, Signal::SIGKILL);
    }
    let _ = l.child.wait();
    all_gone(&pids);
    let left = shm_files(&prefix);
    assert!(!left.is_empty(), "the killed run left nothing to clean up");

    let dir2 = tempfile::tempdir().unwrap();
    let mut next = Launch::start(dir2.path(), H, &[]);
    let next_prefix = run_prefix(&mut next);
    let st = next.finish(Duration::from_secs(240));
    assert_eq!(st.code(), Some(0), "{}", next.stderr_tail());
    assert_same_as_reference(&next.out, &reference);
    let still = shm_files(&prefix);
    assert!(
        still.is_empty(),
        "the killed run's files are still there: {still:?} (of {left:?})"
    );
    assert!(shm_files(&next_prefix).is_empty());
}

/// `--timeout-s` expiring once frames flowed: the echo frozen after the first aperture (with
/// one aperture in flight at a time the mission cannot end), the launcher gives up at the
/// time-out, exits 1 naming it, stops its children (the frozen echo with SIGKILL) and leaves no
/// frame file.
#[test]
fn a_run_that_times_out_once_frames_flowed_leaves_no_frame_files() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    // long enough for the first aperture on a loaded machine (about 5 s on an idle one),
    // short beside the mission's remaining apertures once the echo is frozen
    const TIMEOUT_S: u64 = 45;
    let dir = tempfile::tempdir().unwrap();
    let timeout = TIMEOUT_S.to_string();
    let mut l = Launch::start(dir.path(), H, &["--window", "1", "--timeout-s", &timeout]);
    let started = Instant::now();
    let prefix = run_prefix(&mut l);
    let files = frames_flow(&mut l, &prefix);
    assert!(
        started.elapsed() < Duration::from_secs(TIMEOUT_S),
        "the first aperture came after the time-out"
    );
    signal(l.pid("echo"), Signal::SIGSTOP);
    assert!(l.child.try_wait().unwrap().is_none(), "the run ended first");
    let st = l.finish(Duration::from_secs(TIMEOUT_S + 120));
    assert_eq!(st.code(), Some(1), "{}", l.stderr_tail());
    let err = l.stderr_text();
    assert!(err.contains("timed out after"), "{err}");
    assert!(
        started.elapsed() >= Duration::from_secs(TIMEOUT_S),
        "ended before the time-out:\n{err}"
    );
    let left = shm_files(&prefix);
    assert!(left.is_empty(), "left: {left:?} (while imaging: {files:?})");
}

/// A run that fails once frames flowed: with `--max-restarts 0`, the processor killed with
/// `-9` after the first aperture (it cleans up nothing) makes the launcher give up; it exits 1
/// and leaves no frame file.
#[test]
fn a_run_that_fails_once_frames_flowed_leaves_no_frame_files() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let mut l = Launch::start(dir.path(), H, &["--window", "1", "--max-restarts", "0"]);
    let prefix = run_prefix(&mut l);
    let files = frames_flow(&mut l, &prefix);
    signal(l.pid("echo"), Signal::SIGSTOP);
    assert!(l.child.try_wait().unwrap().is_none(), "the run ended first");
    signal(l.pid("processor"), Signal::SIGKILL);
    let st = l.finish(Duration::from_secs(120));
    assert_eq!(st.code(), Some(1), "{}", l.stderr_tail());
    let err = l.stderr_text();
    assert!(err.contains("giving up"), "{err}");
    let left = shm_files(&prefix);
    assert!(left.is_empty(), "left: {left:?} (while imaging: {files:?})");
}
