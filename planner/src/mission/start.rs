//! The search behind the default start velocity ([`super::Mission::start_velocity_mps`]): the
//! velocity nearest a preferred one from which flying straight on resolves the first landmark
//! slot.

use nalgebra::{Point2, Vector2};

use crate::geometry::{distance, heading_unit, sensing_centre_m, ResolutionCell};

use super::Mission;

/// A computed start velocity kept with its mission: not part of the mission's value (equal
/// missions compare equal whether or not either has computed it; it is not serialized).
#[derive(Debug, Clone, Default)]
pub(super) struct Cache(pub std::sync::OnceLock<[f64; 2]>);

impl PartialEq for Cache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// Coarse grid of the search: speed step, m/s.
const COARSE_SPEED_STEP_MPS: f64 = 0.5;
/// Coarse grid of the search: heading step, rad (1°).
const COARSE_HEADING_STEP_RAD: f64 = std::f64::consts::PI / 180.0;
/// The fine grid around the coarse answer: both steps divided by this.
const REFINE_FACTOR: f64 = 10.0;

/// A search for the velocity nearest `preferred_mps` (Euclidean distance) with its speed in
/// `speed_range_mps` and its heading within a quarter turn of `centre_heading_rad` from which the
/// UAV, flying straight on from the mission's start, has landmark `landmark_m` of slot `t0` in
/// view with its resolution cell within d_min. A grid of 0.5 m/s by 1°, then one of 0.05 m/s by
/// 0.1° over the coarse answer's neighbouring cells: deterministic, about 9 000 cell evaluations.
pub(super) struct StartSearch<'a> {
    pub mission: &'a Mission,
    pub t0: usize,
    pub landmark_m: [f64; 2],
    pub preferred_mps: Vector2<f64>,
    pub speed_range_mps: (f64, f64),
    pub centre_heading_rad: f64,
}

impl StartSearch<'_> {
    /// The nearest resolving velocity, or `None` when the preferred one resolves too (it is the
    /// answer then) or when none on the grid does.
    pub fn nearest_resolving(&self) -> Option<Vector2<f64>> {
        if self.resolves(self.preferred_mps) {
            return None;
        }
        let (lo, hi) = self.speed_range_mps;
        if lo > hi || lo.is_nan() || hi.is_nan() {
            return None;
        }
        let quarter = std::f64::consts::FRAC_PI_2;
        let coarse = self.best_on_grid(
            (lo, hi),
            (
                self.centre_heading_rad - quarter,
                self.centre_heading_rad + quarter,
            ),
            COARSE_SPEED_STEP_MPS,
            COARSE_HEADING_STEP_RAD,
        )?;
        let (speed, heading) = (coarse.norm(), coarse.y.atan2(coarse.x));
        let fine = self.best_on_grid(
            (
                (speed - COARSE_SPEED_STEP_MPS).max(lo),
                (speed + COARSE_SPEED_STEP_MPS).min(hi),
            ),
            (
                heading - COARSE_HEADING_STEP_RAD,
                heading + COARSE_HEADING_STEP_RAD,
            ),
            COARSE_SPEED_STEP_MPS / REFINE_FACTOR,
            COARSE_HEADING_STEP_RAD / REFINE_FACTOR,
        );
        Some(fine.unwrap_or(coarse))
    }

    /// The resolving grid point nearest the preferred velocity over a speed × heading box.
    fn best_on_grid(
        &self,
        speeds_mps: (f64, f64),
        headings_rad: (f64, f64),
        speed_step_mps: f64,
        heading_step_rad: f64,
    ) -> Option<Vector2<f64>> {
        let n_speed = ((speeds_mps.1 - speeds_mps.0) / speed_step_mps).floor() as usize;
        let n_heading = ((headings_rad.1 - headings_rad.0) / heading_step_rad).round() as usize;
        let mut best: Option<(f64, Vector2<f64>)> = None;
        for i in 0..=n_speed {
            let speed = (speeds_mps.0 + i as f64 * speed_step_mps).min(speeds_mps.1);
            for j in 0..=n_heading {
                let v = heading_unit(headings_rad.0 + j as f64 * heading_step_rad) * speed;
                let d = (v - self.preferred_mps).norm();
                if best.is_none_or(|(b, _)| d < b) && self.resolves(v) {
                    best = Some((d, v));
                }
            }
        }
        best.map(|(_, v)| v)
    }

    /// Whether flying straight on from the start at `velocity_mps` keeps the landmark in view
    /// at slot `t0` with its resolution cell within d_min.
    fn resolves(&self, velocity_mps: Vector2<f64>) -> bool {
        let p = self.mission.params();
        let Some(heading) = crate::geometry::heading_rad([0.0, 0.0], velocity_mps.into()) else {
            return false;
        };
        let q = Point2::from(p.start_m) + velocity_mps * (self.t0 as f64 * p.slot_s);
        let centre = sensing_centre_m(q.into(), heading, p.centre_offset_m());
        let in_view = distance(&centre.into(), &self.landmark_m.into()) <= p.sensing_radius_m;
        in_view
            && ResolutionCell::new(p, q.into(), velocity_mps.into(), self.landmark_m).worst_width_m
                <= p.d_min_m
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;
    use crate::landmarks::{LandmarkWindow, LandmarksSpec, Preset};
    use crate::params::Params;

    fn preset_from(start_m: [f64; 2], d_min_m: f64) -> Mission {
        let mut p = Params::default();
        p.start_m = start_m;
        p.d_min_m = d_min_m;
        let spec = LandmarksSpec {
            preset: Some(Preset::Default),
            spacing_m: Some(30.0),
            ..Default::default()
        };
        Mission::new("test", p, &spec).unwrap()
    }

    /// The rule's velocity before any search: least-power speed, the first landmark at the
    /// sensing centre (J h from the start towards it).
    fn sensing_side(m: &Mission) -> Vector2<f64> {
        let p = m.params();
        let model = crate::power::PowerModel::new(p);
        let (speed, _) = model.min_power_in(p.min_speed_mps(), p.max_speed_mps);
        let g = m.target_m(1).unwrap();
        let u = Vector2::new(g[0] - p.start_m[0], g[1] - p.start_m[1]).normalize();
        Vector2::new(-u.y, u.x) * speed
    }

    /// Flying straight on at `v`, slot 1: in view and resolved (checked here from the
    /// geometry's functions, not through the search).
    fn slot_one_resolves(m: &Mission, v: Vector2<f64>) -> bool {
        let p = m.params();
        let g = m.target_m(1).unwrap();
        let q = Point2::from(p.start_m) + v * p.slot_s;
        let heading = v.y.atan2(v.x);
        let c = sensing_centre_m(q.into(), heading, p.centre_offset_m());
        let cell = ResolutionCell::new(p, q.into(), v.into(), g);
        distance(&c.into(), &g.into()) <= p.sensing_radius_m && cell.worst_width_m <= p.d_min_m
    }

    #[test]
    fn the_far_start_gets_the_nearest_velocity_that_resolves_its_first_slot() {
        let m = preset_from([342.0, 940.0], 20.0);
        let preferred = sensing_side(&m);
        assert!(!slot_one_resolves(&m, preferred));
        let v = Vector2::from(m.start_velocity_mps());
        assert!(slot_one_resolves(&m, v), "{v:?}");
        let p = m.params();
        assert!((p.min_speed_mps()..=p.max_speed_mps).contains(&v.norm()));
        // an independent brute force on a grid of 0.1 m/s by 0.2°: no resolving velocity is
        // nearer the preferred one by more than the search's fine grid cell (0.05 m/s by 0.1°)
        let answer = (v - preferred).norm();
        let slack = 0.05 + v.norm() * 0.1f64.to_radians();
        let mut nearest = f64::INFINITY;
        for i in 0..=((p.max_speed_mps - p.min_speed_mps()) / 0.1) as usize {
            let speed = p.min_speed_mps() + 0.1 * i as f64;
            for j in 0..=900 {
                let h = (j as f64 * 0.2 - 90.0).to_radians() + preferred.y.atan2(preferred.x);
                let w = heading_unit(h) * speed;
                if slot_one_resolves(&m, w) {
                    nearest = nearest.min((w - preferred).norm());
                }
            }
        }
        assert!(nearest.is_finite());
        assert!(answer <= nearest + slack, "{answer} against {nearest}");
    }

    #[test]
    fn a_first_slot_that_resolves_on_the_sensing_side_keeps_it() {
        let m = preset_from([342.0, 940.0], 30.0);
        assert!(slot_one_resolves(&m, sensing_side(&m)));
        let v = Vector2::from(m.start_velocity_mps());
        assert!((v - sensing_side(&m)).norm() < 1e-9, "{v:?}");
    }

    #[test]
    fn a_first_slot_that_nothing_resolves_keeps_the_sensing_side() {
        // d_min = 8 m: V_min = 17.7 m/s, and no velocity up to V_m resolves the first slot
        let m = preset_from([342.0, 940.0], 8.0);
        let p = m.params();
        for i in 0..=((p.max_speed_mps - p.min_speed_mps()) / 0.1) as usize {
            let speed = p.min_speed_mps() + 0.1 * i as f64;
            for j in 0..360 {
                let w = heading_unit((j as f64).to_radians()) * speed;
                assert!(!slot_one_resolves(&m, w), "{w:?}");
            }
        }
        let v = Vector2::from(m.start_velocity_mps());
        assert!((v - sensing_side(&m)).norm() < 1e-9, "{v:?}");
    }

    #[test]
    fn a_late_first_window_starts_at_rest_and_a_stated_velocity_is_kept() {
        let spec = LandmarksSpec {
            points: Some(vec![LandmarkWindow {
                x_m: 0.0,
                y_m: 0.0,
                from_s: 10.0,
                to_s: 20.0,
            }]),
            ..Default::default()
        };
        let mut p = Params::default();
        p.horizon_s = 30.0;
        let m = Mission::new("late", p.clone(), &spec).unwrap();
        assert_eq!(m.start_velocity_mps(), [0.0, 0.0]);
        p.start_velocity_mps = Some([3.0, -4.0]);
        let m = Mission::new("stated", p, &spec).unwrap();
        assert_eq!(m.start_velocity_mps(), [3.0, -4.0]);
    }

    #[test]
    fn the_cache_is_not_part_of_the_mission() {
        let a = preset_from([342.0, 940.0], 20.0);
        let b = a.clone();
        let v = a.start_velocity_mps();
        assert_eq!(a, b);
        assert_eq!(b.start_velocity_mps(), v);
        let json = serde_json::to_string(&a).unwrap();
        let c: Mission = serde_json::from_str(&json).unwrap();
        assert_eq!(c, a);
        assert_eq!(c.start_velocity_mps(), v);
    }
}
