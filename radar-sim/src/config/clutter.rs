//! The `[clutter]` table: distributed ground clutter under the objects (constant-γ model), off
//! by default; and its validation. The model itself is [`crate::clutter`].

use serde::{Deserialize, Serialize};

use super::finite;
use crate::error::{RadarError, Result};

/// Most scatterers per resolution cell (`clutter.scatterers_per_cell`).
pub const MAX_SCATTERERS_PER_CELL: f64 = 100.0;

/// Terrain classes with a tabulated constant-γ reflectivity, at 10 GHz, scaled to the carrier by
/// `5 log10(f / 10 GHz)` dB (Barton, "Land clutter models for radar design and analysis",
/// *Proc. IEEE* 73(2), 1985). The table is that of MathWorks' `surfacegamma` (Radar Toolbox),
/// value for value and frequency law included, which takes flatland, farmland and wooded hills
/// from Nathanson, Reilly & Cohen, *Radar Design Principles* (2nd ed., 1999) and woods,
/// metropolitan and rugged mountains from Long, *Radar Reflectivity of Land and Sea* (3rd ed.,
/// 2001).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Terrain {
    /// Flatland: γ = −20 dB (Nathanson).
    Flatland,
    /// Farmland: γ = −15 dB (Nathanson).
    Farmland,
    /// Woods: γ = −15 dB (Long).
    Woods,
    /// Wooded hills: γ = −10 dB (Nathanson).
    WoodedHills,
    /// Metropolitan: γ = 0 dB (Long).
    Metropolitan,
    /// Rugged mountains: γ = 0 dB (Long).
    RuggedMountains,
}

impl Terrain {
    /// γ at 10 GHz, dB (the table above).
    pub fn gamma_db_at_10ghz(self) -> f64 {
        match self {
            Terrain::Flatland => -20.0,
            Terrain::Farmland | Terrain::Woods => -15.0,
            Terrain::WoodedHills => -10.0,
            Terrain::Metropolitan | Terrain::RuggedMountains => 0.0,
        }
    }

    /// γ at carrier frequency `carrier_hz`, dB: Barton's `γ(f) = γ(10 GHz) + 5 log10(f / 10 GHz)`.
    pub fn gamma_db(self, carrier_hz: f64) -> f64 {
        self.gamma_db_at_10ghz() + 5.0 * (carrier_hz / 10e9).log10()
    }
}

/// The `[clutter]` table: distributed ground clutter.
///
/// ```toml
/// [clutter]
/// enabled = true
/// terrain = "farmland"        # or gamma_db = -12.0 (at the carrier)
/// scatterers_per_cell = 16.0
/// seed = 11
/// # half_width_m = 100.0      # default: processing.grid_half_m + the guard band
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ClutterConfig {
    /// Synthesise ground clutter. Default false (no clutter: the objects over a black ground).
    pub enabled: bool,
    /// Terrain class whose tabulated γ is used (exclusive with `gamma_db`). Default farmland.
    pub terrain: Option<Terrain>,
    /// γ at the carrier, dB (exclusive with `terrain`): σ⁰ = γ √(sin ψ_i sin ψ_s).
    pub gamma_db: Option<f64>,
    /// Scatterers per resolution cell (the smallest integrated response area of the run's
    /// looks), ≥ 1. Default 16: a finite lattice leaves a texture common to the looks (their
    /// intensities correlate by about 0.6 / this: 0.15 at 4, 0.03 at 16), which thickens the
    /// multilook image's tail beyond the CFAR's design.
    pub scatterers_per_cell: f64,
    /// Seed of the scatterers' jitter, amplitudes and phases. Default 11.
    pub seed: u64,
    /// Half-width of the square clutter patch around each landmark, m. Default: the image's
    /// `processing.grid_half_m` plus the guard band (`processing.guard_band_m`).
    pub half_width_m: Option<f64>,
}

impl Default for ClutterConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            terrain: None,
            gamma_db: None,
            scatterers_per_cell: 16.0,
            seed: 11,
            half_width_m: None,
        }
    }
}

impl ClutterConfig {
    /// The table equals its defaults (then it is left out of a serialised scene, so that a
    /// scene without clutter serialises as before the table existed).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Checks every value; the error names the first bad field.
    pub fn validate(&self) -> Result<()> {
        if self.terrain.is_some() && self.gamma_db.is_some() {
            return Err(RadarError::config(
                "clutter.gamma_db",
                "give either `terrain` or `gamma_db`, not both",
            ));
        }
        if let Some(g) = self.gamma_db {
            finite("clutter.gamma_db", g)?;
            if !(-60.0..=20.0).contains(&g) {
                return Err(RadarError::config(
                    "clutter.gamma_db",
                    format!("{g} dB: must lie in [−60, 20] dB (measured land γ spans about −25 to 0 dB)"),
                ));
            }
        }
        let k = self.scatterers_per_cell;
        finite("clutter.scatterers_per_cell", k)?;
        if !(1.0..=MAX_SCATTERERS_PER_CELL).contains(&k) {
            return Err(RadarError::config(
                "clutter.scatterers_per_cell",
                format!("{k}: must lie in [1, {MAX_SCATTERERS_PER_CELL}]"),
            ));
        }
        if let Some(h) = self.half_width_m {
            finite("clutter.half_width_m", h)?;
            if h <= 0.0 {
                return Err(RadarError::config(
                    "clutter.half_width_m",
                    format!("{h} must be > 0"),
                ));
            }
        }
        Ok(())
    }

    /// γ (linear) at carrier `carrier_hz`: `gamma_db` as given, or the terrain's (farmland by
    /// default) scaled to the carrier.
    pub fn gamma_linear(&self, carrier_hz: f64) -> f64 {
        let db = self.gamma_db.unwrap_or_else(|| {
            self.terrain
                .unwrap_or(Terrain::Farmland)
                .gamma_db(carrier_hz)
        });
        10f64.powf(db / 10.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_off_and_valid() {
        let c = ClutterConfig::default();
        assert!(!c.enabled);
        assert!(c.is_default());
        c.validate().unwrap();
        // farmland at 10 GHz: −15 dB; at 3.5 GHz: −15 + 5 log10(0.35) = −17.28 dB
        assert!((10.0 * c.gamma_linear(10e9).log10() + 15.0).abs() < 1e-9);
        assert!((10.0 * c.gamma_linear(3.5e9).log10() + 17.2798).abs() < 1e-3);
    }

    #[test]
    fn terrain_table_is_surfacegamma_s() {
        // MathWorks' surfacegamma at 10 GHz, and its law γ0 + 5 log10(f / 10 GHz): at 1 GHz
        // every class is 5 dB lower, at 3 GHz 2.6 dB lower.
        let table = [
            (Terrain::Flatland, -20.0),
            (Terrain::Farmland, -15.0),
            (Terrain::Woods, -15.0),
            (Terrain::WoodedHills, -10.0),
            (Terrain::Metropolitan, 0.0),
            (Terrain::RuggedMountains, 0.0),
        ];
        for (t, db) in table {
            assert_eq!(t.gamma_db_at_10ghz(), db, "{t:?}");
            assert!((t.gamma_db(10e9) - db).abs() < 1e-12, "{t:?}");
            assert!((t.gamma_db(1e9) - (db - 5.0)).abs() < 1e-12, "{t:?}");
            assert!((t.gamma_db(3e9) - (db - 2.6144)).abs() < 1e-4, "{t:?}");
        }
        // the terrain names a scene file uses
        let names: Vec<String> = table
            .iter()
            .map(|(t, _)| serde_json::to_string(t).unwrap())
            .collect();
        assert_eq!(
            names,
            [
                "\"flatland\"",
                "\"farmland\"",
                "\"woods\"",
                "\"wooded-hills\"",
                "\"metropolitan\"",
                "\"rugged-mountains\""
            ]
        );
    }

    #[test]
    fn bad_values_name_their_field() {
        let cases: [(ClutterConfig, &str); 6] = [
            (
                ClutterConfig {
                    terrain: Some(Terrain::Woods),
                    gamma_db: Some(-10.0),
                    ..Default::default()
                },
                "clutter.gamma_db",
            ),
            (
                ClutterConfig {
                    gamma_db: Some(f64::NAN),
                    ..Default::default()
                },
                "clutter.gamma_db",
            ),
            (
                ClutterConfig {
                    gamma_db: Some(40.0),
                    ..Default::default()
                },
                "clutter.gamma_db",
            ),
            (
                ClutterConfig {
                    scatterers_per_cell: 0.5,
                    ..Default::default()
                },
                "clutter.scatterers_per_cell",
            ),
            (
                ClutterConfig {
                    scatterers_per_cell: f64::INFINITY,
                    ..Default::default()
                },
                "clutter.scatterers_per_cell",
            ),
            (
                ClutterConfig {
                    half_width_m: Some(-3.0),
                    ..Default::default()
                },
                "clutter.half_width_m",
            ),
        ];
        for (c, field) in cases {
            let e = c.validate().unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        }
    }
}
