//! The ground truth: objects of a homogeneous Poisson point process in a disk (optionally a
//! hard-core version with a least separation, built by sequential rejection), plus the
//! mission's landmarks. Ground is z = 0.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Poisson};
use serde::{Deserialize, Serialize};

use crate::config::ObjectsConfig;
use crate::error::{RadarError, Result};

/// One point scatterer on the ground.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SceneObject {
    /// 0-based id (landmarks first, in schedule order, when included).
    pub id: usize,
    /// Ground x, m.
    pub x_m: f64,
    /// Ground y, m.
    pub y_m: f64,
    /// Radar cross-section, m².
    pub rcs_m2: f64,
    /// Reflection phase, rad.
    pub phase_rad: f64,
    /// The mission's landmark index, if this object is a landmark.
    pub landmark: Option<usize>,
}

impl SceneObject {
    /// Ground position (x, y), m.
    pub fn pos_m(&self) -> [f64; 2] {
        [self.x_m, self.y_m]
    }
}

/// The centre of the bounding box of `points` (the origin if there are none).
pub fn bbox_centre(points: &[[f64; 2]]) -> [f64; 2] {
    if points.is_empty() {
        return [0.0, 0.0];
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0]
}

/// Builds the scene: landmarks (if `include_landmarks`) then the random objects.
/// `default_separation_m` is used when the config gives no `min_separation_m` (the mission's d_min).
pub fn generate(
    cfg: &ObjectsConfig,
    landmarks_m: &[[f64; 2]],
    default_separation_m: f64,
) -> Result<Vec<SceneObject>> {
    cfg.validate()?;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let centre = cfg.center_m.unwrap_or_else(|| bbox_centre(landmarks_m));
    let sep = cfg.min_separation_m.unwrap_or(default_separation_m);
    let mut out: Vec<SceneObject> = Vec::new();
    if cfg.include_landmarks {
        for (i, p) in landmarks_m.iter().enumerate() {
            out.push(SceneObject {
                id: out.len(),
                x_m: p[0],
                y_m: p[1],
                rcs_m2: cfg.landmark_rcs_m2,
                phase_rad: rng.gen_range(0.0..std::f64::consts::TAU),
                landmark: Some(i),
            });
        }
    }
    let r = cfg.radius_m;
    let n = match (cfg.count, cfg.intensity_per_km2) {
        (Some(n), _) => n,
        (None, Some(_)) => {
            // validate() bounds the mean by MAX_OBJECTS
            let mean = cfg.mean_poisson_count().unwrap_or(0.0);
            if mean <= 0.0 {
                0
            } else {
                let p = Poisson::new(mean)
                    .map_err(|e| RadarError::config("objects.intensity_per_km2", e.to_string()))?;
                p.sample(&mut rng) as usize
            }
        }
        (None, None) => 40,
    };
    // Sequential rejection: a candidate closer than `sep` to any placed object is redrawn.
    let max_tries = 2000usize;
    for k in 0..n {
        let mut placed = false;
        for _ in 0..max_tries {
            let rho = r * rng.gen::<f64>().sqrt();
            let phi = rng.gen_range(0.0..std::f64::consts::TAU);
            let p = [centre[0] + rho * phi.cos(), centre[1] + rho * phi.sin()];
            let ok = sep <= 0.0
                || out
                    .iter()
                    .all(|o| (o.x_m - p[0]).hypot(o.y_m - p[1]) >= sep);
            if ok {
                let spread = if cfg.rcs_spread_db > 0.0 {
                    rng.gen_range(-cfg.rcs_spread_db..=cfg.rcs_spread_db)
                } else {
                    0.0
                };
                out.push(SceneObject {
                    id: out.len(),
                    x_m: p[0],
                    y_m: p[1],
                    rcs_m2: cfg.rcs_m2 * 10f64.powf(spread / 10.0),
                    phase_rad: rng.gen_range(0.0..std::f64::consts::TAU),
                    landmark: None,
                });
                placed = true;
                break;
            }
        }
        if !placed {
            return Err(RadarError::config(
                "objects.min_separation_m",
                format!(
                    "could place only {k} of {n} objects {sep} m apart in a disk of radius {r} m"
                ),
            ));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn landmarks_first_then_objects_in_disk() {
        let cfg = ObjectsConfig {
            count: Some(50),
            radius_m: 200.0,
            center_m: Some([10.0, -5.0]),
            ..Default::default()
        };
        let lm = [[0.0, 0.0], [0.0, 30.0]];
        let s = generate(&cfg, &lm, 20.0).unwrap();
        assert_eq!(s.len(), 52);
        assert_eq!(s[1].landmark, Some(1));
        for o in &s[2..] {
            assert!((o.x_m - 10.0).hypot(o.y_m + 5.0) <= 200.0 + 1e-9);
        }
        assert_eq!(s, generate(&cfg, &lm, 20.0).unwrap());
    }

    #[test]
    fn impossible_separation_is_a_named_error() {
        let cfg = ObjectsConfig {
            count: Some(500),
            radius_m: 50.0,
            ..Default::default()
        };
        let e = generate(&cfg, &[], 20.0).unwrap_err().to_string();
        assert!(e.contains("objects.min_separation_m"), "{e}");
    }

    #[test]
    fn poisson_count_mean() {
        // λ = 100 /km², R = 500 m: mean 78.5 objects; average over seeds.
        let mut total = 0usize;
        for seed in 0..40 {
            let cfg = ObjectsConfig {
                intensity_per_km2: Some(100.0),
                radius_m: 500.0,
                seed,
                min_separation_m: Some(0.0),
                include_landmarks: false,
                ..Default::default()
            };
            total += generate(&cfg, &[], 0.0).unwrap().len();
        }
        let mean = total as f64 / 40.0;
        assert!((mean - 78.54).abs() < 4.0, "{mean}");
    }

    proptest! {
        #[test]
        fn separation_holds(seed in 0u64..1000, n in 1usize..40, sep in 0.0f64..25.0) {
            let cfg = ObjectsConfig {
                count: Some(n), radius_m: 400.0, seed, min_separation_m: Some(sep),
                ..Default::default()
            };
            let s = generate(&cfg, &[[0.0, 0.0]], 20.0).unwrap();
            for (i, a) in s.iter().enumerate() {
                for b in &s[i + 1..] {
                    prop_assert!((a.x_m - b.x_m).hypot(a.y_m - b.y_m) >= sep);
                }
            }
        }
    }
}
