//! Rotary-wing propulsion power (paper eq. `speed`, after Zeng et al. 2019) and the pieces the
//! convex schemes use: the induced-power auxiliary variable of eq. (mu) and its SCA surrogates;
//! and its extension to climbing and descending flight ([`PowerModel::power_3d_w`]).

use crate::Params;

/// The propulsion-power model, evaluated at horizontal speed `V` (m/s).
///
/// P(V) = P0 (1 + 3V²/U_tip²) + P1 (sqrt(1 + V⁴/(4 v0⁴)) − V²/(2 v0²))^½ + ½ d_f ρ s A V³.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerModel {
    /// P0, W.
    pub blade_power_w: f64,
    /// U_tip, m/s.
    pub tip_speed_mps: f64,
    /// P1, W.
    pub induced_power_w: f64,
    /// v0, m/s.
    pub induced_velocity_mps: f64,
    /// ½ d_f ρ s A, the coefficient of V³ (W s³/m³).
    pub parasite_coeff: f64,
    /// Weight W = m g of the vehicle, N (the climb power only: [`PowerModel::climb_w`]).
    pub weight_n: f64,
}

impl PowerModel {
    /// The model of a parameter set.
    pub fn new(p: &Params) -> Self {
        Self {
            blade_power_w: p.blade_power_w,
            tip_speed_mps: p.tip_speed_mps,
            induced_power_w: p.induced_power_w,
            induced_velocity_mps: p.induced_velocity_mps,
            parasite_coeff: 0.5
                * p.fuselage_drag_ratio
                * p.air_density_kgpm3
                * p.rotor_solidity
                * p.rotor_disc_area_m2,
            weight_n: p.uav_mass_kg * crate::params::STANDARD_GRAVITY_MPS2,
        }
    }

    /// Coefficient of V² in the blade-profile term, 3 P0 / U_tip² (W s²/m²).
    pub fn blade_quadratic_coeff(&self) -> f64 {
        3.0 * self.blade_power_w / (self.tip_speed_mps * self.tip_speed_mps)
    }

    /// Blade-profile power P0 (1 + 3V²/U_tip²), W.
    pub fn blade_w(&self, speed_mps: f64) -> f64 {
        self.blade_power_w + self.blade_quadratic_coeff() * speed_mps * speed_mps
    }

    /// The dimensionless induced factor ι(V) = (sqrt(1 + V⁴/(4 v0⁴)) − V²/(2 v0²))^½,
    /// evaluated in a form that stays accurate at high speed. It is the `q_t` of eq. (mu).
    pub fn induced_factor(&self, speed_mps: f64) -> f64 {
        let v0 = self.induced_velocity_mps;
        let a = speed_mps * speed_mps / (2.0 * v0 * v0);
        // sqrt(1 + a²) − a = 1 / (sqrt(1 + a²) + a)
        (1.0 / ((1.0 + a * a).sqrt() + a)).sqrt()
    }

    /// Induced power P1 ι(V), W.
    pub fn induced_w(&self, speed_mps: f64) -> f64 {
        self.induced_power_w * self.induced_factor(speed_mps)
    }

    /// Parasite power ½ d_f ρ s A V³, W.
    pub fn parasite_w(&self, speed_mps: f64) -> f64 {
        self.parasite_coeff * speed_mps.powi(3)
    }

    /// Total propulsion power P(V), W.
    pub fn power_w(&self, speed_mps: f64) -> f64 {
        self.blade_w(speed_mps) + self.induced_w(speed_mps) + self.parasite_w(speed_mps)
    }

    /// The extra power of a vertical rate `climb_mps` (v_z, up positive), W:
    /// W v_z when climbing, 0 when descending or level.
    ///
    /// W v_z is the rate at which the vehicle gains potential energy, the work-energy form of the
    /// rotary-wing model in three dimensions (Zeng, Xu, Zhang, IEEE TWC 2019: the energy of a
    /// flight adds m g (h_end − h_start) to ∫ P(V) dt). It is a lower bound of the extra power of
    /// any climb and close to it in forward flight (V ≫ v0, the induced velocity then small);
    /// near hover momentum theory gives less (about W v_z / 2 for v_z ≪ v0, the induced velocity
    /// falling as the climb adds inflow), so there it overstates the cost.
    ///
    /// Descent is given no credit: a multirotor's motors do not recover the potential energy
    /// (the work-energy form's −W |v_z| would be a regenerative brake it does not have), and the
    /// level power is an upper bound of the power in a slow descent (less induced power as the
    /// descent opposes the inflow). Descent rates near v0 (the vortex-ring state) are outside
    /// the model; the default limit `max_descent_mps` = 1 m/s is far below v0 = 5.4 m/s.
    pub fn climb_w(&self, climb_mps: f64) -> f64 {
        self.weight_n * climb_mps.max(0.0)
    }

    /// Propulsion power of flight at horizontal speed `speed_mps` and vertical rate `climb_mps`
    /// (up positive), W: P(V, v_z) = P(V) + W max(v_z, 0) ([`PowerModel::climb_w`] states the
    /// model and its limits). Convex in (V, v_z) where P(V) is, so the convex schemes can use it.
    /// Equal to [`PowerModel::power_w`] in level flight and in descent.
    pub fn power_3d_w(&self, speed_mps: f64, climb_mps: f64) -> f64 {
        self.power_w(speed_mps) + self.climb_w(climb_mps)
    }

    /// Hover power P0 + P1, W.
    pub fn hover_w(&self) -> f64 {
        self.blade_power_w + self.induced_power_w
    }

    /// The paper's convex surrogate P̃ (eq. newpm) at speed `V` and auxiliary value `q`:
    /// P0 + 3P0/U_tip² V² + P1 q + ½ d_f ρ s A V³. Equal to P(V) when q = ι(V).
    pub fn surrogate_w(&self, speed_mps: f64, aux: f64) -> f64 {
        self.blade_w(speed_mps) + self.induced_power_w * aux + self.parasite_w(speed_mps)
    }

    /// The speed of least power and that power, (V*, P(V*)), found by golden-section search
    /// on [0, `upper_mps`] (P is unimodal in V for physical parameters).
    pub fn min_power(&self, upper_mps: f64) -> (f64, f64) {
        let v = golden_min(|v| self.power_w(v), 0.0, upper_mps);
        (v, self.power_w(v))
    }

    /// The speed of least energy per metre, argmin P(V)/V on (0, `upper_mps`], and P(V)/V there (J/m).
    pub fn min_energy_per_metre(&self, upper_mps: f64) -> (f64, f64) {
        let lo = 1e-3 * upper_mps;
        let v = golden_min(|v| self.power_w(v) / v, lo, upper_mps);
        (v, self.power_w(v) / v)
    }

    /// Least power over the admissible speeds [lo, hi]: the floor of any trajectory's mean power.
    pub fn min_power_in(&self, lo_mps: f64, hi_mps: f64) -> (f64, f64) {
        let v = golden_min(|v| self.power_w(v), lo_mps, hi_mps);
        (v, self.power_w(v))
    }
}

/// Tangent lower bound of the convex function x² + y²/v0² at (x0, y0), the right-hand side of
/// eq. (eq.q): returns (constant, d/dx, d/dy) so that the bound is c + gx·x + gy·y.
pub fn eq_q_tangent(aux0: f64, speed0_mps: f64, v0_mps: f64) -> (f64, f64, f64) {
    let inv = 1.0 / (v0_mps * v0_mps);
    // f(x0, y0) + 2 x0 (x − x0) + 2 y0/v0² (y − y0) = −x0² − y0²/v0² + 2 x0 x + 2 y0/v0² y
    (
        -(aux0 * aux0) - speed0_mps * speed0_mps * inv,
        2.0 * aux0,
        2.0 * speed0_mps * inv,
    )
}

/// Golden-section search for the minimiser of a unimodal `f` on [a, b].
pub fn golden_min(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..200 {
        if (b - a).abs() < 1e-12 * (1.0 + a.abs() + b.abs()) {
            break;
        }
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn model() -> PowerModel {
        PowerModel::new(&Params::default())
    }

    #[test]
    fn hover_power_is_p0_plus_p1() {
        let m = model();
        assert!((m.power_w(0.0) - 121.4).abs() < 1e-12);
        assert!((m.hover_w() - 121.4).abs() < 1e-12);
    }

    #[test]
    fn least_power_near_18_1_mps() {
        let (v, p) = model().min_power(100.0);
        assert!((v - 18.1).abs() < 0.1, "V* = {v}");
        assert!((p - 50.3).abs() < 0.1, "P(V*) = {p}");
        // erratum 4 (docs/paper-notes.md): the paper's "≈ 35 m/s" is wrong for Table II.
        assert!(model().power_w(35.0) > p + 10.0);
    }

    #[test]
    fn least_energy_per_metre_near_24_4_mps() {
        let (v, _) = model().min_energy_per_metre(100.0);
        assert!((v - 24.4).abs() < 0.1, "V_me = {v}");
    }

    #[test]
    fn floor_energy_of_default_mission() {
        let (_, p) = model().min_power(50.0);
        let floor = 300.0 * p;
        assert!((floor - 15_090.0).abs() < 20.0, "{floor}");
    }

    #[test]
    fn induced_factor_satisfies_eq_mu() {
        let m = model();
        for v in [0.0, 1.0, 5.4, 10.0, 30.0, 100.0, 1000.0] {
            let q = m.induced_factor(v);
            let lhs = 1.0 / (q * q);
            let rhs = q * q + v * v / (5.4 * 5.4);
            assert!((lhs - rhs).abs() <= 1e-9 * lhs, "V={v}: {lhs} vs {rhs}");
        }
    }

    /// Closed forms of the climb extension: W = m g; level flight and descent cost P(V); a climb
    /// at v_z costs W v_z more.
    #[test]
    fn climb_power_closed_forms() {
        let m = model();
        assert!((m.weight_n - 2.0 * 9.80665).abs() < 1e-12);
        for v in [0.0, 7.07, 18.1, 50.0] {
            assert_eq!(m.power_3d_w(v, 0.0), m.power_w(v));
            assert_eq!(m.power_3d_w(v, -1.0), m.power_w(v));
            // PX4's default climb limit of 3 m/s: 3 × 19.613 = 58.84 W more
            assert!((m.power_3d_w(v, 3.0) - m.power_w(v) - 58.839_9).abs() < 1e-9);
        }
    }

    proptest! {
        /// Over any vertical profile with the horizontal speeds fixed, the energy above level
        /// flight is W times the total height climbed (descents free): a climb from H to H + Δ
        /// costs exactly W Δ whichever rates it takes.
        #[test]
        fn climb_energy_is_weight_times_height_climbed(
            rates in proptest::collection::vec(-1.0f64..3.0, 1..50), slot_s in 0.1f64..2.0,
        ) {
            let m = model();
            let extra: f64 = rates
                .iter()
                .map(|&vz| (m.power_3d_w(18.0, vz) - m.power_w(18.0)) * slot_s)
                .sum();
            let climbed: f64 = rates.iter().map(|&vz| vz.max(0.0) * slot_s).sum();
            prop_assert!((extra - m.weight_n * climbed).abs() <= 1e-9 * (1.0 + extra.abs()));
        }

        /// P(V, v_z) is convex along any segment (midpoint inequality) in the speed range where
        /// P(V) is convex (above the speed of least power) and in v_z everywhere.
        #[test]
        fn power_3d_is_midpoint_convex(
            v1 in 18.2f64..50.0, v2 in 18.2f64..50.0, z1 in -1.0f64..3.0, z2 in -1.0f64..3.0,
        ) {
            let m = model();
            let mid = m.power_3d_w(0.5 * (v1 + v2), 0.5 * (z1 + z2));
            prop_assert!(mid <= 0.5 * (m.power_3d_w(v1, z1) + m.power_3d_w(v2, z2)) + 1e-9);
        }

        /// The tangent of eq. (eq.q) lies below x² + y²/v0² everywhere and touches it at the point.
        #[test]
        fn eq_q_tangent_is_a_global_lower_bound(
            x0 in 0.01f64..2.0, y0 in 0.0f64..60.0, x in 0.0f64..2.0, y in 0.0f64..60.0,
        ) {
            let v0 = 5.4;
            let (c, gx, gy) = eq_q_tangent(x0, y0, v0);
            let f = |x: f64, y: f64| x * x + y * y / (v0 * v0);
            prop_assert!(c + gx * x + gy * y <= f(x, y) + 1e-12);
            prop_assert!((c + gx * x0 + gy * y0 - f(x0, y0)).abs() < 1e-9);
        }

        /// The surrogate equals P(V) at q = ι(V) and exceeds it for any q satisfying (p32).
        #[test]
        fn surrogate_bounds_power(v in 0.0f64..60.0, extra in 0.0f64..1.0) {
            let m = model();
            let q = m.induced_factor(v);
            prop_assert!((m.surrogate_w(v, q) - m.power_w(v)).abs() < 1e-9);
            // any feasible q of 1/q² ≤ q² + V²/v0² is ≥ ι(V)
            let q2 = q + extra;
            prop_assert!(1.0 / (q2 * q2) <= q2 * q2 + v * v / (5.4 * 5.4) + 1e-12);
            prop_assert!(m.surrogate_w(v, q2) >= m.power_w(v) - 1e-9);
        }
    }
}
