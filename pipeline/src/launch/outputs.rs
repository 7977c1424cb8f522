//! Step 3 of a run: the outputs. Writes what `cellsar-radar-sim closed-loop` writes
//! (detections, images, metrics, `report.json`) from the collected results, plus
//! `pipeline.json` (timings, counters, events) and `report.md`, and prints the summary.

use std::path::Path;

use std::collections::BTreeMap;

use anyhow::{anyhow, Result};
use bridge::CounterSnapshot;
use serde::Serialize;
use serde_json::Value;

use super::imaging::Collected;
use super::session::Session;
use super::Outcome;
use crate::events::Event;
use crate::protocol::{Plan, ServiceStatus};
use crate::senders::Refused;
use crate::services::os::write_file_atomic;
use crate::services::process::MissionContext;

/// `pipeline.json`: how a run went, beside its outputs.
#[derive(Debug, Serialize)]
pub struct PipelineJson {
    /// The mission's name.
    pub mission: String,
    /// Its id.
    pub mission_id: String,
    /// Its apertures.
    pub apertures: usize,
    /// Its IQ frames.
    pub frames: u64,
    /// Pulses per frame.
    pub frame_pulses: usize,
    /// `iox` or `zenoh` (`--transport`).
    pub transport: String,
    /// Whether the launcher started a router (`--router`).
    pub router: bool,
    /// Wall time of the run, s.
    pub wall_s: f64,
    /// Seconds from the plan request to the plan.
    pub plan_s: f64,
    /// Seconds the collection took.
    pub imaging_s: f64,
    /// Seconds from the start of the collection to each new aperture.
    pub aperture_done_s: Vec<f64>,
    /// Restarts of each local child, by role.
    pub restarts: BTreeMap<String, u32>,
    /// What the collection took, skipped and refused.
    pub collector: CollectorJson,
    /// The last status of each service, by role.
    pub services: BTreeMap<String, ServiceStatus>,
    /// The events kept (the first and the latest).
    pub events: Vec<Value>,
    /// Events between those kept, dropped.
    pub events_dropped: u64,
    /// Instances not recorded because as many known ones were alive.
    pub unrecorded_senders: u64,
}

/// The collector's counters in `pipeline.json`.
#[derive(Debug, Serialize)]
pub struct CollectorJson {
    /// Messages received again, dropped.
    pub duplicates: u64,
    /// Messages of other missions, out of range or refused as foreign.
    pub foreign: u64,
    /// Messages that contradict themselves, skipped.
    pub malformed: u64,
    /// Requests to publish results again.
    pub resend_requests: u64,
    /// Messages refused as foreign (wrong key, unknown sender).
    pub refused_senders: u64,
    /// The same, by kind.
    pub refused_by_kind: Refused,
    /// Plan replies that did not answer the request.
    pub refused_plans: u64,
    /// The detections subscriber's counters.
    pub detections: CounterSnapshot,
    /// The images subscriber's counters.
    pub images: CounterSnapshot,
    /// The metrics subscriber's counters.
    pub metrics: CounterSnapshot,
    /// The status subscriber's counters.
    pub status: CounterSnapshot,
}

/// What the run knows once the plan came.
pub(super) struct Planned<'p> {
    pub plan: &'p Plan,
    pub mission: &'p planner::Mission,
    pub ctx: &'p MissionContext,
    /// Seconds from the request to the plan.
    pub plan_s: f64,
}

impl Session<'_> {
    /// Writes every output of a complete run; the outcome: complete, or a missed landmark
    /// under `--strict`.
    pub fn finish(&self, planned: &Planned<'_>, c: &Collected) -> Result<Outcome> {
        let (out, resolved, plan) = (self.setup.out, planned.mission, planned.plan);
        c.col.write()?;
        let m = c
            .col
            .metrics()
            .cloned()
            .ok_or_else(|| anyhow!("no metrics"))?;
        let report = radar_sim::run::loop_report(resolved, &plan.result.evaluation, m);
        radar_sim::io::write_json(&out.join("report.json"), &report)?;
        let wall_s = self.setup.wall.elapsed().as_secs_f64();
        let pipeline = self.pipeline_json(planned, c, wall_s);
        write_file_atomic(
            &out.join("pipeline.json"),
            serde_json::to_string_pretty(&pipeline)?.as_bytes(),
        )?;
        let widths = window_worst_widths_m(resolved, &plan.result.evaluation);
        let n = planned.ctx.apertures.len();
        let pipeline = serde_json::to_value(&pipeline)?;
        write_report_md(out, resolved, plan, &report, &widths, &pipeline, n)?;
        self.print_summary(&report, wall_s);
        self.setup.events.emit(&Event::Done {
            wall_s,
            all_in_view_detected: report.all_in_view_detected,
        });
        if !report.all_in_view_detected {
            self.say(&missed_landmarks(resolved, &widths, &report));
        }
        Ok(if report.all_in_view_detected || !self.args().strict {
            Outcome::Complete
        } else {
            Outcome::MissedLandmark
        })
    }

    fn pipeline_json(&self, planned: &Planned<'_>, c: &Collected, wall_s: f64) -> PipelineJson {
        let args = self.args();
        let subs = &self.subs;
        PipelineJson {
            mission: planned.mission.name().to_string(),
            mission_id: planned.plan.mission_id.to_string(),
            apertures: planned.ctx.apertures.len(),
            frames: planned.ctx.layout.total_frames(),
            frame_pulses: planned.ctx.layout.frame_pulses(),
            transport: format!("{:?}", args.transport).to_lowercase(),
            router: args.router,
            wall_s,
            plan_s: planned.plan_s,
            imaging_s: c.imaging_s,
            aperture_done_s: c.aperture_done_s.clone(),
            restarts: self.restarts(),
            collector: CollectorJson {
                duplicates: c.col.duplicates,
                foreign: c.col.foreign,
                malformed: c.col.malformed,
                resend_requests: c.resend_requests,
                refused_senders: self.senders.refused,
                refused_by_kind: self.senders.refused_by_kind(),
                refused_plans: self.refused_plans,
                detections: subs.detections.counters().snapshot(),
                images: subs.images.counters().snapshot(),
                metrics: subs.metrics.counters().snapshot(),
                status: subs.statuses.counters().snapshot(),
            },
            services: c.last_status.clone(),
            events: self.setup.events.all(),
            events_dropped: self.setup.events.dropped(),
            unrecorded_senders: self.senders.unrecorded(),
        }
    }

    fn print_summary(&self, report: &radar_sim::run::LoopReport, wall_s: f64) {
        self.say("aperture landmark  in-view  detected  SNR/dB");
        for r in &report.rows {
            self.say(&format!(
                "{:>8} {:>8} {:>8.2} {:>9} {:>7.1}",
                r.aperture,
                r.landmark.map(|l| l.to_string()).unwrap_or_default(),
                r.in_view_fraction,
                r.detected_label(),
                r.snr_db.unwrap_or(f64::NAN)
            ));
        }
        self.say(&format!(
            "every landmark in view detected: {}",
            if report.all_in_view_detected {
                "yes"
            } else {
                "NO"
            }
        ));
        self.say(&format!(
            "wall time {wall_s:.1} s; outputs in {}",
            self.setup.out.display()
        ));
    }
}

/// Median of the plan's worst resolution-cell width (general cell, erratum 12 (docs/paper-notes.md)) over the
/// slots of each landmark window, m (NaN for a landmark without slots).
fn window_worst_widths_m(mission: &planner::Mission, eval: &planner::Evaluation) -> Vec<f64> {
    let n = mission.schedule().landmarks.len();
    let mut widths: Vec<Vec<f64>> = vec![Vec::new(); n];
    for (s, lm) in eval.slots.iter().zip(&mission.schedule().slot_landmark) {
        if let Some(w) = lm.and_then(|l| widths.get_mut(l)) {
            w.push(s.worst_width_m);
        }
    }
    widths
        .into_iter()
        .map(|mut w| {
            if w.is_empty() {
                return f64::NAN;
            }
            w.sort_by(f64::total_cmp);
            w[w.len() / 2]
        })
        .collect()
}

/// One line naming the in-view landmarks that were not detected and whether the plan's
/// resolution cell explains it.
fn missed_landmarks(
    mission: &planner::Mission,
    widths: &[f64],
    report: &radar_sim::run::LoopReport,
) -> String {
    let d_min = mission.params().d_min_m;
    let mut wide = 0;
    let missed: Vec<String> = report
        .rows
        .iter()
        .filter(|r| r.missed_in_view())
        .map(|r| match r.landmark.and_then(|l| widths.get(l)) {
            Some(w) if *w > d_min => {
                wide += 1;
                format!("{} (cell {w:.0} m)", r.aperture)
            }
            _ => r.aperture.to_string(),
        })
        .collect();
    let why = if wide > 0 {
        format!(
            "; a cell wider than d_min = {d_min} m (near-blind bistatic geometry, which the \
             paper's resolution criterion allows) can merge neighbouring objects"
        )
    } else {
        String::new()
    };
    format!(
        "not detected although in view: aperture(s) {}{why}; see report.md",
        missed.join(", ")
    )
}

fn write_report_md(
    out: &Path,
    mission: &planner::Mission,
    plan: &Plan,
    report: &radar_sim::run::LoopReport,
    widths: &[f64],
    pipeline: &Value,
    n: usize,
) -> Result<()> {
    use std::fmt::Write as _;
    let m = &report.metrics;
    let mut s = String::new();
    let _ = writeln!(s, "# cellsar run: {}\n", mission.name());
    let _ = writeln!(
        s,
        "- plan: {} slots, energy {:.0} J (feasible {}; {}), planned in {:.1} s",
        mission.slots(),
        plan.summary.energy_j,
        plan.summary.feasible,
        match (plan.summary.lower_bound_j, plan.summary.bound_gap_pct) {
            (Some(b), Some(gap)) => format!(
                "no feasible trajectory uses less than {b:.0} J: the plan is at most {gap:.1} % above it"
            ),
            _ => "no energy bound".to_string(),
        },
        pipeline["plan_s"].as_f64().unwrap_or(f64::NAN)
    );
    let sm = &plan.summary;
    let _ = writeln!(
        s,
        "- vehicle: {} dynamics, peak acceleration {:.2} m/s² between slots, {} slots above the \
         {:.2} m/s² limit (max_accel_mps2)",
        sm.dynamics, sm.max_accel_mps2, sm.slots_over_accel_limit, sm.accel_limit_mps2
    );
    if let Some(line) = crate::report::vehicle_limits_line(sm) {
        let _ = writeln!(s, "- vehicle limits: {line}");
    }
    let best_effort = plan.result.best_effort.as_ref();
    if let (Some(b), Some(r)) = (best_effort, plan.summary.resolution_shortfall.as_ref()) {
        let _ = writeln!(
            s,
            "- resolution: general, best effort: {} of {} windows with a cell wider than d_min \
             (the least-energy plan{note}: {}), {} unresolved slots (the least-energy plan: {}; \
             the first: {}), for {:.0} J more energy than the least-energy plan's {:.0} J \
             ({:+.1} %)",
            r.unresolved_windows,
            r.windows.len(),
            b.least_energy_shortfall.unresolved_windows,
            r.unresolved_slots,
            b.least_energy_shortfall.unresolved_slots,
            r.first_unresolved_slot
                .map_or_else(|| "none".to_string(), |k| format!("slot {k}")),
            plan.summary.energy_j - b.least_energy_j,
            b.least_energy_j,
            plan.summary.extra_energy_pct.unwrap_or(f64::NAN),
            note = crate::report::least_energy_basis_note(&plan.summary)
        );
    }
    let _ = writeln!(
        s,
        "- imaging: {n} apertures in {:.1} s; wall time {:.1} s",
        pipeline["imaging_s"].as_f64().unwrap_or(f64::NAN),
        pipeline["wall_s"].as_f64().unwrap_or(f64::NAN)
    );
    let _ = writeln!(s, "- detection: {}", m.detection_summary());
    let _ = writeln!(s, "- canceller: {}", m.canceller_summary());
    let _ = writeln!(
        s,
        "- every landmark in view detected: {}",
        if report.all_in_view_detected {
            "yes"
        } else {
            "NO"
        }
    );
    let _ = writeln!(s, "- restarts: {}", pipeline["restarts"]);
    let d_min = mission.params().d_min_m;
    let _ = writeln!(
        s,
        "\n\"cell\" is the median over the window's slots of the worst width of the plan's \
         resolution cell (general bistatic cell, erratum 12 (docs/paper-notes.md)); above d_min = {d_min} m \
         the geometry is near blind: objects d_min apart along the cell's long side fall into \
         one cell although the paper's δ_r, δ_a ≤ d_min hold (the default `--resolution general` \
         avoids this as far as the geometry allows; `--resolution paper` plans the least-energy \
         plan)."
    );
    // the least-energy plan's cell per landmark, beside a best-effort plan's
    let least: Option<Vec<(usize, f64)>> = best_effort.map(|b| {
        b.least_energy_shortfall
            .windows
            .iter()
            .map(|w| (w.landmark, w.median_worst_width_m))
            .collect()
    });
    let least_width = |l: usize| {
        least
            .as_ref()
            .and_then(|v| v.iter().find(|w| w.0 == l))
            .map(|w| w.1)
    };
    let _ = writeln!(
        s,
        "\n| aperture | landmark | in view | detected | SNR/dB | cell/m |{}\n|---:|---:|---:|:---:|---:|---:|{}",
        if least.is_some() { " least-energy plan's cell/m |" } else { "" },
        if least.is_some() { "---:|" } else { "" }
    );
    for r in &report.rows {
        let w = r
            .landmark
            .and_then(|l| widths.get(l).copied())
            .unwrap_or(f64::NAN);
        let beside = match (&least, r.landmark.and_then(least_width)) {
            (Some(_), Some(lw)) => {
                format!(" {lw:.1}{} |", if lw > d_min { " (> d_min)" } else { "" })
            }
            (Some(_), None) => " |".to_string(),
            (None, _) => String::new(),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {} | {:.1} | {:.1}{} |{beside}",
            r.aperture,
            r.landmark.map(|l| l.to_string()).unwrap_or_default(),
            r.in_view_fraction,
            match r.detected {
                Some(true) => "yes",
                Some(false) => "no",
                None => "not scored",
            },
            r.snr_db.unwrap_or(f64::NAN),
            w,
            if w > d_min { " (> d_min)" } else { "" }
        );
    }
    let _ = writeln!(s, "\nFiles: plan/, images/aperture_NNN.{{npy,png}}, detections.csv, detections.json, metrics.json, report.json, pipeline.json (timings, counters, events), logs/.");
    Ok(write_file_atomic(&out.join("report.md"), s.as_bytes())?)
}
