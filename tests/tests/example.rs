//! The committed example output (`docs/example/`) is what the documented commands write today.
//!
//! The main job's outputs (`report.json`, `metrics.json`, `detections.csv`, the plan summary)
//! are compared with a fresh `cellsar-radar-sim closed-loop` of the same mission and scene (the
//! launcher's outputs equal the closed loop's byte for byte, see `system.rs`), twice: with the
//! native kernels and with the portable ones (`CELLSAR_KERNELS=portable`, see
//! `radar_sim::kernels`). The two kernel sets round differently, as two CPUs with other features
//! do, so the check holds on a machine other than the one that wrote the example only if its
//! tolerances cover that spread: running it with both shows they do, on one machine.
//!
//! What is compared, and how closely (wall-clock and CPU times are left out):
//! - **The plan** (`plan/summary.json`, and the plan's widths in the metrics) to 1e-6 relative:
//!   the planner runs no CPU-dependent kernel.
//! - **Image quantities**: an image pixel sums P = 1000 pulses (100 Hz over a 10 s window) in
//!   f32 (unit roundoff u = 2⁻²⁴ ≈ 6e-8). Two summation orders of P terms differ by at most
//!   about 2Pu ≈ 1.2e-4 of the sum of their magnitudes, so a pixel's power moves by at most
//!   δ ≈ 2.4e-4 relative (≈ 1e-3 dB); the f64 stages before it (FFTs, canceller) add
//!   nothing at this scale. Smooth functions of the pixels (floors, suppression, SNRs, measured
//!   widths) are compared at about ten times that: [`DB_TOL`], [`REL_TOL`]; a detection's
//!   sub-pixel peak and its SNR, read off a flat top, move most: they are compared at
//!   [`SNR_TOL_DB`] and within one pixel.
//! - **Counts that come from thresholds** (pixels above the CFAR threshold, detections, false
//!   alarms): only what lies within δ of its threshold can cross it. Above a threshold
//!   T = ln(1/P_fa) ≈ 13.8 on exponentially distributed power, that is a share 2δT ≈ 0.7 % of
//!   those counted; [`count_close`] allows 2 % of the count plus 2 (a Poisson margin for the
//!   small counts).
//! - **Detection**: every landmark's and object's detection as committed (Pd to one pair of its
//!   denominator); each object found or not as committed, its strongest detection matched to
//!   the committed one in the same aperture within one pixel; an object's number of detections
//!   and the false alarms per aperture as counts.
//!
//! The `reproduce` report's headline and tables are compared with a fresh
//! `cellsar-planner reproduce` with the same arguments to 1e-6 (plans only).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use harness::{bin, root};
use serde_json::{Map, Value};

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

/// Relative tolerance of the plan: the same solver steps on every machine.
const PLAN_REL_TOL: f64 = 1e-6;
/// Relative tolerance (of the value, at least of 1) of smooth image quantities.
const REL_TOL: f64 = 1e-3;
/// Tolerance of image powers in dB (10·log10(1 + 10·δ) ≈ 0.01 dB).
const DB_TOL: f64 = 0.01;
/// Tolerance of a detection's peak SNR, dB.
const SNR_TOL_DB: f64 = 0.05;
/// Tolerance of lengths measured on the image (position errors, widths), m.
const LENGTH_TOL_M: f64 = 0.01;

fn close(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan())
        || a == b
        || (a - b).abs() <= PLAN_REL_TOL * a.abs().max(b.abs()).max(1e-9)
}

/// Counts from thresholds: within 2 % of the larger plus 2 (see the module docs).
fn count_close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 2.0 + 0.02 * a.abs().max(b.abs())
}

/// Identifiers, compared exactly.
fn is_id(key: &str) -> bool {
    matches!(
        key,
        "aperture" | "landmark" | "truth_id" | "resolution_from"
    )
}

/// An image quantity of key `key` (see the module docs).
fn image_close(key: &str, a: f64, b: f64) -> bool {
    let integers = a.fract() == 0.0 && b.fract() == 0.0;
    if close(a, b) {
        true
    } else if is_id(key) || key.starts_with("worst_width") {
        false // identifiers, and the plan's cell (not measured on the image)
    } else if key.starts_with("design_false_alarm") {
        // the CFAR design's expectation over the pixels counted: a count's tolerance
        (a - b).abs() <= 0.02 * a.abs().max(b.abs()) + 1e-3
    } else if integers {
        count_close(a, b)
    } else if key.ends_with("snr_db") {
        (a - b).abs() <= SNR_TOL_DB
    } else if key.ends_with("_db") {
        (a - b).abs() <= DB_TOL
    } else if key.ends_with("_m") {
        (a - b).abs() <= LENGTH_TOL_M.max(REL_TOL * a.abs().max(b.abs()))
    } else {
        (a - b).abs() <= REL_TOL * a.abs().max(b.abs()).max(1.0)
    }
}

/// Detection probabilities and their denominators: a probability may move by one pair.
const PD_KEYS: [(&str, &str); 3] = [
    ("pd", "strong_objects"),
    ("pd_all", "strong_objects"),
    ("pd_distinct", "strong_distinct_objects"),
];

/// The differences of `got` from `want` but for timings, numbers compared by `near` (given the
/// key they stand under), each naming its place (`path` and below), all of them so that a
/// failure shows the whole change.
fn json_differences(
    path: &str,
    key: &str,
    want: &Value,
    got: &Value,
    near: fn(&str, f64, f64) -> bool,
    out: &mut Vec<String>,
) {
    match (want, got) {
        (Value::Object(w), Value::Object(g)) => {
            object_differences(path, w, g, near, out);
        }
        (Value::Array(w), Value::Array(g)) if w.len() == g.len() => {
            for (i, (wv, gv)) in w.iter().zip(g).enumerate() {
                json_differences(&format!("{path}[{i}]"), key, wv, gv, near, out);
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
            if !near(key, w, g) {
                out.push(format!("{path}: committed {w}, fresh {g}"));
            }
        }
        _ if want != got => out.push(format!("{path}: committed {want}, fresh {got}")),
        _ => {}
    }
}

/// [`json_differences`] of two objects; detection probabilities to one pair of their
/// denominator.
fn object_differences(
    path: &str,
    w: &Map<String, Value>,
    g: &Map<String, Value>,
    near: fn(&str, f64, f64) -> bool,
    out: &mut Vec<String>,
) {
    for (k, wv) in w {
        if is_timing(k) {
            continue;
        }
        let Some(gv) = g.get(k) else {
            out.push(format!("{path}.{k}: missing in the fresh run"));
            continue;
        };
        let pd = PD_KEYS.iter().find(|(p, _)| p == k);
        match (pd, wv.as_f64(), gv.as_f64()) {
            (Some((_, denominator)), Some(a), Some(b)) => {
                let n = w.get(*denominator).and_then(Value::as_f64).unwrap_or(1.0);
                if (a - b).abs() > 1.0 / n.max(1.0) + 1e-9 {
                    out.push(format!(
                        "{path}.{k}: committed {a}, fresh {b} (more than one of {n} pairs)"
                    ));
                }
            }
            _ => json_differences(&format!("{path}.{k}"), k, wv, gv, near, out),
        }
    }
    for k in g.keys() {
        if !(is_timing(k) || w.contains_key(k)) {
            out.push(format!("{path}.{k}: new in the fresh run"));
        }
    }
}

fn json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// One row of detections.csv.
struct Detection {
    x_m: f64,
    y_m: f64,
    snr_db: f64,
    pixels: f64,
    error_m: f64,
}

/// detections.csv by aperture: the detections of each object (by truth id) and the number of
/// false alarms.
type ByAperture = BTreeMap<u64, (BTreeMap<u64, Vec<Detection>>, usize)>;

fn detections(path: &Path) -> ByAperture {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("aperture,x_m,y_m,snr_db,pixels,truth_id,error_m"),
        "{}: header",
        path.display()
    );
    let mut out = ByAperture::new();
    for (k, line) in lines.enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 7, "{} line {}: {line}", path.display(), k + 2);
        let num = |i: usize| -> f64 {
            f[i].parse()
                .unwrap_or_else(|e| panic!("{} line {}: {e}", path.display(), k + 2))
        };
        let entry = out.entry(num(0) as u64).or_default();
        if f[5].is_empty() {
            entry.1 += 1;
        } else {
            entry.0.entry(num(5) as u64).or_default().push(Detection {
                x_m: num(1),
                y_m: num(2),
                snr_db: num(3),
                pixels: num(4),
                error_m: num(6),
            });
        }
    }
    out
}

/// The differences of the fresh detections from the committed ones: per aperture, every object
/// detected as committed (detected or not, exactly), its strongest detection within `pixel_m`
/// of the committed one with its SNR, error and size, and its number of detections and the
/// false alarms as counts from thresholds ([`count_close`]: a second peak of an object, or a
/// false alarm, that lies within rounding of its threshold may come or go on another CPU).
fn detection_differences(want: &ByAperture, got: &ByAperture, pixel_m: f64, out: &mut Vec<String>) {
    let empty = (BTreeMap::new(), 0);
    for a in want
        .keys()
        .chain(got.keys().filter(|a| !want.contains_key(a)))
    {
        let (w, g) = (want.get(a).unwrap_or(&empty), got.get(a).unwrap_or(&empty));
        if !count_close(w.1 as f64, g.1 as f64) {
            out.push(format!(
                "detections.csv aperture {a}: {} false alarms committed, {} fresh",
                w.1, g.1
            ));
        }
        for id in
            w.0.keys()
                .chain(g.0.keys().filter(|id| !w.0.contains_key(id)))
        {
            let (wd, gd) = (
                w.0.get(id).map_or(&[][..], Vec::as_slice),
                g.0.get(id).map_or(&[][..], Vec::as_slice),
            );
            let strongest = |d: &[Detection]| {
                d.iter()
                    .max_by(|x, y| x.snr_db.total_cmp(&y.snr_db))
                    .map(|x| (x.x_m, x.y_m, x.snr_db, x.pixels, x.error_m))
            };
            let (Some(c), Some(f)) = (strongest(wd), strongest(gd)) else {
                if wd.len() != gd.len() {
                    out.push(format!(
                        "detections.csv aperture {a} object {id}: {} detections committed, {} fresh",
                        wd.len(),
                        gd.len()
                    ));
                }
                continue;
            };
            if !count_close(wd.len() as f64, gd.len() as f64) {
                out.push(format!(
                    "detections.csv aperture {a} object {id}: {} detections committed, {} fresh",
                    wd.len(),
                    gd.len()
                ));
            }
            let moved_m = (c.0 - f.0).hypot(c.1 - f.1);
            if moved_m > pixel_m
                || (c.2 - f.2).abs() > SNR_TOL_DB
                || (c.4 - f.4).abs() > pixel_m
                || !count_close(c.3, f.3)
            {
                out.push(format!(
                    "detections.csv aperture {a} object {id}: committed ({}, {}) m, {} dB, {} px, \
                     error {} m; fresh ({}, {}) m, {} dB, {} px, error {} m",
                    c.0, c.1, c.2, c.3, c.4, f.0, f.1, f.2, f.3, f.4
                ));
            }
        }
    }
}

/// Runs the main job's closed loop with the kernel set `kernels` into a fresh directory, and
/// compares it with the committed example; panics listing every difference.
fn check_main_job(kernels: &str) {
    let example = root().join("docs/example/main-job");
    let scene = root().join("radar-sim/scenes/default.toml");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = Command::new(bin("cellsar-radar-sim"))
        .arg("closed-loop")
        .arg(root().join("missions/default-30m.toml"))
        .arg("--scene")
        .arg(&scene)
        .arg("--out")
        .arg(&out)
        .env(radar_sim::kernels::KERNELS_ENV, kernels)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "closed-loop with {kernels} kernels: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let mut differences = Vec::new();
    for (committed, fresh, near) in [
        (
            "report.json",
            "report.json",
            image_close as fn(&str, f64, f64) -> bool,
        ),
        ("metrics.json", "processed/metrics.json", image_close),
        ("plan/summary.json", "plan/summary.json", |_: &str, a, b| {
            close(a, b)
        }),
    ] {
        json_differences(
            committed,
            "",
            &json(&example.join(committed)),
            &json(&out.join(fresh)),
            near,
            &mut differences,
        );
    }
    let pixel_m = radar_sim::config::SceneFile::from_path(&scene)
        .unwrap()
        .processing
        .pixel_m;
    detection_differences(
        &detections(&example.join("detections.csv")),
        &detections(&out.join("processed/detections.csv")),
        pixel_m,
        &mut differences,
    );
    assert!(
        differences.is_empty(),
        "with the {kernels} kernels: regenerate docs/example (docs/example/regenerate.sh), or fix \
         the change:\n{}",
        differences.join("\n")
    );
}

#[test]
fn the_main_job_example_is_current() {
    check_main_job("native");
}

/// The same with the portable kernels: the tolerances cover another rounding of every image.
#[test]
fn the_main_job_example_is_current_with_the_portable_kernels() {
    check_main_job("portable");
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

/// The tolerances pass the rounding measured between the kernel sets (and between two hosts)
/// and refuse a change a user would see.
#[test]
fn the_tolerances_tell_rounding_from_a_change() {
    // measured between the native and portable kernels of one x86-64 host
    assert!(image_close("cfar_fallback_pixels", 936.0, 939.0));
    assert!(image_close("image_floor_db", 0.6244, 0.6244 + 3.05e-4));
    assert!(image_close(
        "mean_position_error_m",
        0.09748,
        0.09748 * (1.0 + 1.8e-5)
    ));
    // changes
    assert!(!image_close("cfar_fallback_pixels", 936.0, 970.0));
    assert!(!image_close("false_alarms", 9.0, 12.0));
    assert!(!image_close("image_floor_db", 0.6244, 0.64));
    assert!(!image_close("landmark_snr_db", 47.16, 47.3));
    assert!(!image_close("worst_width_m", 18.85, 18.85 * (1.0 + 1e-5)));
    assert!(!image_close("aperture", 3.0, 4.0));
    assert!(!image_close("measured_m", 3.035, 3.06));
}

/// Detections: an object found or lost, or its strongest peak moved, is a change; a second peak
/// of an object or a false alarm near its threshold is rounding.
#[test]
fn detections_are_compared_at_their_tolerances() {
    let det = |x_m: f64, snr_db: f64| Detection {
        x_m,
        y_m: 0.0,
        snr_db,
        pixels: 40.0,
        error_m: 0.1,
    };
    let one = |ds: Vec<Detection>, false_alarms: usize| -> ByAperture {
        let mut objects = BTreeMap::new();
        if !ds.is_empty() {
            objects.insert(7, ds);
        }
        BTreeMap::from([(3, (objects, false_alarms))])
    };
    let differences = |want: &ByAperture, got: &ByAperture| {
        let mut out = Vec::new();
        detection_differences(want, got, 1.0, &mut out);
        out
    };
    let committed = one(vec![det(0.0, 40.0)], 1);
    // rounding: the same peak a little off, a second weak peak, one false alarm more
    assert!(differences(&committed, &one(vec![det(0.3, 40.02)], 1)).is_empty());
    assert!(differences(&committed, &one(vec![det(0.0, 40.0), det(9.0, 14.0)], 2)).is_empty());
    // changes: the object lost, its peak moved or weaker, false alarms well beyond rounding
    assert_eq!(differences(&committed, &one(vec![], 1)).len(), 1);
    assert_eq!(
        differences(&committed, &one(vec![det(2.5, 40.0)], 1)).len(),
        1
    );
    assert_eq!(
        differences(&committed, &one(vec![det(0.0, 39.5)], 1)).len(),
        1
    );
    assert_eq!(
        differences(&committed, &one(vec![det(0.0, 40.0)], 5)).len(),
        1
    );
}
