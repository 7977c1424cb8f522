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

/// The base station's sectored antenna, the element pattern of 3GPP TR 38.901 Table 7.3-1
/// pointed at the sector's azimuth φ_s and electrically down-tilted by θ_tilt:
/// `A_V(θ) = −min(12 ((θ − 90° − θ_tilt)/θ_3dB)², SLA_V)` (θ the zenith angle),
/// `A_H(φ) = −min(12 ((φ − φ_s)/φ_3dB)², A_max)`, `A = −min(−(A_V + A_H), A_max)`, and the
/// power gain `G_max + A` dB. TR 38.901's values: θ_3dB = φ_3dB = 65°, SLA_V = A_max = 30 dB;
/// G_max is the scene's `tx_gain_dbi` (the panel's peak gain).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SectorAntenna {
    /// Sector azimuth φ_s, rad from +x counter-clockwise.
    pub azimuth_rad: f64,
    /// Electrical down-tilt θ_tilt below the horizon, rad.
    pub downtilt_rad: f64,
    /// Half-power beamwidth, both planes, rad.
    pub beamwidth_rad: f64,
    /// Front-to-back ratio A_max, dB (> 0).
    pub front_to_back_db: f64,
    /// Side-lobe limit of the vertical cut SLA_V, dB (> 0).
    pub sidelobe_db: f64,
}

impl SectorAntenna {
    /// The pattern A(θ, φ) in dB (≤ 0) towards `p` from the antenna at `bs`.
    pub fn pattern_db(&self, bs: [f64; 3], p: [f64; 3]) -> f64 {
        let d = [p[0] - bs[0], p[1] - bs[1], p[2] - bs[2]];
        let horiz = d[0].hypot(d[1]);
        // zenith angle: 90° horizontal, more below
        let zenith = horiz.atan2(d[2]);
        let phi = d[1].atan2(d[0]) - self.azimuth_rad;
        let phi =
            (phi + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        let bw = self.beamwidth_rad;
        let tilt = std::f64::consts::FRAC_PI_2 + self.downtilt_rad;
        let av = -(12.0 * ((zenith - tilt) / bw).powi(2)).min(self.sidelobe_db);
        let ah = -(12.0 * (phi / bw).powi(2)).min(self.front_to_back_db);
        -(-(av + ah)).min(self.front_to_back_db)
    }

    /// The pattern as a power factor (≤ 1) towards `p`.
    pub fn gain_towards(&self, bs: [f64; 3], p: [f64; 3]) -> f64 {
        10f64.powf(self.pattern_db(bs, p) / 10.0)
    }
}

#[cfg(test)]
mod sector_tests {
    use super::*;

    fn sector() -> SectorAntenna {
        SectorAntenna {
            azimuth_rad: 135f64.to_radians(),
            downtilt_rad: 10f64.to_radians(),
            beamwidth_rad: 65f64.to_radians(),
            front_to_back_db: 30.0,
            sidelobe_db: 30.0,
        }
    }

    /// The point at azimuth `az` and depression `dep` (degrees) 1 km from the BS at the origin.
    fn at(az: f64, dep: f64) -> [f64; 3] {
        let (a, e) = (az.to_radians(), dep.to_radians());
        [
            1e3 * e.cos() * a.cos(),
            1e3 * e.cos() * a.sin(),
            -1e3 * e.sin(),
        ]
    }

    #[test]
    fn tr_38_901_element_pattern() {
        let s = sector();
        let o = [0.0; 3];
        assert!(s.pattern_db(o, at(135.0, 10.0)).abs() < 1e-12, "boresight");
        // half the beamwidth off boresight in either plane: −3 dB
        for p in [
            at(135.0 + 32.5, 10.0),
            at(135.0 - 32.5, 10.0),
            at(135.0, 42.5),
        ] {
            assert!(
                (s.pattern_db(o, p) + 3.0).abs() < 1e-9,
                "{}",
                s.pattern_db(o, p)
            );
        }
        // behind: the front-to-back ratio; far above a narrow beam: the vertical side-lobe
        // limit (65° beams never reach it: 12 (100°/65°)² = 28.4 dB at the zenith)
        assert!((s.pattern_db(o, at(-45.0, 10.0)) + 30.0).abs() < 1e-12);
        assert!((s.pattern_db(o, at(135.0, -60.0)) + 12.0 * (70.0f64 / 65.0).powi(2)).abs() < 1e-9);
        let narrow = SectorAntenna {
            beamwidth_rad: 20f64.to_radians(),
            sidelobe_db: 20.0,
            ..s
        };
        assert!((narrow.pattern_db(o, at(135.0, -60.0)) + 20.0).abs() < 1e-12);
        // the sum of both cuts is capped at A_max
        assert!((s.pattern_db(o, at(-45.0, -60.0)) + 30.0).abs() < 1e-12);
        let both = s.pattern_db(o, at(135.0 + 32.5, 42.5));
        assert!((both + 6.0).abs() < 1e-9, "{both}");
        assert!((s.gain_towards(o, at(135.0 + 32.5, 10.0)) - 10f64.powf(-0.3)).abs() < 1e-12);
        // azimuths wrap
        let w = SectorAntenna {
            azimuth_rad: 170f64.to_radians(),
            ..s
        };
        assert!(
            (w.pattern_db(o, at(-170.0, 10.0)) - w.pattern_db(o, at(150.0, 10.0))).abs() < 1e-9
        );
    }
}
