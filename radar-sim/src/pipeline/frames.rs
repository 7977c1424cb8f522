//! Frames of synthesised pulses ([`synthesize_frames`]).

use rustfft::num_complex::Complex32;

use crate::error::Result;
use crate::synth::{Components, Synthesizer};
use crate::track::PulseMeta;

/// Receives one frame: its pulse metadata and `pulses × samples` IQ.
pub type FrameSink<'a> = dyn FnMut(&[PulseMeta], &[Complex32]) -> Result<()> + 'a;

/// Synthesises the pulses of one aperture in frames of at most `frame_pulses`, handing each
/// frame (its pulse metadata and `pulses × samples` IQ) to `sink` before the next is made.
pub fn synthesize_frames(
    synth: &Synthesizer,
    pulses: &[PulseMeta],
    frame_pulses: usize,
    comps: Components,
    sink: &mut FrameSink<'_>,
) -> Result<()> {
    for chunk in pulses.chunks(frame_pulses.max(1)) {
        let iq = synth.synthesize_frame(chunk, comps)?;
        sink(chunk, &iq)?;
    }
    Ok(())
}
