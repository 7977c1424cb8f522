//! 5G NR downlink as 3GPP TS 38.211 (Rel-16) lays it out: the frame structure (§4), the
//! pseudo-random and m-sequences (§5.2, §7.4.2), the reference signals at their resource
//! elements (§7.4.1, §7.4.3) and the downlink resource grid a cell transmits.
//!
//! Pure: no I/O, no randomness beyond the seeded data of [`grid`]. One job per file:
//! - [`frame`]: numerology μ, cyclic prefixes, slots, the carrier's PRBs and FFT size, the TDD
//!   pattern (which symbols are downlink);
//! - [`sequences`]: the length-31 Gold sequence c(n), the PSS/SSS m-sequences, the modulation
//!   mapper (§5.1) and every c_init;
//! - [`signals`]: SSB (PSS, SSS, PBCH DMRS, PBCH), TRS, PRS and PDSCH DMRS at their REs;
//! - [`grid`]: one downlink symbol's resource grid (reference signals, data on the loaded PRBs,
//!   nothing elsewhere) and what the UAV knows of it;
//! - [`illumination`]: which symbols of the stream make the radar's pulses, and the PRF.
//!
//! Subcarrier indices `k` count from subcarrier 0 of common resource block 0, which this model
//! puts at the carrier's lowest subcarrier (N_grid^start = 0, point A at the band's edge).

pub mod frame;
pub mod grid;
pub mod illumination;
pub mod sequences;
pub mod signals;

pub use frame::{CyclicPrefix, FrameStructure, SymbolUse, TddPattern};
pub use grid::{NrGrid, Reference};
pub use illumination::{NrIllumination, PulseSlots};
/// The complex type of every value in this module.
pub use rustfft::num_complex::Complex64;

/// Subcarriers per resource block, N_sc^RB (§4.4.4.1).
pub const SUBCARRIERS_PER_PRB: usize = 12;

/// An invalid NR parameter; `field` is its dotted name in the scene file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct NrError {
    /// Dotted name, e.g. `radar.nr.numerology`.
    pub field: String,
    /// What the value must satisfy.
    pub reason: String,
}

impl NrError {
    /// An error naming `field`.
    pub fn new(field: impl Into<String>, reason: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

impl From<NrError> for crate::error::RadarError {
    fn from(e: NrError) -> Self {
        crate::error::RadarError::config(e.field, e.reason)
    }
}

/// Result alias of the NR module.
pub type NrResult<T> = std::result::Result<T, NrError>;
