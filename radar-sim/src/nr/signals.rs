//! The downlink reference signals at their resource elements (TS 38.211 §7.4): the SS/PBCH block
//! (PSS, SSS, PBCH DMRS and the PBCH's own REs, §7.4.3.1), the CSI-RS for tracking (TRS: one
//! port, density 3, §7.4.1.5), the PRS (§7.4.1.7) and the PDSCH DMRS (type 1, port 1000,
//! §7.4.1.1). Subcarriers `k` count from CRB 0 (the carrier's lowest subcarrier); `l` is the
//! symbol within the slot. Values have unit power (β = 1).

use rustfft::num_complex::Complex64;

use super::frame::{FrameStructure, SymbolUse};
use super::sequences::{
    check_cell_id, csi_rs_c_init, pbch_dmrs_c_init, pdsch_dmrs_c_init, prs_c_init, pss,
    qpsk_sequence, sss, SYNC_LENGTH,
};
use super::{NrError, NrResult, SUBCARRIERS_PER_PRB};

/// What a resource element carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ReKind {
    /// Primary synchronisation signal.
    Pss,
    /// Secondary synchronisation signal.
    Sss,
    /// DMRS of the PBCH.
    PbchDmrs,
    /// PBCH data (the MIB: not a reference signal).
    Pbch,
    /// CSI-RS for tracking.
    Trs,
    /// Positioning reference signal.
    Prs,
    /// DMRS of the PDSCH.
    PdschDmrs,
}

impl ReKind {
    /// Whether the UAV knows the value a priori (a reference signal, not data).
    pub fn is_pilot(self) -> bool {
        !matches!(self, ReKind::Pbch)
    }
}

/// One resource element.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Re {
    /// Subcarrier from CRB 0.
    pub k: usize,
    /// Symbol within the slot.
    pub l: usize,
    /// What it carries.
    pub kind: ReKind,
    /// Its value (0 for [`ReKind::Pbch`], whose data the grid fills in).
    pub value: Complex64,
}

/// Subcarriers of an SS/PBCH block, 240 (20 PRBs).
pub const SSB_SUBCARRIERS: usize = 240;

/// The SS/PBCH block of cell `cell_id` with index ī_SSB = `i_ssb_bar` at subcarrier offset 0 and
/// symbol offset 0 (Table 7.4.3.1-1): PSS on symbol 0 and SSS on symbol 2 at k = 56..=182, the
/// PBCH DMRS at k = ν, ν + 4, … (ν = N_ID^cell mod 4) on symbols 1 and 3 and on symbol 2 below
/// k = 48 and from k = 192, the PBCH on the other REs of symbols 1–3; the REs of symbols 0 and 2
/// around the PSS and SSS are empty. The DMRS takes r(0..144) in order of k, then l.
pub fn ssb(cell_id: u16, i_ssb_bar: u8) -> NrResult<Vec<Re>> {
    check_cell_id(cell_id, "radar.nr.cell_id")?;
    if i_ssb_bar > 7 {
        return Err(NrError::new(
            "i_ssb_bar",
            format!("{i_ssb_bar} must lie in 0..=7"),
        ));
    }
    let mut out = Vec::with_capacity(4 * SSB_SUBCARRIERS);
    for (l, d, kind) in [
        (0, pss(cell_id)?, ReKind::Pss),
        (2, sss(cell_id)?, ReKind::Sss),
    ] {
        out.extend(d.iter().enumerate().map(|(n, &v)| Re {
            k: 56 + n,
            l,
            kind,
            value: Complex64::new(f64::from(v), 0.0),
        }));
    }
    let dmrs = qpsk_sequence(pbch_dmrs_c_init(cell_id, i_ssb_bar), 144);
    let nu = usize::from(cell_id % 4);
    let mut r = dmrs.iter();
    for l in 1..=3 {
        for k in 0..SSB_SUBCARRIERS {
            if l == 2 && (48..192).contains(&k) {
                continue;
            }
            if k % 4 == nu {
                let value = r.next().copied().unwrap_or_default();
                out.push(Re {
                    k,
                    l,
                    kind: ReKind::PbchDmrs,
                    value,
                });
            } else {
                out.push(Re {
                    k,
                    l,
                    kind: ReKind::Pbch,
                    value: Complex64::default(),
                });
            }
        }
    }
    debug_assert_eq!(out.len(), 2 * SYNC_LENGTH + 432 + 144);
    Ok(out)
}

/// The first symbols of the SS/PBCH block candidates in a half frame (TS 38.213 §4.1), in the
/// carrier's numerology: Case A {2, 8} + 14n (μ = 0, n = 0..4), Case C {2, 8} + 14n (μ = 1,
/// n = 0..4), Case D {4, 8, 16, 20} + 28n (μ = 3, n ∈ {0..3, 5..8, 10..13, 15..18}); μ = 2 has no
/// SSB numerology in the standard and takes Case C's pattern (n = 0..4).
pub fn ssb_candidate_symbols(numerology: u8) -> Vec<usize> {
    match numerology {
        3 => [0usize, 1, 2, 3, 5, 6, 7, 8, 10, 11, 12, 13, 15, 16, 17, 18]
            .iter()
            .flat_map(|n| [4, 8, 16, 20].map(|s| s + 28 * n))
            .collect(),
        _ => (0..4).flat_map(|n| [2, 8].map(|s| s + 14 * n)).collect(),
    }
}

/// Where and how often the cell sends SS/PBCH blocks.
#[derive(Debug, Clone, PartialEq)]
pub struct SsbConfig {
    /// Physical cell id N_ID^cell, 0..=1007.
    pub cell_id: u16,
    /// The block's lowest PRB (its 20 PRBs must fit the carrier).
    pub first_prb: usize,
    /// Blocks per burst: the first `count` candidates of [`ssb_candidate_symbols`].
    pub count: usize,
    /// Burst period, ms: 5, 10, 20, 40, 80 or 160 (the burst is in the first half frame of
    /// its period: with 5 ms, every half frame has one).
    pub period_ms: u32,
    /// L_max, the most SSBs per half frame of the band (TS 38.213 §4.1): 4 or 8 at μ ≤ 2
    /// (Cases A and C), 64 at μ = 3 (Case D). It sets ī_SSB (TS 38.211 §7.4.1.4.1).
    pub l_max: usize,
}

/// ī_SSB of block `i_ssb` in half frame `n_hf` (0 or 1) for `l_max` (TS 38.211 §7.4.1.4.1):
/// i_SSB + 4 n_hf for L_max = 4, else the three least significant bits of i_SSB.
pub fn i_ssb_bar(i_ssb: usize, n_hf: usize, l_max: usize) -> u8 {
    if l_max == 4 {
        (i_ssb % 4 + 4 * (n_hf % 2)) as u8
    } else {
        (i_ssb % 8) as u8
    }
}

impl SsbConfig {
    /// Checks the values against `frame`; errors name the field under `prefix`.
    pub fn validate(&self, frame: &FrameStructure, prefix: &str) -> NrResult<()> {
        check_cell_id(self.cell_id, &format!("{prefix}.cell_id"))?;
        if self.first_prb + 20 > frame.prbs() {
            return Err(NrError::new(
                format!("{prefix}.ssb_first_prb"),
                format!(
                    "the block's 20 PRBs from PRB {} do not fit the carrier's {}",
                    self.first_prb,
                    frame.prbs()
                ),
            ));
        }
        let mu = frame.numerology();
        let l_max_ok = if mu == 3 {
            self.l_max == 64
        } else {
            self.l_max == 4 || self.l_max == 8
        };
        if !l_max_ok {
            return Err(NrError::new(
                format!("{prefix}.ssb_l_max"),
                format!(
                    "{} at μ = {mu}: TS 38.213 §4.1 gives L_max = 4 or 8 for Cases A and C \
                     (μ ≤ 2), 64 for Case D (μ = 3)",
                    self.l_max
                ),
            ));
        }
        let max = ssb_candidate_symbols(mu).len().min(self.l_max);
        if self.count == 0 || self.count > max {
            return Err(NrError::new(
                format!("{prefix}.ssb_count"),
                format!(
                    "{} must lie in 1..={max} at μ = {}",
                    self.count,
                    frame.numerology()
                ),
            ));
        }
        if ![5, 10, 20, 40, 80, 160].contains(&self.period_ms) {
            return Err(NrError::new(
                format!("{prefix}.ssb_period_ms"),
                format!("{} must be one of 5, 10, 20, 40, 80, 160", self.period_ms),
            ));
        }
        Ok(())
    }

    /// The REs of every block in slot `slot` (counted from slot 0 of frame 0).
    pub fn res_in_slot(&self, frame: &FrameStructure, slot: u64) -> Vec<Re> {
        let sps = frame.symbols_per_slot() as u64;
        let slots_per_period = u64::from(self.period_ms) * frame.slots_per_subframe() as u64;
        let in_period = slot % slots_per_period;
        let first = in_period * sps; // symbol of the half frame the burst occupies
        let slots_per_frame = frame.slots_per_frame() as u64;
        let n_hf = ((slot % slots_per_frame) * 2 / slots_per_frame) as usize;
        let k0 = self.first_prb * SUBCARRIERS_PER_PRB;
        let mut out = Vec::new();
        for (i, &s) in ssb_candidate_symbols(frame.numerology())
            .iter()
            .take(self.count)
            .enumerate()
        {
            let s = s as u64;
            if s + 4 <= first || s >= first + sps {
                continue;
            }
            let Ok(block) = ssb(self.cell_id, i_ssb_bar(i, n_hf, self.l_max)) else {
                continue;
            };
            for re in block {
                let l = s + re.l as u64;
                if (first..first + sps).contains(&l) {
                    out.push(Re {
                        k: re.k + k0,
                        l: (l - first) as usize,
                        ..re
                    });
                }
            }
        }
        out
    }
}

/// A periodic burst of slots: `length` consecutive slots every `period_slots`, from slot
/// `offset_slot` (slots counted from slot 0 of frame 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Periodicity {
    /// Period, slots.
    pub period_slots: u64,
    /// First slot of the burst within the period.
    pub offset_slot: u64,
    /// Consecutive slots per burst.
    pub length: u64,
}

impl Periodicity {
    /// Whether slot `slot` is in a burst.
    pub fn contains(&self, slot: u64) -> bool {
        let p = self.period_slots.max(1);
        (slot % p + p - self.offset_slot % p) % p < self.length
    }

    /// Refuses a burst that puts one of `symbols` on a symbol the TDD pattern does not make
    /// downlink: TS 38.213 §11.1, no PDSCH, CSI-RS or DL PRS in symbols that
    /// tdd-UL-DL-ConfigurationCommon makes uplink (the guard symbols are silent in this model).
    /// The TDD period's worth of bursts covers every case. Errors name `field`.
    fn check_downlink(
        &self,
        frame: &FrameStructure,
        symbols: &[usize],
        what: &str,
        field: &str,
    ) -> NrResult<()> {
        let tdd = frame.tdd();
        for q in 0..tdd.slots().len() as u64 {
            for j in 0..self.length {
                let slot = self.offset_slot + q * self.period_slots + j;
                if let Some(&l) = symbols
                    .iter()
                    .find(|&&l| tdd.symbol_use(slot, l) != SymbolUse::Downlink)
                {
                    return Err(NrError::new(
                        field,
                        format!(
                            "the {what} falls on symbol {l} of slot {slot}, which the TDD \
                             pattern does not make downlink: TS 38.213 §11.1 sends no {what} \
                             in uplink symbols (choose its period, offset and symbols so that \
                             it stays in downlink symbols)"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    fn validate(&self, field: &str) -> NrResult<()> {
        if self.period_slots == 0 || self.offset_slot >= self.period_slots {
            return Err(NrError::new(
                field,
                format!(
                    "period {} slots and offset {} must satisfy 0 ≤ offset < period",
                    self.period_slots, self.offset_slot
                ),
            ));
        }
        if self.length == 0 || self.length > self.period_slots {
            return Err(NrError::new(
                field,
                format!("{} slots per burst must lie in 1..=period", self.length),
            ));
        }
        Ok(())
    }
}

/// The CSI-RS for tracking (TRS): one port, density ρ = 3, no CDM (Table 7.4.1.5.3-1 row 1):
/// REs k0, k0 + 4, k0 + 8 of every PRB on symbols l0 and l0 + 4 of each slot of a two-slot burst
/// (TS 38.214 §5.1.6.1.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TrsConfig {
    /// Scrambling id n_ID, 0..=1023.
    pub scrambling_id: u16,
    /// First subcarrier k0 in each PRB, 0..=3.
    pub k0: usize,
    /// First symbol l0: 4, 5 or 6 (the second is l0 + 4).
    pub l0: usize,
    /// When it is sent (two consecutive slots per burst).
    pub period: Periodicity,
}

/// The TRS periods of a 15 kHz carrier, slots (TS 38.214 §5.1.6.1.1: 2^μ X_p slots, X_p = 10,
/// 20, 40 or 80).
pub const TRS_PERIODS_AT_15KHZ: [u64; 4] = [10, 20, 40, 80];

impl TrsConfig {
    /// Checks the values against `frame`; errors name the field under `prefix`.
    pub fn validate(&self, frame: &FrameStructure, prefix: &str) -> NrResult<()> {
        if self.scrambling_id > 1023 {
            return Err(NrError::new(
                format!("{prefix}.trs_scrambling_id"),
                format!("{} must lie in 0..=1023", self.scrambling_id),
            ));
        }
        if self.k0 > 3 {
            return Err(NrError::new(
                format!("{prefix}.trs_k0"),
                format!("{} must lie in 0..=3", self.k0),
            ));
        }
        if !(4..=6).contains(&self.l0) {
            return Err(NrError::new(
                format!("{prefix}.trs_first_symbol"),
                format!("{} must be 4, 5 or 6 (TS 38.214 §5.1.6.1.1)", self.l0),
            ));
        }
        let field = format!("{prefix}.trs_period_slots");
        self.period.validate(&field)?;
        let scale = 1u64 << frame.numerology();
        if !TRS_PERIODS_AT_15KHZ
            .iter()
            .any(|x| x * scale == self.period.period_slots)
        {
            return Err(NrError::new(
                field,
                format!(
                    "a TRS every {} slots: TS 38.214 §5.1.6.1.1 allows 2^μ × {{10, 20, 40, 80}} \
                     = {:?} slots at μ = {}",
                    self.period.period_slots,
                    TRS_PERIODS_AT_15KHZ.map(|x| x * scale),
                    frame.numerology()
                ),
            ));
        }
        self.period.check_downlink(
            frame,
            &[self.l0, self.l0 + 4],
            "TRS (CSI-RS)",
            &format!("{prefix}.trs_offset_slot"),
        )
    }

    /// The REs in slot `slot`: for each symbol l, PRB n and i = 0..3, k = 12n + k0 + 4i carries
    /// r_l(3n + i) (m' = ⌊nα⌋ + k' + ⌊k̄ρ/12⌋, α = ρ = 3).
    pub fn res_in_slot(&self, frame: &FrameStructure, slot: u64) -> Vec<Re> {
        if !self.period.contains(slot) {
            return Vec::new();
        }
        let n_s = (slot % frame.slots_per_frame() as u64) as usize;
        let sps = frame.symbols_per_slot();
        let mut out = Vec::with_capacity(6 * frame.prbs());
        for l in [self.l0, self.l0 + 4] {
            let r = qpsk_sequence(
                csi_rs_c_init(self.scrambling_id, n_s, l, sps),
                3 * frame.prbs(),
            );
            for (m, value) in r.into_iter().enumerate() {
                let (n, i) = (m / 3, m % 3);
                out.push(Re {
                    k: SUBCARRIERS_PER_PRB * n + self.k0 + 4 * i,
                    l,
                    kind: ReKind::Trs,
                    value,
                });
            }
        }
        out
    }
}

/// The frequency offsets k′ of the PRS by symbol l − l_start and comb size (Table 7.4.1.7.3-1):
/// each cycle of `comb` symbols visits every offset once.
pub fn prs_offsets(comb: usize) -> &'static [usize] {
    match comb {
        2 => &[0, 1],
        4 => &[0, 2, 1, 3],
        6 => &[0, 3, 1, 4, 2, 5],
        _ => &[0, 6, 3, 9, 1, 7, 4, 10, 2, 8, 5, 11],
    }
}

/// Least PRS bandwidth, PRBs (dl-PRS-ResourceBandwidth, TS 38.331).
pub const PRS_MIN_PRBS: usize = 24;

/// Largest PRS bandwidth, PRBs (dl-PRS-ResourceBandwidth, TS 38.331; steps of 4 from 24).
pub const PRS_MAX_PRBS: usize = 272;

/// A PRS resource over the whole carrier (§7.4.1.7): the carrier's PRBs are its bandwidth,
/// 24..=272 in steps of 4; it is sent in downlink symbols only.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PrsConfig {
    /// Sequence id n_ID^PRS, 0..=4095.
    pub sequence_id: u16,
    /// Comb size K_comb: 2, 4, 6 or 12.
    pub comb: usize,
    /// Symbols per slot L_PRS: 2, 4, 6 or 12, at least the comb size except comb 2 (Table
    /// 7.4.1.7.3-1: comb 2 with 2, 4, 6, 12; comb 4 with 4, 12; comb 6 with 6, 12; comb 12
    /// with 12).
    pub symbols: usize,
    /// First symbol l_start (l_start + L_PRS ≤ symbols per slot).
    pub start_symbol: usize,
    /// RE offset k_offset^PRS, 0..comb.
    pub re_offset: usize,
    /// When it is sent.
    pub period: Periodicity,
}

impl PrsConfig {
    /// Checks the values against `frame`; errors name the field under `prefix`.
    pub fn validate(&self, frame: &FrameStructure, prefix: &str) -> NrResult<()> {
        if self.sequence_id > 4095 {
            return Err(NrError::new(
                format!("{prefix}.prs_sequence_id"),
                format!("{} must lie in 0..=4095", self.sequence_id),
            ));
        }
        let allowed: &[usize] = match self.comb {
            2 => &[2, 4, 6, 12],
            4 => &[4, 12],
            6 => &[6, 12],
            12 => &[12],
            c => {
                return Err(NrError::new(
                    format!("{prefix}.prs_comb"),
                    format!("{c} must be 2, 4, 6 or 12"),
                ))
            }
        };
        if !allowed.contains(&self.symbols) {
            return Err(NrError::new(
                format!("{prefix}.prs_symbols"),
                format!(
                    "{} symbols with comb {}: must be one of {allowed:?}",
                    self.symbols, self.comb
                ),
            ));
        }
        if self.start_symbol + self.symbols > frame.symbols_per_slot() {
            return Err(NrError::new(
                format!("{prefix}.prs_start_symbol"),
                format!(
                    "{} + {} symbols exceed the slot's {}",
                    self.start_symbol,
                    self.symbols,
                    frame.symbols_per_slot()
                ),
            ));
        }
        if self.re_offset >= self.comb {
            return Err(NrError::new(
                format!("{prefix}.prs_re_offset"),
                format!("{} must lie in 0..{}", self.re_offset, self.comb),
            ));
        }
        let n = frame.prbs();
        if !(PRS_MIN_PRBS..=PRS_MAX_PRBS).contains(&n) || !n.is_multiple_of(4) {
            return Err(NrError::new(
                format!("{prefix}.prbs"),
                format!(
                    "the PRS spans the carrier's {n} PRBs: TS 38.211 §7.4.1.7 \
                     (dl-PRS-ResourceBandwidth, TS 38.331) allows 24..=272 PRBs in steps of 4 \
                     (set radar.nr.prbs, or prs = false)"
                ),
            ));
        }
        let field = format!("{prefix}.prs_period_slots");
        self.period.validate(&field)?;
        let symbols: Vec<usize> = (self.start_symbol..self.start_symbol + self.symbols).collect();
        self.period.check_downlink(frame, &symbols, "PRS", &field)
    }

    /// The REs in slot `slot`: symbol l carries r_l(m) at k = m K_comb + ((k_offset + k′) mod
    /// K_comb) (§7.4.1.7.3), m = 0..12 N_RB / K_comb.
    pub fn res_in_slot(&self, frame: &FrameStructure, slot: u64) -> Vec<Re> {
        if !self.period.contains(slot) {
            return Vec::new();
        }
        let n_s = (slot % frame.slots_per_frame() as u64) as usize;
        let sps = frame.symbols_per_slot();
        let per_symbol = frame.subcarriers() / self.comb;
        let offsets = prs_offsets(self.comb);
        let mut out = Vec::with_capacity(self.symbols * per_symbol);
        for j in 0..self.symbols {
            let l = self.start_symbol + j;
            let shift = (self.re_offset + offsets[j % offsets.len()]) % self.comb;
            let r = qpsk_sequence(prs_c_init(self.sequence_id, n_s, l, sps), per_symbol);
            out.extend(r.into_iter().enumerate().map(|(m, value)| Re {
                k: m * self.comb + shift,
                l,
                kind: ReKind::Prs,
                value,
            }));
        }
        out
    }
}

/// The PDSCH DMRS, type 1, single symbol, port 1000 (Δ = 0, w_f = w_t = 1), mapping type A.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PdschDmrsConfig {
    /// Scrambling id N_ID, 0..=65535.
    pub scrambling_id: u16,
    /// n_SCID, 0 or 1.
    pub n_scid: u8,
    /// dmrs-TypeA-Position l0: 2 or 3.
    pub type_a_position: usize,
    /// dmrs-AdditionalPosition: 0..=3 (3 only with l0 = 2).
    pub additional_positions: usize,
}

/// TS 38.211 Table 7.4.1.1.2-3, PDSCH mapping type A, single-symbol DMRS: the DMRS symbols
/// after l0 by l_d = 3..=14 (row l_d − 3) and dmrs-AdditionalPosition 0..=3 (column), with
/// l1 = 11 (the table's l1 is 12 only with lte-CRS-ToMatchAround, which this cell has not).
/// l_d < 3 has no entry. Checked against OpenAirInterface (`nr_mac_common.c`,
/// `table_7_4_1_1_2_3_pdsch_dmrs_positions_l`) and srsRAN Project
/// (`pdsch_dmrs_symbol_mask.cpp`), which agree on every type A entry.
const TYPE_A_SINGLE_SYMBOL: [[&[usize]; 4]; 12] = [
    [&[], &[], &[], &[]],                // l_d = 3
    [&[], &[], &[], &[]],                // 4
    [&[], &[], &[], &[]],                // 5
    [&[], &[], &[], &[]],                // 6
    [&[], &[], &[], &[]],                // 7
    [&[], &[7], &[7], &[7]],             // 8
    [&[], &[7], &[7], &[7]],             // 9
    [&[], &[9], &[6, 9], &[6, 9]],       // 10
    [&[], &[9], &[6, 9], &[6, 9]],       // 11
    [&[], &[9], &[6, 9], &[5, 8, 11]],   // 12
    [&[], &[11], &[7, 11], &[5, 8, 11]], // 13
    [&[], &[11], &[7, 11], &[5, 8, 11]], // 14
];

/// The DMRS symbols l̄ of a PDSCH of mapping type A whose last symbol is l_d − 1
/// (`duration` = l_d, counted from symbol 0 of the slot), l0 = `type_a_position` and
/// dmrs-AdditionalPosition `additional` (TS 38.211 §7.4.1.1.2, Table 7.4.1.1.2-3, single-symbol
/// DMRS). `None` where the clause defines none: l_d outside 3..=14, l0 outside {2, 3},
/// `additional` above 3, l0 = 3 with `additional` = 3, or l0 = 3 with l_d = 3 (applicable only
/// with dmrs-TypeA-Position 2).
pub fn pdsch_dmrs_symbols_type_a(
    duration: usize,
    type_a_position: usize,
    additional: usize,
) -> Option<Vec<usize>> {
    let l0 = type_a_position;
    if !(3..=14).contains(&duration)
        || !(2..=3).contains(&l0)
        || additional > 3
        || (l0 == 3 && (additional == 3 || duration == 3))
    {
        return None;
    }
    let extra = TYPE_A_SINGLE_SYMBOL[duration - 3][additional];
    Some(std::iter::once(l0).chain(extra.iter().copied()).collect())
}

impl PdschDmrsConfig {
    /// Checks the values; errors name the field under `prefix`.
    pub fn validate(&self, prefix: &str) -> NrResult<()> {
        if self.n_scid > 1 {
            return Err(NrError::new(
                format!("{prefix}.dmrs_n_scid"),
                format!("{} must be 0 or 1", self.n_scid),
            ));
        }
        if !(2..=3).contains(&self.type_a_position) {
            return Err(NrError::new(
                format!("{prefix}.dmrs_type_a_position"),
                format!("{} must be 2 or 3", self.type_a_position),
            ));
        }
        if self.additional_positions > 3 {
            return Err(NrError::new(
                format!("{prefix}.dmrs_additional_positions"),
                format!("{} must lie in 0..=3", self.additional_positions),
            ));
        }
        if self.type_a_position == 3 && self.additional_positions == 3 {
            return Err(NrError::new(
                format!("{prefix}.dmrs_additional_positions"),
                "3 with dmrs_type_a_position = 3: TS 38.211 §7.4.1.1.2 supports \
                 dmrs-AdditionalPosition 3 only with dmrs-TypeA-Position 2",
            ));
        }
        Ok(())
    }

    /// The DMRS symbols of a PDSCH that spans symbols 0..`duration` of the slot
    /// ([`pdsch_dmrs_symbols_type_a`]); `None` where Table 7.4.1.1.2-3 has no entry (no PDSCH is
    /// scheduled then).
    pub fn symbols(&self, duration: usize) -> Option<Vec<usize>> {
        pdsch_dmrs_symbols_type_a(duration, self.type_a_position, self.additional_positions)
    }

    /// The REs of a PDSCH on symbols 0..`duration` of slot `slot` over PRBs `prbs` (indices from
    /// CRB 0): symbol l carries r_l(2n + k′) at k = 4n + 2k′ (n over the PRBs' halves), with
    /// r_l from c_init of §7.4.1.1.1 (λ̄ = 0). The odd subcarriers of a DMRS symbol stay empty
    /// (two CDM groups without data).
    pub fn res_in_slot(
        &self,
        frame: &FrameStructure,
        slot: u64,
        duration: usize,
        prbs: &[usize],
    ) -> Vec<Re> {
        let n_s = (slot % frame.slots_per_frame() as u64) as usize;
        let sps = frame.symbols_per_slot();
        let Some(&top) = prbs.iter().max() else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for l in self.symbols(duration).unwrap_or_default() {
            let c = pdsch_dmrs_c_init(self.scrambling_id, self.n_scid, 0, n_s, l, sps);
            // six values per PRB from CRB 0: r(6n .. 6n + 6) on k = 12n + 0, 2, …, 10
            let r = qpsk_sequence(c, 6 * (top + 1));
            for &n in prbs {
                for j in 0..6 {
                    out.push(Re {
                        k: SUBCARRIERS_PER_PRB * n + 2 * j,
                        l,
                        kind: ReKind::PdschDmrs,
                        value: r[6 * n + j],
                    });
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests;
