//! The launcher's event log: kept for `pipeline.json`, and printed as JSON lines on stdout
//! with `--events-json` (what the system tests read).
//!
//! Peers decide how many events some kinds make (liveliness changes, refused plan replies), so
//! what is kept is bounded: the first [`KEEP_FIRST`] events of the run and the latest
//! [`KEEP_LATEST`] (at most [`KEEP_LATEST_BYTES`] bytes of JSON together); those in between are
//! dropped and counted ([`Events::dropped`]). Every event is still printed.

use std::collections::VecDeque;
use std::io::Write;
use std::sync::Mutex;
use std::time::Instant;

use std::collections::BTreeMap;

use serde::Serialize;
use serde_json::{Map, Value};

use crate::protocol::{Role, ServiceState};

/// One event of a run: `{"t_s": <seconds since the start>, "event": "<name>", <fields>}`,
/// the name the variant's in snake case.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// The run's network: the Zenoh flags of the launcher and of its children, and the
    /// iceoryx2 flags.
    Network {
        /// The launcher's Zenoh flags.
        launcher: Vec<String>,
        /// The children's Zenoh flags.
        children: Vec<String>,
        /// The children's iceoryx2 flags.
        iox: Vec<String>,
    },
    /// A child started.
    ChildStarted {
        /// Its role.
        role: String,
        /// Its process id.
        pid: u32,
        /// Its restarts so far.
        restarts: u32,
    },
    /// A child exited.
    ChildExited {
        /// Its role.
        role: String,
        /// How it exited.
        status: String,
    },
    /// A child was started again.
    ChildRestarted {
        /// Its role.
        role: String,
        /// Its new process id.
        pid: u32,
        /// Its restarts so far.
        restarts: u32,
    },
    /// A child was stopped at the end of the run.
    ChildStopped {
        /// Its role.
        role: String,
        /// How it exited.
        status: String,
    },
    /// A liveliness token came or went.
    Alive {
        /// The role it names.
        role: String,
        /// The instance it names.
        instance: String,
        /// Whether it came (true) or went.
        alive: bool,
    },
    /// The launcher waits for something (from 2 s on, then every 30 s).
    Waiting {
        /// What it waits for.
        #[serde(rename = "for")]
        waiting_for: String,
        /// The launcher's Zenoh session.
        session: String,
        /// Routers connected.
        routers: usize,
        /// Peers connected.
        peers: usize,
        /// Seconds waited.
        waited_s: u64,
    },
    /// A planner refused the plan request.
    PlanRefused {
        /// The planner.
        planner: String,
        /// Why.
        reason: String,
    },
    /// The plan request is sent again.
    PlanRetry {
        /// The attempt.
        attempt: u32,
        /// What went wrong before.
        error: String,
    },
    /// The mission is planned.
    Planned {
        /// Its id.
        mission_id: String,
        /// Its apertures.
        apertures: usize,
        /// Its IQ frames.
        frames: u64,
        /// Pulses per frame.
        frame_pulses: usize,
        /// Seconds the plan took.
        plan_s: f64,
    },
    /// A service's status.
    Status {
        /// Its role.
        role: Role,
        /// Its state.
        state: ServiceState,
        /// Units done.
        done: u64,
        /// Its counters.
        counters: BTreeMap<String, u64>,
    },
    /// An aperture's detections arrived.
    Detections {
        /// The aperture.
        aperture: u32,
        /// Its detections.
        count: usize,
    },
    /// One more aperture has both its detections and its image.
    Aperture {
        /// Apertures done.
        done: usize,
        /// Apertures in the mission.
        total: usize,
    },
    /// The mission's metrics arrived.
    Metrics,
    /// The processor is asked to publish results again.
    ResendRequest {
        /// The apertures asked for.
        apertures: Vec<u32>,
        /// Whether the metrics are asked for.
        metrics: bool,
    },
    /// The run is done.
    Done {
        /// Its wall time, s.
        wall_s: f64,
        /// Whether every landmark in view was detected.
        all_in_view_detected: bool,
    },
    /// The run was interrupted (SIGINT/SIGTERM).
    Interrupted,
}

/// The run's first events kept for `pipeline.json`.
pub const KEEP_FIRST: usize = 1024;

/// The run's latest events kept for `pipeline.json`.
pub const KEEP_LATEST: usize = 4096;

/// Most bytes (JSON) of the latest events kept.
pub const KEEP_LATEST_BYTES: usize = 4 << 20;

#[derive(Debug, Default)]
struct Kept {
    first: Vec<Value>,
    latest: VecDeque<(Value, usize)>,
    latest_bytes: usize,
    dropped: u64,
}

/// Events of one run.
#[derive(Debug)]
pub struct Events {
    start: Instant,
    print: bool,
    log: Mutex<Kept>,
}

impl Events {
    /// A log; `print` also writes each event as one JSON line to stdout.
    pub fn new(print: bool) -> Self {
        Events {
            start: Instant::now(),
            print,
            log: Mutex::new(Kept::default()),
        }
    }

    /// Seconds since the start.
    pub fn elapsed_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// Records `{"t_s": .., "event": name, fields...}` of `e`.
    pub fn emit(&self, e: &Event) {
        let mut m = Map::new();
        m.insert(
            "t_s".into(),
            Value::from((self.elapsed_s() * 1e3).round() / 1e3),
        );
        if let Ok(Value::Object(fields)) = serde_json::to_value(e) {
            m.extend(fields);
        }
        let v = Value::Object(m);
        let line = v.to_string();
        if self.print {
            let mut out = std::io::stdout().lock();
            let _ = writeln!(out, "{line}");
            let _ = out.flush();
        }
        if let Ok(mut k) = self.log.lock() {
            if k.first.len() < KEEP_FIRST {
                k.first.push(v);
                return;
            }
            k.latest_bytes += line.len();
            k.latest.push_back((v, line.len()));
            while k.latest.len() > KEEP_LATEST || k.latest_bytes > KEEP_LATEST_BYTES {
                let Some((_, bytes)) = k.latest.pop_front() else {
                    break;
                };
                k.latest_bytes -= bytes;
                k.dropped += 1;
            }
        }
    }

    /// Every event kept: the first ones, then the latest ones.
    pub fn all(&self) -> Vec<Value> {
        self.log
            .lock()
            .map(|k| {
                k.first
                    .iter()
                    .cloned()
                    .chain(k.latest.iter().map(|(v, _)| v.clone()))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Events between the first and the latest kept that were dropped.
    pub fn dropped(&self) -> u64 {
        self.log.lock().map(|k| k.dropped).unwrap_or(0)
    }

    /// Events named `name`.
    pub fn named(&self, name: &str) -> Vec<Value> {
        self.all()
            .into_iter()
            .filter(|e| e["event"] == name)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flood of events keeps the run's first and its latest ones, within the bounds.
    #[test]
    fn a_flood_keeps_the_first_and_the_latest_events_within_bounds() {
        let e = Events::new(false);
        let n = KEEP_FIRST + KEEP_LATEST + 10_000;
        for i in 0..n {
            e.emit(&Event::Alive {
                role: "echo".into(),
                instance: format!("e{i}"),
                alive: true,
            });
        }
        let all = e.all();
        assert_eq!(all.len(), KEEP_FIRST + KEEP_LATEST);
        assert_eq!(e.dropped(), 10_000);
        let i = |v: &Value| v["instance"].as_str().unwrap().to_string();
        assert_eq!(i(&all[0]), "e0");
        assert_eq!(i(&all[KEEP_FIRST - 1]), format!("e{}", KEEP_FIRST - 1));
        assert_eq!(i(&all[KEEP_FIRST]), format!("e{}", KEEP_FIRST + 10_000));
        assert_eq!(i(all.last().unwrap()), format!("e{}", n - 1));
        // bytes: large events keep the latest within KEEP_LATEST_BYTES
        let big = "x".repeat(64 << 10);
        for _ in 0..200 {
            e.emit(&Event::PlanRefused {
                planner: "p".into(),
                reason: big.clone(),
            });
        }
        let latest: usize = e.all()[KEEP_FIRST..]
            .iter()
            .map(|v| v.to_string().len())
            .sum();
        assert!(latest <= KEEP_LATEST_BYTES, "{latest}");
        assert!(e.all().len() > KEEP_FIRST);
    }

    /// An event is its name and fields after the time, as the system tests and
    /// `--events-json` readers expect (`for` for a wait, a unit variant with its name only).
    #[test]
    fn events_are_their_name_and_fields() {
        let e = Events::new(false);
        e.emit(&Event::Waiting {
            waiting_for: "a planner".into(),
            session: "mode peer".into(),
            routers: 0,
            peers: 2,
            waited_s: 30,
        });
        e.emit(&Event::Interrupted);
        e.emit(&Event::Status {
            role: Role::Processor,
            state: ServiceState::Done,
            done: 3,
            counters: BTreeMap::from([("frames".to_string(), 30)]),
        });
        let all = e.all();
        let keys = |v: &Value| v.as_object().unwrap().keys().cloned().collect::<Vec<_>>();
        assert_eq!(all[0]["event"], "waiting");
        assert_eq!(all[0]["for"], "a planner");
        assert_eq!(all[0]["peers"], 2);
        let mut want = vec![
            "event", "for", "peers", "routers", "session", "t_s", "waited_s",
        ];
        let mut got = keys(&all[0]);
        want.sort_unstable();
        got.sort_unstable();
        assert_eq!(got, want);
        assert_eq!(keys(&all[1]).len(), 2, "{}", all[1]);
        assert_eq!(all[1]["event"], "interrupted");
        assert_eq!(all[2]["event"], "status");
        assert_eq!(all[2]["role"], "processor");
        assert_eq!(all[2]["state"], "done");
        assert_eq!(all[2]["counters"]["frames"], 30);
        assert!(all.iter().all(|v| v["t_s"].is_number()));
    }
}
