//! What another local user can do to a run of `cellsar run` on the same host, and what a run
//! does when a thread one of its services depends on fails.
//!
//! - `another_user_cannot_write_the_runs_shared_memory_nor_read_its_outputs` (`[root]`: it
//!   needs root and `setpriv` to act as `nobody`, and shows as ignored where they are
//!   missing): while a run waits for its echo, `nobody` cannot open the iceoryx2 node counter of
//!   the run (the segment whose version field, written, made every node creation fail) nor any
//!   other of its files in `/dev/shm` for writing, and cannot enter its output directory; an
//!   entry `nobody` makes under the run's prefix survives the run's clean-up, which removes the
//!   run's own entries.
//! - `a_failing_frame_receiver_ends_the_run_within_seconds_naming_the_cause`: the processor's
//!   iceoryx2 receiver thread fails at its start (its domain's node counter holds another
//!   version, as a user who could write it would leave it): the run ends with exit 1 within
//!   seconds, not at `--timeout-s`, and the launcher's output names the thread and the cause.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::time::{Duration, Instant};

use harness::pipeline::*;

const H: f64 = 30.0;

/// What starts a process as another user.
const SETPRIV: &str = "/usr/bin/setpriv";

/// Why the `[root]` test cannot run here (`None`: it can).
fn another_user_unavailable() -> Option<String> {
    let me = std::fs::metadata("/proc/self").map(|m| m.uid()).ok();
    if me != Some(0) {
        Some(format!("not root (uid {me:?})"))
    } else if !std::path::Path::new(SETPRIV).exists() {
        Some(format!("no {SETPRIV}"))
    } else {
        None
    }
}

/// Runs `sh -c SCRIPT sh ARGS...` as `nobody` (at most 60 s); its exit status and output.
fn as_nobody(script: &str, args: &[&str]) -> (bool, String) {
    let o = std::process::Command::new("timeout")
        .args([
            "60",
            SETPRIV,
            "--reuid=65534",
            "--regid=65534",
            "--clear-groups",
        ])
        .args(["sh", "-c", script, "sh"])
        .args(args)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), text)
}

/// The run's iceoryx2 prefix, from its `network` event.
fn iox_prefix(net: &serde_json::Value) -> String {
    let iox: Vec<&str> = net["iox"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    iox.windows(2)
        .find(|w| w[0] == "--iox-prefix")
        .map(|w| w[1].to_string())
        .unwrap_or_else(|| panic!("no --iox-prefix in {net}"))
}

fn mode(path: &std::path::Path) -> u32 {
    std::fs::metadata(path).unwrap().permissions().mode() & 0o777
}

fn another_user_cannot_write_the_runs_shared_memory_nor_read_its_outputs() {
    assert_eq!(another_user_unavailable(), None);
    let me = std::fs::metadata("/proc/self").unwrap().uid();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // so that `nobody` may reach the output directory but for its own mode
    std::fs::set_permissions(d, std::fs::Permissions::from_mode(0o755)).unwrap();
    // no echo: the run waits for it, its processor and planner up
    let mut l = Launch::start(d, H, &["--external", "echo", "--peer-timeout-s", "600"]);
    let net = l.event("network", Duration::from_secs(300));
    let prefix = iox_prefix(&net);
    l.event("planned", Duration::from_secs(600));
    // the processor's files of the mission's frame service beside the node counter, once it
    // took the mission on (bounded; what exists then is checked)
    let deadline = Instant::now() + Duration::from_secs(120);
    while shm_files(&prefix).len() < 2 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(100));
    }
    let files = shm_files(&prefix);
    let counter = files
        .iter()
        .find(|f| f.ends_with(".global_mgmt"))
        .unwrap_or_else(|| panic!("no node counter among {files:?}"));
    for f in &files {
        let p = std::path::Path::new("/dev/shm").join(f);
        let m = std::fs::metadata(&p).unwrap();
        assert_eq!(m.uid(), me, "{f}");
        assert_eq!(mode(&p) & 0o077, 0, "{f} has mode {:o}", mode(&p));
        // `exec 3<>` opens for reading and writing without truncating
        let (ok, text) = as_nobody("exec 3<>\"$1\"", &[&p.display().to_string()]);
        assert!(!ok, "nobody opened {f} for writing");
        assert!(text.contains("Permission denied"), "{f}: {text}");
    }
    eprintln!(
        "node counter {counter}: mode {:o}",
        mode(&std::path::Path::new("/dev/shm").join(counter))
    );
    // nor read the outputs: the output directory is the run's user's only
    let (ok, text) = as_nobody("ls \"$1\"", &[&l.out.display().to_string()]);
    assert!(!ok && text.contains("Permission denied"), "{text}");
    // what nobody may make under the run's prefix is nobody's, and stays
    let planted = format!("/dev/shm/{prefix}planted");
    let (ok, text) = as_nobody("echo x > \"$1\"", &[&planted]);
    assert!(ok, "{text}");
    assert_eq!(std::fs::metadata(&planted).unwrap().uid(), 65534);
    harness::signal(l.child.id(), nix::sys::signal::Signal::SIGINT);
    let st = l.finish(Duration::from_secs(300));
    assert_eq!(st.code(), Some(130), "{}", l.stderr_tail());
    let left = shm_files(&prefix);
    let _ = std::fs::remove_file(&planted);
    assert_eq!(left, vec![format!("{prefix}planted")], "after the run");
    // the outputs written: directories 0700, files 0600
    for sub in ["", "logs", "plan"] {
        let p = l.out.join(sub);
        assert_eq!(mode(&p), 0o700, "{}", p.display());
    }
    for sub in ["logs", "plan"] {
        for e in std::fs::read_dir(l.out.join(sub)).unwrap().flatten() {
            if e.file_type().unwrap().is_file() {
                assert_eq!(mode(&e.path()), 0o600, "{}", e.path().display());
            }
        }
    }
}

fn a_failing_frame_receiver_ends_the_run_within_seconds_naming_the_cause() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let prefix = format!("fr{}x_", std::process::id());
    // the domain's node counter, as iceoryx2 lays it out, with another version
    let path = format!(
        "/dev/shm/{}",
        pipeline::launch::iox_node_counter_name(&prefix)
    );
    let mut bytes = [0u8; 16];
    bytes[..8].copy_from_slice(&0x0000_dead_0000_0001u64.to_ne_bytes());
    std::fs::write(&path, bytes).unwrap();
    struct Cleanup(String);
    impl Drop for Cleanup {
        fn drop(&mut self) {
            for f in shm_files(&self.0) {
                let _ = std::fs::remove_file(format!("/dev/shm/{f}"));
            }
        }
    }
    let _cleanup = Cleanup(prefix.clone());
    let root = d.join("iox").display().to_string();
    let args = run_args(
        d,
        "out",
        &[
            "--external",
            "echo",
            "--iox-prefix",
            &prefix,
            "--iox-root",
            &root,
            "--max-restarts",
            "0",
            "--peer-timeout-s",
            "900",
            "--timeout-s",
            "900",
        ],
    );
    let started = Instant::now();
    let ended = cellsar_bounded(&args, d, Duration::from_secs(600), |_| {});
    eprintln!(
        "ended in {:.1} s: {:?}\n{}",
        started.elapsed().as_secs_f64(),
        ended.code,
        ended.stderr
    );
    assert_eq!(ended.code, Some(1), "{}", ended.stderr);
    // seconds on an idle machine; far below --timeout-s on a loaded one
    assert!(
        ended.elapsed < Duration::from_secs(300),
        "{:?}",
        ended.elapsed
    );
    for cause in [
        "processor",
        "the frame receiver thread stopped",
        "UnableToGenerateUniqueNodeId",
    ] {
        assert!(ended.stderr.contains(cause), "{cause}:\n{}", ended.stderr);
    }
}

/// Runs the tests as libtest would; the `[root]` test shows as ignored (the reason printed
/// once above) where the machine cannot run it.
fn main() {
    use libtest_mimic::{Arguments, Trial};
    let args = Arguments::from_args();
    let why_not = another_user_unavailable();
    if let Some(why) = &why_not {
        println!("the [root] tests are ignored on this machine: {why}");
    }
    let trial = |name: &str, run: fn()| {
        Trial::test(name, move || {
            run();
            Ok(())
        })
    };
    let trials = vec![
        trial(
            "a_failing_frame_receiver_ends_the_run_within_seconds_naming_the_cause",
            a_failing_frame_receiver_ends_the_run_within_seconds_naming_the_cause,
        ),
        trial(
            "another_user_cannot_write_the_runs_shared_memory_nor_read_its_outputs",
            another_user_cannot_write_the_runs_shared_memory_nor_read_its_outputs,
        )
        .with_kind("root")
        .with_ignored_flag(why_not.is_some()),
    ];
    libtest_mimic::run(&args, trials).exit()
}
