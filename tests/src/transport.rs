//! The transport's processes: isolated iceoryx2 environments, Zenoh endpoints, the bridge and
//! the frame tools as child processes with bounded waits.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use bridge::iox::IoxEnv;
use bridge::ZenohArgs;

static COUNTER: AtomicUsize = AtomicUsize::new(0);

/// An isolated iceoryx2 environment (own root directory, own shared-memory prefix); removes
/// its files and shared-memory objects when dropped.
pub struct Iso {
    pub dir: tempfile::TempDir,
    pub prefix: String,
}

impl Iso {
    pub fn new(tag: &str) -> Iso {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        Iso {
            dir: tempfile::tempdir().expect("tempdir"),
            prefix: format!("ct{}_{n}_{tag}_", std::process::id()),
        }
    }

    pub fn root(&self) -> PathBuf {
        self.dir.path().join("iox")
    }

    pub fn env(&self) -> IoxEnv {
        IoxEnv::isolated(&self.root(), &self.prefix).expect("iox env")
    }

    pub fn args(&self) -> Vec<String> {
        vec![
            "--iox-root".into(),
            self.root().display().to_string(),
            "--iox-prefix".into(),
            self.prefix.clone(),
        ]
    }
}

impl Drop for Iso {
    fn drop(&mut self) {
        if let Ok(rd) = std::fs::read_dir("/dev/shm") {
            for e in rd.flatten() {
                if e.file_name().to_string_lossy().starts_with(&self.prefix) {
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
    }
}

pub use crate::{free_port, signal, wait_until, Signal};

/// A Unix-socket Zenoh endpoint in `dir`.
pub fn unix_endpoint(dir: &Path, name: &str) -> String {
    format!("unixsock-stream/{}", dir.join(name).display())
}

/// Zenoh args of a peer listening on `listen` (no scouting).
pub fn z_listen(listen: &str) -> ZenohArgs {
    ZenohArgs::isolated(&[listen.to_string()], &[])
}

/// Zenoh args of a peer connecting to `connect` (no scouting, loopback listener).
pub fn z_connect(connect: &str) -> ZenohArgs {
    ZenohArgs::isolated(&["tcp/127.0.0.1:0".to_string()], &[connect.to_string()])
}

/// The frame tools and transport benchmark (this crate's binary).
pub fn bench_exe() -> PathBuf {
    crate::bin("cellsar-bridge-bench")
}

/// The `cellsar-bridge` binary.
pub fn bridge_exe() -> PathBuf {
    crate::bin("cellsar-bridge")
}

/// A child process whose stdout lines are collected, killed (and reaped) on drop.
pub struct Proc {
    pub name: String,
    pub child: Child,
    lines: mpsc::Receiver<String>,
    stderr_path: PathBuf,
}

impl Proc {
    /// Starts `exe args` with stderr written to `<dir>/<name>.err`.
    pub fn spawn(name: &str, exe: &Path, args: &[String], dir: &Path, rust_log: &str) -> Proc {
        Proc::spawn_with_env(name, exe, args, dir, Some(rust_log))
    }

    /// As [`Proc::spawn`]; `RUST_LOG` is set to `rust_log`, or removed with `None` (the
    /// binary's default log level).
    pub fn spawn_with_env(
        name: &str,
        exe: &Path,
        args: &[String],
        dir: &Path,
        rust_log: Option<&str>,
    ) -> Proc {
        let stderr_path = dir.join(format!("{name}.err"));
        let err = std::fs::File::create(&stderr_path).expect("stderr file");
        let mut cmd = Command::new(exe);
        match rust_log {
            Some(l) => cmd.env("RUST_LOG", l),
            None => cmd.env_remove("RUST_LOG"),
        };
        let mut child = cmd
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::from(err))
            .spawn()
            .unwrap_or_else(|e| panic!("starting {name}: {e}"));
        let out = child.stdout.take().expect("stdout");
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Proc {
            name: name.to_string(),
            child,
            lines: rx,
            stderr_path,
        }
    }

    pub fn line(&self, timeout: Duration) -> String {
        match self.lines.recv_timeout(timeout) {
            Ok(l) => l,
            Err(_) => panic!(
                "{}: no output within {timeout:?}; stderr:\n{}",
                self.name,
                self.stderr_tail()
            ),
        }
    }

    pub fn ready(&self) {
        let l = self.line(Duration::from_secs(30));
        assert_eq!(l, "READY", "{}: {}", self.name, self.stderr_tail());
    }

    pub fn report(&mut self, timeout: Duration) -> serde_json::Value {
        let l = self.line(timeout);
        let v: serde_json::Value = serde_json::from_str(&l)
            .unwrap_or_else(|e| panic!("{}: bad report {l:?}: {e}", self.name));
        self.wait(Duration::from_secs(10));
        v
    }

    pub fn pid(&self) -> String {
        self.child.id().to_string()
    }

    /// Sends `sig` to the process, which must still exist.
    pub fn signal(&self, sig: Signal) {
        let pid = nix::unistd::Pid::from_raw(self.child.id() as i32);
        nix::sys::signal::kill(pid, sig)
            .unwrap_or_else(|e| panic!("kill -{sig} {}: {e}", self.name));
    }

    pub fn wait(&mut self, timeout: Duration) -> ExitStatus {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.child.try_wait().expect("try_wait") {
                return s;
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                panic!("{} did not exit within {timeout:?}", self.name);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr_path).unwrap_or_default()
    }

    pub fn stderr_tail(&self) -> String {
        let s = self.stderr();
        let lines: Vec<&str> = s.lines().collect();
        lines[lines.len().saturating_sub(30)..].join("\n")
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            crate::signal(self.child.id(), Signal::SIGCONT);
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

pub fn s(v: &str) -> String {
    v.to_string()
}
