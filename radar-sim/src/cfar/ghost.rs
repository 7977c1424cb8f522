//! The coherent ghost of an echo beyond the cyclic prefix, tabulated for the exact response
//! ([`GhostProfile`]).
//!
//! An echo that arrives more than the CP after the window's start leaves in each window the
//! previous symbol's tail and only part of its own symbol. Range compression turns that into a
//! profile spread over all delays; where the reference's values are the same in every pulse
//! (the pilots of the same slot of the frame), the deterministic part of it repeats from pulse
//! to pulse and focuses like the echo itself, beside it in range. [`GhostProfile`] holds that
//! part for one source and look, relative to the source's main peak, as a function of the
//! delay from the source's own (samples), so that [`super::ExactResponse`] can add it to the
//! point response.

use rustfft::num_complex::{Complex32, Complex64};

/// The ghost of one source in one look: `g(x)`, the compressed profile's expected value at `x`
/// samples from the source's delay with the main peak's share taken out, over the main peak's
/// value for the same echo inside the CP (unit factor: it multiplies the source's per-pulse
/// gain, the overlap factor included), tabulated over one period of the profile at the
/// processor's upsampling (as the range profiles the images are formed from:
/// `RangeCompressor::profile_window`). Linear interpolation between the samples errs by at most
/// `(π b / U)² / 8` in amplitude for a band `b` of the sample rate (0.5 % at b = 0.8, U = 8).
#[derive(Debug, Clone, PartialEq)]
pub struct GhostProfile {
    table: Vec<Complex32>,
    per_sample: usize,
}

impl GhostProfile {
    /// The profile whose value at `x = t / per_sample` samples is `table[t]`, t = 0 .. N ·
    /// `per_sample` (one period of N samples).
    pub fn from_table(table: Vec<Complex32>, per_sample: usize) -> Self {
        Self {
            table,
            per_sample: per_sample.max(1),
        }
    }

    /// `g(x)` at `x` samples from the source's delay (periodic in N), by linear interpolation.
    pub fn at(&self, x: f64) -> Complex64 {
        let nu = self.table.len();
        if nu == 0 || !x.is_finite() {
            return Complex64::default();
        }
        let t = (x * self.per_sample as f64).rem_euclid(nu as f64);
        let i = (t.floor() as usize).min(nu - 1);
        let frac = t - i as f64;
        let (a, b) = (self.table[i], self.table[(i + 1) % nu]);
        let lerp = a + (b - a) * frac as f32;
        Complex64::new(f64::from(lerp.re), f64::from(lerp.im))
    }

    /// Peak of `|g|` over the table.
    pub fn peak(&self) -> f64 {
        self.table
            .iter()
            .map(|v| f64::from(v.norm()))
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_the_profile_between_its_samples() {
        // a few subcarriers with arbitrary values: the table at any x against the direct sum
        let n = 64;
        let first = -20i64;
        let z: Vec<Complex64> = (0..40)
            .map(|i| Complex64::from_polar(1.0 + (i % 5) as f64, 0.37 * i as f64))
            .collect();
        let centre = 13.3;
        let scale = Complex64::new(0.5, -0.25);
        let direct = |x: f64| -> Complex64 {
            z.iter()
                .enumerate()
                .map(|(i, v)| {
                    let k = (first + i as i64) as f64;
                    v * scale
                        * Complex64::from_polar(
                            1.0,
                            std::f64::consts::TAU * k * (centre + x) / n as f64,
                        )
                })
                .sum()
        };
        const U: usize = 8;
        let g = GhostProfile::from_table(
            (0..n * U)
                .map(|t| {
                    let v = direct(t as f64 / U as f64);
                    Complex32::new(v.re as f32, v.im as f32)
                })
                .collect(),
            U,
        );
        // linear interpolation errs by at most |v| θ²/8 per subcarrier, θ its phase step
        // between table samples (2π 20/64/8 at the band's edge)
        let theta = std::f64::consts::TAU * 20.0 / n as f64 / U as f64;
        let bound = z.iter().map(|v| (v * scale).norm()).sum::<f64>() * theta * theta / 8.0;
        for t in 0..997 {
            let x = -70.0 + t as f64 * 0.173;
            let err = (g.at(x) - direct(x)).norm();
            assert!(err <= bound * 1.0001 + 1e-9, "x = {x}: {err} > {bound}");
        }
        // and where x falls on the table's samples, exactly (to f32)
        for t in 0..n * U {
            let x = t as f64 / U as f64;
            assert!(
                (g.at(x) - direct(x)).norm() < 1e-5 * bound / theta.powi(2),
                "x = {x}"
            );
        }
        let peak = (0..n * U)
            .map(|t| direct(t as f64 / U as f64).norm())
            .fold(0.0, f64::max);
        assert!((g.peak() - peak).abs() / peak < 1e-5);
    }
}
