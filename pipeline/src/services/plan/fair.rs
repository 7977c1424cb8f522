//! The planner's request queue, fair across requesters: at most
//! [`MAX_QUEUED_PER_REQUESTER`] queued requests per requester and [`MAX_QUEUED_REQUESTS`] in
//! all, served in turn (round robin between the requesters that have one queued), so that a
//! peer flooding the planner with requests holds one place in the queue, not all of them.
//!
//! A requester is what the query's selector names in its [`REQUESTER_PARAMETER`]
//! (`cellsar/plan?requester=<id>`; the launcher sends its Zenoh session id); requests without
//! one share the anonymous requester `""`. Nothing vouches for the name: a peer that names
//! itself differently in each request (or opens many sessions) takes one place per name,
//! up to the whole queue.

use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

use bridge::net::{IncomingQuery, TypedQueryable};
use bridge::{Refusal, RefusalKind};

/// Requests the planner queues at most, all requesters together (more are refused as busy).
pub const MAX_QUEUED_REQUESTS: usize = 16;

/// Requests one requester may have queued at once (another is refused as busy until the
/// queued one is taken up).
pub const MAX_QUEUED_PER_REQUESTER: usize = 1;

/// The selector parameter that names the requester of a plan request.
pub const REQUESTER_PARAMETER: &str = "requester";

/// Longest requester name taken, bytes (a longer one is cut at a character boundary).
pub const MAX_REQUESTER_BYTES: usize = 64;

/// Why [`FairQueue::push`] did not queue a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Full {
    /// The requester already has [`MAX_QUEUED_PER_REQUESTER`] requests queued.
    Requester,
    /// [`MAX_QUEUED_REQUESTS`] requests are queued.
    Queue,
}

impl Full {
    /// The busy refusal's message.
    pub fn message(self) -> &'static str {
        match self {
            Full::Requester => "server busy: a request of this requester is already queued",
            Full::Queue => "server busy: request queue full",
        }
    }
}

/// The requester of a request: `named` (the selector's [`REQUESTER_PARAMETER`]) cut to
/// [`MAX_REQUESTER_BYTES`]; `""` (anonymous) when it names none.
pub fn requester_of(named: Option<&str>) -> String {
    let s = named.unwrap_or("");
    let mut end = s.len().min(MAX_REQUESTER_BYTES);
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    s[..end].to_string()
}

/// Queued items per requester, taken in turn.
pub struct FairQueue<T> {
    queues: HashMap<String, VecDeque<T>>,
    /// The requesters with an item queued, each once, in the order of their turns.
    turns: VecDeque<String>,
    len: usize,
    max_total: usize,
    max_per: usize,
}

impl<T> FairQueue<T> {
    /// An empty queue of at most `max_total` items, `max_per` per requester (each at least 1).
    pub fn new(max_total: usize, max_per: usize) -> Self {
        FairQueue {
            queues: HashMap::new(),
            turns: VecDeque::new(),
            len: 0,
            max_total: max_total.max(1),
            max_per: max_per.max(1),
        }
    }

    /// Queues `item` of `requester`, or gives it back with why not.
    pub fn push(&mut self, requester: &str, item: T) -> Result<(), (T, Full)> {
        let held = self.queues.get(requester).map_or(0, VecDeque::len);
        if held >= self.max_per {
            return Err((item, Full::Requester));
        }
        if self.len >= self.max_total {
            return Err((item, Full::Queue));
        }
        if held == 0 {
            self.turns.push_back(requester.to_string());
        }
        self.queues
            .entry(requester.to_string())
            .or_default()
            .push_back(item);
        self.len += 1;
        Ok(())
    }

    /// The oldest item of the requester whose turn it is, with its requester; that requester
    /// goes to the end of the turns if it has more.
    pub fn pop(&mut self) -> Option<(String, T)> {
        let requester = self.turns.pop_front()?;
        let q = self.queues.get_mut(&requester)?;
        let item = q.pop_front()?;
        if q.is_empty() {
            self.queues.remove(&requester);
        } else {
            self.turns.push_back(requester.clone());
        }
        self.len -= 1;
        Some((requester, item))
    }

    /// Items queued.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether none is queued.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// A [`FairQueue`] shared by the thread that takes requests off the queryable and the
/// service loop that answers them.
pub struct SharedQueue<T> {
    queue: Mutex<FairQueue<T>>,
    ready: Condvar,
}

impl<T> SharedQueue<T> {
    /// An empty queue of at most `max_total` items, `max_per` per requester.
    pub fn new(max_total: usize, max_per: usize) -> Self {
        SharedQueue {
            queue: Mutex::new(FairQueue::new(max_total, max_per)),
            ready: Condvar::new(),
        }
    }

    /// [`FairQueue::push`]; a poisoned lock refuses as a full queue.
    pub fn push(&self, requester: &str, item: T) -> Result<(), (T, Full)> {
        let Ok(mut q) = self.queue.lock() else {
            return Err((item, Full::Queue));
        };
        q.push(requester, item)?;
        self.ready.notify_one();
        Ok(())
    }

    /// [`FairQueue::pop`], waiting at most `wait` for an item.
    pub fn pop_timeout(&self, wait: Duration) -> Option<(String, T)> {
        let q = self.queue.lock().ok()?;
        let (mut q, _) = self
            .ready
            .wait_timeout_while(q, wait, |q| q.is_empty())
            .ok()?;
        q.pop()
    }
}

/// Takes the requests off `requests` as they come (so that the queryable's own queue stays
/// empty) into `queue` by requester ([`requester_of`] its [`REQUESTER_PARAMETER`]), refusing
/// as busy, counted in `busy`, those it has no room for; until `done` is set. Gives the
/// malformed requests that the queryable counted.
pub fn take_requests<Req>(
    requests: TypedQueryable<Req>,
    queue: &SharedQueue<IncomingQuery<Req>>,
    busy: &AtomicU64,
    done: &AtomicBool,
) -> u64 {
    while !done.load(Ordering::Relaxed) {
        let Some(q) = requests.recv_timeout(Duration::from_millis(100)) else {
            continue;
        };
        let requester = requester_of(q.parameter(REQUESTER_PARAMETER));
        if let Err((q, full)) = queue.push(&requester, q) {
            busy.fetch_add(1, Ordering::Relaxed);
            tracing::debug!(requester = %requester, reason = full.message(), "plan request refused as busy");
            if let Err(e) = q.refuse(&Refusal::new(RefusalKind::Busy, full.message())) {
                tracing::debug!(error = %e, "busy refusal failed");
            }
        }
    }
    requests.counters().snapshot().malformed
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// One requester flooding holds one place; another requester's request is taken next.
    #[test]
    fn a_flooding_requester_holds_one_place() {
        let mut q = FairQueue::new(MAX_QUEUED_REQUESTS, MAX_QUEUED_PER_REQUESTER);
        assert_eq!(q.push("", 0), Ok(()));
        for n in 1..100 {
            assert_eq!(q.push("", n), Err((n, Full::Requester)));
        }
        assert_eq!(q.push("launcher", 1000), Ok(()));
        assert_eq!(q.len(), 2);
        assert_eq!(q.pop(), Some((String::new(), 0)));
        // the flood's next request is queued behind the launcher's
        assert_eq!(q.push("", 100), Ok(()));
        assert_eq!(q.pop(), Some(("launcher".to_string(), 1000)));
        assert_eq!(q.pop(), Some((String::new(), 100)));
        assert_eq!(q.pop(), None);
        assert!(q.is_empty());
    }

    /// Turns go round: with two places per requester, a requester's second item waits for
    /// every other requester's first.
    #[test]
    fn requesters_are_served_in_turn() {
        let mut q = FairQueue::new(10, 2);
        for (r, n) in [("a", 1), ("a", 2), ("b", 3), ("c", 4), ("b", 5)] {
            assert_eq!(q.push(r, n), Ok(()));
        }
        assert_eq!(q.push("a", 6), Err((6, Full::Requester)));
        let order: Vec<i32> = std::iter::from_fn(|| q.pop().map(|(_, n)| n)).collect();
        assert_eq!(order, [1, 3, 4, 2, 5]);
        let mut q = FairQueue::new(2, 2);
        assert_eq!(q.push("a", 1), Ok(()));
        assert_eq!(q.push("b", 2), Ok(()));
        assert_eq!(q.push("c", 3), Err((3, Full::Queue)));
        assert_eq!(Full::Queue.message(), "server busy: request queue full");
    }

    /// The service's own bounds: 16 requesters, one request each, fill the queue; the 17th
    /// requester is refused as `Queue` and a second request of a queued one as `Requester`.
    #[test]
    fn the_services_queue_holds_sixteen_requesters_one_request_each() {
        let mut q = FairQueue::new(MAX_QUEUED_REQUESTS, MAX_QUEUED_PER_REQUESTER);
        for n in 0..MAX_QUEUED_REQUESTS {
            assert_eq!(q.push(&format!("r{n}"), n), Ok(()));
        }
        assert_eq!(MAX_QUEUED_REQUESTS, 16);
        assert_eq!(q.push("r16", 16), Err((16, Full::Queue)));
        assert_eq!(q.push("r0", 17), Err((17, Full::Requester)));
        assert_eq!(q.len(), MAX_QUEUED_REQUESTS);
        assert_eq!(q.pop(), Some(("r0".to_string(), 0)));
        assert_eq!(q.push("r16", 16), Ok(()));
    }

    #[test]
    fn requester_names_are_bounded() {
        assert_eq!(requester_of(None), "");
        assert_eq!(requester_of(Some("abc")), "abc");
        let long = "\u{e9}".repeat(MAX_REQUESTER_BYTES); // 2 bytes each
        let cut = requester_of(Some(&long));
        assert_eq!(cut.len(), MAX_REQUESTER_BYTES);
        assert!(long.starts_with(&cut));
    }

    proptest! {
        /// Whatever the pushes and pops: the bounds hold, nothing is lost or duplicated, each
        /// requester's items come out in their order, and between two items of one requester
        /// every other requester that had one queued after the first of them is served.
        #[test]
        fn bounded_lossless_and_fair(ops in proptest::collection::vec((0u8..4, any::<bool>()), 0..300)) {
            let mut q = FairQueue::new(5, 2);
            let mut next = 0u32;
            let mut queued: Vec<(String, u32)> = Vec::new();
            // per requester served: the others that were waiting then and not served since
            let mut owed: HashMap<String, Vec<String>> = HashMap::new();
            for (who, push) in ops {
                if push {
                    let r = format!("r{who}");
                    let mine = queued.iter().filter(|(q2, _)| *q2 == r).count();
                    match q.push(&r, next) {
                        Ok(()) => queued.push((r, next)),
                        Err((n, Full::Requester)) => prop_assert!(n == next && mine == 2),
                        Err((n, Full::Queue)) => prop_assert!(n == next && queued.len() == 5),
                    }
                    next += 1;
                } else if let Some((r, n)) = q.pop() {
                    let at = queued.iter().position(|x| x.0 == r && x.1 == n);
                    prop_assert!(at.is_some(), "{} {} was not queued", r, n);
                    let first_of_r = queued.iter().position(|x| x.0 == r);
                    prop_assert_eq!(at, first_of_r, "not the oldest item of {}", r);
                    queued.remove(at.unwrap_or_default());
                    if let Some(w) = owed.get(&r) {
                        prop_assert!(w.is_empty(), "{} served again before {:?}", r, w);
                    }
                    for w in owed.values_mut() {
                        w.retain(|x| *x != r);
                    }
                    let mut waiting: Vec<String> =
                        queued.iter().map(|x| x.0.clone()).filter(|x| *x != r).collect();
                    waiting.dedup();
                    owed.insert(r, waiting);
                } else {
                    prop_assert!(queued.is_empty());
                }
                prop_assert_eq!(q.len(), queued.len());
                prop_assert!(q.len() <= 5);
            }
        }
    }
}
