//! The committed example output (`docs/example/`) is what the documented commands write today:
//! the main job's `report.json`, `metrics.json` and plan summary against a fresh closed loop of
//! the same mission and scene (the launcher's outputs equal the closed loop's byte for byte,
//! see `system.rs`), and the `reproduce` report's headline and tables against a fresh
//! `cellsar-planner reproduce` with the same arguments. Numbers are compared to a relative
//! tolerance of 1e-6 (the imaging results to 1e-3: see `close_imaging`); wall-clock and CPU
//! times are left out.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::Command;

use harness::pipeline::closed_loop;
use harness::{bin, root};
use serde_json::Value;

/// Keys whose values are times measured on the machine that ran the example.
fn is_timing(key: &str) -> bool {
    const TIMING: [&str; 7] = [
        "_s",
        "seconds",
        "cpu",
        "wall",
        "elapsed",
        "load",
        "process_us",
    ];
    TIMING
        .iter()
        .any(|t| key.ends_with(t) || key.contains("cpu_") || key == *t)
}

fn close(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || a == b || (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1e-9)
}

/// Imaging results to 1e-3 of their size (at least of 1): rustfft chooses its kernels by the
/// CPU's features at run time, so images and what is measured on them differ in their last
/// digits between machines (measured between two x86-64 hosts: image floors by up to 4e-4 dB,
/// detection positions by 1 mm). The plan is the same to 1e-6 everywhere.
fn close_imaging(a: f64, b: f64) -> bool {
    close(a, b) || (a - b).abs() <= 1e-3 * a.abs().max(b.abs()).max(1.0)
}

/// A detections.csv field to the imaging tolerance, and positions, errors (m) and SNRs (dB) to
/// 0.05 more: the sub-pixel peak of a flat, poorly localised detection moves most (measured:
/// 4 cm on one 5.4 m-error detection of the main job between two x86-64 hosts).
fn close_csv_field(a: &str, b: &str) -> bool {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => close_imaging(x, y) || (x - y).abs() <= 0.05,
        _ => a == b,
    }
}

/// The differences of `got` from `want` but for timings, numbers compared by `near`, each naming
/// its place (`path` and below), all of them so that a failure shows the whole change.
fn json_differences(
    path: &str,
    want: &Value,
    got: &Value,
    near: fn(f64, f64) -> bool,
    out: &mut Vec<String>,
) {
    match (want, got) {
        (Value::Object(w), Value::Object(g)) => {
            for (k, wv) in w {
                if is_timing(k) {
                    continue;
                }
                match g.get(k) {
                    Some(gv) => json_differences(&format!("{path}.{k}"), wv, gv, near, out),
                    None => out.push(format!("{path}.{k}: missing in the fresh run")),
                }
            }
            for k in g.keys() {
                if !(is_timing(k) || w.contains_key(k)) {
                    out.push(format!("{path}.{k}: new in the fresh run"));
                }
            }
        }
        (Value::Array(w), Value::Array(g)) if w.len() == g.len() => {
            for (i, (wv, gv)) in w.iter().zip(g).enumerate() {
                json_differences(&format!("{path}[{i}]"), wv, gv, near, out);
            }
        }
        (Value::Array(w), Value::Array(g)) => {
            out.push(format!(
                "{path}: {} entries committed, {} fresh",
                w.len(),
                g.len()
            ));
        }
        (Value::Number(w), Value::Number(g)) => {
            let (w, g) = (w.as_f64().unwrap(), g.as_f64().unwrap());
            if !near(w, g) {
                out.push(format!("{path}: committed {w}, fresh {g}"));
            }
        }
        _ if want != got => out.push(format!("{path}: committed {want}, fresh {got}")),
        _ => {}
    }
}

fn json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn the_main_job_example_is_current() {
    let example = root().join("docs/example/main-job");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let mission = planner::Mission::from_path(&root().join("missions/default-30m.toml")).unwrap();
    closed_loop(
        &mission,
        &root().join("radar-sim/scenes/default.toml"),
        &out,
    );
    let mut differences = Vec::new();
    for (committed, fresh, near) in [
        (
            "report.json",
            "report.json",
            close_imaging as fn(f64, f64) -> bool,
        ),
        ("metrics.json", "processed/metrics.json", close_imaging),
        ("plan/summary.json", "plan/summary.json", close),
    ] {
        json_differences(
            committed,
            &json(&example.join(committed)),
            &json(&out.join(fresh)),
            near,
            &mut differences,
        );
    }
    let committed = std::fs::read_to_string(example.join("detections.csv")).unwrap();
    let fresh = std::fs::read_to_string(out.join("processed/detections.csv")).unwrap();
    let (c_rows, f_rows): (Vec<&str>, Vec<&str>) =
        (committed.lines().collect(), fresh.lines().collect());
    if c_rows.len() != f_rows.len() {
        differences.push(format!(
            "detections.csv: {} rows committed, {} fresh",
            c_rows.len(),
            f_rows.len()
        ));
    }
    for (k, (c, f)) in c_rows.iter().zip(&f_rows).enumerate() {
        let same = c.split(',').count() == f.split(',').count()
            && c.split(',')
                .zip(f.split(','))
                .all(|(a, b)| close_csv_field(a, b));
        if !same {
            differences.push(format!(
                "detections.csv line {}: committed {c}, fresh {f}",
                k + 1
            ));
        }
    }
    assert!(
        differences.is_empty(),
        "regenerate docs/example (docs/example/regenerate.sh), or fix the change:\n{}",
        differences.join("\n")
    );
}

/// The numbers of a report line, times in seconds (a number followed by " s") left out.
fn numbers(line: &str) -> Vec<f64> {
    let mut v = Vec::new();
    let chars: Vec<char> = line.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let starts = chars[i].is_ascii_digit()
            || (chars[i] == '-' && chars.get(i + 1).is_some_and(char::is_ascii_digit));
        if !starts || (i > 0 && (chars[i - 1].is_alphanumeric() || chars[i - 1] == '_')) {
            i += 1;
            continue;
        }
        let j = (i + 1..chars.len())
            .find(|&j| !(chars[j].is_ascii_digit() || chars[j] == '.'))
            .unwrap_or(chars.len());
        let text: String = chars[i..j].iter().collect();
        let seconds = chars[j..].iter().collect::<String>().starts_with(" s")
            && !chars[j..].iter().collect::<String>().starts_with(" sl");
        if let (Ok(x), false) = (text.trim_end_matches('.').parse::<f64>(), seconds) {
            v.push(x);
        }
        i = j;
    }
    v
}

#[test]
fn the_reproduce_example_is_current() {
    let example = root().join("docs/example/reproduce/REPORT.md");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("reproduce");
    let o = Command::new(bin("cellsar-planner"))
        .args(["reproduce", "--quick", "--only", "4a,4c,5,6,7,t3", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let committed = std::fs::read_to_string(&example).unwrap();
    let fresh = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    let lines = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| !l.starts_with("Total time") && !l.starts_with("Generated by"))
            .map(str::to_string)
            .collect()
    };
    let (c, f) = (lines(&committed), lines(&fresh));
    assert_eq!(c.len(), f.len(), "REPORT.md: line counts differ");
    for (k, (a, b)) in c.iter().zip(&f).enumerate() {
        // the plans table's last column is the solve time
        let strip = |l: &str| {
            if l.starts_with("| ") {
                let cells: Vec<&str> = l.trim_end_matches('|').split('|').collect();
                cells[..cells.len().saturating_sub(1)].join("|")
            } else {
                l.to_string()
            }
        };
        let (a, b) = (strip(a), strip(b));
        let (na, nb) = (numbers(&a), numbers(&b));
        assert_eq!(na.len(), nb.len(), "REPORT.md line {}: {a} / {b}", k + 1);
        for (x, y) in na.iter().zip(&nb) {
            assert!(close(*x, *y), "REPORT.md line {}: {a} / {b}", k + 1);
        }
    }
}
