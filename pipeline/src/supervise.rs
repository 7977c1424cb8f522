//! Child processes: start, watch, restart within a bound, stop (SIGTERM, then SIGKILL after a
//! grace period), always reaped.

use std::fs::OpenOptions;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use nix::sys::signal::Signal;

use crate::events::{Event, Events};
use crate::protocol::Role;

/// Environment variable with the launcher's pid, set for every child.
pub const PARENT_ENV: &str = "CELLSAR_LAUNCHER_PID";

/// In a child of the launcher (`CELLSAR_LAUNCHER_PID` set): sets `stop` when the launcher is
/// gone (killed without a chance to stop its children), so no service outlives its run.
pub fn exit_with_launcher(stop: &std::sync::Arc<std::sync::atomic::AtomicBool>) {
    let Some(launcher) = std::env::var(PARENT_ENV)
        .ok()
        .and_then(|v| v.parse::<u32>().ok())
    else {
        return;
    };
    let stop = stop.clone();
    let _ = std::thread::Builder::new()
        .name("launcher-watch".into())
        .spawn(move || loop {
            if std::os::unix::process::parent_id() != launcher {
                tracing::warn!(launcher, "the launcher is gone: stopping");
                stop.store(true, std::sync::atomic::Ordering::Relaxed);
                return;
            }
            std::thread::sleep(Duration::from_millis(250));
        });
}

/// Errors of the supervisor. A variant whose message includes its cause does not also return
/// it from `source()` (each cause is printed once).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SuperviseError {
    /// A child could not be started.
    #[error("starting {role} ({exe}): {error}")]
    Spawn {
        /// Role of the child.
        role: String,
        /// Executable.
        exe: String,
        /// The OS error (in the message).
        error: std::io::Error,
    },
    /// The log file of a child could not be opened.
    #[error("log file {path}: {error}")]
    Log {
        /// The file.
        path: PathBuf,
        /// The OS error (in the message).
        error: std::io::Error,
    },
    /// A child kept failing.
    #[error("{role} failed {failures} times (last: {last}); giving up (see {log})")]
    KeepsFailing {
        /// Role.
        role: String,
        /// Failures.
        failures: u32,
        /// Last exit status.
        last: String,
        /// Its log file.
        log: String,
    },
}

/// What to start.
#[derive(Debug, Clone)]
pub struct ChildSpec {
    /// Role (planner, echo, processor, bridge, router).
    pub role: Role,
    /// Executable.
    pub exe: PathBuf,
    /// Arguments.
    pub args: Vec<String>,
    /// Log file (stdout and stderr, appended across restarts).
    pub log: PathBuf,
    /// `RUST_LOG` for the child (None: inherit).
    pub rust_log: Option<String>,
}

/// One supervised child.
#[derive(Debug)]
pub struct Supervised {
    /// What it is.
    pub spec: ChildSpec,
    child: Option<Child>,
    /// Restarts so far.
    pub restarts: u32,
    /// Unexpected exits so far.
    pub failures: u32,
    restart_at: Option<Instant>,
    last_exit: Option<String>,
    /// The length of the log when the child was last started: what it wrote since is its own.
    log_start: u64,
}

/// What happened to a child during a poll.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ChildEvent {
    /// It exited; it will be restarted.
    Exited {
        /// Role.
        role: String,
        /// Exit status.
        status: String,
    },
    /// It was started again.
    Restarted {
        /// Role.
        role: String,
        /// New pid.
        pid: u32,
        /// Restart count.
        restarts: u32,
    },
}

impl Supervised {
    /// Starts `spec`.
    pub fn start(spec: ChildSpec, events: &Events) -> Result<Supervised, SuperviseError> {
        let mut s = Supervised {
            spec,
            child: None,
            restarts: 0,
            failures: 0,
            restart_at: None,
            last_exit: None,
            log_start: 0,
        };
        s.spawn(events)?;
        Ok(s)
    }

    fn spawn(&mut self, events: &Events) -> Result<u32, SuperviseError> {
        let log = open_log(&self.spec.log)?;
        self.log_start = log.metadata().map(|m| m.len()).unwrap_or(0);
        let log2 = log.try_clone().map_err(|error| SuperviseError::Log {
            path: self.spec.log.clone(),
            error,
        })?;
        let mut cmd = Command::new(&self.spec.exe);
        cmd.args(&self.spec.args)
            .stdin(Stdio::null())
            .stdout(Stdio::from(log))
            .stderr(Stdio::from(log2));
        if let Some(l) = &self.spec.rust_log {
            cmd.env("RUST_LOG", l);
        }
        cmd.env(PARENT_ENV, std::process::id().to_string());
        let child = cmd.spawn().map_err(|error| SuperviseError::Spawn {
            role: self.spec.role.to_string(),
            exe: self.spec.exe.display().to_string(),
            error,
        })?;
        let pid = child.id();
        events.emit(&Event::ChildStarted {
            role: self.spec.role.to_string(),
            pid,
            restarts: self.restarts,
        });
        tracing::info!(role = %self.spec.role, pid, "started");
        self.child = Some(child);
        Ok(pid)
    }

    /// The pid of the running child.
    pub fn pid(&self) -> Option<u32> {
        self.child.as_ref().map(Child::id)
    }

    /// Checks the child; restarts it (after `backoff`) if it exited, unless it has failed
    /// more than `max_restarts` times.
    pub fn poll(
        &mut self,
        events: &Events,
        max_restarts: u32,
        backoff: Duration,
    ) -> Result<Option<ChildEvent>, SuperviseError> {
        if let Some(c) = self.child.as_mut() {
            match c.try_wait() {
                Ok(None) => return Ok(None),
                Ok(Some(status)) => {
                    self.child = None;
                    self.failures += 1;
                    // with the error it printed, so that the launcher's own output names the
                    // cause
                    let st = match last_error(&self.spec.log, self.log_start) {
                        Some(e) => format!("{}: {e}", describe(status)),
                        None => describe(status),
                    };
                    tracing::warn!(role = %self.spec.role, status = %st, "child exited");
                    events.emit(&Event::ChildExited {
                        role: self.spec.role.to_string(),
                        status: st.clone(),
                    });
                    self.last_exit = Some(st.clone());
                    if self.failures > max_restarts {
                        return Err(SuperviseError::KeepsFailing {
                            role: self.spec.role.to_string(),
                            failures: self.failures,
                            last: st,
                            log: self.spec.log.display().to_string(),
                        });
                    }
                    self.restart_at = Some(Instant::now() + backoff);
                    return Ok(Some(ChildEvent::Exited {
                        role: self.spec.role.to_string(),
                        status: st,
                    }));
                }
                Err(e) => {
                    tracing::warn!(role = %self.spec.role, error = %e, "try_wait");
                    return Ok(None);
                }
            }
        }
        if let Some(t) = self.restart_at {
            if Instant::now() >= t {
                self.restart_at = None;
                self.restarts += 1;
                let pid = self.spawn(events)?;
                events.emit(&Event::ChildRestarted {
                    role: self.spec.role.to_string(),
                    pid,
                    restarts: self.restarts,
                });
                return Ok(Some(ChildEvent::Restarted {
                    role: self.spec.role.to_string(),
                    pid,
                    restarts: self.restarts,
                }));
            }
        }
        Ok(None)
    }

    /// Sends SIGTERM (if running).
    pub fn terminate(&self) {
        if let Some(pid) = self.pid() {
            signal(pid, Signal::SIGTERM);
        }
    }

    /// Waits for the child to exit until `deadline`, then kills it; always reaps it.
    pub fn reap(&mut self, deadline: Instant) -> Option<String> {
        let mut c = self.child.take()?;
        loop {
            match c.try_wait() {
                Ok(Some(s)) => return Some(describe(s)),
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(20))
                }
                _ => {
                    tracing::warn!(role = %self.spec.role, "did not stop in time: killed");
                    let _ = c.kill();
                    return c.wait().ok().map(|s| format!("{} (killed)", describe(s)));
                }
            }
        }
    }
}

impl Drop for Supervised {
    fn drop(&mut self) {
        if let Some(c) = self.child.as_mut() {
            if let Ok(None) = c.try_wait() {
                signal(c.id(), Signal::SIGCONT);
                let _ = c.kill();
            }
            let _ = c.wait();
        }
    }
}

/// Stops every child: SIGTERM to all, then waits up to `grace` for each, then SIGKILL.
pub fn stop_all(children: &mut [Supervised], grace: Duration, events: &Events) {
    for c in children.iter() {
        c.terminate();
    }
    let deadline = Instant::now() + grace;
    for c in children.iter_mut() {
        if let Some(st) = c.reap(deadline) {
            events.emit(&Event::ChildStopped {
                role: c.spec.role.to_string(),
                status: st,
            });
        }
    }
}

fn open_log(path: &Path) -> Result<std::fs::File, SuperviseError> {
    OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(|error| SuperviseError::Log {
            path: path.to_path_buf(),
            error,
        })
}

/// The last line starting with `error: ` (how every binary prints the error it exits with)
/// that a child wrote to `log` from byte `from` on, within the last 64 KiB, without the
/// prefix and cut to 1000 characters.
fn last_error(log: &Path, from: u64) -> Option<String> {
    use std::io::{Read, Seek, SeekFrom};
    const TAIL: u64 = 64 * 1024;
    let mut f = std::fs::File::open(log).ok()?;
    let len = f.metadata().ok()?.len();
    let start = from.max(len.saturating_sub(TAIL));
    f.seek(SeekFrom::Start(start)).ok()?;
    let mut bytes = Vec::new();
    f.take(TAIL).read_to_end(&mut bytes).ok()?;
    let text = String::from_utf8_lossy(&bytes);
    let line = text.lines().rev().find_map(|l| l.strip_prefix("error: "))?;
    Some(line.chars().take(1000).collect())
}

fn describe(s: ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (s.code(), s.signal()) {
        (Some(c), _) => format!("exit code {c}"),
        (None, Some(sig)) => format!("killed by signal {sig}"),
        _ => s.to_string(),
    }
}

/// Sends `sig` to process `pid` (no error if the process is gone).
pub fn signal(pid: u32, sig: Signal) {
    if let Ok(pid) = i32::try_from(pid) {
        let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), sig);
    }
}

#[cfg(test)]
mod tests {
    use super::last_error;

    #[test]
    fn a_childs_last_error_is_read_from_what_it_wrote_since_its_start() {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("processor.log");
        let earlier = "error: an earlier start's failure\n";
        std::fs::write(
            &log,
            format!(
                "{earlier}INFO started\nerror: the frame receiver thread stopped: create node\n\
                 WARN the launcher is gone\n"
            ),
        )
        .unwrap();
        assert_eq!(
            last_error(&log, 0).as_deref(),
            Some("the frame receiver thread stopped: create node")
        );
        // a child that printed no error since its start: none, not the earlier one's
        std::fs::write(&log, format!("{earlier}INFO started\n")).unwrap();
        assert_eq!(last_error(&log, earlier.len() as u64), None);
        assert_eq!(last_error(&dir.path().join("missing.log"), 0), None);
    }
}
