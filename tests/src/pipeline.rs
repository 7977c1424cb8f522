//! The pipeline's processes: the `cellsar` launcher with its event stream, services started
//! directly, the in-process closed-loop reference, output comparison; bounded waits, reaped
//! children.

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

use serde_json::Value;

pub use crate::{free_port, root, running, signal, Signal};

/// The `cellsar` binary.
pub fn exe() -> PathBuf {
    crate::bin("cellsar")
}

/// The shortened paper mission of radar-sim (30 landmarks, 10 s each; cut with --horizon-s).
pub fn mission() -> PathBuf {
    root().join("missions/default-30m.toml")
}

/// The small test scene.
pub fn scene() -> PathBuf {
    root().join("tests/data/small-scene.toml")
}

/// The arguments of `cellsar echo` started by hand on the test scene, joining the launcher's
/// network as its own children do: the `children` and `iox` flags of its `network` event.
pub fn echo_args(network: &Value) -> Vec<String> {
    let mut args = vec![
        "echo".to_string(),
        "--scene".to_string(),
        scene().display().to_string(),
    ];
    for key in ["children", "iox"] {
        let flags = network[key]
            .as_array()
            .unwrap_or_else(|| panic!("the network event has no `{key}` list: {network}"));
        args.extend(flags.iter().map(|v| {
            v.as_str()
                .unwrap_or_else(|| panic!("`{key}` holds a non-string: {v}"))
                .to_string()
        }));
    }
    args
}

/// `cellsar-radar-sim closed-loop` on the same inputs, in this process (same library calls),
/// cached per horizon: `<dir>/processed/{detections.csv,metrics.json,...}`, `<dir>/report.json`.
pub fn reference(horizon_s: f64) -> PathBuf {
    static CACHE: OnceLock<Mutex<HashMap<u64, (tempfile::TempDir, PathBuf)>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
    let mut c = cache.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, p)) = c.get(&horizon_s.to_bits()) {
        return p.clone();
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("closed-loop");
    let m = planner::Mission::from_path(&mission()).unwrap();
    let m = radar_sim::run::shorten(&m, horizon_s).unwrap();
    closed_loop(&m, &scene(), &out);
    c.insert(horizon_s.to_bits(), (dir, out.clone()));
    out
}

/// `cellsar-radar-sim closed-loop` of `mission` with `scene` into `out`, in this process (the
/// same library calls, the binaries' default resolution): `out/{plan,recording,processed}/`,
/// `out/report.json`.
pub fn closed_loop(mission: &planner::Mission, scene: &Path, out: &Path) {
    let scene = radar_sim::config::SceneFile::from_path(scene).unwrap();
    let options = planner::PlanOptions {
        resolution: planner::DEFAULT_RESOLUTION,
        ..planner::PlanOptions::default()
    };
    let result = planner::plan(mission, &options).unwrap();
    pipeline::report::write_plan_dir(&out.join("plan"), mission, &result).unwrap();
    let (m2, traj) = pipeline::report::read_plan_dir(&out.join("plan")).unwrap();
    radar_sim::run::simulate(&m2, &traj, &scene, &out.join("recording"), &mut |_, _| {}).unwrap();
    let metrics = radar_sim::run::process(
        &out.join("recording"),
        &out.join("processed"),
        &mut |_, _| {},
        &mut pipeline::report::image_svg::write_aperture_view,
    )
    .unwrap();
    let report = radar_sim::run::loop_report(&m2, &result.evaluation, metrics);
    radar_sim::io::write_json(&out.join("report.json"), &report).unwrap();
}

/// Asserts that the launcher's outputs in `out` are those of the closed loop in `reference`:
/// the same bytes in detections.csv/.json, metrics.json, report.json and every image.
pub fn assert_same_as_reference(out: &Path, reference: &Path) {
    let pairs = [
        ("detections.csv", "processed/detections.csv"),
        ("detections.json", "processed/detections.json"),
        ("metrics.json", "processed/metrics.json"),
        ("report.json", "report.json"),
        ("plan/trajectory.csv", "plan/trajectory.csv"),
        ("plan/mission.toml", "plan/mission.toml"),
    ];
    for (a, b) in pairs {
        let x = std::fs::read(out.join(a)).unwrap_or_else(|e| panic!("{a}: {e}"));
        let y = std::fs::read(reference.join(b)).unwrap();
        assert!(
            x == y,
            "{a} differs from closed-loop's {b}:\n--- pipeline\n{}\n--- closed-loop\n{}",
            String::from_utf8_lossy(&x),
            String::from_utf8_lossy(&y)
        );
    }
    let imgs = reference.join("processed/images");
    let mut n = 0;
    for e in std::fs::read_dir(&imgs).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        if name.ends_with(".npy") || name.ends_with(".png") || name.ends_with(".svg") {
            let x = std::fs::read(out.join("images").join(&name))
                .unwrap_or_else(|e| panic!("images/{name}: {e}"));
            assert!(
                x == std::fs::read(e.path()).unwrap(),
                "images/{name} differs"
            );
            n += 1;
        }
    }
    assert!(n >= 2, "no images compared");
    // each image comes as .npy, .png and the annotated .svg
    let svgs = std::fs::read_dir(&imgs)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(".svg"))
        .count();
    assert!(svgs >= 1, "no annotated SVG images");
}

/// Detections per aperture in a detections.csv.
pub fn rows_per_aperture(csv: &Path) -> HashMap<String, usize> {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut m = HashMap::new();
    for l in text.lines().skip(1) {
        *m.entry(l.split(',').next().unwrap().to_string())
            .or_insert(0) += 1;
    }
    m
}

/// How a bounded run of the `cellsar` binary ended.
pub struct Ended {
    /// Exit code (None: killed by a signal).
    pub code: Option<i32>,
    /// Its stderr.
    pub stderr: String,
    /// Its pid (for the iceoryx2 prefix `cs<pid>_` of a launcher).
    pub pid: u32,
    /// How long it ran.
    pub elapsed: Duration,
}

/// Runs `cellsar ARGS` (stdin closed, stdout discarded, stderr kept) and waits at most
/// `timeout` for it (then kills it and fails the test); `on_start` is called once it runs
/// (to send it a signal, say).
pub fn cellsar_bounded(
    args: &[std::ffi::OsString],
    dir: &Path,
    timeout: Duration,
    on_start: impl FnOnce(u32),
) -> Ended {
    let err = dir.join(format!("cellsar-{}.err", std::process::id()));
    let started = Instant::now();
    let mut child = Command::new(exe())
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(std::fs::File::create(&err).unwrap()))
        .spawn()
        .unwrap();
    let pid = child.id();
    on_start(pid);
    let deadline = started + timeout;
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if Instant::now() >= deadline {
            signal(pid, Signal::SIGTERM);
            std::thread::sleep(Duration::from_secs(2));
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "cellsar {args:?} did not end within {timeout:?}; stderr:\n{}",
                std::fs::read_to_string(&err).unwrap_or_default()
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Ended {
        code: status.code(),
        stderr: std::fs::read_to_string(&err).unwrap_or_default(),
        pid,
        elapsed: started.elapsed(),
    }
}

/// Files in /dev/shm whose names start with `prefix`.
pub fn shm_files(prefix: &str) -> Vec<String> {
    std::fs::read_dir("/dev/shm")
        .map(|rd| {
            rd.flatten()
                .map(|e| e.file_name().to_string_lossy().to_string())
                .filter(|n| n.starts_with(prefix))
                .collect()
        })
        .unwrap_or_default()
}

/// A `cellsar run` with `--events-json`; killed and reaped (children included) on drop.
pub struct Launch {
    pub child: Child,
    pub out: PathBuf,
    events: mpsc::Receiver<Value>,
    pub seen: Vec<Value>,
    stderr: PathBuf,
}

impl Launch {
    /// Starts `cellsar run MISSION --scene SCENE --out <dir>/out --horizon-s H --events-json
    /// --timeout-s 240 <extra>` (without `--timeout-s 240` when `extra` gives one).
    pub fn start(dir: &Path, horizon_s: f64, extra: &[&str]) -> Launch {
        Launch::start_in(&[], dir, horizon_s, extra)
    }

    /// As [`Launch::start`], the command prefixed by `prefix` (e.g. `ip netns exec NS`).
    pub fn start_in(prefix: &[&str], dir: &Path, horizon_s: f64, extra: &[&str]) -> Launch {
        Launch::start_files_in(prefix, &mission(), &scene(), dir, horizon_s, extra)
    }

    /// As [`Launch::start_in`], on the mission file `mission` and the scene file `scene`
    /// instead of the main mission and the small test scene.
    pub fn start_files_in(
        prefix: &[&str],
        mission: &Path,
        scene: &Path,
        dir: &Path,
        horizon_s: f64,
        extra: &[&str],
    ) -> Launch {
        let out = dir.join("out");
        let stderr = dir.join("launcher.err");
        let mut cmd = match prefix.split_first() {
            Some((p, rest)) => {
                let mut c = Command::new(p);
                c.args(rest).arg(exe());
                c
            }
            None => Command::new(exe()),
        };
        let mut child = cmd
            .arg("run")
            .arg(mission)
            .arg("--scene")
            .arg(scene)
            .arg("--out")
            .arg(&out)
            .args(["--horizon-s", &horizon_s.to_string(), "--events-json"])
            .args(["--resend-after-s", "2"])
            // 240 s unless `extra` names a time-out of its own (the flag may not repeat)
            .args(if extra.iter().any(|a| a.starts_with("--timeout-s")) {
                &[][..]
            } else {
                &["--timeout-s", "240"][..]
            })
            .args(extra)
            .env("RUST_LOG", "info")
            .stdout(Stdio::piped())
            .stderr(Stdio::from(std::fs::File::create(&stderr).unwrap()))
            .spawn()
            .unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if let Ok(v) = serde_json::from_str::<Value>(&line) {
                    if tx.send(v).is_err() {
                        break;
                    }
                }
            }
        });
        Launch {
            child,
            out,
            events: rx,
            seen: Vec::new(),
            stderr,
        }
    }

    fn pump(&mut self, timeout: Duration) -> bool {
        match self.events.recv_timeout(timeout) {
            Ok(v) => {
                self.seen.push(v);
                true
            }
            Err(_) => false,
        }
    }

    /// Waits for an event matching `pred` (also among those already seen after `from`).
    pub fn wait_for(
        &mut self,
        what: &str,
        timeout: Duration,
        pred: impl Fn(&Value) -> bool,
    ) -> Value {
        let deadline = Instant::now() + timeout;
        let mut i = 0;
        loop {
            while i < self.seen.len() {
                if pred(&self.seen[i]) {
                    return self.seen[i].clone();
                }
                i += 1;
            }
            let left = deadline.saturating_duration_since(Instant::now());
            assert!(
                !left.is_zero(),
                "timed out waiting for {what}; events:\n{}\nlauncher stderr:\n{}",
                self.seen
                    .iter()
                    .filter(|e| e["event"] != "status")
                    .map(|e| e.to_string())
                    .collect::<Vec<_>>()
                    .join("\n"),
                self.stderr_tail()
            );
            self.pump(left.min(Duration::from_millis(200)));
        }
    }

    pub fn event(&mut self, name: &str, timeout: Duration) -> Value {
        let n = name.to_string();
        self.wait_for(name, timeout, move |e| e["event"] == n.as_str())
    }

    /// The current pid of the child with `role`.
    pub fn pid(&self, role: &str) -> u32 {
        self.seen
            .iter()
            .rev()
            .find(|e| {
                (e["event"] == "child_started" || e["event"] == "child_restarted")
                    && e["role"] == role
            })
            .and_then(|e| e["pid"].as_u64())
            .unwrap_or_else(|| panic!("no pid for {role}")) as u32
    }

    /// Waits for the launcher to exit (draining events).
    pub fn finish(&mut self, timeout: Duration) -> ExitStatus {
        let deadline = Instant::now() + timeout;
        loop {
            while self.pump(Duration::from_millis(10)) {}
            if let Some(s) = self.child.try_wait().unwrap() {
                while self.pump(Duration::from_millis(50)) {}
                return s;
            }
            assert!(
                Instant::now() < deadline,
                "launcher did not finish within {timeout:?}; stderr:\n{}",
                self.stderr_tail()
            );
        }
    }

    /// The launcher's whole stderr.
    pub fn stderr_text(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default()
    }

    pub fn stderr_tail(&self) -> String {
        let s = std::fs::read_to_string(&self.stderr).unwrap_or_default();
        let l: Vec<&str> = s.lines().collect();
        l[l.len().saturating_sub(40)..].join("\n")
    }

    pub fn log(&self, role: &str) -> String {
        std::fs::read_to_string(self.out.join("logs").join(format!("{role}.log")))
            .unwrap_or_default()
    }

    pub fn pipeline_json(&self) -> Value {
        serde_json::from_str(&std::fs::read_to_string(self.out.join("pipeline.json")).unwrap())
            .unwrap()
    }

    pub fn named(&self, name: &str) -> Vec<Value> {
        self.seen
            .iter()
            .filter(|e| e["event"] == name)
            .cloned()
            .collect()
    }
}

impl Drop for Launch {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            signal(self.child.id(), Signal::SIGTERM);
            let deadline = Instant::now() + Duration::from_secs(20);
            while Instant::now() < deadline {
                if let Ok(Some(_)) = self.child.try_wait() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// A service started directly (not by the launcher), killed and reaped on drop.
pub struct Service {
    pub name: String,
    pub child: Child,
    pub log: PathBuf,
}

impl Service {
    pub fn start(name: &str, dir: &Path, args: &[String]) -> Service {
        Service::start_in(&[], name, dir, args)
    }

    /// As [`Service::start`], the command prefixed by `prefix` (e.g. `ip netns exec NS`).
    pub fn start_in(prefix: &[&str], name: &str, dir: &Path, args: &[String]) -> Service {
        Service::start_exe_in(prefix, &exe(), name, dir, args)
    }

    /// As [`Service::start_in`], another binary than `cellsar` (e.g. a frame tool).
    pub fn start_exe_in(
        prefix: &[&str],
        program: &Path,
        name: &str,
        dir: &Path,
        args: &[String],
    ) -> Service {
        let log = dir.join(format!("{name}.log"));
        let f = std::fs::File::create(&log).unwrap();
        let mut cmd = match prefix.split_first() {
            Some((p, rest)) => {
                let mut c = Command::new(p);
                c.args(rest).arg(program);
                c
            }
            None => Command::new(program),
        };
        let child = cmd
            .args(args)
            .env("RUST_LOG", "info")
            .stdout(Stdio::from(f.try_clone().unwrap()))
            .stderr(Stdio::from(f))
            .spawn()
            .unwrap();
        Service {
            name: name.to_string(),
            child,
            log,
        }
    }

    pub fn stop(&mut self, timeout: Duration) -> ExitStatus {
        signal(self.child.id(), Signal::SIGTERM);
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                return s;
            }
            assert!(Instant::now() < deadline, "{} did not stop", self.name);
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Waits until the log contains `text` (e.g. a tool's `READY`), or panics after `timeout`
    /// with the log.
    pub fn wait_for_log(&self, text: &str, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        while !self.log_text().contains(text) {
            assert!(
                Instant::now() < deadline,
                "{}: no `{text}` within {timeout:?}:\n{}",
                self.name,
                self.log_text()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    pub fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            signal(self.child.id(), Signal::SIGCONT);
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// The value of `key=<n>` in the last line of `log` that contains `marker`.
pub fn counter(log: &str, marker: &str, key: &str) -> Option<u64> {
    let line = log.lines().rev().find(|l| l.contains(marker))?;
    let pat = format!("{key}=");
    let i = line.find(&pat)? + pat.len();
    line[i..]
        .chars()
        .take_while(|c| c.is_ascii_digit())
        .collect::<String>()
        .parse()
        .ok()
}

/// Prints the logs of a test's processes when the test fails (on drop while panicking):
/// each file of `files` and every `*.log` in `dirs` (a launcher's `out/logs`), the last
/// `tail_lines` lines of each but its trace lines, with its path. Declare it after the temporary directory that
/// holds the logs, so that it is dropped (and prints) before the directory is removed.
pub struct LogsOnFailure {
    /// Log files.
    pub files: Vec<PathBuf>,
    /// Directories whose `*.log` files are printed too.
    pub dirs: Vec<PathBuf>,
    /// Lines printed from the end of each file.
    pub tail_lines: usize,
}

impl LogsOnFailure {
    /// The logs of `files` and `dirs`, the last 400 lines of each.
    pub fn new(files: Vec<PathBuf>, dirs: Vec<PathBuf>) -> Self {
        LogsOnFailure {
            files,
            dirs,
            tail_lines: 400,
        }
    }

    /// The logs of a deployment run in `dir` as the network tests lay it out: `<name>.log` of
    /// each process started by hand, the launcher's `launcher.err`, and its children's logs in
    /// `out/logs`.
    pub fn of_run(dir: &Path, processes: &[&str]) -> Self {
        Self::new(
            processes
                .iter()
                .map(|n| dir.join(format!("{n}.log")))
                .chain([dir.join("launcher.err")])
                .collect(),
            vec![dir.join("out/logs")],
        )
    }
}

impl Drop for LogsOnFailure {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            return;
        }
        let mut files = self.files.clone();
        for d in &self.dirs {
            let mut in_dir: Vec<PathBuf> = std::fs::read_dir(d)
                .map(|r| {
                    r.filter_map(|e| e.ok().map(|e| e.path()))
                        .filter(|p| p.extension().is_some_and(|e| e == "log"))
                        .collect()
                })
                .unwrap_or_default();
            in_dir.sort();
            files.extend(in_dir);
        }
        for f in files {
            let text = std::fs::read_to_string(&f).unwrap_or_else(|e| format!("(unreadable: {e})"));
            // trace lines (a router's every access-control decision) would hide the rest
            let all = text.lines().count();
            let lines: Vec<&str> = text.lines().filter(|l| !l.contains(" TRACE ")).collect();
            let from = lines.len().saturating_sub(self.tail_lines);
            eprintln!(
                "===== {} (last {} of {all} lines, {} trace lines left out) =====\n{}",
                f.display(),
                lines.len() - from,
                all - lines.len(),
                lines[from..].join("\n")
            );
        }
    }
}

/// The arguments of `cellsar run` on the default mission and scene over 30 s, writing to
/// `dir/out`, followed by `extra`.
pub fn run_args(dir: &std::path::Path, out: &str, extra: &[&str]) -> Vec<std::ffi::OsString> {
    let mut a: Vec<std::ffi::OsString> = vec!["run".into(), mission().into(), "--scene".into()];
    a.push(scene().into());
    a.push("--out".into());
    a.push(dir.join(out).into());
    a.extend(["--horizon-s", "30"].iter().map(std::ffi::OsString::from));
    a.extend(extra.iter().map(std::ffi::OsString::from));
    a
}
