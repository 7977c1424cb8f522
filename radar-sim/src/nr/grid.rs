//! One downlink symbol's resource grid, as the BS sends it and as the UAV knows it.
//!
//! The BS transmits, in downlink symbols only (the TDD pattern's D symbols and the special slot's
//! DL part): the SS/PBCH blocks, the TRS, the PRS, and a PDSCH on the loaded PRBs of each slot
//! (its DMRS, then QAM data of the PRB's order); every other RE is empty. Where two signals claim
//! an RE, the first of SSB, TRS, PRS, PDSCH DMRS, PDSCH wins (the PDSCH is rate-matched around
//! the others). The loaded PRBs of a slot are `round(load × N_RB)` PRBs drawn from the seed and
//! the slot; data bits come from the seed and the symbol, in any order.
//!
//! What the UAV knows ([`Reference`]): `ideal` every value; `pilots` the reference signals' REs
//! (PSS, SSS, PBCH DMRS, TRS, PRS, PDSCH DMRS) with the others masked (zero); `reconstructed` the
//! pilots plus the data and PBCH REs decided hard from its own equalised direct-path recording
//! ([`NrGrid::reconstruct`]).

use rand::seq::index::sample;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::frame::{FrameStructure, SymbolUse};
use super::sequences::{hard_decision, modulate};
use super::signals::{PdschDmrsConfig, PrsConfig, Re, SsbConfig, TrsConfig};
use super::{Complex64, NrError, NrResult, SUBCARRIERS_PER_PRB};
use crate::config::Modulation;

/// What the UAV's processor knows of the transmitted signal.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Reference {
    /// Every transmitted value (today's model).
    #[default]
    Ideal,
    /// The reference signals' REs only; the rest masked out.
    Pilots,
    /// The pilots, and the data demodulated by hard decisions from the direct path.
    Reconstructed,
}

/// The role of one RE in a symbol.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Nothing is sent.
    Empty,
    /// A reference signal: known to the UAV.
    Pilot,
    /// Data of this modulation (PDSCH, or the PBCH in QPSK): unknown to the UAV.
    Data(Modulation),
}

/// One downlink symbol: its N_sc values (unit mean power per occupied RE) and their roles.
#[derive(Debug, Clone, PartialEq)]
pub struct NrSymbol {
    /// Transmitted value of each occupied subcarrier k = 0..12 N_RB.
    pub values: Vec<Complex64>,
    /// What each carries.
    pub roles: Vec<Role>,
}

impl NrSymbol {
    /// The values the UAV knows a priori: pilots kept, the rest zero.
    pub fn pilots(&self) -> Vec<Complex64> {
        self.values
            .iter()
            .zip(&self.roles)
            .map(|(v, r)| {
                if *r == Role::Pilot {
                    *v
                } else {
                    Complex64::default()
                }
            })
            .collect()
    }

    /// A symbol that carries nothing (N_sc subcarriers).
    fn empty(nsc: usize) -> Self {
        Self {
            values: vec![Complex64::default(); nsc],
            roles: vec![Role::Empty; nsc],
        }
    }

    /// Share of subcarriers that carry anything.
    pub fn occupancy(&self) -> f64 {
        let used = self.roles.iter().filter(|r| **r != Role::Empty).count();
        used as f64 / self.roles.len().max(1) as f64
    }
}

/// One slot's reference signals (SSB, TRS, PRS: the order in which they claim REs), its
/// PDSCH DMRS and the symbols that carry it, and its loaded PRBs.
struct SlotRes {
    signals: Vec<Vec<Re>>,
    dmrs_symbols: Vec<usize>,
    dmrs: Vec<Re>,
    prbs: Vec<usize>,
}

/// The cell's downlink: frame, signals, PDSCH load and QAM orders, data seed.
#[derive(Debug, Clone, PartialEq)]
pub struct NrGrid {
    /// Frame structure.
    pub frame: FrameStructure,
    /// SS/PBCH blocks, if sent.
    pub ssb: Option<SsbConfig>,
    /// TRS, if sent.
    pub trs: Option<TrsConfig>,
    /// PRS, if sent.
    pub prs: Option<PrsConfig>,
    /// The PDSCH's DMRS.
    pub dmrs: PdschDmrsConfig,
    /// Share of PRBs that carry a PDSCH in each slot, 0..=1.
    pub load: f64,
    /// QAM order of PRB n: `modulations[n mod len]` (non-empty).
    pub modulations: Vec<Modulation>,
    /// Seed of the scheduling and the data.
    pub seed: u64,
}

impl NrGrid {
    /// Checks the parts against the frame; errors name the field under `prefix`.
    pub fn validate(&self, prefix: &str) -> NrResult<()> {
        if let Some(s) = &self.ssb {
            s.validate(&self.frame, prefix)?;
        }
        if let Some(t) = &self.trs {
            t.validate(&self.frame, prefix)?;
        }
        if let Some(p) = &self.prs {
            p.validate(&self.frame, prefix)?;
        }
        self.dmrs.validate(prefix)?;
        if !(self.load.is_finite() && (0.0..=1.0).contains(&self.load)) {
            return Err(NrError::new(
                format!("{prefix}.load"),
                format!("{} must lie in 0..=1", self.load),
            ));
        }
        if self.modulations.is_empty() {
            return Err(NrError::new(
                format!("{prefix}.modulations"),
                "needs at least one modulation",
            ));
        }
        Ok(())
    }

    /// The PRBs that carry a PDSCH in slot `slot` (ascending).
    pub fn loaded_prbs(&self, slot: u64) -> Vec<usize> {
        let n = self.frame.prbs();
        let count = ((self.load * n as f64).round() as usize).min(n);
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ 0x5C4E_D000_0000_0000);
        rng.set_stream(slot);
        let mut prbs = sample(&mut rng, n, count).into_vec();
        prbs.sort_unstable();
        prbs
    }

    /// The DL symbols of slot `slot` from symbol 0 (the PDSCH's duration).
    fn downlink_symbols(&self, slot: u64) -> usize {
        (0..self.frame.symbols_per_slot())
            .take_while(|&l| self.frame.tdd().symbol_use(slot, l) == SymbolUse::Downlink)
            .count()
    }

    /// Symbol `m` (counted from symbol 0 of frame 0) as the BS sends it.
    pub fn symbol(&self, m: u64) -> NrSymbol {
        self.symbols(m, 1).remove(0)
    }

    /// Symbols `first .. first + count` as the BS sends them ([`Self::symbol`] of each): the
    /// reference signals' REs of each slot are generated once for all its symbols.
    pub fn symbols(&self, first: u64, count: usize) -> Vec<NrSymbol> {
        let sps = self.frame.symbols_per_slot() as u64;
        let end = first + count as u64;
        let mut out = Vec::with_capacity(count);
        let mut m = first;
        while m < end {
            let slot = m / sps;
            let slot_end = ((slot + 1) * sps).min(end);
            let mut res: Option<SlotRes> = None;
            for mm in m..slot_end {
                if self.frame.symbol_use(mm) != SymbolUse::Downlink {
                    out.push(NrSymbol::empty(self.frame.subcarriers()));
                    continue;
                }
                let r = res.get_or_insert_with(|| self.slot_res(slot));
                out.push(self.symbol_in_slot(mm, r));
            }
            m = slot_end;
        }
        out
    }

    /// The reference signals' REs of slot `slot`, in the order they claim REs, and its PDSCH.
    fn slot_res(&self, slot: u64) -> SlotRes {
        let mut signals = Vec::new();
        if let Some(s) = &self.ssb {
            signals.push(s.res_in_slot(&self.frame, slot));
        }
        if let Some(t) = &self.trs {
            signals.push(t.res_in_slot(&self.frame, slot));
        }
        if let Some(p) = &self.prs {
            signals.push(p.res_in_slot(&self.frame, slot));
        }
        let duration = self.downlink_symbols(slot);
        let prbs = self.loaded_prbs(slot);
        let dmrs_symbols = self.dmrs.symbols(duration).unwrap_or_default();
        let dmrs = if dmrs_symbols.is_empty() {
            Vec::new()
        } else {
            self.dmrs.res_in_slot(&self.frame, slot, duration, &prbs)
        };
        SlotRes {
            signals,
            dmrs_symbols,
            dmrs,
            prbs,
        }
    }

    /// Downlink symbol `m` of the slot whose REs are `res`.
    fn symbol_in_slot(&self, m: u64, res: &SlotRes) -> NrSymbol {
        let nsc = self.frame.subcarriers();
        let mut values = vec![Complex64::default(); nsc];
        let mut roles = vec![Role::Empty; nsc];
        let sps = self.frame.symbols_per_slot() as u64;
        let l = (m % sps) as usize;
        let mut data_rng = ChaCha8Rng::seed_from_u64(self.seed ^ 0x0DA7_A000_0000_0000);
        data_rng.set_stream(m);
        let mut put = |res: &[Re], values: &mut [Complex64], roles: &mut [Role]| {
            for re in res.iter().filter(|r| r.l == l && r.k < nsc) {
                if roles[re.k] != Role::Empty {
                    continue;
                }
                if re.kind.is_pilot() {
                    values[re.k] = re.value;
                    roles[re.k] = Role::Pilot;
                } else {
                    let bits = [data_rng.gen::<bool>() as u8, data_rng.gen::<bool>() as u8];
                    values[re.k] = modulate(Modulation::Qpsk, &bits)[0];
                    roles[re.k] = Role::Data(Modulation::Qpsk);
                }
            }
        };
        for sig in &res.signals {
            put(sig, &mut values, &mut roles);
        }
        if res.dmrs_symbols.is_empty() {
            return NrSymbol { values, roles };
        }
        if res.dmrs_symbols.contains(&l) {
            put(&res.dmrs, &mut values, &mut roles);
            return NrSymbol { values, roles }; // no data beside a DMRS (two CDM groups)
        }
        for &n in &res.prbs {
            let modulation = self.modulations[n % self.modulations.len()];
            let q = modulation.bits() as usize;
            for k in SUBCARRIERS_PER_PRB * n..SUBCARRIERS_PER_PRB * (n + 1) {
                if roles[k] != Role::Empty {
                    continue;
                }
                let bits: Vec<u8> = (0..q).map(|_| data_rng.gen::<bool>() as u8).collect();
                values[k] = modulate(modulation, &bits)[0];
                roles[k] = Role::Data(modulation);
            }
        }
        NrSymbol { values, roles }
    }

    /// What the UAV reconstructs of symbol `m` from `equalised`, its own recording of the direct
    /// path divided by the channel (one value per subcarrier): pilots as known, each data RE the
    /// hard decision of its modulation, empty REs zero. A wrong decision is a wrong reference
    /// value.
    pub fn reconstruct(&self, symbol: &NrSymbol, equalised: &[Complex64]) -> Vec<Complex64> {
        symbol
            .roles
            .iter()
            .zip(&symbol.values)
            .zip(equalised)
            .map(|((role, v), y)| match role {
                Role::Empty => Complex64::default(),
                Role::Pilot => *v,
                Role::Data(m) => hard_decision(*m, *y),
            })
            .collect()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::nr::frame::{CyclicPrefix, TddPattern};
    use crate::nr::signals::Periodicity;
    use rand_distr::{Distribution, StandardNormal};

    pub(crate) fn grid(load: f64) -> NrGrid {
        let tdd = TddPattern::parse("DDDSU", "10:2:2", 1, 14, "p", "s").unwrap();
        let frame =
            FrameStructure::new(1, CyclicPrefix::Normal, 52, None, tdd, "radar.nr").unwrap();
        let g = NrGrid {
            frame,
            ssb: Some(SsbConfig {
                cell_id: 7,
                first_prb: 15,
                count: 4,
                period_ms: 20,
                l_max: 8,
            }),
            trs: Some(TrsConfig {
                scrambling_id: 7,
                k0: 0,
                l0: 4,
                period: Periodicity {
                    period_slots: 20,
                    offset_slot: 2,
                    length: 2,
                },
            }),
            prs: Some(PrsConfig {
                sequence_id: 7,
                comb: 4,
                symbols: 4,
                start_symbol: 10,
                re_offset: 0,
                period: Periodicity {
                    period_slots: 5,
                    offset_slot: 2,
                    length: 1,
                },
            }),
            dmrs: PdschDmrsConfig {
                scrambling_id: 7,
                n_scid: 0,
                type_a_position: 2,
                additional_positions: 1,
            },
            load,
            modulations: vec![Modulation::Qpsk, Modulation::Qam16, Modulation::Qam64],
            seed: 3,
        };
        g.validate("radar.nr").unwrap();
        g
    }

    #[test]
    fn only_downlink_symbols_carry_anything() {
        let g = grid(1.0);
        for m in 0..5 * 14 {
            let s = g.symbol(m);
            let dl = g.frame.symbol_use(m) == SymbolUse::Downlink;
            assert_eq!(s.occupancy() > 0.0, dl, "symbol {m}");
        }
        // a full load fills every RE of a plain data symbol, with unit mean power
        let s = g.symbol(14 * 2 + 5);
        assert_eq!(s.occupancy(), 1.0);
        assert_eq!(g.symbol(99), g.symbol(99), "reproducible");
    }

    /// Symbols made a slot at a time are the symbols made one by one, across slot boundaries
    /// and uplink symbols.
    #[test]
    fn symbols_of_a_run_are_the_symbols_one_by_one() {
        let g = grid(0.6);
        for (first, count) in [(0u64, 5usize), (12, 20), (2 * 14 + 9, 6), (4 * 14 + 3, 15)] {
            let run = g.symbols(first, count);
            assert_eq!(run.len(), count);
            for (m, s) in (first..).zip(&run) {
                assert_eq!(*s, g.symbol(m), "symbol {m}");
            }
        }
    }

    #[test]
    fn load_and_modulation_per_prb() {
        let g = grid(0.3);
        let prbs = g.loaded_prbs(2);
        assert_eq!(prbs.len(), 16); // round(0.3 × 52)
        assert_ne!(prbs, g.loaded_prbs(7), "scheduling changes per slot");
        let s = g.symbol(14 * 2 + 5);
        for (k, role) in s.roles.iter().enumerate() {
            let n = k / 12;
            match role {
                Role::Data(m) => {
                    assert!(prbs.contains(&n));
                    assert_eq!(*m, g.modulations[n % 3]);
                }
                Role::Empty => assert!(!prbs.contains(&n)),
                Role::Pilot => {}
            }
        }
        // a DMRS symbol: the DMRS on even subcarriers of the loaded PRBs only
        let d = g.symbol(14 * 2 + 2);
        for (k, role) in d.roles.iter().enumerate() {
            let want = prbs.contains(&(k / 12)) && k % 2 == 0;
            assert_eq!(*role == Role::Pilot, want, "k {k}");
        }
        let empty = NrGrid {
            load: 0.0,
            ..g.clone()
        };
        assert!(empty
            .symbol(14 * 2 + 5)
            .roles
            .iter()
            .all(|r| *r == Role::Empty));
        let bad = NrGrid { load: 1.5, ..g };
        assert_eq!(bad.validate("radar.nr").unwrap_err().field, "radar.nr.load");
    }

    #[test]
    fn signals_land_in_their_symbols() {
        let g = grid(0.0);
        // SSB at symbols 2..6 and 8..12 of slots 0 and 1 (PSS at 2 and 8); TRS at 4 and 8 of
        // slots 2 and 3; PRS at 10..14 of slot 2 (its period is 5 slots)
        let pss = g.symbol(2);
        assert_eq!(pss.roles.iter().filter(|r| **r == Role::Pilot).count(), 127);
        let trs = g.symbol(2 * 14 + 8);
        assert_eq!(
            trs.roles.iter().filter(|r| **r == Role::Pilot).count(),
            3 * 52
        );
        let prs = g.symbol(2 * 14 + 11);
        assert_eq!(
            prs.roles.iter().filter(|r| **r == Role::Pilot).count(),
            624 / 4
        );
        assert!(g.symbol(13).roles.iter().all(|r| *r == Role::Empty));
        assert!(g
            .symbol(3 * 14 + 11)
            .roles
            .iter()
            .all(|r| *r == Role::Empty));
        // the pilots mask keeps exactly the pilots
        let p = pss.pilots();
        for (v, r) in p.iter().zip(&pss.roles) {
            assert_eq!(v.norm() > 0.0, *r == Role::Pilot);
        }
    }

    #[test]
    fn reconstruction_is_exact_at_high_snr_and_errs_at_low() {
        let g = grid(1.0);
        let s = g.symbol(14 * 2 + 5);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut noisy = |sigma: f64| -> Vec<Complex64> {
            s.values
                .iter()
                .map(|v| {
                    let a: f64 = StandardNormal.sample(&mut rng);
                    let b: f64 = StandardNormal.sample(&mut rng);
                    v + Complex64::new(a, b) * sigma
                })
                .collect()
        };
        let clean = g.reconstruct(&s, &noisy(1e-3));
        for (a, b) in clean.iter().zip(&s.values) {
            assert!((a - b).norm() < 1e-12);
        }
        // at 10 dB SNR (σ² = 0.1 per RE) the 64-QAM PRBs err often, the QPSK PRBs rarely
        let rough = g.reconstruct(&s, &noisy((0.05f64).sqrt()));
        let errs = |m: Modulation| {
            let idx: Vec<usize> = (0..s.roles.len())
                .filter(|&k| s.roles[k] == Role::Data(m))
                .collect();
            idx.iter()
                .filter(|&&k| (rough[k] - s.values[k]).norm() > 1e-9)
                .count() as f64
                / idx.len() as f64
        };
        let (q, q64) = (errs(Modulation::Qpsk), errs(Modulation::Qam64));
        assert!(q < 0.01 && q64 > 0.2, "QPSK {q}, 64-QAM {q64}");
    }
}
