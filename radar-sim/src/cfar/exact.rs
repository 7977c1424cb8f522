//! The exact point response of a look image ([`ExactResponse`]) and sidelobe editing against
//! it: the stronger peaks' responses are subtracted coherently, look by look, at a candidate
//! peak (CLEAN, Högbom 1974, evaluated at the candidate pixels only), and the candidate is a
//! detection only where the residual still exceeds its CFAR threshold and the model's error.
//!
//! The image of a point scatterer at `q` (complex amplitude `a`) at ground point `p` is, in look
//! `l`, `a R_l(p, q)` with
//! `R_l(p, q) = Σ_k w_k h(Δd_k) e^{j2π ΔR_k/λ} / Σ_k w_k`, the sum over the look's pulses
//! (slow-time weights `w_k`), `ΔR_k = R_k(p) − R_k(q)` the bistatic range difference,
//! `Δd_k = ΔR_k f_s / c` in samples, and `h` the range-compressed pulse response normalised to
//! `h(0) = 1`: the tapered sum over the occupied subcarriers
//! `h(x) = Σ_i w_i e^{j2π k_i x/N} / Σ_i w_i`, in closed form for a cosine taper
//! (`w_i = a0 − a1 cos(2π(i + ½)/n)`: three Dirichlet kernels). The cost of one evaluation is
//! the look's pulses; no image is formed.

use rustfft::num_complex::{Complex32, Complex64};

use super::ghost::GhostProfile;
use crate::backproject::{BpGeometry, BpPulse};
use crate::waveform::C_MPS;

/// Relative amplitude error of a predicted response (the sources' positions on the pixel grid
/// and their refinement, the backprojection's interpolation of the range profiles, the
/// sources' noise): a candidate whose residual after subtracting the predicted responses is
/// below this squared times their predicted power is within the model's error (a sidelobe).
/// −10 dB in amplitude: the interpolation's share is below 1 % of the peak (the test
/// `exact_response_matches_a_backprojected_point` measures 0.22 %); the rest is left to the
/// sources' sub-pixel positions (a parabola through the pixel grid's peak) and their noise.
pub const EXACT_MODEL_ERROR: f64 = 0.316;

/// The range-compressed pulse response `h` of a cosine-tapered band of contiguous subcarriers,
/// normalised to 1 at zero delay (exact: the closed form of the tapered sum).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeResponse {
    fft_size: f64,
    first_index: f64,
    subcarriers: usize,
    a0: f64,
    a1: f64,
}

/// `Σ_{i<n} e^{jθi}`.
fn dirichlet(n: usize, theta: f64) -> Complex64 {
    let s = (0.5 * theta).sin();
    let nf = n as f64;
    if s.abs() < 1e-12 {
        // θ a multiple of 2π: every term is 1 (to the rounding of θ)
        return Complex64::new(nf, 0.0);
    }
    Complex64::from_polar((0.5 * nf * theta).sin() / s, 0.5 * theta * (nf - 1.0))
}

impl RangeResponse {
    /// The response of `subcarriers` contiguous subcarriers from index `first_index` (FFT size
    /// `fft_size`) with the spectral taper `weighting`.
    pub fn new(
        weighting: crate::config::Weighting,
        fft_size: usize,
        first_index: i64,
        subcarriers: usize,
    ) -> Self {
        let n = subcarriers.max(1);
        // the taper as a0 − a1 cos(2π(i + ½)/n): the cosines sum to 0 over i (n ≥ 2)
        let w = weighting.weights(n);
        let a0 = w.iter().sum::<f64>() / n as f64;
        let c0 = (std::f64::consts::PI / n as f64).cos();
        let a1 = if n >= 2 && c0.abs() > 1e-12 {
            (a0 - w[0]) / c0
        } else {
            0.0
        };
        Self {
            fft_size: fft_size.max(1) as f64,
            first_index: first_index as f64,
            subcarriers: n,
            a0,
            a1,
        }
    }

    /// `h(x)` at delay `x` samples from the peak.
    pub fn at(&self, x: f64) -> Complex64 {
        let n = self.subcarriers;
        let theta = std::f64::consts::TAU * x / self.fft_size;
        let step = std::f64::consts::TAU / n as f64;
        let half = Complex64::from_polar(1.0, 0.5 * step);
        // Σ_i (a0 − a1/2 (e^{j2π(i+½)/n} + e^{−j2π(i+½)/n})) e^{jθi}
        let sum = dirichlet(n, theta) * self.a0
            - (half * dirichlet(n, theta + step) + half.conj() * dirichlet(n, theta - step))
                * (0.5 * self.a1);
        let norm = self.a0 * n as f64;
        if norm == 0.0 {
            return Complex64::new(0.0, 0.0);
        }
        sum * Complex64::from_polar(1.0 / norm, theta * self.first_index)
    }
}

/// The exact point response of each look image of an aperture (see the module doc).
#[derive(Debug, Clone)]
pub struct ExactResponse {
    geom: BpGeometry,
    pulses: Vec<BpPulse>,
    looks: Vec<std::ops::Range<usize>>,
    range: RangeResponse,
}

impl ExactResponse {
    /// The response of looks `looks` (ranges of `pulses`) under `geom`, with the range response
    /// `range`.
    pub fn new(
        geom: BpGeometry,
        pulses: Vec<BpPulse>,
        looks: Vec<std::ops::Range<usize>>,
        range: RangeResponse,
    ) -> Self {
        let n = pulses.len();
        let looks = looks
            .into_iter()
            .map(|r| r.start.min(n)..r.end.min(n))
            .collect();
        Self {
            geom,
            pulses,
            looks,
            range,
        }
    }

    /// Number of looks.
    pub fn looks(&self) -> usize {
        self.looks.len()
    }

    /// Number of pulses (of all looks).
    pub fn pulses(&self) -> usize {
        self.pulses.len()
    }

    /// `R_l(p, q)`: the image at `p` of look `look` of a point at `q` whose echo's amplitude is
    /// `gains[k]` in pulse k (the link budget: antenna gain, ranges; all 1 where `gains` does
    /// not give every pulse), normalised to 1 at `p = q` (0 for a look that does not exist or
    /// has no weight).
    pub fn response(&self, look: usize, p: [f64; 2], q: [f64; 2], gains: &[f64]) -> Complex64 {
        self.response_with(look, p, q, gains, None)
    }

    /// [`Self::response`] with the point's coherent ghost in this look added to the range
    /// response (`h(x) + g(x)`: an echo beyond the cyclic prefix, [`GhostProfile`]).
    pub fn response_with(
        &self,
        look: usize,
        p: [f64; 2],
        q: [f64; 2],
        gains: &[f64],
        ghost: Option<&GhostProfile>,
    ) -> Complex64 {
        let Some(r) = self.looks.get(look) else {
            return Complex64::new(0.0, 0.0);
        };
        let gain = |k: usize| {
            if gains.len() == self.pulses.len() {
                gains[k]
            } else {
                1.0
            }
        };
        let mut acc = Complex64::new(0.0, 0.0);
        let mut wsum = 0.0;
        for (k, pl) in self.pulses.iter().enumerate().take(r.end).skip(r.start) {
            let w = pl.weight as f64 * gain(k);
            let dr =
                self.geom.bistatic_range_m(p, pl.pos_m) - self.geom.bistatic_range_m(q, pl.pos_m);
            let cyc = dr / self.geom.wavelength_m;
            let x = dr * self.geom.fs_hz / C_MPS;
            let h = match ghost {
                Some(g) => self.range.at(x) + g.at(x),
                None => self.range.at(x),
            };
            acc += h * Complex64::from_polar(w, std::f64::consts::TAU * (cyc - cyc.floor()));
            wsum += w;
        }
        if wsum == 0.0 {
            return Complex64::new(0.0, 0.0);
        }
        acc / wsum
    }
}

/// Per look the coherent ghost of a point at a ground position, given its peak in the
/// multilook image ([`LookImages::ghosts`]).
pub type GhostsOf<'a> = dyn Fn([f64; 2], f64) -> Vec<Option<GhostProfile>> + Sync + 'a;

/// The complex look images a detection pass edits against: per look the grid's image and the
/// guard band's (on the band's grid), scaled by `scale` into the multilook image's units
/// (multilook = `scale` × Σ_l |I_l|²).
#[derive(Clone, Copy)]
pub struct LookImages<'a> {
    /// The exact response of the looks.
    pub response: &'a ExactResponse,
    /// Per look: the complex image on the detection grid.
    pub grid: &'a [Vec<Complex32>],
    /// The guard band's grid (`None` without a band).
    pub band_grid: Option<crate::backproject::Grid>,
    /// Per look: the complex image on the guard band's grid (empty without a band).
    pub band: &'a [Vec<Complex32>],
    /// Multilook image per |I|² summed over the looks.
    pub scale: f64,
    /// Per pulse the echo amplitude of a unit point at a ground position (the link budget), for
    /// [`ExactResponse::response`]'s `gains`.
    pub gains: &'a (dyn Fn([f64; 2]) -> Vec<f64> + Sync),
    /// Per look the coherent ghost of a point at a ground position whose echo lies beyond the
    /// cyclic prefix, given its peak in the multilook image (`None` in a look where it has
    /// none, where it is too weak to matter, or without a model of it).
    pub ghosts: Option<&'a GhostsOf<'a>>,
}

impl std::fmt::Debug for LookImages<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LookImages")
            .field("looks", &self.grid.len())
            .field("band_grid", &self.band_grid)
            .field("scale", &self.scale)
            .field("ghosts", &self.ghosts.is_some())
            .finish_non_exhaustive()
    }
}

/// One source of the CLEAN pass: its (refined) position and per look the complex amplitude of
/// the point there.
#[derive(Debug, Clone)]
pub(super) struct Source {
    pos: [f64; 2],
    amp: Vec<Complex64>,
    gains: Vec<f64>,
    ghosts: Vec<Option<GhostProfile>>,
}

impl Source {
    fn ghost(&self, look: usize) -> Option<&GhostProfile> {
        self.ghosts.get(look).and_then(Option::as_ref)
    }
}

/// The per-look prediction of the sources' responses at `p`.
pub(super) fn predict(resp: &ExactResponse, sources: &[Source], p: [f64; 2]) -> Vec<Complex64> {
    (0..resp.looks())
        .map(|l| {
            sources
                .iter()
                .map(|s| s.amp[l] * resp.response_with(l, p, s.pos, &s.gains, s.ghost(l)))
                .sum()
        })
        .collect()
}

/// The source of a peak measured at `at` (pixel position) with per-look values `values`,
/// refined to `pos` (its echo's per-pulse amplitudes `gains`, its per-look ghosts `ghosts`),
/// after subtracting the responses of the stronger `sources` there.
pub(super) fn source(
    resp: &ExactResponse,
    sources: &[Source],
    at: [f64; 2],
    pos: [f64; 2],
    values: &[Complex64],
    (gains, ghosts): (Vec<f64>, Vec<Option<GhostProfile>>),
) -> Source {
    let pred = predict(resp, sources, at);
    let amp = (0..resp.looks())
        .map(|l| {
            let ghost = ghosts.get(l).and_then(Option::as_ref);
            let own = resp.response_with(l, at, pos, &gains, ghost);
            let v = values.get(l).copied().unwrap_or_default() - pred[l];
            if own.norm() > 1e-6 {
                v / own
            } else {
                v
            }
        })
        .collect();
    Source {
        pos,
        amp,
        gains,
        ghosts,
    }
}

/// `(residual, predicted)` power of a candidate with per-look values `values` at `at`, in the
/// multilook image's units: the power left after subtracting the sources' responses, and
/// their predicted power there.
pub(super) fn residual(
    resp: &ExactResponse,
    sources: &[Source],
    at: [f64; 2],
    values: &[Complex64],
    scale: f64,
) -> (f64, f64) {
    let pred = predict(resp, sources, at);
    let (mut res, mut pw) = (0.0, 0.0);
    for (l, p) in pred.iter().enumerate() {
        let v = values.get(l).copied().unwrap_or_default();
        res += (v - p).norm_sqr();
        pw += p.norm_sqr();
    }
    (res * scale, pw * scale)
}
