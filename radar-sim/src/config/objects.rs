//! The `[objects]` table: the random scene's objects and their validation.

use serde::{Deserialize, Serialize};

use super::{finite, non_negative, positive, MAX_OBJECTS};
use crate::error::{RadarError, Result};

/// The `[objects]` table: the random scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ObjectsConfig {
    /// Fixed number of objects (exclusive with `intensity_per_km2`). Default 40.
    pub count: Option<usize>,
    /// Intensity of the Poisson process, objects per km² (exclusive with `count`).
    pub intensity_per_km2: Option<f64>,
    /// Radius R of the disk, m. Default 300.
    pub radius_m: f64,
    /// Centre of the disk (x, y), m. Default: the centre of the landmarks' bounding box.
    pub center_m: Option<[f64; 2]>,
    /// Seed of the object process (positions, RCS spread, reflection phases). Default 1.
    pub seed: u64,
    /// Least distance between two objects (and between an object and a landmark), m.
    /// Default: the mission's d_min. 0 gives a plain Poisson process.
    pub min_separation_m: Option<f64>,
    /// Radar cross-section of each object, m². Default 10.
    pub rcs_m2: f64,
    /// Objects' RCS drawn uniformly in dB within ± this spread around `rcs_m2`. Default 0.
    pub rcs_spread_db: f64,
    /// Add the mission's landmarks as objects. Default true.
    pub include_landmarks: bool,
    /// RCS of a landmark object, m². Default 10.
    pub landmark_rcs_m2: f64,
}

impl Default for ObjectsConfig {
    fn default() -> Self {
        Self {
            count: None,
            intensity_per_km2: None,
            radius_m: 300.0,
            center_m: None,
            seed: 1,
            min_separation_m: None,
            rcs_m2: 10.0,
            rcs_spread_db: 0.0,
            include_landmarks: true,
            landmark_rcs_m2: 10.0,
        }
    }
}

impl ObjectsConfig {
    /// Checks every value; the error names the first bad field.
    pub fn validate(&self) -> Result<()> {
        if self.count.is_some() && self.intensity_per_km2.is_some() {
            return Err(RadarError::config(
                "objects.count",
                "give either `count` or `intensity_per_km2`, not both",
            ));
        }
        if let Some(i) = self.intensity_per_km2 {
            non_negative("objects.intensity_per_km2", i)?;
        }
        if let Some(n) = self.count {
            if n > MAX_OBJECTS {
                return Err(RadarError::config(
                    "objects.count",
                    format!("{n} objects: at most {MAX_OBJECTS}"),
                ));
            }
        }
        positive("objects.radius_m", self.radius_m)?;
        if let Some(mean) = self.mean_poisson_count() {
            if mean > MAX_OBJECTS as f64 {
                return Err(RadarError::config(
                    "objects.intensity_per_km2",
                    format!(
                        "gives {mean:.0} objects on average in a disk of radius {} m (at most {MAX_OBJECTS})",
                        self.radius_m
                    ),
                ));
            }
        }
        if let Some(c) = self.center_m {
            finite("objects.center_m[0]", c[0])?;
            finite("objects.center_m[1]", c[1])?;
        }
        if let Some(d) = self.min_separation_m {
            non_negative("objects.min_separation_m", d)?;
        }
        positive("objects.rcs_m2", self.rcs_m2)?;
        non_negative("objects.rcs_spread_db", self.rcs_spread_db)?;
        positive("objects.landmark_rcs_m2", self.landmark_rcs_m2)?;
        Ok(())
    }

    /// Mean number of Poisson objects, λ π R² (`None` when `count` fixes it or no intensity is
    /// given).
    pub fn mean_poisson_count(&self) -> Option<f64> {
        match (self.count, self.intensity_per_km2) {
            (None, Some(lambda)) => {
                Some(lambda * std::f64::consts::PI * self.radius_m * self.radius_m / 1e6)
            }
            _ => None,
        }
    }
}
