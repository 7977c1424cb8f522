//! # cellsar pipeline: the launcher
//!
//! `cellsar run MISSION --scene SCENE --out DIR` runs the mission as separate processes: the
//! planner service, the echo simulator and the processor (and, when frames go over Zenoh, the
//! bridge; with `--router`, a Zenoh router), supervises them and writes the same outputs as
//! `cellsar-radar-sim closed-loop`.
//!
//! - [`launch`]: the run itself (network set-up, children, plan, collection, outputs);
//! - [`supervise`]: child processes (start, restart within a bound, stop, reap);
//! - [`collect`]: results de-duplicated by mission and aperture, and the output files;
//! - [`roles`]: the bridge and router roles of the `cellsar` binary;
//! - [`events`]: the event log (`pipeline.json`, `--events-json`);
//! - [`exit`]: the exit codes of the `cellsar` binary and the failures that carry them.
//!
//! The `cellsar` binary is also every child: `cellsar planner` is `cellsar-planner serve`,
//! `cellsar echo` is `cellsar-radar-sim echo`, `cellsar process` is
//! `cellsar-radar-sim process-service` (same library code and flags), so that one
//! `cargo run -p pipeline --bin cellsar` builds everything the run needs.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod collect;
pub mod events;
pub mod exit;
pub mod launch;
pub mod roles;
pub mod supervise;
