//! NR frame structure (TS 38.211 §4.2–§4.3, §5.3.1): numerology μ (Δf = 2^μ · 15 kHz), 10 ms
//! frames of ten 1 ms subframes of 2^μ slots, 14 symbols per slot (normal CP) or 12 (extended
//! CP, μ = 2 only); the carrier's bandwidth as PRBs and its FFT size; the TDD pattern.
//!
//! Cyclic prefixes in samples at FFT size N (sample rate N Δf), from §5.3.1's
//! N_CP,l^μ = 144 κ 2^−μ (+ 16 κ for l = 0 and l = 7·2^μ, l counted within the subframe) and
//! 512 κ 2^−μ (extended), with N_u^μ = 2048 κ 2^−μ: normal `9N/128`, the longer first symbol of
//! each half subframe `9N/128 + 2^μ N/128`, extended `N/4`. A subframe then holds exactly
//! `15 N 2^μ` samples (1 ms).

use super::{NrError, NrResult, SUBCARRIERS_PER_PRB};

/// Highest numerology supported (μ = 3, 120 kHz).
pub const MAX_NUMEROLOGY: u8 = 3;

/// Most PRBs of a carrier, N_grid^size,μ ≤ 275 (§4.4.2).
pub const MAX_PRBS: usize = 275;

/// Least FFT size (the CP lengths are whole samples for a power of two ≥ 128).
pub const MIN_FFT_SIZE: usize = 128;

/// Largest FFT size accepted.
pub const MAX_FFT_SIZE: usize = 1 << 16;

/// Cyclic prefix length (§4.2, Table 4.2-1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CyclicPrefix {
    /// Normal CP: 14 symbols per slot.
    Normal,
    /// Extended CP: 12 symbols per slot (μ = 2 only).
    Extended,
}

/// What a symbol of the TDD pattern carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SymbolUse {
    /// Downlink: the BS transmits (the only symbols that illuminate).
    Downlink,
    /// Guard period of a special slot: nobody transmits.
    Guard,
    /// Uplink: the BS is silent (the UEs' signals are not modelled).
    Uplink,
}

/// One slot of a TDD pattern.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlotKind {
    /// `D`: every symbol downlink.
    Downlink,
    /// `S`: the special slot, split into downlink, guard and uplink symbols.
    Special,
    /// `U`: every symbol uplink.
    Uplink,
}

/// A TDD pattern: slot kinds repeated from slot 0 of frame 0, and the special slot's split.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TddPattern {
    slots: Vec<SlotKind>,
    /// Downlink, guard and uplink symbols of a special slot (sum: symbols per slot).
    special: [usize; 3],
}

impl TddPattern {
    /// Parses a pattern such as `"DDDSU"` (one letter per slot: `D`, `S` or `U`) with the special
    /// slot's split `"DL:GP:UL"` in symbols, such as `"10:2:2"`. The period (pattern length ×
    /// slot duration) must divide 20 ms (38.213 §11.1); the split must add up to
    /// `symbols_per_slot`. Errors name `pattern_field` or `split_field`.
    pub fn parse(
        pattern: &str,
        split: &str,
        numerology: u8,
        symbols_per_slot: usize,
        pattern_field: &str,
        split_field: &str,
    ) -> NrResult<Self> {
        let slots = pattern
            .chars()
            .map(|c| match c.to_ascii_uppercase() {
                'D' => Ok(SlotKind::Downlink),
                'S' => Ok(SlotKind::Special),
                'U' => Ok(SlotKind::Uplink),
                other => Err(NrError::new(
                    pattern_field,
                    format!("{pattern:?}: slot {other:?} is none of D, S, U"),
                )),
            })
            .collect::<NrResult<Vec<_>>>()?;
        if slots.is_empty() {
            return Err(NrError::new(pattern_field, "the pattern is empty"));
        }
        let per_20ms = 20usize << numerology;
        if !per_20ms.is_multiple_of(slots.len()) {
            return Err(NrError::new(
                pattern_field,
                format!(
                    "{pattern:?} lasts {} slots of {} ms; the period must divide 20 ms \
                     ({per_20ms} slots at μ = {numerology})",
                    slots.len(),
                    1.0 / f64::from(1u32 << numerology)
                ),
            ));
        }
        check_tdd_period(&slots, pattern, numerology, pattern_field)?;
        if !slots.contains(&SlotKind::Downlink) && !slots.contains(&SlotKind::Special) {
            return Err(NrError::new(
                pattern_field,
                format!("{pattern:?} has no downlink slot: nothing would illuminate"),
            ));
        }
        let parts = split
            .split(':')
            .map(|p| p.trim().parse::<usize>())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| NrError::new(split_field, format!("{split:?}: {e}")))?;
        let special: [usize; 3] = parts.try_into().map_err(|_| {
            NrError::new(
                split_field,
                format!("{split:?} must be three counts DL:GP:UL, e.g. \"10:2:2\""),
            )
        })?;
        if special.iter().sum::<usize>() != symbols_per_slot {
            return Err(NrError::new(
                split_field,
                format!(
                    "{split:?} adds up to {} symbols; a slot has {symbols_per_slot}",
                    special.iter().sum::<usize>()
                ),
            ));
        }
        Ok(Self { slots, special })
    }

    /// Every slot downlink (FDD downlink, or a TDD cell seen in downlink only).
    pub fn all_downlink() -> Self {
        Self {
            slots: vec![SlotKind::Downlink],
            special: [0, 0, 0],
        }
    }

    /// The slots of one period.
    pub fn slots(&self) -> &[SlotKind] {
        &self.slots
    }

    /// Downlink, guard and uplink symbols of the special slot.
    pub fn special_split(&self) -> [usize; 3] {
        self.special
    }

    /// The kind of slot `slot` (counted from slot 0 of frame 0).
    pub fn slot_kind(&self, slot: u64) -> SlotKind {
        // the pattern is non-empty (checked when built)
        self.slots[(slot % self.slots.len() as u64) as usize]
    }

    /// What symbol `symbol` of slot `slot` carries.
    pub fn symbol_use(&self, slot: u64, symbol: usize) -> SymbolUse {
        match self.slot_kind(slot) {
            SlotKind::Downlink => SymbolUse::Downlink,
            SlotKind::Uplink => SymbolUse::Uplink,
            SlotKind::Special => {
                if symbol < self.special[0] {
                    SymbolUse::Downlink
                } else if symbol < self.special[0] + self.special[1] {
                    SymbolUse::Guard
                } else {
                    SymbolUse::Uplink
                }
            }
        }
    }

    /// Share of all symbols that are downlink.
    pub fn downlink_share(&self, symbols_per_slot: usize) -> f64 {
        let dl: usize = self
            .slots
            .iter()
            .map(|k| match k {
                SlotKind::Downlink => symbols_per_slot,
                SlotKind::Special => self.special[0],
                SlotKind::Uplink => 0,
            })
            .sum();
        dl as f64 / (self.slots.len() * symbols_per_slot) as f64
    }
}

/// The TDD periods P of TS 38.331 `dl-UL-TransmissionPeriodicity` (and its `-v1530` extension,
/// 3 and 4 ms), in units of 0.125 ms (TS 38.213 §11.1): 0.5, 0.625, 1, 1.25, 2, 2.5, 3, 4, 5,
/// 10 ms.
pub const TDD_PERIODS_EIGHTHS_MS: [u32; 10] = [4, 5, 8, 10, 16, 20, 24, 32, 40, 80];

/// Refuses a pattern whose slot sequence no TDD period of TS 38.213 §11.1 gives: the pattern
/// repeats every `m` slots (its shortest period), and some period P of
/// [`TDD_PERIODS_EIGHTHS_MS`] must hold a whole number P · 2^μ of slots that `m` divides (an
/// all-`D` pattern is thus the same at every length).
fn check_tdd_period(
    slots: &[SlotKind],
    pattern: &str,
    numerology: u8,
    field: &str,
) -> NrResult<()> {
    let n = slots.len();
    let m = (1..=n)
        .find(|&m| n.is_multiple_of(m) && (m..n).all(|i| slots[i] == slots[i - m]))
        .unwrap_or(n);
    let per_8ms = 1u32 << numerology; // slots in 0.125 ms × 8
    let allowed: Vec<usize> = TDD_PERIODS_EIGHTHS_MS
        .iter()
        .filter(|&&e| (e * per_8ms).is_multiple_of(8))
        .map(|&e| (e * per_8ms / 8) as usize)
        .collect();
    if allowed.iter().any(|p| p.is_multiple_of(m)) {
        return Ok(());
    }
    Err(NrError::new(
        field,
        format!(
            "{pattern:?} repeats every {m} slots ({} ms): TS 38.213 §11.1 \
             (dl-UL-TransmissionPeriodicity, TS 38.331) allows a TDD period of 0.5, 0.625, 1, \
             1.25, 2, 2.5, 3, 4, 5 or 10 ms, i.e. {allowed:?} slots at μ = {numerology}",
            m as f64 / f64::from(1u32 << numerology)
        ),
    ))
}

/// Where a symbol lies: frame, slot within the frame, symbol within the slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SymbolPos {
    /// System frame number (not wrapped at 1024).
    pub frame: u64,
    /// Slot within the frame, n_s,f^μ ∈ 0..10·2^μ.
    pub slot: usize,
    /// Symbol within the slot, l ∈ 0..N_symb^slot.
    pub symbol: usize,
}

/// A carrier's frame structure: numerology, CP, bandwidth in PRBs, FFT size, TDD pattern.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameStructure {
    numerology: u8,
    cp: CyclicPrefix,
    prbs: usize,
    fft_size: usize,
    tdd: TddPattern,
}

impl FrameStructure {
    /// A carrier of `prbs` PRBs at numerology `numerology` with `cp`, FFT size `fft_size` (None:
    /// the least power of two ≥ 128 whose 85 % holds the occupied subcarriers, as MATLAB's and
    /// py3gpp's `nrOFDMInfo`), TDD pattern `tdd`. Errors name the field under `prefix` (e.g.
    /// `radar.nr`).
    pub fn new(
        numerology: u8,
        cp: CyclicPrefix,
        prbs: usize,
        fft_size: Option<usize>,
        tdd: TddPattern,
        prefix: &str,
    ) -> NrResult<Self> {
        if numerology > MAX_NUMEROLOGY {
            return Err(NrError::new(
                format!("{prefix}.numerology"),
                format!("μ = {numerology} must lie in 0..={MAX_NUMEROLOGY}"),
            ));
        }
        if cp == CyclicPrefix::Extended && numerology != 2 {
            return Err(NrError::new(
                format!("{prefix}.cyclic_prefix"),
                format!("the extended CP exists at μ = 2 only (Table 4.2-1), not μ = {numerology}"),
            ));
        }
        if prbs == 0 || prbs > MAX_PRBS {
            return Err(NrError::new(
                format!("{prefix}.prbs"),
                format!("{prbs} must lie in 1..={MAX_PRBS}"),
            ));
        }
        let sc = prbs * SUBCARRIERS_PER_PRB;
        let fft_size = match fft_size {
            Some(n) => {
                if !n.is_power_of_two() || !(MIN_FFT_SIZE..=MAX_FFT_SIZE).contains(&n) {
                    return Err(NrError::new(
                        format!("{prefix}.fft_size"),
                        format!("{n} must be a power of two in {MIN_FFT_SIZE}..={MAX_FFT_SIZE}"),
                    ));
                }
                if sc + 2 > n {
                    return Err(NrError::new(
                        format!("{prefix}.fft_size"),
                        format!(
                            "{n} cannot hold {prbs} PRBs = {sc} subcarriers (need ≥ {})",
                            sc + 2
                        ),
                    ));
                }
                n
            }
            None => {
                let mut n = MIN_FFT_SIZE;
                while (n as f64) * 0.85 < sc as f64 {
                    n *= 2;
                }
                n
            }
        };
        Ok(Self {
            numerology,
            cp,
            prbs,
            fft_size,
            tdd,
        })
    }

    /// Numerology μ.
    pub fn numerology(&self) -> u8 {
        self.numerology
    }

    /// Cyclic prefix.
    pub fn cyclic_prefix(&self) -> CyclicPrefix {
        self.cp
    }

    /// Bandwidth in PRBs, N_RB.
    pub fn prbs(&self) -> usize {
        self.prbs
    }

    /// Occupied subcarriers, 12 N_RB.
    pub fn subcarriers(&self) -> usize {
        self.prbs * SUBCARRIERS_PER_PRB
    }

    /// FFT size N.
    pub fn fft_size(&self) -> usize {
        self.fft_size
    }

    /// The TDD pattern.
    pub fn tdd(&self) -> &TddPattern {
        &self.tdd
    }

    /// Subcarrier spacing Δf = 2^μ · 15 kHz, Hz.
    pub fn subcarrier_spacing_hz(&self) -> f64 {
        15e3 * f64::from(1u32 << self.numerology)
    }

    /// Sample rate N Δf, Hz.
    pub fn sample_rate_hz(&self) -> f64 {
        self.fft_size as f64 * self.subcarrier_spacing_hz()
    }

    /// Occupied bandwidth 12 N_RB Δf, Hz.
    pub fn bandwidth_hz(&self) -> f64 {
        self.subcarriers() as f64 * self.subcarrier_spacing_hz()
    }

    /// Symbols per slot, N_symb^slot: 14 (normal CP) or 12 (extended).
    pub fn symbols_per_slot(&self) -> usize {
        match self.cp {
            CyclicPrefix::Normal => 14,
            CyclicPrefix::Extended => 12,
        }
    }

    /// Slots per subframe, 2^μ.
    pub fn slots_per_subframe(&self) -> usize {
        1 << self.numerology
    }

    /// Slots per frame, 10 · 2^μ.
    pub fn slots_per_frame(&self) -> usize {
        10 << self.numerology
    }

    /// Symbols per subframe.
    pub fn symbols_per_subframe(&self) -> usize {
        self.symbols_per_slot() * self.slots_per_subframe()
    }

    /// Slot duration, s.
    pub fn slot_s(&self) -> f64 {
        1e-3 / self.slots_per_subframe() as f64
    }

    /// Samples per subframe (1 ms), 15 N 2^μ.
    pub fn samples_per_subframe(&self) -> usize {
        15 * self.fft_size * self.slots_per_subframe()
    }

    /// The ordinary CP length, samples: 9N/128 (normal) or N/4 (extended).
    pub fn base_cp_samples(&self) -> usize {
        match self.cp {
            CyclicPrefix::Normal => 9 * self.fft_size / 128,
            CyclicPrefix::Extended => self.fft_size / 4,
        }
    }

    /// The extra CP of the first symbol of each half subframe, 2^μ N / 128 samples (16 κ T_c);
    /// 0 for the extended CP.
    pub fn long_cp_extra_samples(&self) -> usize {
        match self.cp {
            CyclicPrefix::Normal => (self.fft_size << self.numerology) / 128,
            CyclicPrefix::Extended => 0,
        }
    }

    /// CP length of symbol `l` of the subframe (0..symbols_per_subframe), samples.
    pub fn cp_samples_in_subframe(&self, l: usize) -> usize {
        let half = 7 << self.numerology;
        let long = self.cp == CyclicPrefix::Normal && (l == 0 || l == half);
        self.base_cp_samples()
            + if long {
                self.long_cp_extra_samples()
            } else {
                0
            }
    }

    /// CP length of symbol `m` (counted from symbol 0 of frame 0), samples.
    pub fn cp_samples(&self, m: u64) -> usize {
        self.cp_samples_in_subframe((m % self.symbols_per_subframe() as u64) as usize)
    }

    /// Samples of symbol `m`, CP included.
    pub fn symbol_samples(&self, m: u64) -> usize {
        self.fft_size + self.cp_samples(m)
    }

    /// The sample at which symbol `m` starts (its CP first), from the start of frame 0.
    pub fn symbol_start_sample(&self, m: u64) -> u64 {
        let per_sf = self.symbols_per_subframe() as u64;
        let (sf, l) = (m / per_sf, m % per_sf);
        let half = 7u64 << self.numerology;
        let long_before = if self.cp == CyclicPrefix::Normal {
            u64::from(l > 0) + u64::from(l > half)
        } else {
            0
        };
        sf * self.samples_per_subframe() as u64
            + l * (self.fft_size + self.base_cp_samples()) as u64
            + long_before * self.long_cp_extra_samples() as u64
    }

    /// The sample at which symbol `m`'s useful part (after its CP) starts.
    pub fn useful_start_sample(&self, m: u64) -> u64 {
        self.symbol_start_sample(m) + self.cp_samples(m) as u64
    }

    /// Frame, slot and symbol of symbol `m`.
    pub fn locate(&self, m: u64) -> SymbolPos {
        let sps = self.symbols_per_slot() as u64;
        let slot = m / sps;
        let spf = self.slots_per_frame() as u64;
        SymbolPos {
            frame: slot / spf,
            slot: (slot % spf) as usize,
            symbol: (m % sps) as usize,
        }
    }

    /// What symbol `m` carries in the TDD pattern.
    pub fn symbol_use(&self, m: u64) -> SymbolUse {
        let sps = self.symbols_per_slot() as u64;
        self.tdd.symbol_use(m / sps, (m % sps) as usize)
    }

    /// Symbols per second on average (all directions), 1 / mean symbol duration.
    pub fn symbol_rate_hz(&self) -> f64 {
        self.symbols_per_subframe() as f64 * 1e3
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(mu: u8, cp: CyclicPrefix, n: Option<usize>) -> FrameStructure {
        FrameStructure::new(mu, cp, 24, n, TddPattern::all_downlink(), "radar.nr").unwrap()
    }

    #[test]
    fn cp_lengths_per_clause_5_3_1() {
        // in T_c units with κ = 64: N_u = 2048κ2^−μ, N_CP = 144κ2^−μ (+16κ), 512κ2^−μ
        let kappa = 64.0;
        for mu in 0..=3u8 {
            let f = frame(mu, CyclicPrefix::Normal, Some(4096));
            let tc_per_sample = 2048.0 * kappa / f64::from(1u32 << mu) / 4096.0;
            let short = 144.0 * kappa / f64::from(1u32 << mu) / tc_per_sample;
            let long = short + 16.0 * kappa / tc_per_sample;
            assert_eq!(f.cp_samples_in_subframe(1) as f64, short);
            assert_eq!(f.cp_samples_in_subframe(0) as f64, long);
            assert_eq!(f.cp_samples_in_subframe(7 << mu) as f64, long, "μ = {mu}");
            let longs = (0..f.symbols_per_subframe())
                .filter(|&l| f.cp_samples_in_subframe(l) as f64 == long)
                .count();
            assert_eq!(longs, 2, "two longer CPs per subframe, μ = {mu}");
            // a subframe is 1 ms
            let total: usize = (0..f.symbols_per_subframe())
                .map(|l| f.cp_samples_in_subframe(l) + 4096)
                .sum();
            assert_eq!(total, f.samples_per_subframe());
            assert!((total as f64 / f.sample_rate_hz() - 1e-3).abs() < 1e-15);
            assert_eq!(f.slots_per_frame(), 10 << mu);
            assert_eq!(f.symbols_per_slot(), 14);
        }
        let e = frame(2, CyclicPrefix::Extended, Some(4096));
        assert_eq!(e.symbols_per_slot(), 12);
        assert_eq!(e.base_cp_samples(), 1024);
        assert_eq!(
            e.symbols_per_subframe() * (4096 + 1024),
            e.samples_per_subframe()
        );
        // μ = 2 at 4096: 288 and 416 samples (1.17 µs and 1.69 µs at 245.76 MHz)
        let f = frame(2, CyclicPrefix::Normal, Some(4096));
        assert_eq!(
            (f.base_cp_samples(), f.cp_samples_in_subframe(0)),
            (288, 416)
        );
    }

    #[test]
    fn symbol_starts_add_up() {
        for (mu, cp) in [
            (0, CyclicPrefix::Normal),
            (1, CyclicPrefix::Normal),
            (2, CyclicPrefix::Normal),
            (2, CyclicPrefix::Extended),
            (3, CyclicPrefix::Normal),
        ] {
            let f = frame(mu, cp, Some(1024));
            let mut s = 0u64;
            for m in 0..(3 * f.symbols_per_subframe() as u64 + 5) {
                assert_eq!(f.symbol_start_sample(m), s, "μ {mu} {cp:?} m {m}");
                s += f.symbol_samples(m) as u64;
            }
        }
    }

    #[test]
    fn locate_and_default_fft() {
        let f = frame(1, CyclicPrefix::Normal, None);
        assert_eq!(f.fft_size(), 512); // 288 subcarriers: 288 / 0.85 = 339
        let p = f.locate(14 * 20 + 14 * 3 + 5);
        assert_eq!((p.frame, p.slot, p.symbol), (1, 3, 5));
        let big = FrameStructure::new(
            2,
            CyclicPrefix::Normal,
            208,
            None,
            TddPattern::all_downlink(),
            "r",
        )
        .unwrap();
        assert_eq!(big.fft_size(), 4096);
        assert!((big.bandwidth_hz() - 149.76e6).abs() < 1.0);
        assert!((big.sample_rate_hz() - 245.76e6).abs() < 1.0);
    }

    #[test]
    fn bad_values_name_their_field() {
        let t = TddPattern::all_downlink;
        let e =
            FrameStructure::new(4, CyclicPrefix::Normal, 10, None, t(), "radar.nr").unwrap_err();
        assert_eq!(e.field, "radar.nr.numerology");
        let e =
            FrameStructure::new(1, CyclicPrefix::Extended, 10, None, t(), "radar.nr").unwrap_err();
        assert_eq!(e.field, "radar.nr.cyclic_prefix");
        let e =
            FrameStructure::new(1, CyclicPrefix::Normal, 276, None, t(), "radar.nr").unwrap_err();
        assert_eq!(e.field, "radar.nr.prbs");
        for n in [100, 256, 1 << 17] {
            let e = FrameStructure::new(1, CyclicPrefix::Normal, 24, Some(n), t(), "radar.nr")
                .unwrap_err();
            assert_eq!(e.field, "radar.nr.fft_size", "{n}");
        }
    }

    #[test]
    fn tdd_pattern() {
        let p = TddPattern::parse("DDDSU", "10:2:2", 1, 14, "p", "s").unwrap();
        let uses: Vec<_> = (0..14).map(|l| p.symbol_use(3, l)).collect();
        assert_eq!(uses[9], SymbolUse::Downlink);
        assert_eq!(uses[10], SymbolUse::Guard);
        assert_eq!(uses[11], SymbolUse::Guard);
        assert_eq!(uses[12], SymbolUse::Uplink);
        assert_eq!(p.symbol_use(4, 0), SymbolUse::Uplink);
        assert_eq!(p.symbol_use(5, 0), SymbolUse::Downlink); // repeats
        assert!((p.downlink_share(14) - (3.0 * 14.0 + 10.0) / 70.0).abs() < 1e-15);
        let f = FrameStructure::new(1, CyclicPrefix::Normal, 24, None, p, "r").unwrap();
        assert_eq!(f.symbol_use(14 * 3 + 10), SymbolUse::Guard);
        assert_eq!(f.symbol_use(14 * 4), SymbolUse::Uplink);
        // errors
        let e = TddPattern::parse("DDXU", "10:2:2", 1, 14, "p", "s").unwrap_err();
        assert_eq!(e.field, "p");
        let e = TddPattern::parse("DDDSU", "10:2", 1, 14, "p", "s").unwrap_err();
        assert_eq!(e.field, "s");
        let e = TddPattern::parse("DDDSU", "10:2:3", 1, 14, "p", "s").unwrap_err();
        assert_eq!(e.field, "s");
        let e = TddPattern::parse("DDDSUUU", "10:2:2", 1, 14, "p", "s").unwrap_err();
        assert!(e.reason.contains("20 ms"), "{e}");
        let e = TddPattern::parse("UUUU", "10:2:2", 1, 14, "p", "s").unwrap_err();
        assert!(e.reason.contains("no downlink"), "{e}");
        assert!(TddPattern::parse("", "10:2:2", 1, 14, "p", "s").is_err());
    }

    #[test]
    fn tdd_periods_are_those_of_ts_38_213() {
        // D…DU of n slots repeats every n slots; at μ it is a TDD pattern of TS 38.213 §11.1 iff
        // some period P of 0.5, 0.625, 1, 1.25, 2, 2.5, 3, 4, 5, 10 ms holds a whole number of
        // slots that n divides (P = n slots, or the pattern repeated), and n divides 20 ms
        let eighths = [4u32, 5, 8, 10, 16, 20, 24, 32, 40, 80];
        for mu in 0..=3u8 {
            for n in 2..=200usize {
                let pattern = format!("{}U", "D".repeat(n - 1));
                let legal = eighths.iter().any(|&e| {
                    let p8 = e << mu; // 8 × slots in P
                    p8.is_multiple_of(8) && ((p8 / 8) as usize).is_multiple_of(n)
                });
                let divides_20 = (20usize << mu).is_multiple_of(n);
                let r = TddPattern::parse(&pattern, "10:2:2", mu, 14, "p", "s");
                assert_eq!(r.is_ok(), legal && divides_20, "μ = {mu}, {n} slots: {r:?}");
                if let Err(e) = r {
                    assert_eq!(e.field, "p");
                    assert!(!divides_20 || e.reason.contains("TS 38.213 §11.1"), "{e}");
                }
            }
        }
        // DDDSU is 5, 2.5, 1.25, 0.625 ms at μ = 0..3; "D" repeats every slot at any length
        for mu in 0..=3 {
            TddPattern::parse("DDDSU", "10:2:2", mu, 14, "p", "s").unwrap();
            TddPattern::parse("D", "10:2:2", mu, 14, "p", "s").unwrap();
            TddPattern::parse(&"D".repeat(20 << mu), "10:2:2", mu, 14, "p", "s").unwrap();
        }
        // 20 ms divides 20 ms but is no TDD period
        let twenty = format!("{}U", "D".repeat(19));
        let e = TddPattern::parse(&twenty, "10:2:2", 0, 14, "p", "s").unwrap_err();
        assert!(e.reason.contains("TS 38.213 §11.1"), "{e}");
    }
}
