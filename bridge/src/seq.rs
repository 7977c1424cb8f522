//! Sequence-number bookkeeping: gaps (lost messages) and duplicates (re-sends) per source.
//!
//! Zenoh and iceoryx2 deliver the messages of one publisher in order, so a per-source
//! high-water mark is enough: a jump counts the missing numbers, a number at or below the mark
//! is a duplicate (at-least-once delivery de-duplicated by the receiver).

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
                let missing = seq - *last - 1;
                *last = seq;
                self.missing += missing;
                SeqObservation::Gap { missing }
            }
            Some(_) => {
                self.duplicates += 1;
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

    proptest! {
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
