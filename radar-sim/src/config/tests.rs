//! Tests of [`super`].

use super::*;

#[test]
fn defaults_validate_and_round_trip() {
    let s = SceneFile::default();
    s.validate().unwrap();
    let text = toml::to_string(&s).unwrap();
    let back = SceneFile::from_toml_str(&text, "x.toml").unwrap();
    assert_eq!(back, s);
    assert!((s.radar.sample_rate_hz() - 245.76e6).abs() < 1.0);
    // kT0F fs with F = 5 dB at 245.76 MHz: −85.0 dBm.
    let dbm = 10.0 * (s.radar.noise_power_w() * 1e3).log10();
    assert!((dbm - (-85.04)).abs() < 0.05, "{dbm}");
}

#[test]
fn errors_name_the_field() {
    let e = SceneFile::from_toml_str("[radar]\nprf_hz = -1\n", "s.toml").unwrap_err();
    assert!(e.to_string().contains("radar.prf_hz"), "{e}");
    let e = SceneFile::from_toml_str("[radar]\nprfhz = 1\n", "s.toml").unwrap_err();
    assert!(
        e.to_string().contains("s.toml") && e.to_string().contains("prfhz"),
        "{e}"
    );
    let e = SceneFile::from_toml_str("[objects]\ncount = 3\nintensity_per_km2 = 2\n", "s.toml")
        .unwrap_err();
    assert!(e.to_string().contains("objects.count"), "{e}");
    let e = SceneFile::from_toml_str("[radar]\ncp_samples = 5000\n", "s.toml").unwrap_err();
    assert!(e.to_string().contains("radar.cp_samples"), "{e}");
}

fn err(text: &str) -> String {
    SceneFile::from_toml_str(text, "s.toml")
        .unwrap_err()
        .to_string()
}

#[test]
fn prf_is_bounded_by_the_symbol_rate() {
    let r = RadarConfig::default();
    assert!((r.symbol_rate_hz() - 48_000.0).abs() < 1e-6);
    assert!((r.max_prf_hz() - 48_000.0).abs() < 1e-6);
    // at the limit: one pulse per symbol
    SceneFile::from_toml_str("[radar]\nprf_hz = 48000\n", "s.toml").unwrap();
    for prf in ["1e5", "1e7", "48000.5"] {
        let e = err(&format!("[radar]\nprf_hz = {prf}\n"));
        assert!(
            e.contains("radar.prf_hz") && e.contains("48000 Hz") && e.contains("symbols_per_pulse"),
            "{e}"
        );
    }
    // 4 symbols per pulse: at most 12 kHz
    let e = err("[radar]\nprf_hz = 20000\nsymbols_per_pulse = 4\n");
    assert!(e.contains("radar.prf_hz") && e.contains("12000 Hz"), "{e}");
}

#[test]
fn sizes_that_would_exhaust_memory_are_refused_by_field() {
    // samples per pulse
    let e =
        err("[radar]\nfft_size = 1048576\nsymbols_per_pulse = 2\ncp_samples = 0\nprf_hz = 10\n");
    assert!(
        e.contains("radar.symbols_per_pulse") && e.contains("2097152"),
        "{e}"
    );
    // the band must fit the sample rate
    let e = err("[radar]\nbandwidth_hz = 300e6\n");
    assert!(
        e.contains("radar.bandwidth_hz") && e.contains("245760000"),
        "{e}"
    );
    SceneFile::from_toml_str("[radar]\nbandwidth_hz = 150e6\n", "s.toml").unwrap();
    // grid
    let e = err("[processing]\ngrid_half_m = 1000\npixel_m = 0.4\n");
    assert!(
        e.contains("processing.grid_half_m") && e.contains("5001"),
        "{e}"
    );
    SceneFile::from_toml_str(
        "[processing]\ngrid_half_m = 819.2\npixel_m = 0.4\n",
        "s.toml",
    )
    .unwrap();
    // CFAR bands
    let e = err("[processing]\ncfar_train_px = 1000000\n");
    assert!(e.contains("processing.cfar_train_px"), "{e}");
    let e = err("[processing]\ncfar_guard_px = 1000000\n");
    assert!(e.contains("processing.cfar_guard_px"), "{e}");
    // upsampled range profile
    let e = err("[radar]\nfft_size = 262144\ncp_samples = 0\n[processing]\nupsample = 32\n");
    assert!(
        e.contains("processing.upsample") && e.contains("8388608"),
        "{e}"
    );
    // objects: the Poisson mean is checked by validate, not only when generating
    let e = err("[objects]\nintensity_per_km2 = 1e9\nradius_m = 400\n");
    assert!(e.contains("objects.intensity_per_km2"), "{e}");
    let e = err("[objects]\ncount = 2000000\n");
    assert!(e.contains("objects.count"), "{e}");
}

#[test]
fn weighting_factors() {
    assert!((Weighting::None.mainlobe_factor() - 0.886).abs() < 1e-3);
    assert!((Weighting::None.coherence_factor() - 1.0).abs() < 1e-12);
    assert!((Weighting::Hann.coherence_factor() - 35.0 / 18.0).abs() < 1e-3);
    let w = Weighting::Hann.weights(8);
    assert!((w[0] - w[7]).abs() < 1e-12 && w[3] > 0.9);
}

#[test]
fn bs_antenna_errors_name_the_field() {
    SceneFile::from_toml_str("[radar.bs_antenna]\n", "s.toml").unwrap();
    for (text, field) in [
        (
            "[radar.bs_antenna]\nbeamwidth_deg = 0\n",
            "radar.bs_antenna.beamwidth_deg",
        ),
        (
            "[radar.bs_antenna]\nbeamwidth_deg = 400\n",
            "radar.bs_antenna.beamwidth_deg",
        ),
        (
            "[radar.bs_antenna]\ndowntilt_deg = 95\n",
            "radar.bs_antenna.downtilt_deg",
        ),
        (
            "[radar.bs_antenna]\nfront_to_back_db = -3\n",
            "radar.bs_antenna.front_to_back_db",
        ),
        (
            "[radar.bs_antenna]\nsidelobe_db = 0\n",
            "radar.bs_antenna.sidelobe_db",
        ),
        (
            "[radar.bs_antenna]\nazimuth_deg = nan\n",
            "radar.bs_antenna.azimuth_deg",
        ),
    ] {
        let e = err(text);
        assert!(e.starts_with(field), "{text}: {e}");
    }
    let e = err("[radar.bs_antenna]\ntilt = 3\n");
    assert!(e.contains("tilt"), "{e}");
}

/// Values no real cell has are refused, naming the field, the value and the bound; every
/// shipped scene (and the system tests' small scene) lies within them.
#[test]
fn scenes_beyond_a_real_cell_name_field_value_and_bound() {
    let e = err("[radar]\nbandwidth_hz = 500e6\nsubcarrier_spacing_hz = 240e3\n");
    assert!(
        e.contains("radar.bandwidth_hz") && e.contains("500000000") && e.contains("400000000"),
        "{e}"
    );
    let e = err("[radar]\nsubcarrier_spacing_hz = 2e6\nfft_size = 64\ncp_samples = 16\n");
    assert!(
        e.contains("radar.subcarrier_spacing_hz") && e.contains("2000000") && e.contains("960000"),
        "{e}"
    );
    let e = err("[radar]\nnoise_figure_db = -3\n");
    assert!(
        e.contains("radar.noise_figure_db") && e.contains(">= 0 dB"),
        "{e}"
    );
    let e = err("[radar]\nsystem_loss_db = -1\n");
    assert!(
        e.contains("radar.system_loss_db") && e.contains(">= 0 dB"),
        "{e}"
    );
    // the mission's band, when the scene has none, has the same bound
    let r = RadarConfig::default();
    let e = r
        .subcarriers_for("params.bandwidth_hz", 401e6)
        .unwrap_err()
        .to_string();
    assert!(e.contains("params.bandwidth_hz"), "{e}");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut n = 0;
    for dir in ["radar-sim/scenes", "tests/data"] {
        for entry in std::fs::read_dir(root.join(dir)).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|x| x == "toml") {
                SceneFile::from_path(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                n += 1;
            }
        }
    }
    assert!(n >= 6, "{n} scenes");
}

/// The digest names the scene, not its file: comments, key order and defaults written out
/// leave it; any changed value (the cyclic prefix of the same layout) changes it.
#[test]
fn the_digest_is_the_scenes_not_the_files() {
    let a = SceneFile::from_toml_str("[radar]\nfft_size = 1024\ncp_samples = 256\n", "a").unwrap();
    let b = SceneFile::from_toml_str(
        "# the same\n[radar]\ncp_samples = 256 # as a\nfft_size = 1024\nprf_hz = 100.0\n",
        "b",
    )
    .unwrap();
    let c = SceneFile::from_toml_str("[radar]\nfft_size = 1024\ncp_samples = 128\n", "c").unwrap();
    assert_eq!(a.digest(), b.digest());
    assert_ne!(a.digest(), c.digest());
    assert_eq!(a.radar.samples_per_pulse(), c.radar.samples_per_pulse());
    assert_ne!(a.digest(), SceneFile::NO_DIGEST);
    assert_eq!(SceneFile::default().digest(), SceneFile::default().digest());
}
