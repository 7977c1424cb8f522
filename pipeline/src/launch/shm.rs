//! The launcher's iceoryx2 shared memory: what it removes, and only that.
//!
//! - By default each run has its own prefix `cs<pid>x<random>_` (the launcher's process id and
//!   32 random bits, in hexadecimal, so that another user cannot tell the run's names in
//!   advance): at the end the run removes the `/dev/shm` entries with its prefix, and at the
//!   start it removes those of runs whose launcher is gone (killed with `-9`, so it could not
//!   clean up) that belong to the same user: another user's entries are never touched.
//! - With a user-given `--iox-prefix` (or root or config), the environment may be shared with
//!   other live users: nothing is removed by name; at the end iceoryx2 removes the resources of
//!   dead nodes (this run's children that did not exit cleanly), never those of live ones.

use std::path::Path;

use bridge::IoxArgs;

/// Where Linux keeps POSIX shared memory.
const SHM_DIR: &str = "/dev/shm";

/// The prefix of this run's iceoryx2 resources when the user gave none.
pub(super) fn own_prefix() -> String {
    run_prefix(std::process::id(), random_u32())
}

fn run_prefix(pid: u32, random: u32) -> String {
    format!("cs{pid}x{random:08x}_")
}

/// 32 random bits: from the kernel (`/dev/urandom`), else from the standard library's
/// randomly seeded hasher.
fn random_u32() -> u32 {
    use std::io::Read;
    let mut b = [0u8; 4];
    match std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(&mut b)) {
        Ok(()) => u32::from_le_bytes(b),
        Err(_) => {
            use std::hash::{BuildHasher, Hasher};
            let mut h = std::collections::hash_map::RandomState::new().build_hasher();
            h.write_u32(std::process::id());
            (h.finish() >> 32) as u32
        }
    }
}

/// The launcher pid in a name made with [`run_prefix`] (or by a run before the random part,
/// `cs<pid>_`), if it is one.
fn run_pid(name: &str) -> Option<u32> {
    let rest = name.strip_prefix("cs")?;
    let end = rest.find(['_', 'x'])?;
    let digits = &rest[..end];
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    if rest[end..].starts_with('x') {
        let random = rest.get(end + 1..end + 9)?;
        if !random.bytes().all(|b| b.is_ascii_hexdigit())
            || rest.get(end + 9..end + 10) != Some("_")
        {
            return None;
        }
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
/// died, of this user only; returns how many entries were removed.
pub(super) fn clean_dead_runs() -> usize {
    clean_dead_runs_in(
        Path::new(SHM_DIR),
        std::process::id(),
        nix::unistd::geteuid().as_raw(),
        alive,
    )
}

fn clean_dead_runs_in(
    dir: &Path,
    own_pid: u32,
    own_uid: u32,
    alive: impl Fn(u32) -> bool,
) -> usize {
    use std::os::unix::fs::MetadataExt;
    let names = shm_names(dir);
    let stale = stale_names(names.iter().map(String::as_str), own_pid, alive);
    let mut removed = 0;
    for n in stale {
        let path = dir.join(n);
        // another user's entry: not ours to remove, whatever its name says
        match std::fs::symlink_metadata(&path) {
            Ok(m) if m.uid() == own_uid => {}
            _ => continue,
        }
        match std::fs::remove_file(&path) {
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
            remove_own(prefix);
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

/// Removes every `/dev/shm` entry whose name starts with `prefix` (a run's own prefix, or a
/// test's).
pub(crate) fn remove_own(prefix: &str) {
    remove_prefixed(Path::new(SHM_DIR), prefix);
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
        let p = run_prefix(4242, 0xdead_beef);
        assert_eq!(p, "cs4242xdeadbeef_");
        assert_eq!(run_pid(&format!("{p}x")), Some(4242));
        // a run before the random part
        assert_eq!(run_pid("cs4242_x"), Some(4242));
        for other in [
            "cs_x",
            "csabc_x",
            "cs12",
            "iox2_cs12_x",
            "user_cs1_",
            "cs-1_x",
            "cs99999999999_x",
            "cs12xdeadbee_x",
            "cs12xdeadbeefa_x",
            "cs12xdeadbeeg_x",
            "cs12x",
        ] {
            assert_eq!(run_pid(other), None, "{other}");
        }
    }

    #[test]
    fn every_run_has_a_prefix_of_its_own() {
        let a = own_prefix();
        let b = own_prefix();
        assert_ne!(a, b);
        for p in [&a, &b] {
            assert_eq!(run_pid(p), Some(std::process::id()), "{p}");
            assert_eq!(p.len(), format!("cs{}x12345678_", std::process::id()).len());
        }
    }

    #[test]
    fn only_dead_runs_other_than_this_one_are_stale() {
        let names = [
            "cs10_a",
            "cs10x0000000a_b",
            "cs20x0000000a_a",
            "cs30x0000000b_a",
            "iox2_x",
            "mine_cs10_",
        ];
        let alive = |pid| pid == 20;
        assert_eq!(
            stale_names(names, 30, alive),
            vec!["cs10_a", "cs10x0000000a_b"]
        );
    }

    #[test]
    fn clean_up_removes_dead_runs_of_this_user_and_keeps_the_rest() {
        use std::os::unix::fs::MetadataExt;
        let dir = tempfile::tempdir().unwrap();
        let me = std::process::id();
        let uid = nix::unistd::geteuid().as_raw();
        // a process that has exited: its pid is dead (until reused, which `alive` would see)
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let dead = child.id();
        child.wait().unwrap();
        let names = [
            run_prefix(dead, 1) + "seg",
            run_prefix(me, 2) + "seg",
            "cs1x00000003_init".to_string(), // pid 1 is alive
            "user_prefix_seg".to_string(),
            run_prefix(dead, 4) + "other_user",
        ];
        for n in &names {
            std::fs::write(dir.path().join(n), b"x").unwrap();
        }
        // the last one another user's (nobody's) where we may make one (as root)
        let other = dir.path().join(&names[4]);
        if uid == 0 {
            std::os::unix::fs::chown(&other, Some(65534), Some(65534)).unwrap();
            assert_eq!(std::fs::metadata(&other).unwrap().uid(), 65534);
        }
        let removed = clean_dead_runs_in(dir.path(), me, uid, alive);
        let mut left = shm_names(dir.path());
        left.sort();
        if uid == 0 {
            assert_eq!(removed, 1);
            let mut want = names[1..].to_vec();
            want.sort();
            assert_eq!(left, want);
        } else {
            // without root no entry of another user can be made: both dead runs are ours
            assert_eq!(removed, 2);
        }
        // a dead run's entries of another uid are kept
        let dir2 = tempfile::tempdir().unwrap();
        std::fs::write(dir2.path().join(&names[0]), b"x").unwrap();
        assert_eq!(clean_dead_runs_in(dir2.path(), me, uid + 1, alive), 0);
        assert!(dir2.path().join(&names[0]).exists());
        remove_prefixed(dir.path(), &run_prefix(me, 2));
        assert!(!dir.path().join(&names[1]).exists());
        assert!(dir.path().join("user_prefix_seg").exists());
    }
}
