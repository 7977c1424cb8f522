//! Command-line flags shared by several binaries and services (clap), for the libraries'
//! parameters that have no flags of their own.

use radar_sim::limits::{self, IqLimits};

/// The `--max-iq-gib` / `--max-aperture-gib` flags.
#[derive(clap::Args, Debug, Clone, Copy, PartialEq)]
pub struct IqLimitArgs {
    /// Refuse a run whose IQ (all apertures: pulses × samples per pulse × 8 bytes) exceeds
    /// this many GiB; checked before anything is simulated.
    #[arg(long, value_name = "GIB", default_value_t = limits::DEFAULT_MAX_IQ_GIB)]
    pub max_iq_gib: f64,
    /// Refuse a run in which one aperture (its IQ, plus its look images with
    /// `processing.save_complex`) would take more than this many GiB of memory.
    #[arg(long, value_name = "GIB", default_value_t = limits::DEFAULT_MAX_APERTURE_GIB)]
    pub max_aperture_gib: f64,
}

impl Default for IqLimitArgs {
    fn default() -> Self {
        Self {
            max_iq_gib: limits::DEFAULT_MAX_IQ_GIB,
            max_aperture_gib: limits::DEFAULT_MAX_APERTURE_GIB,
        }
    }
}

impl IqLimitArgs {
    /// The limits; the error names the bad flag.
    pub fn limits(&self) -> radar_sim::Result<IqLimits> {
        IqLimits::from_gib(self.max_iq_gib, self.max_aperture_gib)
    }
}
