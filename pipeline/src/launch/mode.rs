//! Who may read what a run writes (`cellsar run --output-mode`): by default only the user who
//! started it.
//!
//! Every writer of the launcher and its children (the atomic writers of
//! `services/os.rs` and radar-sim's `io/atomic.rs`, the logs, the plan directory, the state
//! directory) creates its files with `0o666` and its directories with `0o777`, less the
//! process's umask. The launcher sets that umask once, before it creates anything, and its
//! children inherit it, so the mode applies wherever a run's outputs are created.

use nix::sys::stat::Mode;

/// Who may read a run's outputs.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum OutputMode {
    /// The user who started the run only: directories 0700, files 0600 (umask 077 for the
    /// launcher and its children).
    #[default]
    Private,
    /// As the caller's umask says (with the usual 022: readable by everyone).
    Umask,
}

/// Sets the process umask that `mode` asks for (with [`OutputMode::Private`], the caller's
/// umask with the group's and others' bits added); the launcher's children inherit it.
pub(super) fn apply(mode: OutputMode) {
    if mode == OutputMode::Private {
        // umask(2) returns the old mask and cannot fail: keep what it masked, add the rest
        let old = nix::sys::stat::umask(Mode::from_bits_truncate(0o077));
        nix::sys::stat::umask(old | Mode::from_bits_truncate(0o077));
    }
}
