//! Every process of a mission must read the same scene and use the same `--max-frame-bytes`
//! (docs/deployment.md, "Single host"): the frame layout is a function of both, the scene's
//! digest travels with every aperture request and frame, and a mismatch is refused by name.
//! The run's echo is started by hand (`--external echo`) with another `--max-frame-bytes`, or
//! on another scene (of the same layout, or of another), and the message naming the mismatch
//! is waited for in the logs; the run, which cannot complete, is then interrupted.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::time::{Duration, Instant};

use harness::pipeline::*;
use harness::{signal, Signal};
use serde_json::Value;

const H: f64 = 30.0;

/// Removes the iceoryx2 files of the run of `net` (its `network` event) that the echo,
/// started by hand, left after the launcher's clean-up.
fn remove_echo_segments(net: &Value) {
    let iox: Vec<String> = serde_json::from_value(net["iox"].clone()).unwrap();
    if let Some(i) = iox.iter().position(|a| a == "--iox-prefix") {
        for f in shm_files(&iox[i + 1]) {
            let _ = std::fs::remove_file(format!("/dev/shm/{f}"));
        }
    }
}

/// Starts a run whose echo is started by hand with `edit` applied to its arguments, waits for
/// `needle` in the log of `role` ("echo": the hand-started echo's, else the launcher's child's),
/// interrupts the run (exit 130) and gives that log.
fn mismatched_run(
    d: &std::path::Path,
    edit: impl Fn(&mut Vec<String>),
    role: &str,
    needle: &str,
) -> String {
    let mut l = Launch::start(d, H, &["--external", "echo"]);
    let net = l.event("network", Duration::from_secs(60));
    let mut args = echo_args(&net);
    edit(&mut args);
    let mut echo = Service::start("echo", d, &args);
    let deadline = Instant::now() + Duration::from_secs(120);
    let log = loop {
        let log = if role == "echo" {
            echo.log_text()
        } else {
            l.log(role)
        };
        if log.contains(needle) {
            break log;
        }
        let ended = l.child.try_wait().unwrap();
        assert!(
            ended.is_none() && Instant::now() < deadline,
            "{role}: no {needle:?} (the run {ended:?}):\n{log}\n{}",
            l.stderr_tail()
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    signal(l.child.id(), Signal::SIGINT);
    let st = l.finish(Duration::from_secs(60));
    assert_eq!(st.code(), Some(130), "{}", l.stderr_tail());
    assert!(!l.out.join("metrics.json").exists());
    echo.stop(Duration::from_secs(20));
    remove_echo_segments(&net);
    log
}

/// An echo with another `--max-frame-bytes` than the processor's (256 KiB: 25 pulses of the
/// small scene per frame, against a whole look under the default 4 MiB) refuses the
/// processor's requests, naming the flag.
#[test]
fn another_max_frame_bytes_at_the_echo_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let log = mismatched_run(
        dir.path(),
        |a| a.extend(["--max-frame-bytes".to_string(), "262144".to_string()]),
        "echo",
        "give both the same --max-frame-bytes",
    );
    assert!(
        log.contains("frame layout mismatch: the requester expects"),
        "{log}"
    );
}

/// The small scene with `from` replaced by `to`, written into `dir`; the log names both
/// scenes' digests when an echo on it is refused.
fn other_scene(dir: &std::path::Path, from: &str, to: &str) -> (std::path::PathBuf, [String; 2]) {
    let text = std::fs::read_to_string(scene()).unwrap();
    assert!(text.contains(from), "{text}");
    let other = dir.join("other-scene.toml");
    std::fs::write(&other, text.replace(from, to)).unwrap();
    let digest = |p: &std::path::Path| {
        format!(
            "{:016x}",
            radar_sim::config::SceneFile::from_path(p).unwrap().digest()
        )
    };
    let digests = [digest(&scene()), digest(&other)];
    assert_ne!(digests[0], digests[1]);
    (other, digests)
}

/// Runs the mission with its echo on `other`, and gives the echo's log once it refuses the
/// processor's first aperture request for its scene.
fn echo_on_scene(dir: &std::path::Path, other: &std::path::Path) -> String {
    mismatched_run(
        dir,
        |a| {
            let i = a.iter().position(|x| x == "--scene").unwrap();
            a[i + 1] = other.display().to_string();
        },
        "echo",
        "scene mismatch",
    )
}

/// An echo on another scene of the same layout (the small scene's cyclic prefix of 128 samples
/// instead of 256: the same samples per pulse and frame numbers, other samples) made a run
/// that ended with no detection and exit 0. The processor's first aperture request carries its
/// scene's digest, and the echo refuses it naming both digests and `--scene`.
#[test]
fn another_scene_of_the_same_layout_at_the_echo_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let (other, [ours, theirs]) = other_scene(dir.path(), "cp_samples = 256", "cp_samples = 128");
    let log = echo_on_scene(dir.path(), &other);
    assert!(
        log.contains(&format!(
            "scene digest {ours}, where this service's scene has {theirs}"
        )) && log.contains("the same --scene file"),
        "{log}"
    );
}

/// An echo on a scene of another layout (the small scene with a 2048-point FFT instead of
/// 1024: twice the samples per pulse, the same pulses per frame) is refused the same way, at
/// the first request, before any frame is made.
#[test]
fn another_scene_at_the_echo_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let (other, [ours, theirs]) = other_scene(dir.path(), "fft_size = 1024", "fft_size = 2048");
    let log = echo_on_scene(dir.path(), &other);
    assert!(
        log.contains(&format!(
            "scene digest {ours}, where this service's scene has {theirs}"
        )),
        "{log}"
    );
}
