//! The four binaries of this crate answer `--help` with their subcommands and exit codes, and
//! refuse an unknown subcommand with exit 2. (The system tests of what they do, with real
//! processes, are in the workspace's `tests/` crate; this test also makes `cargo test` build
//! the binaries those tests start.)
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::Command;

fn help(exe: &str) -> String {
    let o = Command::new(exe).arg("--help").output().unwrap();
    assert!(o.status.success(), "{exe} --help: {o:?}");
    String::from_utf8(o.stdout).unwrap()
}

#[test]
fn every_binary_lists_its_subcommands_and_refuses_unknown_ones() {
    let cases: [(&str, &[&str]); 4] = [
        (
            env!("CARGO_BIN_EXE_cellsar"),
            &["run", "planner", "echo", "process", "bridge", "router"],
        ),
        (
            env!("CARGO_BIN_EXE_cellsar-planner"),
            &["plan", "reproduce", "serve", "dmin"],
        ),
        (
            env!("CARGO_BIN_EXE_cellsar-radar-sim"),
            &[
                "simulate",
                "process",
                "closed-loop",
                "echo",
                "process-service",
            ],
        ),
        (env!("CARGO_BIN_EXE_cellsar-bridge"), &[]),
    ];
    for (exe, subcommands) in cases {
        let text = help(exe);
        for s in subcommands {
            assert!(
                text.lines().any(|l| l.trim_start().starts_with(s)),
                "{exe} --help does not list {s}:\n{text}"
            );
        }
        let o = Command::new(exe)
            .arg("no-such-subcommand")
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{exe}: {o:?}");
    }
    assert!(help(env!("CARGO_BIN_EXE_cellsar")).contains("Exit codes"));
}
