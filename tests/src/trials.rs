//! The runner of the test files whose tests decide at run time whether this machine can run
//! them (`harness = false` in `Cargo.toml`: `netns.rs`, `netns_tls.rs`, `topologies.rs`). A test
//! that needs network namespaces where they cannot be made shows as **ignored** in the runner's
//! own summary (`test [netns] NAME ... ignored`, with the reason printed once above), and runs
//! wherever the machine allows it; the command line is libtest's (filters, `--ignored`,
//! `--test-threads`, `--list`), through libtest-mimic.

use libtest_mimic::{Arguments, Trial};

/// What a test needs of the machine beyond the build.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Needs {
    /// Nothing more.
    Nothing,
    /// Network namespaces: `ip` (iproute2) and the right to run `ip netns add` (root or
    /// CAP_NET_ADMIN).
    Netns,
}

/// One test: its name (as `cargo test` filters it), what it needs, and its body (it fails by
/// panicking, as a `#[test]` does).
#[derive(Debug, Clone, Copy)]
pub struct Test {
    /// The name.
    pub name: &'static str,
    /// What it needs of the machine.
    pub needs: Needs,
    /// The body.
    pub run: fn(),
}

impl Test {
    /// A test that needs nothing more than the build.
    pub const fn plain(name: &'static str, run: fn()) -> Self {
        Self {
            name,
            needs: Needs::Nothing,
            run,
        }
    }

    /// A test that needs network namespaces.
    pub const fn netns(name: &'static str, run: fn()) -> Self {
        Self {
            name,
            needs: Needs::Netns,
            run,
        }
    }
}

/// Runs `tests` as libtest would (parsing the process's arguments) and exits with its code.
pub fn main(tests: &[Test]) -> ! {
    let args = Arguments::from_args();
    let netns_missing = if tests.iter().any(|t| t.needs == Needs::Netns) && !args.list {
        crate::netns::unavailable()
    } else {
        None
    };
    if let Some(why) = &netns_missing {
        println!("the [netns] tests are ignored on this machine: {why}");
    }
    let trials = tests
        .iter()
        .map(|t| {
            let run = t.run;
            let trial = Trial::test(t.name, move || {
                run();
                Ok(())
            });
            match t.needs {
                Needs::Nothing => trial,
                Needs::Netns => trial
                    .with_kind("netns")
                    .with_ignored_flag(netns_missing.is_some()),
            }
        })
        .collect();
    libtest_mimic::run(&args, trials).exit()
}
