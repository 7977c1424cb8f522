//! The launcher's iceoryx2 shared memory: what it removes, and only that.
//!
//! - By default each run has its own prefix `cs<pid>_` (the launcher's process id): at the end
//!   the run removes the `/dev/shm` entries with its prefix, and at the start it removes those
//!   of runs whose launcher is gone (killed with `-9`, so it could not clean up).
//! - With a user-given `--iox-prefix` (or root or config), the environment may be shared with
//!   other live users: nothing is removed by name; at the end iceoryx2 removes the resources of
//!   dead nodes (this run's children that did not exit cleanly), never those of live ones.

use std::path::Path;

use bridge::IoxArgs;

/// Where Linux keeps POSIX shared memory.
const SHM_DIR: &str = "/dev/shm";

/// The prefix of this run's iceoryx2 resources when the user gave none.
pub(super) fn own_prefix() -> String {
    run_prefix(std::process::id())
}

fn run_prefix(pid: u32) -> String {
    format!("cs{pid}_")
}

/// The launcher pid in a name made with [`run_prefix`], if it is one.
fn run_pid(name: &str) -> Option<u32> {
    let rest = name.strip_prefix("cs")?;
    let end = rest.find('_')?;
    let digits = &rest[..end];
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// The names among `names` left by runs whose launcher is not alive (`alive` tells), other
/// than this process's.
fn stale_names<'a>(
    names: impl IntoIterator<Item = &'a str>,
    own_pid: u32,
    alive: impl Fn(u32) -> bool,
) -> Vec<&'a str> {
    names
        .into_iter()
        .filter(|n| run_pid(n).is_some_and(|pid| pid != own_pid && !alive(pid)))
        .collect()
}

/// Whether process `pid` exists (a process of another user counts).
fn alive(pid: u32) -> bool {
    let Ok(raw) = i32::try_from(pid) else {
        return false;
    };
    match nix::sys::signal::kill(nix::unistd::Pid::from_raw(raw), None) {
        Ok(()) => true,
        Err(e) => e != nix::errno::Errno::ESRCH,
    }
}

fn shm_names(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|rd| {
            rd.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default()
}

/// Removes the shared memory that runs with a default prefix left behind when their launcher
/// died; returns how many entries were removed.
pub(super) fn clean_dead_runs() -> usize {
    clean_dead_runs_in(Path::new(SHM_DIR), std::process::id(), alive)
}

fn clean_dead_runs_in(dir: &Path, own_pid: u32, alive: impl Fn(u32) -> bool) -> usize {
    let names = shm_names(dir);
    let stale = stale_names(names.iter().map(String::as_str), own_pid, alive);
    let mut removed = 0;
    for n in stale {
        match std::fs::remove_file(dir.join(n)) {
            Ok(()) => removed += 1,
            Err(e) => tracing::debug!(entry = n, error = %e, "stale shared memory not removed"),
        }
    }
    if removed > 0 {
        tracing::info!(
            removed,
            "shared memory of earlier runs whose launcher died removed"
        );
    }
    removed
}

/// The clean-up at the end of a run: with this run's own prefix, every entry with it; in a
/// user-given environment, only the resources of dead iceoryx2 nodes.
pub(super) fn clean_after(iox: &IoxArgs, own: bool) {
    if own {
        if let Some(prefix) = &iox.prefix {
            remove_prefixed(Path::new(SHM_DIR), prefix);
        }
        return;
    }
    match iox.env() {
        Ok(env) => {
            if let Err(e) =
                bridge::FrameNode::new(&env, &format!("launcher-{}", std::process::id()))
            {
                tracing::warn!(error = %e, "iceoryx2 clean-up of dead nodes");
            }
        }
        Err(e) => tracing::warn!(error = %e, "iceoryx2 environment for the clean-up"),
    }
}

fn remove_prefixed(dir: &Path, prefix: &str) {
    for n in shm_names(dir) {
        if n.starts_with(prefix) {
            let _ = std::fs::remove_file(dir.join(n));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_prefixes_round_trip_and_others_are_not_runs() {
        assert_eq!(run_pid(&format!("{}x", run_prefix(4242))), Some(4242));
        for other in [
            "cs_x",
            "csabc_x",
            "cs12",
            "iox2_cs12_x",
            "user_cs1_",
            "cs-1_x",
            "cs99999999999_x",
        ] {
            assert_eq!(run_pid(other), None, "{other}");
        }
    }

    #[test]
    fn only_dead_runs_other_than_this_one_are_stale() {
        let names = [
            "cs10_a",
            "cs10_b",
            "cs20_a",
            "cs30_a",
            "iox2_x",
            "mine_cs10_",
        ];
        let alive = |pid| pid == 20;
        assert_eq!(stale_names(names, 30, alive), vec!["cs10_a", "cs10_b"]);
    }

    #[test]
    fn clean_up_removes_dead_runs_and_keeps_live_and_foreign_entries() {
        let dir = tempfile::tempdir().unwrap();
        let me = std::process::id();
        // a process that has exited: its pid is dead (until reused, which `alive` would see)
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let names = [
            format!("cs{dead}_seg"),
            format!("cs{me}_seg"),
            "cs1_init".to_string(), // pid 1 is alive
            "user_prefix_seg".to_string(),
        ];
        for n in &names {
            std::fs::write(dir.path().join(n), b"x").unwrap();
        }
        let removed = clean_dead_runs_in(dir.path(), me, alive);
        assert_eq!(removed, 1);
        let mut left = shm_names(dir.path());
        left.sort();
        let mut want = names[1..].to_vec();
        want.sort();
        assert_eq!(left, want);
        remove_prefixed(dir.path(), &format!("cs{me}_"));
        assert!(!dir.path().join(&names[1]).exists());
        assert!(dir.path().join("user_prefix_seg").exists());
    }
}
