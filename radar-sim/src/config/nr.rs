//! The `[radar.nr]` table: the 5G NR cell that illuminates (TS 38.211 frame, reference signals,
//! PDSCH load and QAM orders) and which of its symbols make the radar's pulses; and the
//! resolution of `[radar]` under it (the PRF, the symbols per pulse, the numerology and the CP
//! follow from the frame).

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::{Modulation, RadarConfig};
use crate::error::{RadarError, Result};
use crate::nr::frame::MAX_PRBS;
use crate::nr::grid::NrGrid;
use crate::nr::illumination::{NrIllumination, PulseSlots};
use crate::nr::signals::{PdschDmrsConfig, Periodicity, PrsConfig, SsbConfig, TrsConfig};
use crate::nr::{CyclicPrefix, FrameStructure, TddPattern, SUBCARRIERS_PER_PRB};

/// Dotted prefix of the table's fields in errors.
pub const NR_PREFIX: &str = "radar.nr";

/// The `[radar.nr]` table. Every key is optional; the defaults are a 60 kHz TDD cell (DDDSU)
/// with SSB, TRS, a comb-4 PRS and a half-loaded PDSCH, pulsed at 100 Hz on the PRS symbols.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NrConfig {
    /// Numerology μ, 0..=3 (Δf = 2^μ · 15 kHz). Default 2.
    pub numerology: u8,
    /// Cyclic prefix, `"normal"` or `"extended"` (μ = 2 only). Default normal.
    pub cyclic_prefix: CyclicPrefix,
    /// Bandwidth in PRBs, 1..=275. Default: as many as fit the band (`radar.bandwidth_hz`, else
    /// the mission's `bandwidth_hz`).
    pub prbs: Option<usize>,
    /// FFT size, a power of two ≥ 128. Default: the least whose 85 % holds the subcarriers.
    pub fft_size: Option<usize>,
    /// TDD pattern, one letter per slot (`D`, `S`, `U`). Default `"DDDSU"`.
    pub tdd_pattern: String,
    /// The special slot's split `"DL:GP:UL"` in symbols. Default `"10:2:2"`.
    pub special_slot: String,
    /// Physical cell id, 0..=1007 (SSB, and the default scrambling ids). Default 1.
    pub cell_id: u16,
    /// Send SS/PBCH blocks. Default true.
    pub ssb: bool,
    /// The SSB's lowest PRB. Default 0.
    pub ssb_first_prb: usize,
    /// SSBs per burst. Default 4.
    pub ssb_count: usize,
    /// SSB burst period, ms. Default 20.
    pub ssb_period_ms: u32,
    /// L_max of the band (TS 38.213 §4.1): 4 or 8 at μ ≤ 2, 64 at μ = 3; with 4, ī_SSB
    /// carries the half-frame bit (TS 38.211 §7.4.1.4.1). Default 8 (μ ≤ 2), 64 (μ = 3).
    pub ssb_l_max: Option<usize>,
    /// Send the TRS. Default true.
    pub trs: bool,
    /// TRS first subcarrier in each PRB, 0..=3. Default 0.
    pub trs_k0: usize,
    /// TRS first symbol, 4..=6 (the second is 4 later). Default 4.
    pub trs_first_symbol: usize,
    /// TRS burst period, slots (two slots per burst). Default 80.
    pub trs_period_slots: u64,
    /// TRS burst's first slot in the period. Default 0.
    pub trs_offset_slot: u64,
    /// Send the PRS. Default true.
    pub prs: bool,
    /// PRS comb size 2, 4, 6 or 12. Default 4.
    pub prs_comb: usize,
    /// PRS symbols per slot (see [`PrsConfig::symbols`]). Default 4.
    pub prs_symbols: usize,
    /// PRS first symbol. Default 10.
    pub prs_start_symbol: usize,
    /// PRS RE offset, 0..comb. Default 0.
    pub prs_re_offset: usize,
    /// PRS period, slots. Default: `pulse_period_slots` (a PRS in every pulse's slot).
    pub prs_period_slots: Option<u64>,
    /// PRS slot within its period. Default: `pulse_slot`.
    pub prs_offset_slot: Option<u64>,
    /// PDSCH DMRS dmrs-TypeA-Position, 2 or 3. Default 2.
    pub dmrs_type_a_position: usize,
    /// PDSCH DMRS additional positions, 0..=3. Default 1.
    pub dmrs_additional_positions: usize,
    /// Share of PRBs that carry a PDSCH in each slot, 0..=1. Default 0.5.
    pub load: f64,
    /// QAM order of PRB n: `modulations[n mod len]`. Default `["qpsk", "qam16", "qam64"]`.
    pub modulations: Vec<Modulation>,
    /// Slots from one pulse to the next (PRF = 1 / (this × slot duration)). Default 40 (100 Hz
    /// at μ = 2).
    pub pulse_period_slots: u64,
    /// The pulse's slot within its period. Default 2 (the third D slot of DDDSU, clear of the
    /// SSB burst).
    pub pulse_slot: u64,
    /// The pulse's first symbol in its slot. Default 10 (the default PRS's first).
    pub pulse_first_symbol: usize,
    /// Symbols per pulse. Default 4 (the default PRS's: its comb-4 staggering covers every
    /// subcarrier once over them).
    pub pulse_symbols: usize,
}

impl Default for NrConfig {
    fn default() -> Self {
        Self {
            numerology: 2,
            cyclic_prefix: CyclicPrefix::Normal,
            prbs: None,
            fft_size: None,
            tdd_pattern: "DDDSU".into(),
            special_slot: "10:2:2".into(),
            cell_id: 1,
            ssb: true,
            ssb_first_prb: 0,
            ssb_count: 4,
            ssb_period_ms: 20,
            ssb_l_max: None,
            trs: true,
            trs_k0: 0,
            trs_first_symbol: 4,
            trs_period_slots: 80,
            trs_offset_slot: 0,
            prs: true,
            prs_comb: 4,
            prs_symbols: 4,
            prs_start_symbol: 10,
            prs_re_offset: 0,
            prs_period_slots: None,
            prs_offset_slot: None,
            dmrs_type_a_position: 2,
            dmrs_additional_positions: 1,
            load: 0.5,
            modulations: vec![Modulation::Qpsk, Modulation::Qam16, Modulation::Qam64],
            pulse_period_slots: 40,
            pulse_slot: 2,
            pulse_first_symbol: 10,
            pulse_symbols: 4,
        }
    }
}

fn field(name: &str) -> String {
    format!("{NR_PREFIX}.{name}")
}

impl NrConfig {
    /// The carrier's PRBs: `prbs`, or as many as fit `bandwidth_hz` (named `bandwidth_field`).
    pub fn resolved_prbs(&self, bandwidth_hz: f64, bandwidth_field: &str) -> Result<usize> {
        if let Some(n) = self.prbs {
            return Ok(n); // FrameStructure::new checks the range
        }
        let prb_hz = SUBCARRIERS_PER_PRB as f64 * 15e3 * f64::from(1u32 << self.numerology.min(3));
        let n = (bandwidth_hz / prb_hz + 1e-9).floor();
        if n.is_nan() || n < 1.0 {
            return Err(RadarError::config(
                bandwidth_field,
                format!(
                    "B = {bandwidth_hz} Hz holds no PRB of {prb_hz} Hz at μ = {}; set \
                     radar.nr.prbs",
                    self.numerology
                ),
            ));
        }
        Ok((n as usize).min(MAX_PRBS))
    }

    /// The cell and its pulses for a carrier of `prbs` PRBs, data seeded by `seed`; errors name
    /// the field.
    pub fn illumination(&self, prbs: usize, seed: u64) -> Result<NrIllumination> {
        let frame_probe = FrameStructure::new(
            self.numerology,
            self.cyclic_prefix,
            prbs,
            self.fft_size,
            TddPattern::all_downlink(),
            NR_PREFIX,
        )?;
        let tdd = TddPattern::parse(
            &self.tdd_pattern,
            &self.special_slot,
            self.numerology,
            frame_probe.symbols_per_slot(),
            &field("tdd_pattern"),
            &field("special_slot"),
        )?;
        let frame = FrameStructure::new(
            self.numerology,
            self.cyclic_prefix,
            prbs,
            self.fft_size,
            tdd,
            NR_PREFIX,
        )?;
        let id = self.cell_id;
        let grid = NrGrid {
            frame,
            ssb: self.ssb.then_some(SsbConfig {
                cell_id: id,
                first_prb: self.ssb_first_prb,
                count: self.ssb_count,
                period_ms: self.ssb_period_ms,
                l_max: self
                    .ssb_l_max
                    .unwrap_or(if self.numerology >= 3 { 64 } else { 8 }),
            }),
            trs: self.trs.then_some(TrsConfig {
                scrambling_id: id,
                k0: self.trs_k0,
                l0: self.trs_first_symbol,
                period: Periodicity {
                    period_slots: self.trs_period_slots,
                    offset_slot: self.trs_offset_slot,
                    length: 2,
                },
            }),
            prs: self.prs.then_some(PrsConfig {
                sequence_id: id,
                comb: self.prs_comb,
                symbols: self.prs_symbols,
                start_symbol: self.prs_start_symbol,
                re_offset: self.prs_re_offset,
                period: Periodicity {
                    period_slots: self.prs_period_slots.unwrap_or(self.pulse_period_slots),
                    offset_slot: self.prs_offset_slot.unwrap_or(self.pulse_slot),
                    length: 1,
                },
            }),
            dmrs: PdschDmrsConfig {
                scrambling_id: id,
                n_scid: 0,
                type_a_position: self.dmrs_type_a_position,
                additional_positions: self.dmrs_additional_positions,
            },
            load: self.load,
            modulations: self.modulations.clone(),
            seed,
        };
        let pulse = PulseSlots {
            period_slots: self.pulse_period_slots,
            slot: self.pulse_slot,
            first_symbol: self.pulse_first_symbol,
            symbols: self.pulse_symbols,
        };
        let ill = NrIllumination::new(grid, pulse, NR_PREFIX)?;
        if self.prs {
            self.check_prs_period()?;
        }
        Ok(ill)
    }

    /// Refuses a PRS period that no cell can configure: TS 37.355's
    /// `dl-PRS-Periodicity-and-ResourceSetSlotOffset` (TS 38.214 5.1.6.5) allows
    /// 2^μ × [`PRS_PERIODS_AT_15KHZ`] slots.
    fn check_prs_period(&self) -> Result<()> {
        let (period, name) = match self.prs_period_slots {
            Some(p) => (p, "prs_period_slots"),
            None => (self.pulse_period_slots, "pulse_period_slots"),
        };
        let scale = 1u64 << self.numerology.min(3);
        if PRS_PERIODS_AT_15KHZ.iter().any(|b| b * scale == period) {
            return Ok(());
        }
        let allowed: Vec<String> = PRS_PERIODS_AT_15KHZ
            .iter()
            .take(10)
            .map(|b| (b * scale).to_string())
            .collect();
        Err(RadarError::config(
            field(name),
            format!(
                "a PRS every {period} slots: TS 38.214 allows a PRS period of {}, … slots at \
                 μ = {} (2^μ × {{4, 5, 8, 10, 16, 20, 32, 40, …}}){}",
                allowed.join(", "),
                self.numerology,
                if self.prs_period_slots.is_none() {
                    "; the PRS period is the pulse period unless radar.nr.prs_period_slots is set"
                } else {
                    ""
                }
            ),
        ))
    }
}

/// The PRS periods of a 15 kHz carrier, slots (TS 37.355 `dl-PRS-Periodicity-and-
/// ResourceSetSlotOffset`); numerology μ multiplies them by 2^μ.
pub const PRS_PERIODS_AT_15KHZ: [u64; 17] = [
    4, 5, 8, 10, 16, 20, 32, 40, 64, 80, 160, 320, 640, 1280, 2560, 5120, 10240,
];

/// A `[radar]` key that the NR frame sets: refused when given with a value other than its
/// default and the frame's.
fn follows_frame(name: &str, given: f64, default: f64, derived: f64, why: &str) -> Result<()> {
    let same = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
    if same(given, default) || same(given, derived) {
        Ok(())
    } else {
        Err(RadarError::config(
            format!("radar.{name}"),
            format!(
                "{given} differs from {derived}, which [radar.nr] sets ({why}); remove \
                 radar.{name} or change radar.nr"
            ),
        ))
    }
}

impl RadarConfig {
    /// The radar as it runs: without `[radar.nr]` itself; with it, the PRF, the symbols per
    /// pulse, the subcarrier spacing, the FFT size, the (ordinary) CP and the band follow from
    /// the cell (a value given for them that is neither its default nor the cell's is refused,
    /// naming the key), and the cell comes back too. `bandwidth_hz` is the mission's band (the
    /// PRBs' default when neither `radar.nr.prbs` nor `radar.bandwidth_hz` is set).
    pub fn resolve(&self, bandwidth_hz: f64) -> Result<(RadarConfig, Option<Arc<NrIllumination>>)> {
        let Some(nr) = &self.nr else {
            return Ok((self.clone(), None));
        };
        let (b, b_field) = match self.bandwidth_hz {
            Some(b) => (b, "radar.bandwidth_hz"),
            None => (bandwidth_hz, "params.bandwidth_hz"),
        };
        let prbs = nr.resolved_prbs(b, b_field)?;
        let ill = nr.illumination(prbs, self.seed)?;
        let f = &ill.grid.frame;
        let d = RadarConfig::default();
        let mut r = self.clone();
        follows_frame(
            "prf_hz",
            self.prf_hz,
            d.prf_hz,
            ill.prf_hz(),
            "one pulse every pulse_period_slots slots",
        )?;
        follows_frame(
            "symbols_per_pulse",
            self.symbols_per_pulse as f64,
            d.symbols_per_pulse as f64,
            nr.pulse_symbols as f64,
            "pulse_symbols",
        )?;
        follows_frame(
            "subcarrier_spacing_hz",
            self.subcarrier_spacing_hz,
            d.subcarrier_spacing_hz,
            f.subcarrier_spacing_hz(),
            "the numerology",
        )?;
        follows_frame(
            "fft_size",
            self.fft_size as f64,
            d.fft_size as f64,
            f.fft_size() as f64,
            "radar.nr.fft_size or the PRBs",
        )?;
        follows_frame(
            "cp_samples",
            self.cp_samples as f64,
            d.cp_samples as f64,
            f.base_cp_samples() as f64,
            "the numerology's cyclic prefix",
        )?;
        r.prf_hz = ill.prf_hz();
        r.symbols_per_pulse = nr.pulse_symbols;
        r.subcarrier_spacing_hz = f.subcarrier_spacing_hz();
        r.fft_size = f.fft_size();
        r.cp_samples = f.base_cp_samples();
        r.bandwidth_hz = Some(f.bandwidth_hz());
        r.validate()?;
        Ok((r, Some(Arc::new(ill))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::SceneFile;
    use crate::nr::Reference;

    fn scene(text: &str) -> Result<SceneFile> {
        SceneFile::from_toml_str(text, "s.toml")
    }

    #[test]
    fn the_default_cell_resolves_to_100_hz_on_the_prs() {
        let s = scene("[radar]\nreference = \"pilots\"\n[radar.nr]\n").unwrap();
        assert_eq!(s.radar.reference, Reference::Pilots);
        let (r, ill) = s.radar.resolve(150e6).unwrap();
        let ill = ill.unwrap();
        assert_eq!(ill.grid.frame.prbs(), 208); // 150 MHz / 720 kHz
        assert_eq!(r.fft_size, 4096);
        assert_eq!(r.cp_samples, 288);
        assert!((r.prf_hz - 100.0).abs() < 1e-9);
        assert_eq!(r.symbols_per_pulse, 4);
        assert!((r.bandwidth_hz.unwrap() - 149.76e6).abs() < 1.0);
        // the scene round-trips through TOML (meta.json keeps it)
        let back = scene(&toml::to_string(&s).unwrap()).unwrap();
        assert_eq!(back, s);
        // without [radar.nr] nothing changes
        let plain = SceneFile::default();
        assert_eq!(plain.radar.resolve(150e6).unwrap().0, plain.radar);
        assert!(!toml::to_string(&plain).unwrap().contains("reference"));
    }

    #[test]
    fn prs_periods_are_those_of_ts_38_214() {
        for mu in 0..=3u8 {
            for p in 1..=20_480u64 {
                let nr = NrConfig {
                    numerology: mu,
                    prs_period_slots: Some(p),
                    ..NrConfig::default()
                };
                // 2^μ × {4, 5, 8, 10, 16, 20, 32, 40, 64, 80, 160, …, 10240}
                let base = p % (1 << mu) == 0 && {
                    let b = p >> mu;
                    [4, 5, 8, 10, 16, 20, 32, 40, 64, 80].contains(&b)
                        || ((160..=10_240).contains(&b)
                            && b % 160 == 0
                            && (b / 160).is_power_of_two())
                };
                assert_eq!(nr.check_prs_period().is_ok(), base, "μ = {mu}, {p} slots");
            }
        }
        // the default pulse period is a PRS period at every numerology
        for mu in 0..=3u8 {
            let nr = NrConfig {
                numerology: mu,
                ..NrConfig::default()
            };
            nr.check_prs_period().unwrap();
        }
    }

    #[test]
    fn bad_values_name_their_field() {
        let f = |t: &str| {
            let s = scene(t)?;
            s.radar.resolve(150e6).map(|_| ())
        };
        for (text, name) in [
            ("[radar.nr]\nnumerology = 4\n", "radar.nr.numerology"),
            (
                "[radar.nr]\nnumerology = 1\ncyclic_prefix = \"extended\"\n",
                "radar.nr.cyclic_prefix",
            ),
            ("[radar.nr]\nprbs = 300\n", "radar.nr.prbs"),
            (
                "[radar.nr]\ntdd_pattern = \"DDXU\"\n",
                "radar.nr.tdd_pattern",
            ),
            (
                "[radar.nr]\nspecial_slot = \"10:2\"\n",
                "radar.nr.special_slot",
            ),
            ("[radar.nr]\nprs_comb = 3\n", "radar.nr.prs_comb"),
            ("[radar.nr]\nload = 1.5\n", "radar.nr.load"),
            ("[radar.nr]\nmodulations = []\n", "radar.nr.modulations"),
            (
                "[radar.nr]\npulse_slot = 4\npulse_period_slots = 5\n",
                "radar.nr.pulse_slot",
            ),
            ("[radar.nr]\npulse_symbols = 0\n", "radar.nr.pulse_symbols"),
            (
                "[radar.nr]\npulse_period_slots = 30\n",
                "radar.nr.pulse_period_slots",
            ),
            (
                "[radar.nr]\nprs_period_slots = 30\n",
                "radar.nr.prs_period_slots",
            ),
            ("[radar.nr]\ncell_id = 2000\n", "radar.nr.cell_id"),
            (
                "[radar.nr]\nssb_first_prb = 200\n",
                "radar.nr.ssb_first_prb",
            ),
            ("[radar]\nprf_hz = 200\n[radar.nr]\n", "radar.prf_hz"),
            ("[radar]\nfft_size = 2048\n[radar.nr]\n", "radar.fft_size"),
            ("[radar]\nreference = \"pilots\"\n", "radar.reference"),
            (
                "[radar]\nreference = \"reconstructed\"\ndirect_path = false\n[radar.nr]\n",
                "radar.reference",
            ),
        ] {
            let e = f(text).unwrap_err().to_string();
            assert!(e.starts_with(&format!("{name}:")), "{text}: {e}");
        }
        let e = scene("[radar]\nreference = \"guess\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("reference"), "{e}");
        let e = scene("[radar.nr]\nprs_kamm = 4\n").unwrap_err().to_string();
        assert!(e.contains("prs_kamm"), "{e}");
        // a value equal to the cell's is accepted
        f("[radar]\nprf_hz = 100\nsymbols_per_pulse = 4\ncp_samples = 288\n[radar.nr]\n").unwrap();
    }
}
