//! The UAV's right-looking receive antenna: a uniformly illuminated L_a × W_a aperture whose
//! boresight points right of the heading, η from nadir (towards the sensing centre).
//!
//! Field pattern `sinc(L_a a/λ) sinc(W_a e/λ)` with `a`, `e` the direction cosines along the
//! track and along the aperture's height axis; power gain `G0 F²` with `G0 = 4π L_a W_a / λ²`,
//! floored at `sidelobe_floor` in front and `backlobe` behind the aperture plane.

use serde::{Deserialize, Serialize};

use crate::config::RadarConfig;

/// A receive antenna pattern.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Antenna {
    /// Length along track L_a, m.
    pub length_m: f64,
    /// Height W_a, m.
    pub height_m: f64,
    /// Wavelength, m.
    pub wavelength_m: f64,
    /// Look angle η from nadir, rad.
    pub look_rad: f64,
    /// Peak gain G0 (linear).
    pub peak_gain: f64,
    /// Floor in front, linear relative to the peak.
    pub floor: f64,
    /// Gain behind the aperture, linear relative to the peak.
    pub back: f64,
}

/// sin(πx)/(πx).
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        1.0
    } else {
        let p = std::f64::consts::PI * x;
        p.sin() / p
    }
}

impl Antenna {
    /// The antenna of `radar` at wavelength λ and look angle η.
    pub fn new(radar: &RadarConfig, wavelength_m: f64, look_rad: f64) -> Self {
        Self {
            length_m: radar.antenna_length_m,
            height_m: radar.antenna_height_m,
            wavelength_m,
            look_rad,
            peak_gain: 4.0 * std::f64::consts::PI * radar.antenna_length_m * radar.antenna_height_m
                / (wavelength_m * wavelength_m),
            floor: 10f64.powf(radar.sidelobe_floor_db / 10.0),
            back: 10f64.powf(radar.backlobe_db / 10.0),
        }
    }

    /// Boresight and aperture axes for a heading unit vector (x, y): (boresight, along, height).
    pub fn axes(&self, heading: [f64; 2]) -> ([f64; 3], [f64; 3], [f64; 3]) {
        let h = [heading[0], heading[1], 0.0];
        let r = [heading[1], -heading[0], 0.0]; // right of track
        let (s, c) = self.look_rad.sin_cos();
        let b = [s * r[0], s * r[1], -c];
        // e = h × b (unit: h ⟂ b, both unit)
        let e = [
            h[1] * b[2] - h[2] * b[1],
            h[2] * b[0] - h[0] * b[2],
            h[0] * b[1] - h[1] * b[0],
        ];
        (b, h, e)
    }

    /// Power gain (linear) towards unit direction `u` (from the UAV) for a UAV heading `heading`.
    pub fn gain(&self, heading: [f64; 2], u: [f64; 3]) -> f64 {
        let (b, h, e) = self.axes(heading);
        let dot = |p: [f64; 3], q: [f64; 3]| p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
        if dot(u, b) <= 0.0 {
            return self.peak_gain * self.back;
        }
        let f = sinc(self.length_m * dot(u, h) / self.wavelength_m)
            * sinc(self.height_m * dot(u, e) / self.wavelength_m);
        self.peak_gain * (f * f).max(self.floor)
    }

    /// Power gain towards ground/space point `p` from a UAV at `uav` with heading `heading`.
    pub fn gain_towards(&self, uav: [f64; 3], heading: [f64; 2], p: [f64; 3]) -> f64 {
        let d = [p[0] - uav[0], p[1] - uav[1], p[2] - uav[2]];
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if n == 0.0 {
            return self.peak_gain * self.back;
        }
        self.gain(heading, [d[0] / n, d[1] / n, d[2] / n])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ant() -> Antenna {
        Antenna::new(&RadarConfig::default(), 0.1, std::f64::consts::FRAC_PI_4)
    }

    #[test]
    fn peak_at_sensing_centre_and_right_looking() {
        let a = ant();
        let uav = [0.0, 0.0, 1000.0];
        let heading = [0.0, 1.0]; // north: right is east
        let centre = [1000.0, 0.0, 0.0];
        assert!((a.gain_towards(uav, heading, centre) / a.peak_gain - 1.0).abs() < 1e-12);
        // 25 dBi for a 0.5 m × 0.5 m aperture at λ = 0.1 m.
        assert!((10.0 * a.peak_gain.log10() - 24.97).abs() < 0.01);
        // The mirror point on the left is behind the aperture.
        let left = [-1000.0, 0.0, 0.0];
        assert!((a.gain_towards(uav, heading, left) / a.peak_gain - a.back).abs() < 1e-12);
    }

    #[test]
    fn elevation_width_matches_sensing_radius() {
        // r_s = λH/(2 W_a cos²η) is where the elevation argument W_a e/λ reaches 1/2 (a ≈ −3.9 dB).
        let a = ant();
        let uav = [0.0, 0.0, 1000.0];
        let heading = [0.0, 1.0];
        let g = a.gain_towards(uav, heading, [1200.0, 0.0, 0.0]) / a.peak_gain;
        let db = 10.0 * g.log10();
        assert!(db < -2.5 && db > -5.0, "{db}");
        // along track: first null at a = λ/L_a, i.e. ~ R λ / L_a ≈ 283 m at R = 1414 m.
        let g = a.gain_towards(uav, heading, [1000.0, 200.0, 0.0]) / a.peak_gain;
        assert!(10.0 * g.log10() < -6.0);
    }
}
