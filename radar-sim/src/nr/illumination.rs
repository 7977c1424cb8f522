//! What a radar pulse is under an NR cell: the symbols `first_symbol .. first_symbol + symbols`
//! of one slot every `period_slots` slots (from slot `slot`), all of them downlink. The PRF is
//! the pulse slots' rate, `1 / (period_slots × slot duration)`, not a free parameter; a pulse at
//! nominal time t takes the pulse slot of period `⌊t · PRF⌋`.

use super::frame::SymbolUse;
use super::grid::NrGrid;
use super::{NrError, NrResult};

/// Which symbols of the cell's stream make the radar's pulses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PulseSlots {
    /// Slots from one pulse to the next.
    pub period_slots: u64,
    /// The pulse's slot within the period, `0..period_slots`.
    pub slot: u64,
    /// First symbol of the pulse within its slot.
    pub first_symbol: usize,
    /// Symbols per pulse.
    pub symbols: usize,
}

/// The cell's downlink and the radar's pulses in it.
#[derive(Debug, Clone, PartialEq)]
pub struct NrIllumination {
    /// The downlink resource grid.
    pub grid: NrGrid,
    /// Which symbols make the pulses.
    pub pulse: PulseSlots,
}

impl NrIllumination {
    /// Checks the grid and that every pulse's symbols are downlink (over one TDD period);
    /// errors name the field under `prefix`.
    pub fn new(grid: NrGrid, pulse: PulseSlots, prefix: &str) -> NrResult<Self> {
        let frame = &grid.frame;
        if pulse.period_slots == 0 {
            return Err(NrError::new(
                format!("{prefix}.pulse_period_slots"),
                "must be at least 1",
            ));
        }
        if pulse.slot >= pulse.period_slots {
            return Err(NrError::new(
                format!("{prefix}.pulse_slot"),
                format!(
                    "{} must lie below pulse_period_slots = {}",
                    pulse.slot, pulse.period_slots
                ),
            ));
        }
        let sps = frame.symbols_per_slot();
        if pulse.symbols == 0 || pulse.first_symbol + pulse.symbols > sps {
            return Err(NrError::new(
                format!("{prefix}.pulse_symbols"),
                format!(
                    "{} symbols from symbol {} must be at least 1 and fit the slot's {sps}",
                    pulse.symbols, pulse.first_symbol
                ),
            ));
        }
        let tdd_len = frame.tdd().slots().len() as u64;
        for q in 0..tdd_len {
            let slot = q * pulse.period_slots + pulse.slot;
            for l in pulse.first_symbol..pulse.first_symbol + pulse.symbols {
                if frame.tdd().symbol_use(slot, l) != SymbolUse::Downlink {
                    return Err(NrError::new(
                        format!("{prefix}.pulse_slot"),
                        format!(
                            "pulse {q} takes symbol {l} of slot {slot}, which is not downlink \
                             in the TDD pattern: only downlink symbols illuminate (choose \
                             pulse_slot, pulse_period_slots, pulse_first_symbol so that every \
                             pulse falls in downlink symbols)"
                        ),
                    ));
                }
            }
        }
        grid.validate(prefix)?; // after the pulse: a PRS that follows the pulse names it
        Ok(Self { grid, pulse })
    }

    /// Pulse repetition frequency, 1 / (period_slots × slot duration), Hz.
    pub fn prf_hz(&self) -> f64 {
        1.0 / (self.pulse.period_slots as f64 * self.grid.frame.slot_s())
    }

    /// The first symbol (counted from symbol 0 of frame 0) of the pulse at nominal time `t_s`:
    /// the pulse slot of period ⌊t · PRF⌋.
    pub fn pulse_symbol(&self, t_s: f64) -> u64 {
        let q = (t_s * self.prf_hz()).floor().max(0.0) as u64;
        let slot = q * self.pulse.period_slots + self.pulse.slot;
        slot * self.grid.frame.symbols_per_slot() as u64 + self.pulse.first_symbol as u64
    }

    /// The centre time of the pulse starting at symbol `m`, s: the middle between the first
    /// symbol's start (CP first) and the last symbol's end.
    pub fn pulse_centre_s(&self, m: u64) -> f64 {
        let f = &self.grid.frame;
        let last = m + self.pulse.symbols as u64 - 1;
        let a = f.symbol_start_sample(m) as f64;
        let b = (f.symbol_start_sample(last) + f.symbol_samples(last) as u64) as f64;
        0.5 * (a + b) / f.sample_rate_hz()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nr::grid::tests::grid;

    fn pulse(period: u64, slot: u64, first: usize, symbols: usize) -> PulseSlots {
        PulseSlots {
            period_slots: period,
            slot,
            first_symbol: first,
            symbols,
        }
    }

    #[test]
    fn prf_and_pulse_symbols_follow_the_frame() {
        // μ = 1 (0.5 ms slots), a pulse every 20 slots: 100 Hz
        let ill = NrIllumination::new(grid(0.5), pulse(20, 2, 10, 4), "radar.nr").unwrap();
        assert!((ill.prf_hz() - 100.0).abs() < 1e-9);
        // the pulse of period q starts at slot 20 q + 2, symbol 10
        for q in 0..50u64 {
            let t = (q as f64 + 0.5) / 100.0;
            assert_eq!(ill.pulse_symbol(t), (20 * q + 2) * 14 + 10, "q {q}");
            let c = ill.pulse_centre_s(ill.pulse_symbol(t));
            // slot 20 q + 2 starts at (20 q + 2) 0.5 ms; symbols 10..14 are its second half
            let slot0 = (20 * q + 2) as f64 * 0.5e-3;
            assert!(c > slot0 + 0.25e-3 && c < slot0 + 0.5e-3, "{c}");
        }
    }

    #[test]
    fn pulses_outside_downlink_are_refused_by_field() {
        // DDDSU: slot 3 is special (10 DL symbols), slot 4 uplink
        let e = NrIllumination::new(grid(0.5), pulse(5, 4, 0, 1), "radar.nr").unwrap_err();
        assert_eq!(e.field, "radar.nr.pulse_slot");
        let e = NrIllumination::new(grid(0.5), pulse(5, 3, 8, 4), "radar.nr").unwrap_err();
        assert!(e.reason.contains("not downlink"), "{e}");
        NrIllumination::new(grid(0.5), pulse(5, 3, 6, 4), "radar.nr").unwrap();
        // a period that walks the pulse through the pattern onto the uplink slot
        let e = NrIllumination::new(grid(0.5), pulse(3, 0, 0, 1), "radar.nr").unwrap_err();
        assert_eq!(e.field, "radar.nr.pulse_slot");
        let e = NrIllumination::new(grid(0.5), pulse(5, 0, 12, 3), "radar.nr").unwrap_err();
        assert_eq!(e.field, "radar.nr.pulse_symbols");
        let e = NrIllumination::new(grid(0.5), pulse(0, 0, 0, 1), "radar.nr").unwrap_err();
        assert_eq!(e.field, "radar.nr.pulse_period_slots");
    }
}
