//! Step 1 of a run: the plan. Waits for a planner's liveliness token, asks it for the plan and
//! waits for the answer, together at most `--plan-timeout-s`; a busy planner (its request
//! queue full, or this launcher's place in it taken) is asked again after a bounded, jittered
//! pause ([`busy_pause`]) until `--plan-timeout-s`; one that does not answer is asked again at
//! most `--max-restarts` more times; SIGINT/SIGTERM at any moment ends the run as interrupted.
//! The request names this launcher (`cellsar/plan?requester=<Zenoh session id>`), so that the
//! planner serves it in turn with other requesters'.

use std::time::{Duration, Instant};

use anyhow::{anyhow, Context, Result};
use bridge::envelope::DecodeLimits;
use bridge::net::{QueryOptions, WireFormat};
use bridge::{NetError, RefusalKind};
use indicatif::{ProgressBar, ProgressStyle};

use super::plan_refusal;
use super::session::Session;
use crate::events::Event;
use crate::protocol::{self, Plan, PlanRequest, PlanRequestOptions, Role, MAX_PLAN_BYTES};
use crate::services::plan::REQUESTER_PARAMETER;

/// Why `plan` does not answer `request` (`None`: it does): a plan of another mission or with
/// other options than those asked for, or whose mission id is not the one computed from its
/// mission and options ([`protocol::mission_id`]), which every process keys the mission by.
pub(super) fn plan_mismatch(request: &PlanRequest, plan: &Plan) -> Option<String> {
    if plan.mission != request.mission {
        return Some(format!(
            "a plan of another mission ({:?}, asked for {:?})",
            plan.mission.name, request.mission.name
        ));
    }
    if plan.options != request.options {
        return Some("a plan with other options than those asked for".to_string());
    }
    plan.id_problem()
}

/// The shortest and the longest pause before asking a busy planner again: the pause doubles
/// from the first to the second with each busy answer in a row.
const BUSY_PAUSE: (Duration, Duration) = (Duration::from_millis(100), Duration::from_millis(1600));

/// The pause before asking a busy planner again after `busy` busy answers in a row (1 or
/// more): `BUSY_PAUSE.0 × 2^(busy-1)`, at most `BUSY_PAUSE.1`, times a factor in [0.5, 1.0)
/// from `jitter` (any value: its low 16 bits are used), so that launchers that were refused
/// together do not ask again together.
pub(super) fn busy_pause(busy: u32, jitter: u64) -> Duration {
    let base = BUSY_PAUSE
        .0
        .saturating_mul(1u32 << busy.saturating_sub(1).min(16))
        .min(BUSY_PAUSE.1);
    let f = 0.5 + 0.5 * ((jitter & 0xffff) as f64 / 65536.0);
    base.mul_f64(f)
}

/// A fresh random value for [`busy_pause`] (std's per-hasher random keys; no dependency).
fn jitter() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(Instant::now().elapsed().as_nanos());
    h.finish()
}

/// The time left for the plan.
struct PlanClock {
    timeout: Duration,
    deadline: Option<Instant>,
}

impl PlanClock {
    fn left(&self) -> Duration {
        self.deadline.map_or(self.timeout, |d| {
            d.saturating_duration_since(Instant::now())
        })
    }
}

impl Session<'_> {
    /// The plan of `mission`, or `None` when the run was interrupted.
    pub fn request_plan(&mut self, mission: &planner::Mission) -> Result<Option<Plan>> {
        let spinner = ProgressBar::new_spinner();
        if let Ok(s) = ProgressStyle::with_template("{spinner} {prefix:>9} {msg} [{elapsed}]") {
            spinner.set_style(s);
        }
        spinner.set_prefix("planning");
        spinner.enable_steady_tick(Duration::from_millis(200));
        let request = PlanRequest {
            mission: mission.to_file_struct(),
            options: PlanRequestOptions {
                resolution: Some(self.args().resolution),
                strict_resolution: Some(self.args().strict_resolution),
                dynamics: Some(self.args().dynamics),
                ..PlanRequestOptions::default()
            },
        };
        let timeout = self.args().plan_timeout_s.duration();
        let clock = PlanClock {
            timeout,
            deadline: Instant::now().checked_add(timeout),
        };
        let plan = self.ask_until_answered(&request, &clock, &spinner);
        spinner.finish_and_clear();
        plan
    }

    fn no_plan(&self, what: &str) -> anyhow::Error {
        anyhow!(
            "no plan within --plan-timeout-s {} s: {what}",
            self.args().plan_timeout_s
        )
    }

    fn ask_until_answered(
        &mut self,
        request: &PlanRequest,
        clock: &PlanClock,
        spinner: &ProgressBar,
    ) -> Result<Option<Plan>> {
        let mut attempt = 0u32;
        // failures other than busy answers: bounded by --max-restarts
        let mut failures = 0u32;
        let mut busy_in_a_row = 0u32;
        loop {
            attempt += 1;
            if !self.wait_for_planner(clock)? {
                return Ok(None);
            }
            let Some(answer) = self.ask_once(request, clock, spinner)? else {
                return Ok(None);
            };
            match answer {
                Ok(plan) => return Ok(Some(plan)),
                // a busy planner (its request queue full, or this launcher's request still
                // queued) is asked again until --plan-timeout-s: a peer flooding it with
                // requests cannot use up --max-restarts
                Err(NetError::Refused { refusal, .. }) if refusal.kind == RefusalKind::Busy => {
                    busy_in_a_row += 1;
                    let pause = busy_pause(busy_in_a_row, jitter());
                    if clock.left() <= pause {
                        return Err(self.no_plan(&format!(
                            "the planner stayed busy ({}; asked {attempt} times)",
                            refusal.message
                        )));
                    }
                    tracing::warn!(message = %refusal.message, attempt, pause_ms = pause.as_millis() as u64,
                        "the planner is busy; asking again");
                    self.retry_event(attempt, refusal.message.clone());
                    self.pause(pause)?;
                }
                Err(e @ (NetError::Refused { .. } | NetError::Remote { .. })) => {
                    return Err(plan_refusal(e))
                }
                Err(e) if clock.left().is_zero() => {
                    return Err(
                        anyhow::Error::new(e).context(self.no_plan("the planner did not answer"))
                    )
                }
                Err(e) => {
                    busy_in_a_row = 0;
                    failures += 1;
                    // a local planner that is gone (no reply) is bounded by its supervisor
                    // (--max-restarts), whose verdict names the cause: counting its deaths
                    // here too raced it (the third start of a planner that dies at start
                    // could fail the query before its exit was seen). Every other failure,
                    // and an external planner's, is bounded by these attempts; all by
                    // --plan-timeout-s.
                    let supervised =
                        self.local(Role::Planner) && matches!(e, NetError::NoReply { .. });
                    if !supervised && failures > self.args().max_restarts {
                        return Err(e).context("asking the planner for the plan");
                    }
                    tracing::warn!(error = %e, attempt, "no plan; asking again");
                    self.retry_event(attempt, e.to_string());
                    std::thread::sleep(Duration::from_millis(200));
                }
            }
        }
    }

    /// Waits `d` before asking again, the run's clock and signals still watched.
    fn pause(&mut self, d: Duration) -> Result<()> {
        let until = Instant::now() + d;
        while Instant::now() < until && !self.stopped() {
            self.tick()?;
            std::thread::sleep(
                until
                    .saturating_duration_since(Instant::now())
                    .min(Duration::from_millis(20)),
            );
        }
        Ok(())
    }

    /// Counts, logs and reports a plan reply that does not answer the request.
    fn refuse_plan(&mut self, planner: &str, why: &str) {
        self.refused_plans += 1;
        tracing::warn!(planner, reason = %why, "a plan reply that does not answer the request skipped");
        self.setup.events.emit(&Event::PlanRefused {
            planner: planner.into(),
            reason: why.into(),
        });
    }

    fn retry_event(&self, attempt: u32, error: String) {
        self.setup.events.emit(&Event::PlanRetry { attempt, error });
    }

    /// Waits for a planner's token; `false` when interrupted.
    fn wait_for_planner(&mut self, clock: &PlanClock) -> Result<bool> {
        let what = if self.local(Role::Planner) {
            "the planner to announce itself (cellsar/alive/planner/*; see logs/planner.log)"
        } else {
            "an external planner to announce itself (cellsar/alive/planner/*)"
        };
        while !self.planner_alive() {
            // bounded by --plan-timeout-s below
            self.waiting_for(Some(what), None)?;
            if self.stopped() {
                return Ok(false);
            }
            self.check_time("waiting for the planner")?;
            if clock.left().is_zero() {
                return Err(self.no_plan(if self.local(Role::Planner) {
                    "the planner did not announce itself (see logs/planner.log)"
                } else {
                    "no planner announced itself (cellsar/alive/planner/*): start \
                     `cellsar-planner serve` with the same Zenoh flags"
                }));
            }
            self.tick()?;
            std::thread::sleep(Duration::from_millis(20));
        }
        self.waiting_for(None, None)?;
        Ok(true)
    }

    /// Sends the request and waits for its answer, showing the planner's status; `None` when
    /// interrupted.
    fn ask_once(
        &mut self,
        request: &PlanRequest,
        clock: &PlanClock,
        spinner: &ProgressBar,
    ) -> Result<Option<Result<Plan, NetError>>> {
        let selector = format!(
            "{}?{}={}",
            protocol::keys::PLAN,
            REQUESTER_PARAMETER,
            self.node.session().zid()
        );
        let mut query = self.node.start_query::<PlanRequest, Plan>(
            &selector,
            request,
            &QueryOptions {
                timeout: clock.left(),
                format: WireFormat::Bincode,
                limits: DecodeLimits {
                    max_body_bytes: MAX_PLAN_BYTES,
                    verify_crc: true,
                },
                ..QueryOptions::default()
            },
        )?;
        loop {
            if self.stopped() {
                return Ok(None);
            }
            self.check_time("planning")?;
            self.tick()?;
            while let Some(s) = self.subs.statuses.try_recv() {
                if s.message.role == Role::Planner {
                    spinner.set_message(s.message.message.clone());
                }
            }
            match query.poll(Duration::from_millis(20)) {
                None => {}
                Some(Ok(r)) => match plan_mismatch(request, &r.message) {
                    // skipped: the next reply (the planner's own) may still come
                    Some(why) => self.refuse_plan(&r.message.planner, &why),
                    None => return Ok(Some(Ok(r.message))),
                },
                Some(Err(e)) => return Ok(Some(Err(e))),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::services::plan::plan_request;
    use planner::{MissionFile, NoObserver};

    fn request(name: &str) -> PlanRequest {
        PlanRequest {
            mission: MissionFile::from_toml_str(&format!(
                "name = \"{name}\"\n[params]\nhorizon_s = 20.0\n[landmarks]\npoints = [{{ x_m = \
                 0.0, y_m = 0.0, from_s = 0.0, to_s = 10.0 }}, {{ x_m = 0.0, y_m = 30.0, from_s = \
                 10.0, to_s = 20.0 }}]\n"
            ))
            .unwrap(),
            options: PlanRequestOptions {
                resolution: Some(planner::evaluate::ResolutionMode::Paper),
                ..PlanRequestOptions::default()
            },
        }
    }

    /// The pause before asking a busy planner again doubles from 50-100 ms to 0.8-1.6 s, and
    /// the jitter spreads it over half its range.
    #[test]
    fn busy_pauses_are_bounded_and_jittered() {
        let ms = |busy, jitter| busy_pause(busy, jitter).as_secs_f64() * 1e3;
        assert_eq!(ms(1, 0), 50.0);
        assert!((ms(1, 0xffff) - 100.0).abs() < 0.01);
        assert_eq!(ms(2, 0), 100.0);
        assert_eq!(ms(5, 0), 800.0);
        for busy in [6, 7, 100, u32::MAX] {
            assert_eq!(ms(busy, 0), 800.0);
            assert!(ms(busy, u64::MAX) < 1600.0);
        }
        // only the low 16 bits count
        assert_eq!(ms(3, 0x1_0000), ms(3, 0));
        let spread: Vec<f64> = (0..8).map(|j| ms(4, j * 8192)).collect();
        assert!(spread.windows(2).all(|w| w[1] > w[0]), "{spread:?}");
    }

    /// The planner's plan answers its request; one of another mission, with other options,
    /// or with a mission id that its content does not give, does not, each said why.
    #[test]
    fn a_plan_must_answer_the_request_and_carry_its_own_id() {
        let req = request("short");
        let plan = plan_request(&req, "p1", &mut NoObserver).unwrap();
        assert_eq!(plan_mismatch(&req, &plan), None);
        let other = plan_request(&request("other"), "p1", &mut NoObserver).unwrap();
        let why = plan_mismatch(&req, &other).unwrap();
        assert!(why.contains("another mission (Some(\"other\")"), "{why}");
        let opts = PlanRequest {
            options: PlanRequestOptions::default(),
            ..req.clone()
        };
        let why = plan_mismatch(&opts, &plan).unwrap();
        assert!(why.contains("other options"), "{why}");
        let forged = Plan {
            mission_id: other.mission_id,
            ..plan.clone()
        };
        let why = plan_mismatch(&req, &forged).unwrap();
        assert!(
            why.starts_with(&format!("mission id {}", other.mission_id)),
            "{why}"
        );
        assert!(why.ends_with(&plan.mission_id.to_string()), "{why}");
    }
}
