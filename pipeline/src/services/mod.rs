//! The long-running processes of the pipeline, as library code that the binaries call:
//!
//! - [`plan`]: the plan service (`cellsar-planner serve`, `cellsar planner`), the status board
//!   and the plan cache every service keeps;
//! - [`echo`]: the UAV side (`cellsar-radar-sim echo`, `cellsar echo`): synthesises the IQ of
//!   the apertures a processor asks for and publishes it as frames on iceoryx2;
//! - [`process`]: the BS side (`cellsar-radar-sim process-service`, `cellsar process`): pulls
//!   apertures, cancels, images, detects, publishes detections, images and metrics;
//! - [`admission`]: how many missions a service holds, and which result requests it serves;
//! - [`os`]: what every service needs from the OS (stop on signals, atomic state files);
//! - [`radar`]: what the two radar services share (their error, the frame size);
//! - [`bridge`]: the iceoryx2 <-> Zenoh bridge as a process (`cellsar-bridge`, `cellsar bridge`);
//! - [`threads`]: the threads a service depends on, each reporting how it ended;
//! - [`wait`]: what a service waits for, said in its log.
//!
//! Their messages and keys are in [`crate::protocol`].

pub mod admission;
pub mod bridge;
pub mod echo;
pub mod os;
pub mod plan;
pub mod process;
pub mod radar;
#[cfg(test)]
mod radar_tests;
pub mod threads;
pub mod wait;
