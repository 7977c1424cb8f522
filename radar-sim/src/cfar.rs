//! 2-D censored cell-averaging CFAR on an L-look power image, peak detection with non-maximum
//! suppression and sidelobe editing, and the design false-alarm counts on noise.
//!
//! With unit-mean Gamma(L) noise in every pixel and the noise level estimated as the mean of N
//! independent training cells, the false-alarm probability of the threshold α·mean is
//! `P_fa = Σ_{k<L} C(NL+k−1, k) (α/N)^k (1 + α/N)^{−(NL+k)}`; α is solved from it by bisection.
//! Pixels of an oversampled image are correlated, so `N` is the number of training pixels
//! divided by the pixels per resolution cell ([`CfarParams::pixels_per_cell`]).
//!
//! The training cells are censored, not averaged blindly: a pixel above the level that noise
//! exceeds with probability [`CENSOR_PFA`] relative to the image-wide floor is left out, and the
//! mean of the rest is divided by the mean of a censored unit Gamma(L) variable, so that it is
//! unbiased on noise. Strong neighbours' main lobes, ridges and sidelobes thus do not raise the
//! threshold (masking). The image-wide floor is the censored mean's fixed point reached from
//! the receiver's known thermal floor ([`image_floor`]): it follows a floor raised by anything
//! noise-like (the inter-symbol interference of echoes beyond the cyclic prefix) but not the
//! targets' responses, even where they cover most of the image (near-blind geometry). A pixel
//! with fewer than [`MIN_TRAINING_CELLS`] independent training cells is tested against the
//! image-wide floor instead (and counted: [`CfarMap::fallback_pixels`]); no pixel is left
//! untested.
//!
//! Against clutter (an image-wide floor more than [`CLUTTER_FLOOR_RATIO`] above the known
//! thermal floor: ground clutter, whose level varies across the image with the grazing angles,
//! the ranges and the antenna gain) the thresholds follow the local level: the training
//! pixels are censored against their own neighbourhood's first-pass mean instead of the
//! image-wide floor, and a pixel without enough training cells beyond its guard is tested
//! against the censored mean of the box of about 4 × [`MIN_TRAINING_CELLS`] coherence areas
//! around it (no guard: a weak target's own response raises it a little) instead of the
//! image-wide floor. A noise-floored image is processed exactly as before.

mod cluster;
mod detector;
mod exact;
mod ghost;
mod model;
mod stats;

pub use cluster::{
    cluster, cluster_edited, cluster_with_outside, components, outside_peaks, Detection,
};
pub use detector::{ca_cfar, CfarMap, CfarParams, CLUTTER_FLOOR_RATIO};
pub use exact::{ExactResponse, LookImages, RangeResponse, EXACT_MODEL_ERROR};
pub use ghost::GhostProfile;
pub use model::{ResponseModel, MODEL_CELL_MARGIN, MODEL_SCALE_MARGIN};
pub use stats::{
    averaged_pfa, ca_alpha, ca_pfa, censored_mean, expected_peaks_per_m2, gamma_sf, image_floor,
    ln_gamma, unit_gamma_isf, unit_gamma_sf, CENSOR_PFA, MIN_TRAINING_CELLS, SIDELOBE_MARGIN,
};

#[cfg(test)]
mod tests;
