//! The resident memory of a process under test, from `/proc/<pid>/status` (Linux): what a
//! hostile peer made it hold. `VmHWM` is the peak since the process started or since
//! [`reset_peak`].

/// Resident memory of a process, in bytes.
#[derive(Debug, Clone, Copy)]
pub struct Resident {
    /// Resident now (`VmRSS`).
    pub now: u64,
    /// The peak (`VmHWM`).
    pub peak: u64,
}

/// One MiB.
pub const MIB: u64 = 1 << 20;

/// The resident memory of `pid` now and at its peak.
pub fn resident(pid: u32) -> Resident {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status"))
        .unwrap_or_else(|e| panic!("/proc/{pid}/status: {e}"));
    let kib = |field: &str| -> u64 {
        status
            .lines()
            .find_map(|l| l.strip_prefix(field))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
            .unwrap_or_else(|| panic!("no {field} in /proc/{pid}/status:\n{status}"))
    };
    Resident {
        now: kib("VmRSS:") * 1024,
        peak: kib("VmHWM:") * 1024,
    }
}

/// Resets the peak of `pid` to its resident memory now (`echo 5 > /proc/<pid>/clear_refs`),
/// so that [`Resident::peak`] measures what comes after; false where that is not permitted
/// (the peak then counts from the process's start, which only makes a check stricter).
pub fn reset_peak(pid: u32) -> bool {
    std::fs::write(format!("/proc/{pid}/clear_refs"), "5").is_ok()
}

/// The memory of `pid` at the start of a flood; [`Baseline::assert_peak_within`] checks it
/// after.
#[derive(Debug, Clone, Copy)]
pub struct Baseline {
    pid: u32,
    at_start: u64,
}

impl Baseline {
    /// Resets the peak of `pid` and notes its resident memory now.
    pub fn take(pid: u32) -> Baseline {
        reset_peak(pid);
        Baseline {
            pid,
            at_start: resident(pid).now,
        }
    }

    /// Asserts that the peak of the process since [`Baseline::take`] stayed within `bound`
    /// bytes above its resident memory then (`what` names the process and the bound's
    /// reason in the message); gives the growth.
    pub fn assert_peak_within(&self, bound: u64, what: &str) -> u64 {
        // a process that ended has no memory to measure: say so, not that a field is missing
        assert!(
            crate::running(self.pid),
            "{what}: the process (pid {}) has ended",
            self.pid
        );
        let r = resident(self.pid);
        let grew = r.peak.saturating_sub(self.at_start);
        eprintln!(
            "{what}: resident {} MiB at the start, peak {} MiB (+{} MiB; bound +{} MiB)",
            self.at_start / MIB,
            r.peak / MIB,
            grew / MIB,
            bound / MIB
        );
        assert!(
            grew <= bound,
            "{what}: peak resident memory grew by {} MiB, more than the bound of {} MiB \
             (from {} MiB to {} MiB)",
            grew / MIB,
            bound / MIB,
            self.at_start / MIB,
            r.peak / MIB
        );
        grew
    }
}

/// Plans a plan cache keeps (`pipeline::services::plan::MAX_HELD_PLANS`).
pub const CACHE_PLANS: u64 = pipeline::services::plan::MAX_HELD_PLANS as u64;

/// How much more a service may hold at its peak under hostile peers than before, for plans of
/// at most `plan_bytes` encoded: a full plan cache of [`CACHE_PLANS`], each plan decoded at
/// most 4 times its encoded size, plus 64 MiB for Zenoh's buffers, the allocator's slack and
/// the processor's missions (at most `--max-missions`, 16; the forgers' other messages are
/// small). The bound of the hostile suite on the private mesh (`tests/tests/hostile.rs`) and
/// of the forger tests of the secure deployment (`tests/tests/netns_tls.rs`).
pub fn peak_bound(plan_bytes: u64) -> u64 {
    64 * MIB + CACHE_PLANS * 4 * plan_bytes
}
