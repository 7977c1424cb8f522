//! Bistatic SAR geometry on the ground plane z = 0: heading, sensing centre, the paper's range and
//! azimuth resolutions, their general bistatic forms (erratum 11 (docs/paper-notes.md)) and the 2-D resolution
//! cell (erratum 12 (docs/paper-notes.md)).
//!
//! Frames: a world frame with x east, y north, z up, metres. The UAV flies at z = H, the BS antenna
//! is at z = H_b. Headings α are measured from the x axis, counter-clockwise.
//!
//! The vector maths is nalgebra's: [`Point2`] for ground positions, [`Vector2`] for
//! displacements, velocities and gradients, [`Rotation2`] for turns (re-exported here for the
//! crates that use this module), with lengths and directions from [`Length`]. Positions and
//! vectors enter and leave the public functions as `[f64; 2]`, the type in which trajectories,
//! evaluations and parameters are stored and serialized (file and wire formats unchanged) and
//! which radar-sim, fmu and pipeline pass.

pub use nalgebra::{Matrix2, Point2, Rotation2, Vector2};

use crate::params::{Params, SPEED_OF_LIGHT_MPS};

/// Length and direction of a ground vector as the planner has always computed them:
/// ‖v‖ = hypot(v_x, v_y) and v̂ = v · (1/‖v‖). nalgebra's `norm()` (sqrt(v_x² + v_y²)) and
/// `try_normalize` (v / ‖v‖) differ from these in the last bit, and the `paper` and baseline
/// schemes carry last-bit differences of their start into visibly different iterates (with
/// nalgebra's: 22 % in the `baseline` plan's energy on the default 30 m mission, 1e-3 for
/// `paper`): with these, plans are bit-identical to those of the planner before nalgebra.
pub trait Length {
    /// ‖v‖, as `hypot` (no overflow or underflow in the squares).
    fn length(&self) -> f64;
    /// v / ‖v‖, or `None` for a zero or non-finite vector.
    fn direction(&self) -> Option<Vector2<f64>>;
}

impl Length for Vector2<f64> {
    fn length(&self) -> f64 {
        self.x.hypot(self.y)
    }

    fn direction(&self) -> Option<Vector2<f64>> {
        let n = self.length();
        (n > 0.0 && n.is_finite()).then(|| self * (1.0 / n))
    }
}

/// ‖a − b‖, with [`Length::length`].
pub fn distance(a: &Point2<f64>, b: &Point2<f64>) -> f64 {
    (a - b).length()
}

/// The turn by −90° from a direction of flight to its right-hand normal, (a_x, a_y) ↦ (a_y, −a_x).
/// Built from its exact matrix: `Rotation2::new(−π/2)` would carry cos(π/2) ≈ 6e-17 into every
/// product.
pub const RIGHT_TURN: Rotation2<f64> =
    Rotation2::from_matrix_unchecked(Matrix2::new(0.0, 1.0, -1.0, 0.0));

/// Heading α of the displacement `to − from`, rad in [0, 2π), or `None` if the UAV did not move.
pub fn heading_rad(from_m: [f64; 2], to_m: [f64; 2]) -> Option<f64> {
    let d = Point2::from(to_m) - Point2::from(from_m);
    (d.length() > 1e-12).then(|| d.y.atan2(d.x).rem_euclid(std::f64::consts::TAU))
}

/// Unit vector of a heading, (cos α, sin α).
pub fn heading_unit(heading_rad: f64) -> Vector2<f64> {
    Vector2::new(heading_rad.cos(), heading_rad.sin())
}

/// The sensing centre q_c = q + H tan η (sin α, −cos α): right of the track, `offset_m` away.
pub fn sensing_centre_m(pos_m: [f64; 2], heading_rad: f64, offset_m: f64) -> [f64; 2] {
    (Point2::from(pos_m) + RIGHT_TURN * heading_unit(heading_rad) * offset_m).into()
}

/// sin θ_t of the BS illumination at ground point `p`: ‖p − q_b‖ / sqrt(‖p − q_b‖² + H_b²).
pub fn sin_incidence_bs(params: &Params, point_m: [f64; 2]) -> f64 {
    let d = distance(&Point2::from(point_m), &Point2::from(params.bs_m));
    let h = params.bs_height_m;
    if d == 0.0 && h == 0.0 {
        return 0.0;
    }
    d / d.hypot(h)
}

/// The paper's range resolution δ_r = c / (B (sin η + sin θ_t)) at ground point `p`, m.
pub fn range_resolution_paper_m(params: &Params, point_m: [f64; 2]) -> f64 {
    SPEED_OF_LIGHT_MPS
        / (params.bandwidth_hz
            * (params.observation_angle_rad.sin() + sin_incidence_bs(params, point_m)))
}

/// The paper's azimuth resolution δ_a = λ_c H / (T_d V cos η) at speed `V`, m (∞ at V = 0).
pub fn azimuth_resolution_paper_m(params: &Params, speed_mps: f64) -> f64 {
    params.wavelength_m * params.altitude_m
        / (params.integration_time_s * speed_mps * params.observation_angle_rad.cos())
}

/// Gradient of the bistatic range |BS→p| + |p→UAV| with respect to the ground position of `p`
/// (dimensionless): sin θ_t ĝ_t + sin θ_r ĝ_r, with ĝ_t, ĝ_r the unit ground directions from
/// the BS and from the UAV to the point.
pub fn bistatic_range_gradient(params: &Params, uav_m: [f64; 2], point_m: [f64; 2]) -> [f64; 2] {
    let point = Point2::from(point_m);
    // d|from→p|/dp of an antenna at `from`, `height` above the ground: the ground part of the
    // unit 3-D direction, (p − from) / sqrt(‖p − from‖² + height²)
    let range_gradient = |from: [f64; 2], height: f64| {
        let d = point - Point2::from(from);
        let r = (d.norm_squared() + height.powi(2)).sqrt();
        if r > 0.0 {
            d * (1.0 / r)
        } else {
            Vector2::zeros()
        }
    };
    let g =
        range_gradient(params.bs_m, params.bs_height_m) + range_gradient(uav_m, params.altitude_m);
    g.into()
}

/// The general bistatic ground-range resolution c / (B ‖sin θ_t ĝ_t + sin θ_r ĝ_r‖), m
/// (erratum 11 (docs/paper-notes.md)). ∞ when the gradient vanishes.
pub fn range_resolution_general_m(params: &Params, uav_m: [f64; 2], point_m: [f64; 2]) -> f64 {
    let g = Vector2::from(bistatic_range_gradient(params, uav_m, point_m));
    SPEED_OF_LIGHT_MPS / (params.bandwidth_hz * g.length())
}

/// Gradient of the Doppler frequency −(1/λ) dR_r/dt with respect to the ground position of the
/// point, 1/(m s): (v − (v·û) û)_ground / (λ R_r), with û the unit vector UAV → point.
pub fn doppler_gradient(
    params: &Params,
    uav_m: [f64; 2],
    velocity_mps: [f64; 2],
    point_m: [f64; 2],
) -> [f64; 2] {
    let d = Point2::from(point_m) - Point2::from(uav_m);
    let v = Vector2::from(velocity_mps);
    let h = params.altitude_m;
    let r = (d.norm_squared() + h * h).sqrt();
    // û = (d, −H)/r ; v = (v, 0) ; v·û = v·d / r
    let vu = v.dot(&d) / r;
    let g = v - d * (vu / r);
    (g * (1.0 / (params.wavelength_m * r))).into()
}

/// The general azimuth (Doppler) resolution 1 / (T_d ‖∇f_D‖), m. At broadside it equals
/// λ_c R_r / (T_d V), R_r = H / cos η — the paper's δ_a.
pub fn azimuth_resolution_general_m(
    params: &Params,
    uav_m: [f64; 2],
    velocity_mps: [f64; 2],
    point_m: [f64; 2],
) -> f64 {
    let g = Vector2::from(doppler_gradient(params, uav_m, velocity_mps, point_m));
    1.0 / (params.integration_time_s * g.length())
}

/// The angle β between the ground directions BS → point and UAV → point, rad in [0, π].
pub fn bistatic_angle_rad(params: &Params, uav_m: [f64; 2], point_m: [f64; 2]) -> f64 {
    let point = Point2::from(point_m);
    let a = point - Point2::from(params.bs_m);
    let b = point - Point2::from(uav_m);
    a.perp(&b).abs().atan2(a.dot(&b))
}

/// Full axes (major, minor) of the resolution ellipse, m (erratum 12 (docs/paper-notes.md)):
/// the ground points x with xᵀ J x ≤ 1/4, J = a aᵀ + b bᵀ, where a is the range gradient over
/// c/B (‖a‖ = 1/`range_width_m`), b the Doppler gradient times T_d (‖b‖ =
/// 1/`along_track_width_m`) and ψ the angle between them. That is the −3 dB region of the
/// separable range–Doppler response with its two widths as given (times the weightings'
/// main-lobe factors for the image's response); its major axis 1/√λ_min(J) is the longest
/// chord of the cell, which the parallelogram of the iso-range and iso-Doppler lines bounds.
/// With λ± = (tr J ± √((‖a‖² − ‖b‖²)² + 4 (a·b)²))/2 and λ₋ = det J / λ₊ (no cancellation);
/// ∞ where the cell is unbounded (ψ = 0 or a width infinite).
pub fn cell_ellipse_axes_m(
    range_width_m: f64,
    along_track_width_m: f64,
    sin_psi: f64,
) -> (f64, f64) {
    let (a2, b2) = (range_width_m.powi(-2), along_track_width_m.powi(-2));
    let sin2 = sin_psi.clamp(0.0, 1.0).powi(2);
    let det = a2 * b2 * sin2;
    let lambda_max = 0.5 * (a2 + b2 + ((a2 - b2).powi(2) + 4.0 * a2 * b2 * (1.0 - sin2)).sqrt());
    let minor = 1.0 / lambda_max.sqrt();
    let major = if det > 0.0 && det.is_finite() {
        (lambda_max / det).sqrt()
    } else {
        f64::INFINITY
    };
    (major, minor)
}

/// The direction of the worst width: the unit major axis of the ellipse of widths `range_m`
/// along the unit vector `range_dir` and `along_m` along the unit vector `along_dir`
/// ([`cell_ellipse_axes_m`]): the eigenvector of J = r̂r̂ᵀ/range² + d̂d̂ᵀ/along² with the smaller
/// eigenvalue (perpendicular to `range_dir` where J is degenerate).
pub fn cell_ellipse_major_direction(
    range_dir: [f64; 2],
    range_m: f64,
    along_dir: [f64; 2],
    along_m: f64,
) -> [f64; 2] {
    let (g, d) = (Vector2::from(range_dir), Vector2::from(along_dir));
    let j = g * g.transpose() * range_m.powi(-2) + d * d.transpose() * along_m.powi(-2);
    let eig = nalgebra::SymmetricEigen::new(j);
    let k = usize::from(eig.eigenvalues[0] > eig.eigenvalues[1]);
    let u: Vector2<f64> = eig.eigenvectors.column(k).into_owned();
    match u.direction() {
        Some(u) if j.iter().all(|x| x.is_finite()) => u.into(),
        _ => [-range_dir[1], range_dir[0]],
    }
}

/// The 2-D resolution cell at a ground point (erratum 12 (docs/paper-notes.md)): the ellipse
/// [`cell_ellipse_axes_m`] of the range and Doppler widths, inscribed in the parallelogram whose
/// sides are the iso-range lines (⊥ range gradient g) and the iso-Doppler lines (⊥ Doppler
/// gradient, i.e. ⊥ the track at broadside).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResolutionCell {
    /// ‖g‖, the norm of the bistatic range gradient (between |sin θ_t − sin θ_r| and their sum).
    pub grad_norm: f64,
    /// Angle ψ between g and the Doppler-gradient direction (the track at broadside), rad in [0, π/2].
    pub psi_rad: f64,
    /// Width along g: c / (B ‖g‖), m (the general δ_r).
    pub range_width_m: f64,
    /// Width along the Doppler gradient (along track): the general δ_a, m.
    pub along_track_width_m: f64,
    /// Width across the track (along an iso-Doppler line): c / (B ‖g‖ |sin ψ|), m.
    pub cross_track_width_m: f64,
    /// Width along an iso-range line: δ_a / |sin ψ|, m.
    pub iso_range_width_m: f64,
    /// The cell's worst width: its longest chord, the major axis of the ellipse
    /// ([`cell_ellipse_axes_m`]; the paper's convention, without a weighting's main-lobe
    /// factor), m. Two objects this far apart along the worst direction still fall in one cell.
    /// At least the parallelogram's longer side max(cross-track, iso-range) (the ellipse's
    /// chords along those lines), √(1 + cos ψ) (up to √2) times it where the range and
    /// along-track widths are equal, and at most the parallelogram's long diagonal; ∞ in blind
    /// geometry (ψ = 0).
    pub worst_width_m: f64,
    /// The ellipse's minor axis, the cell's narrowest width, m.
    pub minor_width_m: f64,
}

impl ResolutionCell {
    /// The cell at `point_m` seen from a UAV at `uav_m` moving with `velocity_mps`.
    pub fn new(
        params: &Params,
        uav_m: [f64; 2],
        velocity_mps: [f64; 2],
        point_m: [f64; 2],
    ) -> Self {
        let g = Vector2::from(bistatic_range_gradient(params, uav_m, point_m));
        let d = Vector2::from(doppler_gradient(params, uav_m, velocity_mps, point_m));
        let gn = g.length();
        let dn = d.length();
        let range_width_m = SPEED_OF_LIGHT_MPS / (params.bandwidth_hz * gn);
        let along_track_width_m = 1.0 / (params.integration_time_s * dn);
        let sin_psi = if gn > 0.0 && dn > 0.0 {
            (g.perp(&d) / (gn * dn)).abs().min(1.0)
        } else {
            0.0
        };
        let psi_rad = sin_psi.asin();
        let cross_track_width_m = range_width_m / sin_psi;
        let iso_range_width_m = along_track_width_m / sin_psi;
        let (worst_width_m, minor_width_m) =
            cell_ellipse_axes_m(range_width_m, along_track_width_m, sin_psi);
        Self {
            grad_norm: gn,
            psi_rad,
            range_width_m,
            along_track_width_m,
            cross_track_width_m,
            iso_range_width_m,
            worst_width_m,
            minor_width_m,
        }
    }
}

/// The resolution-cell quantities that are linear in the UAV velocity, at a fixed UAV position:
/// the range gradient g, the map A with Doppler gradient d = A v, and the vector k with
/// g × (A v) = k · v. With them the worst width (the ellipse's major axis, [`ResolutionCell`])
/// is at most d where det(J − I/d²) ≥ 0 and ‖g‖ B/c ≥ 1/d, that is the second-order cone
/// |k·v| ≥ c/(B d) ‖(A v, h)‖ with h = √((B‖g‖/c)² − 1/d²) / T_d ([`CellLinear::ellipse_h`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellLinear {
    /// Bistatic range gradient g at the point.
    pub grad: Vector2<f64>,
    /// Symmetric map from the UAV ground velocity (m/s) to the Doppler gradient (1/(m s)).
    pub doppler_map: Matrix2<f64>,
    /// k = A (−g_y, g_x), A applied to g turned left: g × (A v) = k · v.
    pub cross: Vector2<f64>,
}

impl CellLinear {
    /// The quantities for a UAV at `uav_m` looking at `point_m`.
    pub fn new(params: &Params, uav_m: Point2<f64>, point_m: Point2<f64>) -> Self {
        let g = Vector2::from(bistatic_range_gradient(
            params,
            uav_m.into(),
            point_m.into(),
        ));
        let d = point_m - uav_m;
        let r2 = d.norm_squared() + params.altitude_m * params.altitude_m;
        // [`doppler_gradient`] is linear in v: A = k (I − d dᵀ / R_r²), k = 1 / (λ R_r)
        let k = 1.0 / (params.wavelength_m * r2.sqrt());
        let off_diagonal = -k * d.x * d.y / r2;
        let a = Matrix2::new(
            k * (1.0 - d.x * d.x / r2),
            off_diagonal,
            off_diagonal,
            k * (1.0 - d.y * d.y / r2),
        );
        let cross = a * (RIGHT_TURN.inverse() * g);
        Self {
            grad: g,
            doppler_map: a,
            cross,
        }
    }

    /// A v.
    pub fn doppler_gradient(&self, velocity_mps: Vector2<f64>) -> Vector2<f64> {
        self.doppler_map * velocity_mps
    }

    /// h = √((B‖g‖/c)² − 1/d²) / T_d of the worst-width cone for width `d_m` (see the type's
    /// docs), 1/(m s); 0 where the range width c/(B‖g‖) alone exceeds d (no velocity resolves
    /// the point then, and with h = 0 the cone still asks at least for the cross-track width).
    pub fn ellipse_h(&self, params: &Params, d_m: f64) -> f64 {
        let a = params.bandwidth_hz * self.grad.length() / SPEED_OF_LIGHT_MPS;
        (a * a - d_m.powi(-2)).max(0.0).sqrt() / params.integration_time_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn centre_is_right_of_track() {
        // heading north (α = π/2): right is east.
        let c = sensing_centre_m([0.0, 0.0], std::f64::consts::FRAC_PI_2, 1000.0);
        assert!((c[0] - 1000.0).abs() < 1e-9 && c[1].abs() < 1e-9);
        // heading east (α = 0): right is south.
        let c = sensing_centre_m([0.0, 0.0], 0.0, 1000.0);
        assert!(c[0].abs() < 1e-9 && (c[1] + 1000.0).abs() < 1e-9);
    }

    /// Table III: δ_r at θ_t = π/3 for B = 50, 100, 150, 200 MHz.
    #[test]
    fn table_iii() {
        let mut p = Params::default();
        // put the point where sin θ_t = sin(π/3): d / sqrt(d² + H_b²) = √3/2 → d = √3 H_b
        let d = 3f64.sqrt() * p.bs_height_m;
        let point = [p.bs_m[0] + d, p.bs_m[1]];
        for (b, want) in [(50e6, 3.81), (100e6, 1.91), (150e6, 1.27), (200e6, 0.95)] {
            p.bandwidth_hz = b;
            let got = range_resolution_paper_m(&p, point);
            assert!((got - want).abs() < 0.006, "B={b}: {got} vs {want}");
        }
    }

    #[test]
    fn azimuth_at_min_speed_equals_d_min() {
        let p = Params::default();
        let v = p.min_speed_mps();
        assert!((azimuth_resolution_paper_m(&p, v) - p.d_min_m).abs() < 1e-9);
    }

    #[test]
    fn general_reduces_to_paper_when_directions_coincide() {
        let p = Params::default();
        // BS, point and UAV collinear on the ground with the point between them (β = 0):
        // ĝ_t and ĝ_r both point along +x.
        let point = [p.bs_m[0] + 500.0, p.bs_m[1]];
        let uav = [point[0] - p.centre_offset_m(), point[1]];
        let general = range_resolution_general_m(&p, uav, point);
        let paper = range_resolution_paper_m(&p, point);
        assert!(
            (general - paper).abs() < 1e-9 * paper,
            "{general} vs {paper}"
        );
        assert!(bistatic_angle_rad(&p, uav, point).abs() < 1e-12);
    }

    #[test]
    fn broadside_azimuth_general_equals_paper() {
        let p = Params::default();
        let uav = [0.0, 0.0];
        let heading = std::f64::consts::FRAC_PI_2; // north
        let v = 18.0;
        let vel = (heading_unit(heading) * v).into();
        let c = sensing_centre_m(uav, heading, p.centre_offset_m());
        let general = azimuth_resolution_general_m(&p, uav, vel, c);
        let paper = azimuth_resolution_paper_m(&p, v);
        assert!((general - paper).abs() < 1e-9 * paper);
    }

    /// β = 90°: BS→point ⟂ UAV→point; ‖g‖ = sqrt(sin²θ_t + sin²θ_r).
    #[test]
    fn right_bistatic_angle() {
        let p = Params::default();
        let point = [0.0, 0.0];
        let uav = [0.0, p.centre_offset_m()]; // UAV north of the point: ĝ_r = (0, −1)
        let mut q = p.clone();
        q.bs_m = [-2000.0, 0.0]; // BS west: ĝ_t = (1, 0)
        assert!((bistatic_angle_rad(&q, uav, point).to_degrees() - 90.0).abs() < 1e-9);
        let st = sin_incidence_bs(&q, point);
        let sr = p.observation_angle_rad.sin();
        let want = SPEED_OF_LIGHT_MPS / (p.bandwidth_hz * (st * st + sr * sr).sqrt());
        let got = range_resolution_general_m(&q, uav, point);
        assert!((got - want).abs() < 1e-9 * want);
        // flying west (heading π): g = (st, −sr) makes ψ with the track; sin ψ = sr / ‖g‖
        let cell = ResolutionCell::new(&q, uav, [-18.0, 0.0], point);
        let want_psi = (sr / (st * st + sr * sr).sqrt()).asin();
        assert!((cell.psi_rad - want_psi).abs() < 1e-9);
    }

    #[test]
    fn blind_geometry_has_infinite_cross_track_width() {
        let p = Params::default();
        // Track along +x; point is south (right) of the UAV at the broadside centre.
        let uav = [0.0, 0.0];
        let vel = [18.0, 0.0];
        let point = sensing_centre_m(uav, 0.0, p.centre_offset_m());
        // Put the BS so that g is parallel to the track: g = sinθ_t ĝ_t + sinθ_r ĝ_r with
        // ĝ_r = (0,-1) (UAV north of the point). Choose ĝ_t with its y part cancelling.
        let s_r = p.observation_angle_rad.sin();
        // BS far away (sin θ_t ≈ 1): ĝ_t = (cos φ, sin φ) with sin φ = s_r / sin θ_t
        let dist: f64 = 1e5;
        let s_t = dist / dist.hypot(p.bs_height_m);
        let phi = (s_r / s_t).asin();
        let bs = [point[0] - dist * phi.cos(), point[1] - dist * phi.sin()];
        let mut q = p.clone();
        q.bs_m = bs;
        let cell = ResolutionCell::new(&q, uav, vel, point);
        assert!(cell.psi_rad < 1e-6, "psi = {}", cell.psi_rad);
        assert!(cell.cross_track_width_m > 1e5);
        // β is 135° there
        let beta = bistatic_angle_rad(&q, uav, point).to_degrees();
        assert!((beta - 135.0).abs() < 0.01, "beta = {beta}");
    }

    /// Equal range and Doppler widths w: the ellipse's major axis is w / √(1 − cos ψ), the
    /// parallelogram's side w / sin ψ: the major axis is √(1 + cos ψ) times longer (√2 as
    /// ψ → 0).
    #[test]
    fn equal_widths_give_the_ratio_of_the_rhombus() {
        for psi_deg in [90.0f64, 63.0, 51.0, 30.0, 5.0] {
            let (w, s) = (19.0, psi_deg.to_radians().sin());
            let (major, minor) = cell_ellipse_axes_m(w, w, s);
            let c = psi_deg.to_radians().cos();
            assert!(
                (major - w / (1.0 - c).sqrt()).abs() <= 1e-12 * major,
                "{psi_deg}"
            );
            assert!(
                (minor - w / (1.0 + c).sqrt()).abs() <= 1e-12 * minor,
                "{psi_deg}"
            );
            assert!(
                (major / (w / s) - (1.0 + c).sqrt()).abs() <= 1e-12,
                "{psi_deg}"
            );
        }
        assert_eq!(cell_ellipse_axes_m(10.0, 20.0, 0.0).0, f64::INFINITY);
        assert_eq!(
            cell_ellipse_axes_m(f64::INFINITY, 20.0, 0.5).0,
            f64::INFINITY
        );
    }

    proptest! {
        /// The worst width is the longest chord of the −3 dB ellipse, measured in 7200
        /// directions on J = a aᵀ + b bᵀ itself (chord 1/√(uᵀJu) along u), and lies between the
        /// parallelogram's longer side and its long diagonal.
        #[test]
        fn worst_width_is_the_longest_chord(
            r in 0.5f64..50.0, s in 0.5f64..50.0, psi in 0.02f64..1.57,
            turn in 0.0f64..6.3,
        ) {
            let a = Vector2::new(turn.cos(), turn.sin()) / r;
            let b = Vector2::new((turn + psi).cos(), (turn + psi).sin()) / s;
            let j = a * a.transpose() + b * b.transpose();
            let (mut longest, mut shortest) = (0.0f64, f64::INFINITY);
            for k in 0..7200 {
                let t = k as f64 * std::f64::consts::PI / 7200.0;
                let u = Vector2::new(t.cos(), t.sin());
                let chord = 1.0 / (u.transpose() * j * u)[(0, 0)].sqrt();
                longest = longest.max(chord);
                shortest = shortest.min(chord);
            }
            let (major, minor) = cell_ellipse_axes_m(r, s, psi.sin());
            // the sampled maximum is within (π/7200)²/2 of the axis at the ellipse's flattest
            // (relative 1e-7 · (major/minor)²)
            let sampling = 1e-7 * (major / minor).powi(2) + 1e-12;
            prop_assert!(major >= longest * (1.0 - 1e-12), "{major} < {longest}");
            prop_assert!(major <= longest * (1.0 + sampling), "{major} > {longest}");
            prop_assert!((minor - shortest).abs() <= 1e-9 * minor + 1e-7 * shortest);
            let (cross, iso) = (r / psi.sin(), s / psi.sin());
            let diagonal = (cross * cross + iso * iso + 2.0 * cross * iso * psi.cos()).sqrt();
            prop_assert!(major >= cross.max(iso) * (1.0 - 1e-12), "{major} < side");
            prop_assert!(major <= diagonal * (1.0 + 1e-12), "{major} > diagonal {diagonal}");
            // the chord along the major direction is the major axis
            let u = Vector2::from(cell_ellipse_major_direction(
                [turn.cos(), turn.sin()], r, [(turn + psi).cos(), (turn + psi).sin()], s,
            ));
            let chord = 1.0 / (u.transpose() * j * u)[(0, 0)].sqrt();
            prop_assert!((chord / major - 1.0).abs() <= 1e-9, "{chord} along the major direction, {major}");
        }

        /// The worst-width cone of CellLinear holds exactly where the ellipse's major axis is
        /// within d (away from the boundary, and where the range width alone is within d).
        #[test]
        fn the_cone_is_the_worst_width_condition(
            ux in -3000.0f64..3000.0, uy in -3000.0f64..3000.0,
            px in -3000.0f64..3000.0, py in -3000.0f64..3000.0,
            vx in -40.0f64..40.0, vy in -40.0f64..40.0, d in 5.0f64..60.0,
        ) {
            let p = Params::default();
            let (uav, point, vel) = ([ux, uy], [px, py], Vector2::new(vx, vy));
            prop_assume!(vel.norm() > 1.0);
            let cl = CellLinear::new(&p, uav.into(), point.into());
            let cell = ResolutionCell::new(&p, uav, vel.into(), point);
            prop_assume!(cell.range_width_m < d);
            prop_assume!((cell.worst_width_m / d - 1.0).abs() > 1e-6);
            let av = cl.doppler_gradient(vel);
            let h = cl.ellipse_h(&p, d);
            let k = SPEED_OF_LIGHT_MPS / (p.bandwidth_hz * d);
            let cone = cl.cross.dot(&vel).abs() >= k * (av.norm_squared() + h * h).sqrt();
            prop_assert_eq!(cone, cell.worst_width_m <= d, "worst {} d {}", cell.worst_width_m, d);
        }

        /// CellLinear reproduces ResolutionCell: g × d = k·v, and the two width conditions.
        #[test]
        fn cell_linear_matches_cell(
            ux in -3000.0f64..3000.0, uy in -3000.0f64..3000.0,
            px in -3000.0f64..3000.0, py in -3000.0f64..3000.0,
            vx in -40.0f64..40.0, vy in -40.0f64..40.0,
        ) {
            let p = Params::default();
            let (uav, point, vel) = ([ux, uy], [px, py], Vector2::new(vx, vy));
            prop_assume!(vel.norm() > 1.0);
            let cl = CellLinear::new(&p, uav.into(), point.into());
            let d = Vector2::from(doppler_gradient(&p, uav, vel.into(), point));
            let d2 = cl.doppler_gradient(vel);
            prop_assert!((d - d2).norm() <= 1e-9 * (1.0 + d.norm()));
            let gxd = cl.grad.perp(&d);
            prop_assert!((gxd - cl.cross.dot(&vel)).abs() <= 1e-9 * (1.0 + gxd.abs()));
            let cell = ResolutionCell::new(&p, uav, vel.into(), point);
            let iso = cl.grad.norm() / (p.integration_time_s * gxd.abs());
            let cross = SPEED_OF_LIGHT_MPS * d.norm() / (p.bandwidth_hz * gxd.abs());
            prop_assert!((iso - cell.iso_range_width_m).abs() <= 1e-6 * iso);
            prop_assert!((cross - cell.cross_track_width_m).abs() <= 1e-6 * cross);
        }

        /// The general range resolution lies between c/(B(sin θ_t + sin θ_r)) and c/(B|sin θ_t − sin θ_r|).
        #[test]
        fn general_range_resolution_bounds(
            px in -3000.0f64..3000.0, py in -3000.0f64..3000.0,
            ux in -3000.0f64..3000.0, uy in -3000.0f64..3000.0,
        ) {
            let p = Params::default();
            let point = [px, py];
            let uav = [ux, uy];
            let st = sin_incidence_bs(&p, point);
            let dr = distance(&Point2::from(point), &Point2::from(uav));
            let sr = dr / dr.hypot(p.altitude_m);
            let c_b = SPEED_OF_LIGHT_MPS / p.bandwidth_hz;
            let r = range_resolution_general_m(&p, uav, point);
            prop_assert!(r >= c_b / (st + sr) * (1.0 - 1e-9));
            if (st - sr).abs() > 1e-6 {
                prop_assert!(r <= c_b / (st - sr).abs() * (1.0 + 1e-9));
            }
        }

        /// Heading/centre round trip: the centre lies exactly `offset` to the right.
        #[test]
        fn centre_distance_and_side(x in -1e4f64..1e4, y in -1e4f64..1e4, a in 0.0f64..std::f64::consts::TAU, off in 1.0f64..3000.0) {
            let c = sensing_centre_m([x, y], a, off);
            let d = Point2::from(c) - Point2::new(x, y);
            prop_assert!((d.norm() - off).abs() < 1e-6 * off);
            // right side: cross(heading, d) < 0
            prop_assert!(heading_unit(a).perp(&d) < 0.0);
        }
    }
}
