//! Counters of what each endpoint saw, and a rate-limited logger for bad payloads.
//!
//! Every received payload is counted exactly once as `delivered`, `malformed` or `dropped`, so
//! `received = delivered + malformed + dropped` holds at any quiescent point (tests check it).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

/// Live counters of one endpoint (shared between the I/O callback and the owner).
#[derive(Debug, Default)]
pub struct Counters {
    received: AtomicU64,
    delivered: AtomicU64,
    malformed: AtomicU64,
    dropped: AtomicU64,
    sent: AtomicU64,
    send_errors: AtomicU64,
    bytes_in: AtomicU64,
    bytes_out: AtomicU64,
}

/// A consistent-enough copy of [`Counters`] for logs and stats messages.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct CounterSnapshot {
    /// Payloads that arrived.
    pub received: u64,
    /// Payloads decoded and handed on.
    pub delivered: u64,
    /// Payloads rejected by the decoder (bad header, size, checksum, body).
    pub malformed: u64,
    /// Payloads (or deliveries) dropped because a queue or a subscriber buffer was full.
    pub dropped: u64,
    /// Messages sent.
    pub sent: u64,
    /// Sends that failed.
    pub send_errors: u64,
    /// Bytes received.
    pub bytes_in: u64,
    /// Bytes sent.
    pub bytes_out: u64,
}

impl CounterSnapshot {
    /// Field-wise sum.
    pub fn add(&self, o: &CounterSnapshot) -> CounterSnapshot {
        CounterSnapshot {
            received: self.received + o.received,
            delivered: self.delivered + o.delivered,
            malformed: self.malformed + o.malformed,
            dropped: self.dropped + o.dropped,
            sent: self.sent + o.sent,
            send_errors: self.send_errors + o.send_errors,
            bytes_in: self.bytes_in + o.bytes_in,
            bytes_out: self.bytes_out + o.bytes_out,
        }
    }
}

impl std::fmt::Display for CounterSnapshot {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "received={} delivered={} malformed={} dropped={} sent={} send_errors={} bytes_in={} bytes_out={}",
            self.received,
            self.delivered,
            self.malformed,
            self.dropped,
            self.sent,
            self.send_errors,
            self.bytes_in,
            self.bytes_out
        )
    }
}

impl Counters {
    /// A payload of `bytes` bytes arrived.
    pub fn on_received(&self, bytes: usize) {
        self.received.fetch_add(1, Ordering::Relaxed);
        self.bytes_in.fetch_add(bytes as u64, Ordering::Relaxed);
    }
    /// A payload was delivered.
    pub fn on_delivered(&self) {
        self.delivered.fetch_add(1, Ordering::Relaxed);
    }
    /// A payload was malformed.
    pub fn on_malformed(&self) {
        self.malformed.fetch_add(1, Ordering::Relaxed);
    }
    /// `n` payloads or deliveries were dropped.
    pub fn on_dropped(&self, n: u64) {
        self.dropped.fetch_add(n, Ordering::Relaxed);
    }
    /// A message of `bytes` bytes was sent.
    pub fn on_sent(&self, bytes: usize) {
        self.sent.fetch_add(1, Ordering::Relaxed);
        self.bytes_out.fetch_add(bytes as u64, Ordering::Relaxed);
    }
    /// A send failed.
    pub fn on_send_error(&self) {
        self.send_errors.fetch_add(1, Ordering::Relaxed);
    }
    /// Current values.
    pub fn snapshot(&self) -> CounterSnapshot {
        CounterSnapshot {
            received: self.received.load(Ordering::Relaxed),
            delivered: self.delivered.load(Ordering::Relaxed),
            malformed: self.malformed.load(Ordering::Relaxed),
            dropped: self.dropped.load(Ordering::Relaxed),
            sent: self.sent.load(Ordering::Relaxed),
            send_errors: self.send_errors.load(Ordering::Relaxed),
            bytes_in: self.bytes_in.load(Ordering::Relaxed),
            bytes_out: self.bytes_out.load(Ordering::Relaxed),
        }
    }
}

/// Logs rejected payloads at WARN, at most `per_second` lines per second; the rest go to
/// DEBUG and are summarised at WARN ("N more suppressed") when the next window opens, so every
/// bad payload is both counted and accounted for in the log.
#[derive(Debug)]
pub struct BadPayloadLog {
    per_second: u32,
    state: Mutex<LogWindow>,
}

#[derive(Debug)]
struct LogWindow {
    start: Instant,
    shown: u32,
    suppressed: u64,
}

impl BadPayloadLog {
    /// A logger allowing `per_second` WARN lines per second.
    pub fn new(per_second: u32) -> Self {
        BadPayloadLog {
            per_second,
            state: Mutex::new(LogWindow {
                start: Instant::now(),
                shown: 0,
                suppressed: 0,
            }),
        }
    }

    /// Records one rejected payload from `source` with the reason `err`.
    pub fn log(&self, source: &str, len: usize, err: &dyn std::fmt::Display) {
        let Ok(mut w) = self.state.lock() else {
            tracing::warn!(%source, len, error = %err, "rejected payload");
            return;
        };
        if w.start.elapsed() >= Duration::from_secs(1) {
            if w.suppressed > 0 {
                tracing::warn!(
                    suppressed = w.suppressed,
                    "{} more rejected payloads were logged at DEBUG only",
                    w.suppressed
                );
            }
            w.start = Instant::now();
            w.shown = 0;
            w.suppressed = 0;
        }
        if w.shown < self.per_second {
            w.shown += 1;
            tracing::warn!(%source, len, error = %err, "rejected payload");
        } else {
            w.suppressed += 1;
            tracing::debug!(%source, len, error = %err, "rejected payload");
        }
    }
}

impl Drop for BadPayloadLog {
    fn drop(&mut self) {
        if let Ok(w) = self.state.lock() {
            if w.suppressed > 0 {
                tracing::warn!(
                    suppressed = w.suppressed,
                    "{} more rejected payloads were logged at DEBUG only",
                    w.suppressed
                );
            }
        }
    }
}

impl Default for BadPayloadLog {
    fn default() -> Self {
        BadPayloadLog::new(10)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_snapshot() {
        let c = Counters::default();
        c.on_received(10);
        c.on_received(5);
        c.on_delivered();
        c.on_malformed();
        c.on_sent(7);
        let s = c.snapshot();
        assert_eq!(s.received, 2);
        assert_eq!(s.bytes_in, 15);
        assert_eq!(s.delivered + s.malformed + s.dropped, s.received);
        assert_eq!(s.add(&s).bytes_out, 14);
        assert!(s.to_string().contains("malformed=1"));
    }

    #[test]
    fn bad_payload_log_never_blocks() {
        let l = BadPayloadLog::new(2);
        for i in 0..100 {
            l.log("test", i, &"bad");
        }
        let w = l.state.lock().unwrap();
        assert_eq!(w.shown, 2);
        assert_eq!(w.suppressed, 98);
    }
}
