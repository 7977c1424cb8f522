//! Step 1 of a run: the plan. Waits for a planner's liveliness token, asks it for the plan and
//! waits for the answer, together at most `--plan-timeout-s`; a busy planner or one that does
//! not answer is asked again (at most `--max-restarts` more times); SIGINT/SIGTERM at any
//! moment ends the run as interrupted.

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
        loop {
            attempt += 1;
            if !self.wait_for_planner(clock)? {
                return Ok(None);
            }
            let Some(answer) = self.ask_once(request, clock, spinner)? else {
                return Ok(None);
            };
            // a local planner that is gone (no reply) is bounded by its supervisor
            // (--max-restarts), whose verdict names the cause: counting its deaths here too
            // raced it (the third start of a planner that dies at start could fail the query
            // before its exit was seen). Every other failure, and an external planner's, is
            // bounded by these attempts; all by --plan-timeout-s.
            let supervised =
                self.local(Role::Planner) && matches!(answer, Err(NetError::NoReply { .. }));
            let retries_left = supervised || attempt < 1 + self.args().max_restarts;
            match answer {
                Ok(plan) => return Ok(Some(plan)),
                // a busy planner (its request queue full) is asked again, as one that did not
                // answer
                Err(NetError::Refused { refusal, .. })
                    if refusal.kind == RefusalKind::Busy
                        && !clock.left().is_zero()
                        && retries_left =>
                {
                    tracing::warn!(message = %refusal.message, attempt, "the planner is busy; asking again");
                    self.retry_event(attempt, refusal.message.clone());
                    std::thread::sleep(Duration::from_millis(500));
                }
                Err(e @ (NetError::Refused { .. } | NetError::Remote { .. })) => {
                    return Err(plan_refusal(e))
                }
                Err(e) if clock.left().is_zero() => {
                    return Err(
                        anyhow::Error::new(e).context(self.no_plan("the planner did not answer"))
                    )
                }
                Err(e) if retries_left => {
                    tracing::warn!(error = %e, attempt, "no plan; asking again");
                    self.retry_event(attempt, e.to_string());
                    std::thread::sleep(Duration::from_millis(200));
                }
                Err(e) => return Err(e).context("asking the planner for the plan"),
            }
        }
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
        let mut query = self.node.start_query::<PlanRequest, Plan>(
            protocol::keys::PLAN,
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
