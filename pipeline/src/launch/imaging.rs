//! Step 2 of a run: collecting every aperture's detections and image and the mission's
//! metrics as the processor publishes them (each only from a processor instance that announced
//! itself, [`crate::senders::Senders`]), showing progress, and asking the processor again
//! for results that it finished but that did not arrive here. The processor takes on only
//! the missions it is asked results of: the collection asks at once, and again every 2 s
//! while no processor status of the mission came for [`UNATTENDED`] (a processor that joins
//! late or restarts).

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use bridge::net::QueryOptions;
use bridge::MissionId;
use indicatif::{ProgressBar, ProgressStyle};

use super::session::Session;
use crate::collect::{Added, Collector};
use crate::events::Event;
use crate::protocol::{self, ResultAck, ResultRequest, Role, ServiceState, ServiceStatus};

/// How long without a processor status of the mission before the collection asks for the
/// mission again (the processor publishes one every `--status-interval-s`, default 1 s).
const UNATTENDED: Duration = Duration::from_secs(3);

/// What the collection gathered.
pub(super) struct Collected {
    /// The results, de-duplicated.
    pub col: Collector,
    /// Stopped by SIGINT/SIGTERM before every result arrived.
    pub interrupted: bool,
    /// The last status of each role.
    pub last_status: BTreeMap<String, ServiceStatus>,
    /// Requests to publish results again.
    pub resend_requests: u64,
    /// Seconds from the start of the collection to each new aperture.
    pub aperture_done_s: Vec<f64>,
    /// Seconds the collection took.
    pub imaging_s: f64,
}

/// Bookkeeping of the collection loop.
struct Progress {
    bar: ProgressBar,
    started: Instant,
    last_resend: Instant,
    /// When the processor first said that it finished each aperture.
    first_seen_done: BTreeMap<u32, Instant>,
    /// When the last processor status of the mission came.
    processor_seen: Option<Instant>,
}

impl Session<'_> {
    /// Collects the `apertures` results of mission `id` into `out`.
    pub fn collect(&mut self, id: MissionId, apertures: usize) -> Result<Collected> {
        let bar = ProgressBar::new(apertures as u64);
        if let Ok(s) = ProgressStyle::with_template(
            "{prefix:>9} [{bar:40}] {pos}/{len} apertures ({elapsed}, eta {eta}) {msg}",
        ) {
            bar.set_style(s.progress_chars("=> "));
        }
        bar.set_prefix("imaging");
        let mut p = Progress {
            bar,
            started: Instant::now(),
            // the mission is asked for at once
            last_resend: Instant::now()
                .checked_sub(Duration::from_secs(2))
                .unwrap_or_else(Instant::now),
            first_seen_done: BTreeMap::new(),
            processor_seen: None,
        };
        let mut c = Collected {
            col: Collector::new(id, apertures, self.setup.out)?,
            interrupted: false,
            last_status: BTreeMap::new(),
            resend_requests: 0,
            aperture_done_s: Vec::new(),
            imaging_s: 0.0,
        };
        c.interrupted = loop {
            if self.stopped() {
                break true;
            }
            self.check_time("collecting results")?;
            self.tick()?;
            let missing = self.missing_peer();
            let limit = self.args().peer_timeout_s.duration();
            self.waiting_for(missing.as_deref(), Some((limit, "--peer-timeout-s")))?;
            let progressed = self.receive(id, &mut c, &mut p)?;
            if progressed {
                let done = c.col.done();
                if done as u64 > p.bar.position() {
                    c.aperture_done_s.push(p.started.elapsed().as_secs_f64());
                    self.setup.events.emit(&Event::Aperture {
                        done,
                        total: apertures,
                    });
                }
                p.bar.set_position(done as u64);
            }
            if c.col.complete() {
                break false;
            }
            if p.last_resend.elapsed() >= Duration::from_secs(2) {
                p.last_resend = Instant::now();
                self.ask_again(id, &mut c, &p)?;
            }
            if !progressed {
                std::thread::sleep(Duration::from_millis(20));
            }
        };
        p.bar.finish_and_clear();
        c.imaging_s = p.started.elapsed().as_secs_f64();
        Ok(c)
    }

    /// Takes what arrived; whether a new detection or image came.
    fn receive(&mut self, id: MissionId, c: &mut Collected, p: &mut Progress) -> Result<bool> {
        let events = self.setup.events;
        let mut progressed = false;
        // metrics are taken once every aperture's detections agree with them: perhaps with
        // the detections that come now
        let had_metrics = c.col.has_metrics();
        while let Some(d) = self.subs.detections.try_recv() {
            if self.senders.detections(&d.key, &d.message).is_err() {
                c.col.foreign += 1;
                continue;
            }
            let k = d.message.aperture;
            if c.col.add_detections(d.message) == Added::New {
                progressed = true;
                if let Some(dm) = c.col.detections(k) {
                    p.bar.set_message(format!(
                        "aperture {k}: {} detections, landmark {}",
                        dm.detections.len(),
                        match dm.landmark_detected {
                            Some(true) => "detected",
                            Some(false) => "missed",
                            None => "-",
                        }
                    ));
                    events.emit(&Event::Detections {
                        aperture: k,
                        count: dm.detections.len(),
                    });
                }
            }
        }
        while let Some(img) = self.subs.images.try_recv() {
            if self.senders.image(&img.key, &img.message).is_err() {
                c.col.foreign += 1;
                continue;
            }
            if c.col.add_image(&img.message)? == Added::New {
                progressed = true;
            }
        }
        while let Some(m) = self.subs.metrics.try_recv() {
            if self.senders.metrics(&m.key, &m.message).is_err() {
                c.col.foreign += 1;
                continue;
            }
            c.col.add_metrics(m.message);
        }
        if !had_metrics && c.col.has_metrics() {
            events.emit(&Event::Metrics);
        }
        while let Some(s) = self.subs.statuses.try_recv() {
            if s.message.mission_id != id || self.senders.status(&s.key, &s.message).is_err() {
                continue;
            }
            let s = s.message;
            if s.role == Role::Processor && s.state == ServiceState::Failed {
                bail!("the processor gave up the mission: {}", s.message);
            }
            events.emit(&Event::Status {
                role: s.role,
                state: s.state,
                done: s.done,
                counters: s.counters.clone(),
            });
            if s.role == Role::Processor {
                p.processor_seen = Some(Instant::now());
                for k in &s.done_items {
                    p.first_seen_done
                        .entry(*k as u32)
                        .or_insert_with(Instant::now);
                }
            }
            c.last_status.insert(s.role.to_string(), s);
        }
        Ok(progressed)
    }

    /// Asks the processor again for results it has but that did not arrive here: apertures it
    /// finished 2 s ago or more, and the metrics once it is done; asks for the mission (an
    /// empty request, which the processor takes on) while no processor attends to it.
    fn ask_again(&mut self, id: MissionId, c: &mut Collected, p: &Progress) -> Result<()> {
        let stale: Vec<u32> = c
            .col
            .missing()
            .into_iter()
            .filter(|k| {
                p.first_seen_done
                    .get(k)
                    .is_some_and(|t| t.elapsed() >= Duration::from_secs(2))
            })
            .collect();
        let want_metrics = !c.col.has_metrics()
            && c.col.done() == c.col.apertures
            && c.last_status
                .get("processor")
                .is_some_and(|s| s.state == ServiceState::Done);
        let unattended = p.processor_seen.is_none_or(|t| t.elapsed() >= UNATTENDED);
        if stale.is_empty() && !want_metrics && !unattended {
            return Ok(());
        }
        if !stale.is_empty() || want_metrics {
            c.resend_requests += 1;
            self.setup.events.emit(&Event::ResendRequest {
                apertures: stale.clone(),
                metrics: want_metrics,
            });
        }
        let req = ResultRequest {
            mission_id: id,
            apertures: stale,
            metrics: want_metrics,
        };
        match self.node.query_one::<ResultRequest, ResultAck>(
            &protocol::keys::results(id)?,
            &req,
            &QueryOptions {
                timeout: Duration::from_secs(2),
                ..QueryOptions::default()
            },
        ) {
            Ok(a) => {
                tracing::info!(republished = ?a.message.republished, missing = ?a.message.missing, "results asked again")
            }
            Err(e) => tracing::debug!(error = %e, "asking for results again"),
        }
        Ok(())
    }
}
