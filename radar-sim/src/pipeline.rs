//! The streaming API: a [`RadarSetup`] fixes the mission, scene and radar; a
//! [`Synthesizer`](crate::synth::Synthesizer)
//! produces frames of pulses one at a time ([`synthesize_frames`]); a [`Processor`] turns the
//! pulses of one aperture into range profiles ([`Processor::compress`]), look images
//! ([`Processor::image_look`]) and detections ([`Processor::process_aperture`]).
//!
//! Frame layout (also on the wire and in `iq/*.npy`): `pulses × samples` complex f32,
//! row-major, little-endian interleaved (re, im); a pulse holds `symbols_per_pulse` FFT windows
//! of N samples each, symbol-major; [`PulseMeta`](crate::track::PulseMeta) carries each pulse's
//! time, symbol index, UAV
//! position/velocity/heading and receiver window delay.

mod aperture;
mod compress;
mod detect;
mod frames;
mod ghost;
mod imaging;
mod processor;
mod reference;
mod result;
mod setup;

pub use aperture::{CLEAR_SIGNAL, NEAR_OBJECT_REACH};
pub use detect::{cfar_geometry, Detected};
pub use frames::{synthesize_frames, FrameSink};
pub use ghost::{GHOST_PEAK_OVER_MEAN, PATTERN_SAMPLES};
pub use processor::{cp_overlap_factor, Processor};
pub use result::{ApertureResult, Compressed};
pub use setup::RadarSetup;
