//! Resolution check: −3 dB widths of a point target's response, measured along the direction
//! where only the range (resp. only the Doppler) coordinate changes, and mapped to the ground
//! along the bistatic range gradient g (resp. along the Doppler gradient, i.e. the track).
//!
//! The response is separable in the range coordinate ρ = g·x and the Doppler coordinate
//! ν = d·x (d: Doppler gradient). On the iso-Doppler line through the peak (direction v_r ⟂ d)
//! only ρ changes, at |g·v_r| per metre: a width W measured there is a range width W |g·v_r| and
//! a ground width along g of `W |g·v_r| / |g|` — to compare with `c/(B|g|)` times the main-lobe
//! factor. Likewise along the iso-range line (v_a ⟂ g): `W |d·v_a| / |d|` against `1/(T_d|d|)`.

use serde::{Deserialize, Serialize};

/// −3 dB (half-power) width of a sampled magnitude cut around its peak, in the cut's units;
/// `None` if the cut does not fall 3 dB on both sides.
pub fn half_power_width(s: &[f64], power: &[f64]) -> Option<f64> {
    let (ip, &pk) = power.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
    let half = pk / 2.0;
    let mut left = None;
    for i in (0..ip).rev() {
        if power[i] <= half {
            let f = (half - power[i]) / (power[i + 1] - power[i]);
            left = Some(s[i] + f * (s[i + 1] - s[i]));
            break;
        }
    }
    let mut right = None;
    for i in ip + 1..power.len() {
        if power[i] <= half {
            let f = (power[i - 1] - half) / (power[i - 1] - power[i]);
            right = Some(s[i - 1] + f * (s[i] - s[i - 1]));
            break;
        }
    }
    Some(right? - left?)
}

/// Directions of the two cuts for range gradient `g` and Doppler gradient `d`:
/// (iso-Doppler unit direction v_r ⟂ d, iso-range unit direction v_a ⟂ g).
pub fn cut_directions(g: [f64; 2], d: [f64; 2]) -> Option<([f64; 2], [f64; 2])> {
    let ng = g[0].hypot(g[1]);
    let nd = d[0].hypot(d[1]);
    if ng == 0.0 || nd == 0.0 {
        return None;
    }
    Some(([-d[1] / nd, d[0] / nd], [-g[1] / ng, g[0] / ng]))
}

/// A measured resolution beside its predictions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ResolutionReport {
    /// Measured ground range width along g, m.
    pub range_measured_m: f64,
    /// General prediction c/(B|g|) × main-lobe factor, m.
    pub range_general_m: f64,
    /// The paper's δ_r, m (no main-lobe factor).
    pub range_paper_m: f64,
    /// Measured azimuth width along the Doppler gradient (the track at broadside), m.
    pub azimuth_measured_m: f64,
    /// General prediction 1/(T_d |∇f_D|) × main-lobe factor, m.
    pub azimuth_general_m: f64,
    /// The paper's δ_a, m (no main-lobe factor).
    pub azimuth_paper_m: f64,
    /// Main-lobe factor used.
    pub mainlobe_factor: f64,
    /// Bistatic angle at the aperture centre, deg.
    pub bistatic_angle_deg: f64,
    /// Angle between g and the Doppler gradient, deg.
    pub psi_deg: f64,
}

impl ResolutionReport {
    /// Relative error of the range width against the general prediction.
    pub fn range_error(&self) -> f64 {
        self.range_measured_m / self.range_general_m - 1.0
    }

    /// Relative error of the azimuth width against the general prediction.
    pub fn azimuth_error(&self) -> f64 {
        self.azimuth_measured_m / self.azimuth_general_m - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sinc_squared_width_is_0886() {
        let s: Vec<f64> = (-400..=400).map(|i| i as f64 * 0.005).collect();
        let p: Vec<f64> = s.iter().map(|x| crate::antenna::sinc(*x).powi(2)).collect();
        let w = half_power_width(&s, &p).unwrap();
        assert!((w - 0.8859).abs() < 1e-3, "{w}");
        assert!(half_power_width(&s[..300], &p[..300]).is_none());
    }

    #[test]
    fn cut_directions_are_perpendicular() {
        let (vr, va) = cut_directions([0.3, 1.2], [-2.0, 0.5]).unwrap();
        assert!((vr[0] * -2.0 + vr[1] * 0.5).abs() < 1e-12);
        assert!((va[0] * 0.3 + va[1] * 1.2).abs() < 1e-12);
    }
}
