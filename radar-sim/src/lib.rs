//! # cellsar radar simulator and processor
//!
//! Turns a planned UAV trajectory into what the UAV's receiver would record from a cellular
//! base station's OFDM downlink (direct path + bistatic echoes of ground objects + thermal
//! noise), and turns that recording into SAR images and detections.
//!
//! Layers (pure, no I/O): [`config`], [`waveform`], [`antenna`], [`scene`], [`track`],
//! [`synth`], [`cancel`], [`compress`], [`backproject`], [`cfar`], [`scoring`], [`resolution`],
//! [`nr`] (the 5G NR frame and reference signals of TS 38.211),
//! [`pipeline`] (streaming API: one frame of pulses / one aperture at a time). File formats
//! (NPY, CSV, JSON, PNG) live in [`io`]; the bounds on a run's
//! IQ and memory, checked before simulating, in [`limits`].

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod antenna;
pub mod backproject;
pub mod cancel;
pub mod cfar;
pub mod clutter;
pub mod compress;
pub mod config;
pub mod cputime;
mod dsp;
pub mod error;
pub mod io;
pub mod kernels;
pub mod limits;
pub mod linalg;
pub mod nr;
pub mod pipeline;
pub mod psf;
pub mod resolution;
pub mod run;
pub mod scene;
pub mod scoring;
pub mod synth;
pub mod tally;
pub mod track;
pub mod waveform;

pub use error::{RadarError, Result};
