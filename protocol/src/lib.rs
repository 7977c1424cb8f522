//! # cellsar-protocol: the pipeline's wire protocol
//!
//! Every message the processes exchange and every key expression, each defined once. A client
//! (a dashboard, a recorder, another tool's process) depends on this crate and `bridge` alone,
//! without the pipeline's apps (plots, reports, certificates, the launcher); the pipeline
//! re-exports it as `pipeline::protocol`.
//!
//! Built on the transport's envelope ([`bridge::Message`]: kind, schema version, bincode or JSON
//! body); the message kinds are `0x0100..=0x01ff` for the planner ([`plan`], [`status`]) and
//! `0x0300..=0x03ff` for the radar ([`radar`]); the IQ frame is the transport's `0x0200`.
//!
//! - [`keys`]: the key space;
//! - [`plan`]: plan requests, plans, lookups, summaries, the mission id;
//! - [`status`]: the status every service publishes, and its states;
//! - [`role`]: the roles of a deployment;
//! - [`radar`]: aperture requests, frame info, detections, images, metrics, result requests;
//! - [`layout`]: the frame sequence numbers of a mission (a pure function of the mission, so a
//!   re-sent frame keeps its number).

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod keys;
pub mod layout;
pub mod plan;
pub mod radar;
pub mod role;
pub mod status;

pub use layout::{FrameLayout, FrameSlot};
pub use plan::{
    mission_id, BadRequest, Plan, PlanLookup, PlanRequest, PlanRequestOptions, PlanSummary,
    MAX_PLAN_BYTES,
};
pub use radar::*;
pub use role::{Role, UnknownRole};
pub use status::{ServiceState, ServiceStatus};
