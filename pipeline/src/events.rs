//! The launcher's event log: kept for `pipeline.json`, and printed as JSON lines on stdout
//! with `--events-json` (what the system tests read).

use std::io::Write;
use std::sync::Mutex;
use std::time::Instant;

use serde_json::{Map, Value};

/// Events of one run.
#[derive(Debug)]
pub struct Events {
    start: Instant,
    print: bool,
    log: Mutex<Vec<Value>>,
}

impl Events {
    /// A log; `print` also writes each event as one JSON line to stdout.
    pub fn new(print: bool) -> Self {
        Events {
            start: Instant::now(),
            print,
            log: Mutex::new(Vec::new()),
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
        if self.print {
            let mut out = std::io::stdout().lock();
            let _ = writeln!(out, "{v}");
            let _ = out.flush();
        }
        if let Ok(mut l) = self.log.lock() {
            l.push(v);
        }
    }

    /// Every event so far.
    pub fn all(&self) -> Vec<Value> {
        self.log.lock().map(|l| l.clone()).unwrap_or_default()
    }

    /// Events named `name`.
    pub fn named(&self, name: &str) -> Vec<Value> {
        self.all()
            .into_iter()
            .filter(|e| e["event"] == name)
            .collect()
    }
}
