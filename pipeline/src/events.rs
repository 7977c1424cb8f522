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

use serde_json::{Map, Value};

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

    /// Records `{"t_s": .., "event": name, fields...}`.
    pub fn emit(&self, name: &str, fields: &[(&str, Value)]) {
        let mut m = Map::new();
        m.insert(
            "t_s".into(),
            Value::from((self.elapsed_s() * 1e3).round() / 1e3),
        );
        m.insert("event".into(), Value::from(name));
        for (k, v) in fields {
            m.insert((*k).to_string(), v.clone());
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
            e.emit("alive", &[("i", Value::from(i))]);
        }
        let all = e.all();
        assert_eq!(all.len(), KEEP_FIRST + KEEP_LATEST);
        assert_eq!(e.dropped(), 10_000);
        assert_eq!(all[0]["i"], 0);
        assert_eq!(all[KEEP_FIRST - 1]["i"], KEEP_FIRST - 1);
        assert_eq!(all[KEEP_FIRST]["i"], KEEP_FIRST + 10_000);
        assert_eq!(all.last().unwrap()["i"], n - 1);
        // bytes: large events keep the latest within KEEP_LATEST_BYTES
        let big = "x".repeat(64 << 10);
        for _ in 0..200 {
            e.emit("plan_refused", &[("why", Value::from(big.as_str()))]);
        }
        let latest: usize = e.all()[KEEP_FIRST..]
            .iter()
            .map(|v| v.to_string().len())
            .sum();
        assert!(latest <= KEEP_LATEST_BYTES, "{latest}");
        assert!(e.all().len() > KEEP_FIRST);
    }
}
