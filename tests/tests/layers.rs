#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]
//! The layers of ARCHITECTURE.md, checked on the dependency trees cargo resolves: the maths
//! crates link no transport, framework or plotting crate; the protocol crate links none of the
//! pipeline's apps (plots, certificates, progress bars, the pipeline itself), so a client can
//! use it alone; the FMU links no networking.

use std::process::Command;

/// The packages in `package`'s normal dependency tree (every feature, this workspace's lock).
fn tree(package: &str) -> Vec<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(harness::root())
        .args([
            "tree",
            "--locked",
            "--all-features",
            "-e",
            "normal",
            "--prefix",
            "none",
            "--format",
            "{p}",
            "-p",
            package,
        ])
        .output()
        .expect("run cargo tree");
    assert!(
        out.status.success(),
        "cargo tree -p {package}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut names: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect();
    names.sort();
    names.dedup();
    names
}

fn assert_none(package: &str, forbidden: &[&str]) {
    let names = tree(package);
    assert!(
        names.iter().any(|n| n == package),
        "{package} not in its own tree: {names:?}"
    );
    let found: Vec<&String> = names
        .iter()
        .filter(|n| forbidden.contains(&n.as_str()))
        .collect();
    assert!(found.is_empty(), "{package} depends on {found:?}");
}

#[test]
fn the_maths_crates_link_no_transport_framework_or_plotting() {
    let forbidden = [
        "zenoh",
        "iceoryx2",
        "tokio",
        "clap",
        "indicatif",
        "plotters",
        "signal-hook",
        "bridge",
        "pipeline",
    ];
    assert_none("planner", &forbidden);
    assert_none("radar-sim", &forbidden);
}

#[test]
fn the_protocol_links_none_of_the_pipelines_apps() {
    assert_none(
        "cellsar-protocol",
        &["pipeline", "plotters", "rcgen", "indicatif", "signal-hook"],
    );
    // and it is built on the transport
    assert!(tree("cellsar-protocol").iter().any(|n| n == "bridge"));
}

#[test]
fn the_fmu_links_no_networking() {
    assert_none(
        "fmu",
        &[
            "zenoh",
            "iceoryx2",
            "tokio",
            "bridge",
            "cellsar-protocol",
            "pipeline",
            "plotters",
        ],
    );
}
