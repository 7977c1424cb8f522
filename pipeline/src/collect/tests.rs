use super::*;

fn image(aperture: u32, nx: u32, ny: u32, pixels: usize) -> ApertureImage {
    ApertureImage {
        mission_id: MissionId(7),
        aperture,
        nx,
        ny,
        centre_m: [10.0, -5.0],
        spacing_m: 0.5,
        multilook: (0..pixels).map(|i| 1.0 + i as f32).collect(),
        markers: vec![(1, 2)],
        processor: "p1".into(),
    }
}

/// An image that contradicts itself is counted and skipped, never an error, and the
/// aperture's consistent image that comes after it is taken and written; a consistent
/// copy after that is a duplicate.
#[test]
fn a_malformed_image_is_skipped_and_the_real_one_still_counts() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = Collector::new(MissionId(7), 2, dir.path()).unwrap();
    let bad = [
        image(0, 4, 3, 11),
        image(0, 4, 3, 13),
        image(0, 0, 3, 0),
        image(0, u32::MAX, u32::MAX, 0),
        ApertureImage {
            markers: vec![(4, 0)],
            ..image(0, 4, 3, 12)
        },
        ApertureImage {
            markers: vec![(0, 3)],
            ..image(0, 4, 3, 12)
        },
        ApertureImage {
            spacing_m: 0.0,
            ..image(0, 4, 3, 12)
        },
        ApertureImage {
            centre_m: [f64::NAN, 0.0],
            ..image(0, 4, 3, 12)
        },
    ];
    for (i, b) in bad.iter().enumerate() {
        assert!(image_problem(b).is_some(), "{i}");
        assert_eq!(c.add_image(b).unwrap(), Added::Malformed, "{i}");
    }
    assert_eq!(c.malformed, bad.len() as u64);
    let npy = dir.path().join("images/aperture_000.npy");
    assert!(!npy.exists());
    let good = image(0, 4, 3, 12);
    assert_eq!(image_problem(&good), None);
    assert_eq!(c.add_image(&good).unwrap(), Added::New);
    assert!(npy.is_file());
    assert_eq!(c.add_image(&good).unwrap(), Added::Duplicate);
    // another mission's or an aperture out of range: foreign, as before
    assert_eq!(c.add_image(&image(2, 4, 3, 11)).unwrap(), Added::Foreign);
    assert_eq!(
        (c.malformed, c.duplicates, c.foreign),
        (bad.len() as u64, 1, 1)
    );
    let msg = image_problem(&image(0, 4, 3, 11)).unwrap();
    assert_eq!(msg, "11 pixels for a grid of 4 × 3 = 12");
}

fn detections(aperture: u32, apertures: u32, at: &[(usize, f64, f64)]) -> ApertureDetections {
    ApertureDetections {
        mission_id: MissionId(7),
        aperture,
        apertures,
        landmark: None,
        landmark_detected: None,
        landmark_snr_db: None,
        detections: at
            .iter()
            .map(|&(a, x_m, snr_db)| crate::protocol::Detection {
                aperture: a,
                x_m,
                y_m: 1.0,
                snr_db,
                pixels: 3,
                truth_id: None,
                error_m: None,
            })
            .collect(),
        false_alarms: 0,
        process_s: 0.1,
        processor: "p1".into(),
    }
}

/// Detections that contradict themselves are counted and skipped; the aperture's
/// consistent detections that come after them are taken.
#[test]
fn malformed_detections_are_skipped_and_the_real_ones_still_count() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = Collector::new(MissionId(7), 2, dir.path()).unwrap();
    for (bad, why) in [
        (
            detections(1, 3, &[]),
            "3 apertures claimed for a mission of 2",
        ),
        (
            detections(1, 2, &[(1, 5.0, 12.0), (0, 5.0, 12.0)]),
            "a detection of aperture 0 in the message of aperture 1",
        ),
        (
            detections(1, 2, &[(1, f64::INFINITY, 12.0)]),
            "with SNR 12 dB",
        ),
        (detections(1, 2, &[(1, 5.0, f64::NAN)]), "with SNR NaN dB"),
    ] {
        let got = detections_problem(&bad, 2).unwrap();
        assert!(got.contains(why), "{why:?} in {got}");
        assert_eq!(c.add_detections(bad), Added::Malformed);
    }
    assert_eq!(c.malformed, 4);
    assert!(c.detections(1).is_none());
    let good = detections(1, 2, &[(1, 5.0, 12.0), (1, -3.0, f64::INFINITY)]);
    assert_eq!(detections_problem(&good, 2), None);
    assert_eq!(c.add_detections(good), Added::New);
    assert_eq!(c.detections(1).unwrap().detections.len(), 2);
}

/// Metrics of a mission of `n` apertures whose summaries say `verdicts` (landmark 0
/// detected or not per aperture), no detections and no false alarms: the example's
/// metrics with their apertures replaced.
fn metrics(verdicts: &[Option<bool>]) -> MissionMetrics {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/example/main-job/metrics.json");
    let mut m: Metrics = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let template = m.apertures[0].clone();
    m.apertures = verdicts
        .iter()
        .enumerate()
        .map(|(k, v)| radar_sim::run::ApertureSummary {
            aperture: k,
            landmark: Some(0),
            landmark_detected: *v,
            detections: 0,
            false_alarms: 0,
            ..template.clone()
        })
        .collect();
    MissionMetrics {
        mission_id: MissionId(7),
        apertures: verdicts.len() as u32,
        metrics: m,
        processor: "p1".into(),
    }
}

fn verdict(aperture: u32, detected: Option<bool>) -> ApertureDetections {
    ApertureDetections {
        landmark: Some(0),
        landmark_detected: detected,
        ..detections(aperture, 2, &[])
    }
}

/// Metrics are taken only once they agree with every aperture's detections: forged
/// metrics that arrive first are held, then skipped; the processor's are taken, before
/// or after the detections; metrics of another aperture count are skipped at once.
#[test]
fn metrics_are_taken_only_when_they_agree_with_the_detections() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = Collector::new(MissionId(7), 2, dir.path()).unwrap();
    // a forgery that claims every landmark detected, and one of 3 apertures
    assert_eq!(
        c.add_metrics(metrics(&[Some(true), Some(true)])),
        Added::Held
    );
    assert_eq!(
        c.add_metrics(metrics(&[Some(true), Some(true), Some(true)])),
        Added::Malformed
    );
    assert!(!c.has_metrics());
    assert_eq!(c.add_detections(verdict(0, Some(true))), Added::New);
    assert!(!c.has_metrics());
    // the last aperture's detections: the held forgery disagrees (aperture 1 missed)
    assert_eq!(c.add_detections(verdict(1, Some(false))), Added::New);
    assert!(!c.has_metrics());
    assert_eq!(c.malformed, 2);
    // the processor's own metrics agree
    let real = metrics(&[Some(true), Some(false)]);
    assert_eq!(c.add_metrics(real.clone()), Added::New);
    assert_eq!(
        c.metrics().unwrap().apertures[1].landmark_detected,
        Some(false)
    );
    assert_eq!(c.add_metrics(real.clone()), Added::Duplicate);
    // held before the detections, the processor's are taken when the detections come
    let mut c = Collector::new(MissionId(7), 2, dir.path()).unwrap();
    assert_eq!(
        c.add_metrics(metrics(&[Some(true), Some(true)])),
        Added::Held
    );
    assert_eq!(c.add_metrics(real), Added::Held);
    c.add_detections(verdict(0, Some(true)));
    c.add_detections(verdict(1, Some(false)));
    assert!(c.has_metrics());
    assert_eq!(
        c.metrics().unwrap().apertures[1].landmark_detected,
        Some(false)
    );
    assert_eq!(c.malformed, 1);
    let why = metrics_problem(
        &metrics(&[Some(true), Some(true)]).metrics,
        &c.detections,
        2,
    )
    .unwrap();
    assert!(
        why.starts_with("aperture 1: landmark Some(0) detected Some(true)"),
        "{why}"
    );
}

/// The processor's detections of aperture `k` (of 2): landmark 0 detected, two
/// detections, one of them a false alarm.
fn scored(k: u32) -> ApertureDetections {
    ApertureDetections {
        landmark: Some(0),
        landmark_detected: Some(true),
        false_alarms: 1,
        ..detections(k, 2, &[(k as usize, 5.0, 12.0), (k as usize, -3.0, 9.0)])
    }
}

/// Metrics that agree with [`scored`] on both apertures, aperture 1's summary then
/// changed by `change`.
fn scored_metrics(change: impl Fn(&mut radar_sim::run::ApertureSummary)) -> MissionMetrics {
    let mut m = metrics(&[Some(true), Some(true)]);
    for a in &mut m.metrics.apertures {
        a.detections = 2;
        a.false_alarms = 1;
    }
    change(&mut m.metrics.apertures[1]);
    m
}

/// Each of the landmark, the number of detections and the number of false alarms (not
/// only the verdict) must agree: metrics that disagree in any one of them are skipped and
/// counted, whether they come after every aperture's detections or are held before them,
/// and the processor's agreeing metrics are taken after them.
#[test]
fn metrics_disagreeing_in_landmark_detections_or_false_alarms_are_skipped() {
    type Change = fn(&mut radar_sim::run::ApertureSummary);
    let changes: [(Change, &str); 6] = [
        (
            |a| a.landmark = Some(1),
            "landmark Some(1) detected Some(true), 2 detections",
        ),
        (
            |a| a.landmark = None,
            "landmark None detected Some(true), 2 detections",
        ),
        (
            |a| a.detections = 1,
            "detected Some(true), 1 detections, 1 false alarms",
        ),
        (
            |a| a.detections = 3,
            "detected Some(true), 3 detections, 1 false alarms",
        ),
        (
            |a| a.false_alarms = 0,
            "Some(true), 2 detections, 0 false alarms",
        ),
        (
            |a| a.false_alarms = 2,
            "Some(true), 2 detections, 2 false alarms",
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    let real = scored_metrics(|_| {});
    for (change, claims) in changes {
        let forged = scored_metrics(change);
        let all = BTreeMap::from([(0, scored(0)), (1, scored(1))]);
        let why = metrics_problem(&forged.metrics, &all, 2).unwrap();
        let says = "where its detections say landmark Some(0) detected Some(true), 2, 1";
        assert!(
            why.starts_with("aperture 1: ") && why.contains(claims),
            "{why}"
        );
        assert!(why.ends_with(says), "{why}");
        // after the detections: skipped at once
        let mut c = Collector::new(MissionId(7), 2, dir.path()).unwrap();
        assert_eq!(c.add_detections(scored(0)), Added::New);
        assert_eq!(c.add_detections(scored(1)), Added::New);
        assert_eq!(c.add_metrics(forged.clone()), Added::Malformed, "{claims}");
        assert!(!c.has_metrics(), "{claims}");
        assert_eq!(c.malformed, 1, "{claims}");
        assert_eq!(c.add_metrics(real.clone()), Added::New, "{claims}");
        assert_eq!(c.metrics().unwrap().apertures[1].false_alarms, 1);
        // before them: held, then skipped when the last detections come
        let mut c = Collector::new(MissionId(7), 2, dir.path()).unwrap();
        assert_eq!(c.add_metrics(forged), Added::Held, "{claims}");
        c.add_detections(scored(0));
        c.add_detections(scored(1));
        assert!(!c.has_metrics(), "{claims}");
        assert_eq!(c.malformed, 1, "{claims}");
        assert_eq!(c.add_metrics(real.clone()), Added::New, "{claims}");
    }
    // the unchanged metrics agree
    let all = BTreeMap::from([(0, scored(0)), (1, scored(1))]);
    assert_eq!(metrics_problem(&real.metrics, &all, 2), None);
}
