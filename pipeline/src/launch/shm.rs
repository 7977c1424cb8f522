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
//! - Whatever is removed is removed only when it belongs to the user running the launcher
//!   (checked on the entry's owner, not its name).
//! - Before any iceoryx2 node of a run with its own prefix exists, the launcher creates the
//!   domain's node counter (`<prefix>node.<version>.global_mgmt`) itself, with mode 0600
//!   ([`claim_node_counter`]): iceoryx2 would make it writable by every user, and another user
//!   who writes it can make every node creation of the run fail.

use std::io::Write;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};

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
/// test's) and that belongs to the current user: another user's entry under the same prefix
/// is kept, whatever its name.
pub(crate) fn remove_own(prefix: &str) {
    remove_prefixed(Path::new(SHM_DIR), prefix, nix::unistd::geteuid().as_raw());
}

/// Removes the entries of `dir` whose names start with `prefix` and whose owner is `uid`;
/// returns how many were removed.
fn remove_prefixed(dir: &Path, prefix: &str, uid: u32) -> usize {
    let mut removed = 0;
    for n in shm_names(dir) {
        if !n.starts_with(prefix) {
            continue;
        }
        let path = dir.join(&n);
        match std::fs::symlink_metadata(&path) {
            Ok(m) if m.uid() == uid => {}
            Ok(m) => {
                tracing::warn!(entry = %n, owner = m.uid(), "shared memory of another user under the run's prefix kept");
                continue;
            }
            Err(_) => continue,
        }
        if std::fs::remove_file(&path).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// The Rust type iceoryx2 keeps in its node counter; the SHA-1 of its name is part of the
/// segment's name (iceoryx2's `path_for_with_type`).
const NODE_COUNTER_TYPE: &str = "iceoryx2::node::global_management_segment::State";

/// The name of iceoryx2's node counter of the domain `prefix` in `/dev/shm`, as iceoryx2 names
/// it: `<prefix><sha1 of the counter's type name, hex>_node.<major>_<minor>_<patch>.global_mgmt`
/// (`the_node_counter_is_made_private_and_iceoryx2_numbers_its_nodes_from_it` checks that
/// iceoryx2 uses the segment of this name).
pub fn node_counter_name(prefix: &str) -> String {
    use iceoryx2_cal::hash::{sha1::Sha1, Hash};
    let v = iceoryx2_bb_elementary::package_version::PackageVersion::get();
    let type_hash = String::from(Sha1::new(NODE_COUNTER_TYPE.as_bytes()).value());
    format!(
        "{prefix}{type_hash}_node.{}_{}_{}.global_mgmt",
        v.major(),
        v.minor(),
        v.patch()
    )
}

/// Creates the node counter of the iceoryx2 domain `prefix` before iceoryx2 does, readable
/// and writable by the current user only (mode 0600), and returns its path.
///
/// iceoryx2 creates this segment, the `u32` that numbers the domain's nodes, writable by every
/// user (0666) on purpose, and every node creation opens it and checks its version field: a
/// local user who writes that field makes every later node creation of the run fail
/// (`UnableToGenerateUniqueNodeId`). Made first, exclusively and with mode 0600, it is
/// initialised as iceoryx2 initialises it (its version, then a counter of 0), so iceoryx2 opens
/// it and leaves its mode as it is. The run's prefix is not known in advance, so no one can
/// make it first. Fails if the segment exists already (the prefix is not the run's own).
pub(super) fn claim_node_counter(prefix: &str) -> std::io::Result<PathBuf> {
    claim_node_counter_in(Path::new(SHM_DIR), prefix)
}

fn claim_node_counter_in(dir: &Path, prefix: &str) -> std::io::Result<PathBuf> {
    let path = dir.join(node_counter_name(prefix));
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(&path)?;
    // the umask may have taken more than group and others' bits: exactly 0600
    f.set_permissions(std::fs::Permissions::from_mode(0o600))?;
    // iceoryx2's `Data<State>` (repr(C)): the version as u64 (its `PackageVersion::to_u64`),
    // then the counter (u32) and padding to 16 bytes
    let version = iceoryx2_bb_elementary::package_version::PackageVersion::get().to_u64();
    let mut bytes = [0u8; 16];
    bytes[..8].copy_from_slice(&version.to_ne_bytes());
    let written = f.write_all(&bytes).and_then(|()| f.sync_all());
    if let Err(e) = written {
        let _ = std::fs::remove_file(&path);
        return Err(e);
    }
    Ok(path)
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
        remove_prefixed(dir.path(), &run_prefix(me, 2), uid);
        assert!(!dir.path().join(&names[1]).exists());
        assert!(dir.path().join("user_prefix_seg").exists());
    }

    /// The clean-up at the end of a run removes the entries with the run's prefix that belong
    /// to the user running it, and keeps another user's under the same prefix.
    #[test]
    fn the_end_of_run_clean_up_keeps_another_users_entries_under_the_prefix() {
        let dir = tempfile::tempdir().unwrap();
        let uid = nix::unistd::geteuid().as_raw();
        let prefix = run_prefix(std::process::id(), 7);
        let (mine, theirs) = (format!("{prefix}seg"), format!("{prefix}planted"));
        for n in [&mine, &theirs, &"other_seg".to_string()] {
            std::fs::write(dir.path().join(n), b"x").unwrap();
        }
        // another user's entry: nobody's where we may make one (as root); else seen as
        // another user's by running the clean-up under another uid
        let (owner, other_uid) = if uid == 0 {
            std::os::unix::fs::chown(dir.path().join(&theirs), Some(65534), Some(65534)).unwrap();
            (uid, 65534)
        } else {
            (uid, uid + 1)
        };
        if uid == 0 {
            assert_eq!(remove_prefixed(dir.path(), &prefix, owner), 1);
            assert!(!dir.path().join(&mine).exists());
            assert!(
                dir.path().join(&theirs).exists(),
                "another user's entry removed"
            );
        } else {
            assert_eq!(remove_prefixed(dir.path(), &prefix, other_uid), 0);
            assert!(dir.path().join(&mine).exists() && dir.path().join(&theirs).exists());
        }
        assert!(dir.path().join("other_seg").exists());
    }

    /// The node counter the launcher makes is private (0600, the user's) and iceoryx2 takes
    /// it as its own: nodes are created, numbered from it, and its mode stays 0600; a second
    /// claim of the same prefix fails.
    #[test]
    fn the_node_counter_is_made_private_and_iceoryx2_numbers_its_nodes_from_it() {
        let root = tempfile::tempdir().unwrap();
        let prefix = format!("nc{}x{:08x}_", std::process::id(), random_u32());
        struct Cleanup(String);
        impl Drop for Cleanup {
            fn drop(&mut self) {
                remove_own(&self.0);
            }
        }
        let _cleanup = Cleanup(prefix.clone());
        let path = claim_node_counter(&prefix).unwrap();
        let meta = std::fs::metadata(&path).unwrap();
        assert_eq!(meta.permissions().mode() & 0o777, 0o600);
        assert_eq!(meta.uid(), nix::unistd::geteuid().as_raw());
        assert!(claim_node_counter(&prefix).is_err(), "claimed twice");
        let env = bridge::IoxEnv::isolated(root.path(), &prefix).unwrap();
        let a = bridge::FrameNode::new(&env, "counter-a").unwrap();
        let b = bridge::FrameNode::new(&env, "counter-b").unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let counter = u32::from_ne_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        assert_eq!(counter, 2, "two nodes numbered from the claimed counter");
        assert_eq!(
            std::fs::metadata(&path).unwrap().permissions().mode() & 0o777,
            0o600
        );
        // iceoryx2 made no counter of its own beside it
        let counters: Vec<String> = shm_names(Path::new(SHM_DIR))
            .into_iter()
            .filter(|n| n.starts_with(&prefix) && n.ends_with(".global_mgmt"))
            .collect();
        assert_eq!(counters.len(), 1, "{counters:?}");
        drop((a, b));
    }
}
