//! Tests of the parameters' validation and their derived values.

use super::*;

#[test]
fn defaults_are_valid_and_match_spec() {
    let p = Params::default();
    p.validate().unwrap();
    assert_eq!(p.slots(), 600);
    assert!((p.min_speed_mps() - 7.0711).abs() < 1e-3);
    // g tan 30°
    assert!(
        (p.max_accel_mps2 - 5.6619).abs() < 1e-4,
        "{}",
        p.max_accel_mps2
    );
    assert!((p.centre_offset_m() - 1000.0).abs() < 1e-9);
    // r_s from W_a = 0.5 m is the 200 m default.
    assert!((p.sensing_radius_from_antenna_m(0.5) - 200.0).abs() < 1e-9);
    // r_s is a parameter of its own (paper-notes erratum 5): another altitude keeps it, the
    // antenna's formula gives the value a mission sets for it, and an explicit one wins
    let mut low = p.clone();
    low.apply(&ParamsOverride {
        altitude_m: Some(800.0),
        ..Default::default()
    });
    assert_eq!(low.sensing_radius_m, 200.0);
    assert!((low.sensing_radius_from_antenna_m(0.5) - 160.0).abs() < 1e-9);
    low.apply(&ParamsOverride {
        sensing_radius_m: Some(160.0),
        ..Default::default()
    });
    assert_eq!((low.altitude_m, low.sensing_radius_m), (800.0, 160.0));
    // c/(B d_min) − sin η < 0 with the defaults: the range constraint is vacuous.
    assert!(p.range_sin_threshold() < 0.0);
    assert_eq!(p.range_keepout_m(), None);
}

#[test]
fn every_bad_value_names_its_field() {
    for name in Params::scalar_names() {
        for bad in [f64::NAN, f64::INFINITY, -1.0] {
            let mut p = Params::default();
            p.set_by_name(name, bad).unwrap();
            let err = p.validate().unwrap_err();
            let msg = err.to_string();
            assert!(
                msg.contains(name) || (name == "slot_s" && msg.contains("horizon_s")),
                "{name}={bad}: {msg}"
            );
        }
    }
}

/// A mission of finite but absurd numbers (1e300 m/s planned for ten minutes) is refused
/// at once: every scalar just above its bound names the field, the value and the bound.
#[test]
fn values_beyond_the_physical_envelope_name_field_value_and_bound() {
    let mut p = Params::default();
    p.max_speed_mps = 1e300;
    assert_eq!(
        p.validate().unwrap_err().to_string(),
        "parameter `max_speed_mps` = 1e300: must be at most 150 (above the fastest \
         rotary-wing flight on record, 131 m/s)"
    );
    let mut bounded = 0;
    for (name, .., range) in scalar_fields() {
        let (value, bound) = match range {
            Range::PositiveAtMost(hi, _)
            | Range::NonNegativeAtMost(hi, _)
            | Range::Closed(_, hi, _) => (hi * 1.001, hi),
            Range::Positive | Range::NonNegative | Range::Open(..) => continue,
        };
        bounded += 1;
        let mut p = Params::default();
        p.set_by_name(name, value).unwrap();
        let msg = p.validate().unwrap_err().to_string();
        assert!(
            msg.starts_with(&format!("parameter `{name}` = {}", Shown(value)))
                && msg.contains(&short(bound)),
            "{name}: {msg}"
        );
        // the bound itself is allowed
        p.set_by_name(name, bound).unwrap();
        if name != "slot_s" && name != "integration_time_s" {
            assert!(
                p.validate()
                    .err()
                    .is_none_or(|e| !e.to_string().contains(name)),
                "{name} = {bound}"
            );
        }
    }
    assert!(bounded >= 12, "{bounded}");
    // below the least bandwidth and wavelength too
    for (name, value) in [("bandwidth_hz", 1e6), ("wavelength_m", 1e-3)] {
        let mut p = Params::default();
        p.set_by_name(name, value).unwrap();
        let msg = p.validate().unwrap_err().to_string();
        assert!(msg.contains(name) && msg.contains("must lie in ["), "{msg}");
    }
    // the fields that are not plain scalars
    let far = 100_001.0;
    for (set, name) in [
        (
            Box::new(|p: &mut Params| p.start_m = [far, 0.0]) as Box<dyn Fn(&mut Params)>,
            "start_m",
        ),
        (Box::new(|p: &mut Params| p.bs_m = [0.0, -far]), "bs_m"),
        (
            Box::new(|p: &mut Params| p.max_climb_mps = 151.0),
            "max_climb_mps",
        ),
        (
            Box::new(|p: &mut Params| p.max_descent_mps = 151.0),
            "max_descent_mps",
        ),
        (
            Box::new(|p: &mut Params| {
                p.altitude = AltitudeMode::Free;
                p.min_altitude_m = Some(600.0);
                p.max_altitude_m = Some(7001.0);
            }),
            "max_altitude_m",
        ),
    ] {
        let mut p = Params::default();
        set(&mut p);
        let msg = p.validate().unwrap_err().to_string();
        assert!(msg.starts_with(&format!("parameter `{name}`")), "{msg}");
    }
}

#[test]
fn start_velocity_is_checked_by_name() {
    let mut p = Params::default();
    p.start_velocity_mps = Some([f64::NAN, 0.0]);
    assert!(p
        .validate()
        .unwrap_err()
        .to_string()
        .contains("start_velocity_mps"));
    p.start_velocity_mps = Some([40.0, 40.0]);
    let msg = p.validate().unwrap_err().to_string();
    assert!(
        msg.contains("start_velocity_mps") && msg.contains("max_speed_mps"),
        "{msg}"
    );
    p.start_velocity_mps = Some([3.0, -4.0]);
    p.validate().unwrap();
}

#[test]
fn observation_angle_must_be_inside_open_interval() {
    let mut p = Params::default();
    p.observation_angle_rad = std::f64::consts::FRAC_PI_2;
    let msg = p.validate().unwrap_err().to_string();
    assert_eq!(
        msg,
        "parameter `observation_angle_rad` = 1.5707963267948966: must lie in the open \
         interval (0, 1.5708)"
    );
}

#[test]
fn horizon_must_be_whole_number_of_slots() {
    let mut p = Params::default();
    p.horizon_s = 300.2;
    let msg = p.validate().unwrap_err().to_string();
    assert!(
        msg.contains("horizon_s") && msg.ends_with("(ratio 600.4)"),
        "{msg}"
    );
}

#[test]
fn short_numbers() {
    for (x, s) in [
        (std::f64::consts::FRAC_PI_2, "1.5708"),
        (600.0000001, "600"),
        (600.4, "600.4"),
        (2.0, "2"),
        (0.0, "0"),
        (-1.25e-7, "-0.000000125"),
        (123_456_789.0, "123456789"),
        (f64::NAN, "NaN"),
    ] {
        assert_eq!(short(x), s, "{x}");
    }
}

#[test]
fn keepout_when_threshold_positive() {
    let mut p = Params::default();
    p.bandwidth_hz = 10e6; // c/(B d) = 1.5 > 1 + sin(eta)? 1.5 - 0.707 = 0.79
    let k = p.range_sin_threshold();
    assert!(k > 0.0 && k < 1.0);
    let d = p.range_keepout_m().unwrap();
    let sin_theta = d / (d * d + p.bs_height_m.powi(2)).sqrt();
    assert!((sin_theta - k).abs() < 1e-12);
}
