//! How many missions a service holds at once: a peer that publishes plan after plan must not
//! make a service hold (and work on) every one of them.

use std::time::Duration;

/// The default cap on the missions a radar service holds at once (`--max-missions`).
pub const DEFAULT_MAX_MISSIONS: usize = 16;

/// How long a held mission may go without progress (its plan or a frame of it arriving) before
/// it may be dropped to make room for a new one: plans without frames (a peer's, or of a
/// mission whose echo never comes) cannot fill the cap for good.
pub const MISSION_IDLE_TIMEOUT: Duration = Duration::from_secs(60);

/// Whether a held mission may be dropped to make room for a new one, and how readily.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Droppable {
    /// It must be kept: not finished, with progress within [`MISSION_IDLE_TIMEOUT`] or work
    /// queued or in progress.
    No,
    /// Unfinished, but without progress for [`MISSION_IDLE_TIMEOUT`] and with no work queued or
    /// in progress: dropped only when no [`Droppable::Done`] mission is held.
    Idle,
    /// Finished or given up: dropped first.
    Done,
}

/// Whether a held mission may be dropped to make room for a new one: it is `done` (finished or
/// given up), or it has had no progress for [`MISSION_IDLE_TIMEOUT`] (`since_progress`) and
/// has no work queued or in progress (`busy`).
pub fn droppable(done: bool, since_progress: Duration, busy: bool) -> Droppable {
    if done {
        Droppable::Done
    } else if !busy && since_progress >= MISSION_IDLE_TIMEOUT {
        Droppable::Idle
    } else {
        Droppable::No
    }
}

/// What to do with a new mission, given those held.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Admission {
    /// Below the cap: take it.
    Admit,
    /// At the cap: first drop the held mission at this index, then take it.
    Evict(usize),
    /// At the cap and nothing may be dropped: refuse it.
    Refuse,
}

/// Decides on a new mission when `held` missions are held, each with whether it may be dropped,
/// oldest first: the oldest finished or given-up mission makes room, else the oldest idle one.
pub fn admit(held: impl ExactSizeIterator<Item = Droppable>, cap: usize) -> Admission {
    if held.len() < cap {
        return Admission::Admit;
    }
    let mut idle = None;
    for (i, d) in held.enumerate() {
        match d {
            Droppable::Done => return Admission::Evict(i),
            Droppable::Idle => {
                idle.get_or_insert(i);
            }
            Droppable::No => {}
        }
    }
    idle.map_or(Admission::Refuse, Admission::Evict)
}

/// The apertures a result request may make a processor publish again: the distinct indices
/// below `apertures`, in ascending order, at most `apertures` of them (a request cannot make
/// the processor publish one aperture twice or walk through indices it never had).
pub fn requested_apertures(requested: &[u32], apertures: usize) -> Vec<u32> {
    let set: std::collections::BTreeSet<u32> = requested
        .iter()
        .copied()
        .filter(|&k| (k as usize) < apertures)
        .collect();
    set.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    use Droppable::{Done, Idle, No};

    #[test]
    fn below_the_cap_admits() {
        assert_eq!(admit([No, No].into_iter(), 3), Admission::Admit);
        assert_eq!(admit(std::iter::empty::<Droppable>(), 1), Admission::Admit);
    }

    #[test]
    fn at_the_cap_the_oldest_droppable_makes_room() {
        assert_eq!(admit([No, Done, Done].into_iter(), 3), Admission::Evict(1));
        assert_eq!(admit([Done, No].into_iter(), 2), Admission::Evict(0));
        assert_eq!(admit([No, Idle, Idle].into_iter(), 3), Admission::Evict(1));
    }

    /// A finished or given-up mission makes room before an idle one, however much older the
    /// idle one is.
    #[test]
    fn a_done_mission_goes_before_an_idle_one() {
        assert_eq!(admit([Idle, Done].into_iter(), 2), Admission::Evict(1));
        assert_eq!(
            admit([Idle, No, Idle, Done, Done].into_iter(), 5),
            Admission::Evict(3)
        );
        // from the service's view: an idle mission (held long without progress) and a
        // finished one that progressed a moment ago
        let idle = droppable(false, MISSION_IDLE_TIMEOUT * 2, false);
        let done = droppable(true, Duration::ZERO, false);
        assert_eq!((idle, done), (Idle, Done));
        assert_eq!(admit([idle, done].into_iter(), 2), Admission::Evict(1));
    }

    #[test]
    fn at_the_cap_with_nothing_droppable_refuses() {
        assert_eq!(admit([No, No].into_iter(), 2), Admission::Refuse);
        // a cap of zero takes nothing
        assert_eq!(admit(std::iter::empty::<Droppable>(), 0), Admission::Refuse);
    }

    /// A full cap of missions that never got a frame refuses a new mission until they have
    /// been idle for the time-out; then the oldest makes room.
    #[test]
    fn missions_without_progress_make_room_after_the_idle_time_out() {
        let young = Duration::from_secs(5);
        let old = MISSION_IDLE_TIMEOUT;
        let held = |since: Duration| {
            (0..DEFAULT_MAX_MISSIONS)
                .map(move |_| droppable(false, since, false))
                .collect::<Vec<_>>()
        };
        assert_eq!(
            admit(held(young).into_iter(), DEFAULT_MAX_MISSIONS),
            Admission::Refuse
        );
        assert_eq!(
            admit(held(old).into_iter(), DEFAULT_MAX_MISSIONS),
            Admission::Evict(0)
        );
        // busy or done
        assert_eq!(droppable(false, old * 10, true), No);
        assert_eq!(droppable(true, Duration::ZERO, true), Done);
        assert_eq!(droppable(false, old - Duration::from_millis(1), false), No);
    }

    #[test]
    fn requests_are_deduplicated_sorted_and_bounded() {
        assert_eq!(requested_apertures(&[3, 1, 3, 1, 2], 4), vec![1, 2, 3]);
        assert_eq!(requested_apertures(&[7, u32::MAX, 0], 4), vec![0]);
        let flood: Vec<u32> = (0..100_000).map(|i| i % 5).collect();
        assert_eq!(requested_apertures(&flood, 3), vec![0, 1, 2]);
        assert!(requested_apertures(&[0, 1], 0).is_empty());
    }
}
