//! # cellsar pipeline: processes and apps
//!
//! Everything that runs: the protocol the processes speak, the services, the launcher, the
//! reports, and the binaries `cellsar`, `cellsar-planner` and `cellsar-radar-sim`. The maths
//! lives in the `planner` and `radar-sim` crates, the transport in `bridge`.
//!
//! - [`protocol`]: every message and key expression of the pipeline, defined once (the
//!   `cellsar-protocol` crate, which a client uses without this crate's apps);
//! - [`services`]: the plan service, the echo simulator and the processor;
//! - [`launch`]: `cellsar run`, the pipeline as supervised processes (network set-up,
//!   children, plan, collection, outputs); [`supervise`]: child processes (start, restart
//!   within a bound, stop, reap); [`collect`]: results de-duplicated by mission and aperture,
//!   and the output files; [`roles`]: the bridge and router roles of `cellsar`; [`events`]:
//!   the event log (`pipeline.json`, `--events-json`);
//! - [`report`]: a plan directory (files and plots) and `cellsar-planner reproduce` (the
//!   paper's figures);
//! - [`senders`]: which instance the launcher accepts a status or detections from;
//!   [`certs`]: `cellsar certs`, a test CA and per-role certificates for mutual TLS;
//! - [`args`]: flags shared by several binaries; [`exit`]: the exit codes of `cellsar`.
//!
//! The `cellsar` binary is also every child: `cellsar planner` is `cellsar-planner serve`,
//! `cellsar echo` is `cellsar-radar-sim echo`, `cellsar process` is
//! `cellsar-radar-sim process-service` (same library code and flags), so that one
//! `cargo run -p pipeline --bin cellsar` builds everything the run needs.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod args;
pub mod certs;
pub mod collect;
pub mod events;
pub mod exit;
pub mod launch;
/// The wire protocol (the `cellsar-protocol` crate, re-exported under its old path).
pub use cellsar_protocol as protocol;
pub mod report;
pub mod roles;
pub mod senders;
pub mod services;
pub mod supervise;
