//! Sequence-number bookkeeping: gaps (lost messages) and duplicates (re-sends) per source.
//!
//! Zenoh and iceoryx2 deliver the messages of one publisher in order, so a per-source
//! high-water mark is enough: a jump counts the missing numbers, a number at or below the mark
//! is a duplicate (at-least-once delivery de-duplicated by the receiver).
//!
//! Sequence numbers come from peers, so no value may overflow the arithmetic: the number after
//! `u64::MAX` is 0 (a publisher's counter wraps), a gap is computed without underflow, and the
//! totals saturate at `u64::MAX` instead of wrapping.

use std::collections::HashMap;

/// What one observed sequence number means.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeqObservation {
    /// The first number seen from this source.
    First,
    /// The next number in order.
    InOrder,
    /// Newer than expected: `missing` numbers were never seen.
    Gap {
        /// How many numbers were skipped.
        missing: u64,
    },
    /// Already seen (or older): drop it.
    Duplicate,
}

/// Per-source high-water marks with totals.
#[derive(Debug, Default, Clone)]
pub struct SeqTracker {
    last: HashMap<u128, u64>,
    missing: u64,
    duplicates: u64,
}

impl SeqTracker {
    /// An empty tracker.
    pub fn new() -> Self {
        Self::default()
    }

    /// Records `seq` from `source`.
    pub fn observe(&mut self, source: u128, seq: u64) -> SeqObservation {
        match self.last.get_mut(&source) {
            None => {
                self.last.insert(source, seq);
                SeqObservation::First
            }
            Some(last) if seq == last.wrapping_add(1) => {
                *last = seq;
                SeqObservation::InOrder
            }
            Some(last) if seq > *last => {
                // seq > last, so seq - last >= 1: neither subtraction can underflow
                let missing = seq.saturating_sub(*last).saturating_sub(1);
                *last = seq;
                self.missing = self.missing.saturating_add(missing);
                SeqObservation::Gap { missing }
            }
            Some(_) => {
                self.duplicates = self.duplicates.saturating_add(1);
                SeqObservation::Duplicate
            }
        }
    }

    /// Total numbers skipped so far.
    pub fn missing(&self) -> u64 {
        self.missing
    }

    /// Total duplicates so far.
    pub fn duplicates(&self) -> u64 {
        self.duplicates
    }

    /// Forgets a source (e.g. when its publisher went away for good).
    pub fn forget(&mut self, source: u128) {
        self.last.remove(&source);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn classifies() {
        let mut t = SeqTracker::new();
        assert_eq!(t.observe(1, 5), SeqObservation::First);
        assert_eq!(t.observe(1, 6), SeqObservation::InOrder);
        assert_eq!(t.observe(1, 9), SeqObservation::Gap { missing: 2 });
        assert_eq!(t.observe(1, 9), SeqObservation::Duplicate);
        assert_eq!(t.observe(1, 3), SeqObservation::Duplicate);
        assert_eq!(t.observe(2, 0), SeqObservation::First);
        assert_eq!(t.missing(), 2);
        assert_eq!(t.duplicates(), 2);
    }

    #[test]
    fn extreme_numbers_neither_overflow_nor_panic() {
        let mut t = SeqTracker::new();
        // 0 then u64::MAX: the largest possible gap
        assert_eq!(t.observe(1, 0), SeqObservation::First);
        assert_eq!(
            t.observe(1, u64::MAX),
            SeqObservation::Gap {
                missing: u64::MAX - 1
            }
        );
        // the counter wraps: 0 follows u64::MAX
        assert_eq!(t.observe(1, 0), SeqObservation::InOrder);
        assert_eq!(t.observe(1, 1), SeqObservation::InOrder);
        // a second huge gap saturates the total instead of overflowing it
        assert_eq!(
            t.observe(1, u64::MAX),
            SeqObservation::Gap {
                missing: u64::MAX - 2
            }
        );
        assert_eq!(t.missing(), u64::MAX);
        // a source that starts at u64::MAX
        assert_eq!(t.observe(2, u64::MAX), SeqObservation::First);
        assert_eq!(t.observe(2, u64::MAX), SeqObservation::Duplicate);
        assert_eq!(t.observe(2, 0), SeqObservation::InOrder);
        assert_eq!(
            t.observe(2, u64::MAX - 1),
            SeqObservation::Gap {
                missing: u64::MAX - 2
            }
        );
        assert_eq!(t.missing(), u64::MAX);
        // duplicates saturate too
        t.duplicates = u64::MAX - 1;
        assert_eq!(t.observe(2, 0), SeqObservation::Duplicate);
        assert_eq!(t.observe(2, 0), SeqObservation::Duplicate);
        assert_eq!(t.duplicates(), u64::MAX);
    }

    proptest! {
        /// Any sequence of any numbers from any few sources: no panic, and the totals never
        /// decrease (they saturate at u64::MAX).
        #[test]
        fn any_numbers_are_classified_without_overflow(
            obs in proptest::collection::vec(
                (0u128..3, prop_oneof![
                    Just(0u64), Just(1), Just(u64::MAX), Just(u64::MAX - 1), any::<u64>()
                ]),
                1..200,
            )
        ) {
            let mut t = SeqTracker::new();
            let (mut missing, mut duplicates) = (0u64, 0u64);
            for (source, seq) in obs {
                match t.observe(source, seq) {
                    SeqObservation::Gap { missing: m } => prop_assert!(m < u64::MAX),
                    SeqObservation::First | SeqObservation::InOrder | SeqObservation::Duplicate => {}
                }
                prop_assert!(t.missing() >= missing);
                prop_assert!(t.duplicates() >= duplicates);
                missing = t.missing();
                duplicates = t.duplicates();
            }
        }

        /// Numbers near u64::MAX that wrap around to 0 stay in order.
        #[test]
        fn a_wrapping_counter_stays_in_order(start in (u64::MAX - 50)..=u64::MAX, n in 1u64..100) {
            let mut t = SeqTracker::new();
            prop_assert_eq!(t.observe(9, start), SeqObservation::First);
            for k in 1..n {
                prop_assert_eq!(t.observe(9, start.wrapping_add(k)), SeqObservation::InOrder);
            }
            prop_assert_eq!(t.missing(), 0);
            prop_assert_eq!(t.duplicates(), 0);
        }

        /// Delivering an increasing subset of 0..n counts exactly the left-out numbers
        /// (after the first one delivered), and re-delivering any of them is a duplicate.
        #[test]
        fn missing_equals_left_out(keep in proptest::collection::vec(any::<bool>(), 1..200)) {
            let seqs: Vec<u64> = keep.iter().enumerate().filter(|(_, k)| **k).map(|(i, _)| i as u64).collect();
            prop_assume!(!seqs.is_empty());
            let mut t = SeqTracker::new();
            for s in &seqs { t.observe(7, *s); }
            let span = seqs[seqs.len() - 1] - seqs[0] + 1;
            prop_assert_eq!(t.missing(), span - seqs.len() as u64);
            for s in &seqs { prop_assert_eq!(t.observe(7, *s), SeqObservation::Duplicate); }
        }
    }
}
