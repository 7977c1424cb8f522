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
    /// Main-lobe factor of the range weighting (the general range prediction's factor).
    pub mainlobe_factor: f64,
    /// Main-lobe factor of the azimuth weighting.
    pub azimuth_mainlobe_factor: f64,
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

/// Distance from `centre` along unit direction `u` at which `power` (normalised: 1 at the
/// centre) first falls to one half: geometric steps out from `start_m` (×1.25) until the power
/// is below one half, then bisection to a relative bracket of 1e-7. `None` if it stays above one
/// half out to `max_m`.
pub fn half_power_radius(
    power: &dyn Fn([f64; 2]) -> f64,
    centre: [f64; 2],
    u: [f64; 2],
    start_m: f64,
    max_m: f64,
) -> Option<f64> {
    let at = |r: f64| power([centre[0] + r * u[0], centre[1] + r * u[1]]);
    let mut lo = 0.0;
    let mut hi = start_m.max(1e-6);
    loop {
        if at(hi) < 0.5 {
            break;
        }
        lo = hi;
        hi *= 1.25;
        if hi > max_m {
            return None;
        }
    }
    while hi - lo > 1e-7 * hi {
        let mid = 0.5 * (lo + hi);
        if at(mid) < 0.5 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// The −3 dB region of a point response, measured in many directions through its peak (the
/// region is star-shaped about the peak), and its principal widths (erratum 12 (docs/paper-notes.md)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PsfRegion {
    /// Peak position, m.
    pub centre_m: [f64; 2],
    /// Direction angles of the measured chords (from +x, counter-clockwise), rad in [0, π).
    pub directions_rad: Vec<f64>,
    /// Half-power distance along +direction, m.
    pub radius_plus_m: Vec<f64>,
    /// Half-power distance along −direction, m.
    pub radius_minus_m: Vec<f64>,
}

impl PsfRegion {
    /// Measures the region of `power` (normalised: 1 at `centre`) along `n_dirs` equally spaced
    /// directions plus the `extra` directions (unit vectors, e.g. the principal axes).
    /// `start_m`: initial step (a fraction of the smallest expected width); `max_m`: give up
    /// beyond this distance. Directions are measured in parallel.
    pub fn measure(
        power: &(dyn Fn([f64; 2]) -> f64 + Sync),
        centre: [f64; 2],
        n_dirs: usize,
        extra: &[[f64; 2]],
        start_m: f64,
        max_m: f64,
    ) -> Option<Self> {
        use rayon::prelude::*;
        let mut dirs: Vec<f64> = (0..n_dirs)
            .map(|k| std::f64::consts::PI * k as f64 / n_dirs as f64)
            .collect();
        for e in extra {
            dirs.push(e[1].atan2(e[0]).rem_euclid(std::f64::consts::PI));
        }
        let radii: Vec<Option<(f64, f64)>> = dirs
            .par_iter()
            .map(|a| {
                let u = [a.cos(), a.sin()];
                let p = half_power_radius(power, centre, u, start_m, max_m)?;
                let m = half_power_radius(power, centre, [-u[0], -u[1]], start_m, max_m)?;
                Some((p, m))
            })
            .collect();
        let mut order: Vec<usize> = (0..dirs.len()).collect();
        order.sort_by(|a, b| dirs[*a].total_cmp(&dirs[*b]));
        let mut out = Self {
            centre_m: centre,
            directions_rad: Vec::new(),
            radius_plus_m: Vec::new(),
            radius_minus_m: Vec::new(),
        };
        for k in order {
            let (p, m) = radii[k]?;
            out.directions_rad.push(dirs[k]);
            out.radius_plus_m.push(p);
            out.radius_minus_m.push(m);
        }
        Some(out)
    }

    /// The −3 dB chord through the peak along unit direction `u`, m (interpolated between the
    /// measured directions if `u` is not one of them).
    pub fn chord_m(&self, u: [f64; 2]) -> f64 {
        let a = u[1].atan2(u[0]).rem_euclid(std::f64::consts::PI);
        let n = self.directions_rad.len();
        let chord = |k: usize| self.radius_plus_m[k] + self.radius_minus_m[k];
        // exact match first
        if let Some(k) = self
            .directions_rad
            .iter()
            .position(|d| (d - a).abs() < 1e-12)
        {
            return chord(k);
        }
        let k1 = self.directions_rad.iter().position(|d| *d > a).unwrap_or(n);
        let (ka, kb) = ((k1 + n - 1) % n, k1 % n);
        let (da, mut db) = (self.directions_rad[ka], self.directions_rad[kb]);
        if db < da {
            db += std::f64::consts::PI;
        }
        let mut aa = a;
        if aa < da {
            aa += std::f64::consts::PI;
        }
        let t = if db > da { (aa - da) / (db - da) } else { 0.0 };
        chord(ka) + t * (chord(kb) - chord(ka))
    }

    /// The boundary points of the region (both sides of every chord), m.
    pub fn boundary_m(&self) -> Vec<[f64; 2]> {
        let c = self.centre_m;
        let mut pts = Vec::with_capacity(2 * self.directions_rad.len());
        for (k, a) in self.directions_rad.iter().enumerate() {
            let (s, co) = a.sin_cos();
            pts.push([
                c[0] + self.radius_plus_m[k] * co,
                c[1] + self.radius_plus_m[k] * s,
            ]);
        }
        for (k, a) in self.directions_rad.iter().enumerate() {
            let (s, co) = a.sin_cos();
            pts.push([
                c[0] - self.radius_minus_m[k] * co,
                c[1] - self.radius_minus_m[k] * s,
            ]);
        }
        pts
    }

    /// The region's extent along unit vector `n` (the distance between its two supporting lines
    /// perpendicular to `n`), m.
    pub fn caliper_m(&self, n: [f64; 2]) -> f64 {
        let proj: Vec<f64> = self
            .boundary_m()
            .iter()
            .map(|p| p[0] * n[0] + p[1] * n[1])
            .collect();
        proj.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            - proj.iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// The longest measured chord through the peak and its direction (rad).
    pub fn longest_chord(&self) -> (f64, f64) {
        self.directions_rad
            .iter()
            .enumerate()
            .map(|(k, a)| (self.radius_plus_m[k] + self.radius_minus_m[k], *a))
            .fold((0.0, 0.0), |b, x| if x.0 > b.0 { x } else { b })
    }
}

/// Measured principal widths of a point response beside the predicted cell (the errata (docs/paper-notes.md) items
/// 11 and 12); predictions include the main-lobe factor of the weighting used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellReport {
    /// Occupied bandwidth, Hz.
    pub bandwidth_hz: f64,
    /// Bistatic angle between the ground directions BS → point and UAV → point, deg.
    pub bistatic_angle_deg: f64,
    /// Angle ψ between the range gradient g and the Doppler gradient (track), deg.
    pub psi_deg: f64,
    /// Extent of the −3 dB region along g (between its iso-range supporting lines), m.
    pub range_width_m: f64,
    /// Predicted: main-lobe factor × c/(B|g|), m.
    pub range_width_pred_m: f64,
    /// Extent along the Doppler gradient (along track at broadside), m.
    pub along_track_width_m: f64,
    /// Predicted: main-lobe factor × 1/(T|∇f_D|), m.
    pub along_track_width_pred_m: f64,
    /// −3 dB chord along the iso-Doppler line (across the track), m.
    pub cross_track_width_m: f64,
    /// Predicted: main-lobe factor × c/(B|g| sin ψ), m.
    pub cross_track_width_pred_m: f64,
    /// −3 dB chord along the iso-range line, m.
    pub iso_range_width_m: f64,
    /// Predicted: main-lobe factor × δ_a/sin ψ, m.
    pub iso_range_width_pred_m: f64,
    /// The measured worst width: the longest −3 dB chord in any measured direction (the
    /// same as `longest_chord_m`), m.
    pub worst_width_m: f64,
    /// Predicted worst width: the major axis of the −3 dB ellipse of the range and Doppler
    /// widths with their main-lobe factors ([`planner::geometry::cell_ellipse_axes_m`]), m.
    pub worst_width_pred_m: f64,
    /// Predicted narrowest width: that ellipse's minor axis, m.
    pub minor_width_pred_m: f64,
    /// The longest −3 dB chord in any measured direction, m, and its direction, deg.
    pub longest_chord_m: f64,
    /// Direction of the longest chord, deg from +x.
    pub longest_chord_deg: f64,
    /// Chord along g itself, m (shorter than the range width unless g ⟂ track).
    pub chord_along_g_m: f64,
    /// The paper's δ_r (no main-lobe factor), m.
    pub paper_range_m: f64,
    /// The paper's δ_a (no main-lobe factor), m.
    pub paper_azimuth_m: f64,
    /// The planner's (unweighted) worst width, m: what `--resolution general` bounds by d_min.
    pub planner_worst_width_m: f64,
    /// Main-lobe factors used (range, azimuth).
    pub mainlobe_factors: [f64; 2],
    /// The measured region.
    pub region: PsfRegion,
    /// Unit range gradient direction ĝ and Doppler gradient direction d̂ (ground).
    pub axes: [[f64; 2]; 2],
}

impl CellReport {
    /// Relative error of the measured worst width (the longest chord) against the predicted
    /// one (the ellipse's major axis).
    pub fn worst_width_error(&self) -> f64 {
        self.worst_width_m / self.worst_width_pred_m - 1.0
    }

    /// Relative errors (measured / predicted − 1) of range, along-track, cross-track and
    /// iso-range widths.
    pub fn errors(&self) -> [f64; 4] {
        [
            self.range_width_m / self.range_width_pred_m - 1.0,
            self.along_track_width_m / self.along_track_width_pred_m - 1.0,
            self.cross_track_width_m / self.cross_track_width_pred_m - 1.0,
            self.iso_range_width_m / self.iso_range_width_pred_m - 1.0,
        ]
    }

    /// The measured −3 dB region's boundary in local coordinates around the peak, m, ordered
    /// by angle (a closed polygon when joined end to start).
    pub fn local_boundary_m(&self) -> Vec<[f64; 2]> {
        let c = self.region.centre_m;
        let mut pts: Vec<[f64; 2]> = self
            .region
            .boundary_m()
            .iter()
            .map(|p| [p[0] - c[0], p[1] - c[1]])
            .collect();
        pts.sort_by(|a, b| a[1].atan2(a[0]).total_cmp(&b[1].atan2(b[0])));
        pts
    }

    /// The predicted −3 dB cell in local coordinates around the peak: the corners of the
    /// parallelogram |ĝ·x| ≤ R/2, |d̂·x| ≤ A/2 (R, A: the predicted range and along-track
    /// widths), m, in order around it.
    pub fn predicted_cell_m(&self) -> [[f64; 2]; 4] {
        let [g, d] = self.axes;
        let (r, a) = (
            self.range_width_pred_m / 2.0,
            self.along_track_width_pred_m / 2.0,
        );
        let det = g[0] * d[1] - g[1] * d[0];
        let corner = |sr: f64, sa: f64| -> [f64; 2] {
            // solve ĝ·x = sr r, d̂·x = sa a
            let (b1, b2) = (sr * r, sa * a);
            [(b1 * d[1] - b2 * g[1]) / det, (g[0] * b2 - d[0] * b1) / det]
        };
        [
            corner(1.0, 1.0),
            corner(-1.0, 1.0),
            corner(-1.0, -1.0),
            corner(1.0, -1.0),
        ]
    }

    /// The predicted −3 dB ellipse in local coordinates around the peak, m: `n` points of
    /// {x : (ĝ·x / R)² + (d̂·x / A)² = 1/4} (R, A the predicted range and along-track widths),
    /// the ellipse inscribed in [`CellReport::predicted_cell_m`], touching the middles of its
    /// sides: x = (R/2) cos t · u + (A/2) sin t · w with ĝ·u = 1, d̂·u = 0, ĝ·w = 0, d̂·w = 1.
    pub fn predicted_ellipse_m(&self, n: usize) -> Vec<[f64; 2]> {
        let [g, d] = self.axes;
        let det = g[0] * d[1] - g[1] * d[0];
        // u, w: the dual basis of (ĝ, d̂)
        let u = [d[1] / det, -d[0] / det];
        let w = [-g[1] / det, g[0] / det];
        let (r, a) = (
            self.range_width_pred_m / 2.0,
            self.along_track_width_pred_m / 2.0,
        );
        (0..n)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / n as f64;
                let (s, c) = t.sin_cos();
                [r * c * u[0] + a * s * w[0], r * c * u[1] + a * s * w[1]]
            })
            .collect()
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

    /// An analytic separable response sinc²(a·x) sinc²(b·x) (a, b: oblique gradients): the
    /// measured region has the closed-form principal widths of erratum 12 (docs/paper-notes.md).
    #[test]
    fn region_of_a_separable_response_has_the_closed_form_widths() {
        use crate::antenna::sinc;
        for (a, b) in [
            ([0.5, 0.1], [0.02, 0.15]),
            ([0.3, -0.4], [0.1, 0.1]),
            ([0.0, 0.6], [0.01, 0.2]), // ψ ≈ 2.9°: near blind
        ] {
            let pw = move |p: [f64; 2]| {
                (sinc(a[0] * p[0] + a[1] * p[1]) * sinc(b[0] * p[0] + b[1] * p[1])).powi(2)
            };
            let c = [3.0, -2.0];
            let f = move |p: [f64; 2]| pw([p[0] - c[0], p[1] - c[1]]);
            let na = a[0].hypot(a[1]);
            let nb = b[0].hypot(b[1]);
            let sin_psi = (a[0] * b[1] - a[1] * b[0]).abs() / (na * nb);
            let w = 0.885_892_941_378_9;
            // iso-b direction (only a changes) and iso-a direction
            let vr = [-b[1] / nb, b[0] / nb];
            let va = [-a[1] / na, a[0] / na];
            let reg = PsfRegion::measure(&f, c, 90, &[vr, va], 0.05, 1e4).unwrap();
            let rel = |x: f64, y: f64| (x / y - 1.0).abs();
            let ga = [a[0] / na, a[1] / na];
            let gb = [b[0] / nb, b[1] / nb];
            assert!(
                rel(reg.caliper_m(ga), w / na) < 1e-4,
                "{}",
                reg.caliper_m(ga)
            );
            assert!(
                rel(reg.caliper_m(gb), w / nb) < 1e-4,
                "{}",
                reg.caliper_m(gb)
            );
            assert!(rel(reg.chord_m(vr), w / (na * sin_psi)) < 1e-6);
            assert!(rel(reg.chord_m(va), w / (nb * sin_psi)) < 1e-6);
            let (longest, _) = reg.longest_chord();
            assert!(longest >= reg.chord_m(vr).max(reg.chord_m(va)) - 1e-9);
        }
        // a response that never falls by 3 dB within the search: None
        let flat = |_: [f64; 2]| 1.0;
        assert!(PsfRegion::measure(&flat, [0.0, 0.0], 8, &[], 0.1, 100.0).is_none());
    }

    /// The predicted cell's corners lie on the lines ĝ·x = ±R/2 and d̂·x = ±A/2, and the local
    /// boundary is the region's boundary moved to the peak, ordered by angle.
    #[test]
    fn predicted_cell_and_local_boundary() {
        let c = [5.0, -7.0];
        let disc = move |p: [f64; 2]| {
            if (p[0] - c[0]).hypot(p[1] - c[1]) < 3.0 {
                1.0
            } else {
                0.0
            }
        };
        let region = PsfRegion::measure(&disc, c, 24, &[], 0.1, 100.0).unwrap();
        let (s, co) = 0.4f64.sin_cos();
        let g = [co, s];
        let d = [(1.0f64).cos(), (1.0f64).sin()];
        let cell = CellReport {
            bandwidth_hz: 1e8,
            bistatic_angle_deg: 0.0,
            psi_deg: 0.0,
            range_width_m: 0.0,
            range_width_pred_m: 4.0,
            along_track_width_m: 0.0,
            along_track_width_pred_m: 10.0,
            cross_track_width_m: 0.0,
            cross_track_width_pred_m: 0.0,
            iso_range_width_m: 0.0,
            iso_range_width_pred_m: 0.0,
            worst_width_m: 0.0,
            worst_width_pred_m: 0.0,
            minor_width_pred_m: 0.0,
            longest_chord_m: 0.0,
            longest_chord_deg: 0.0,
            chord_along_g_m: 0.0,
            paper_range_m: 0.0,
            paper_azimuth_m: 0.0,
            planner_worst_width_m: 0.0,
            mainlobe_factors: [1.0, 1.0],
            region,
            axes: [g, d],
        };
        let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
        for (p, (sr, sa)) in
            cell.predicted_cell_m()
                .iter()
                .zip([(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)])
        {
            assert!((dot(g, *p) - sr * 2.0).abs() < 1e-12, "{p:?}");
            assert!((dot(d, *p) - sa * 5.0).abs() < 1e-12, "{p:?}");
        }
        // the ellipse: on (ĝ·x/R)² + (d̂·x/A)² = 1/4, its longest chord the predicted major
        // axis of the same widths and angle
        let ellipse = cell.predicted_ellipse_m(3600);
        for p in &ellipse {
            let q = (dot(g, *p) / 4.0).powi(2) + (dot(d, *p) / 10.0).powi(2);
            assert!((q - 0.25).abs() < 1e-12, "{p:?}: {q}");
        }
        let longest = ellipse
            .iter()
            .map(|p| 2.0 * p[0].hypot(p[1]))
            .fold(0.0, f64::max);
        let (major, _) = planner::geometry::cell_ellipse_axes_m(4.0, 10.0, (1.0f64 - 0.4).sin());
        assert!((longest / major - 1.0).abs() < 1e-5, "{longest} vs {major}");
        let b = cell.local_boundary_m();
        assert_eq!(b.len(), 48);
        for p in &b {
            assert!((p[0].hypot(p[1]) - 3.0).abs() < 1e-5, "{p:?}");
        }
        let angles: Vec<f64> = b.iter().map(|p| p[1].atan2(p[0])).collect();
        assert!(angles.windows(2).all(|w| w[0] <= w[1]));
    }
}
