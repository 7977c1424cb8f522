//! Unit tests of instances.

use super::*;

#[test]
fn resource_locations() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("a b ü");
    std::fs::create_dir(&sub).unwrap();
    let s = sub.to_str().unwrap();
    let enc = s.replace(' ', "%20").replace('ü', "%C3%BC");
    assert_eq!(
        parse_resource_location(&format!("file://{enc}")).unwrap(),
        sub
    );
    assert_eq!(
        parse_resource_location(&format!("file:{enc}")).unwrap(),
        sub
    );
    assert_eq!(
        parse_resource_location(&format!("file://localhost{enc}")).unwrap(),
        sub
    );
    assert_eq!(parse_resource_location(s).unwrap(), sub);
    assert!(parse_resource_location("file://host/x").is_err());
    assert!(parse_resource_location("http://x/y").is_err());
    assert!(parse_resource_location("/does/not/exist").is_err());
    assert!(parse_resource_location("file:///a%zz").is_err());
}

fn instance(version: FmiVersion) -> Instance {
    Instance::new(
        version,
        ModelKind::Planner,
        "test",
        None,
        Logger::new(Callback::None, "test", false),
    )
}

fn vr(name: &str) -> u32 {
    table::PLANNER_VARS
        .iter()
        .find(|v| v.name == name)
        .unwrap()
        .vr
}

#[test]
fn refused_multi_value_sets_change_nothing() {
    for version in [FmiVersion::Fmi2, FmiVersion::Fmi3] {
        let mut inst = instance(version);
        let (alt, bw) = (vr("altitude_m"), vr("bandwidth_hz"));
        let e = inst
            .set_real("set", &[alt, bw], &[1100.0, f64::NAN])
            .unwrap_err();
        assert!(e.message.contains("bandwidth_hz"), "{}", e.message);
        assert!(inst
            .set_real("set", &[alt, 999_999], &[1100.0, 1.0])
            .is_err());
        // too few values for the array start_m after a good value
        if version == FmiVersion::Fmi3 {
            assert!(inst
                .set_real("set", &[alt, vr("start_m")], &[1100.0, 1.0])
                .is_err());
        }
        assert!(inst
            .set_string(
                "set",
                &[vr("mission_file"), alt],
                &["other.toml".to_string(), "x".to_string()]
            )
            .is_err());
        assert!(inst
            .set_int(
                "set",
                &[table::planner_vr::DEBUG_INJECT_PANIC, vr("replan_count")],
                &[1, 0]
            )
            .is_err());
        inst.enter_initialization("enter", Some((0.0, None)))
            .unwrap();
        let mut out = [0.0];
        inst.get_real("get", &[alt], &mut out).unwrap();
        assert_eq!(out[0], 1000.0, "{version:?}");
        let mut s = [std::ptr::null()];
        inst.get_string("get", &[vr("mission_file")], &mut s)
            .unwrap();
        // SAFETY: get_string hands out NUL-terminated strings that live until the next call.
        let text = unsafe { std::ffi::CStr::from_ptr(s[0]) };
        assert_eq!(text.to_str().unwrap(), "default_mission.toml");
        #[cfg(feature = "test-hooks")]
        assert!(
            matches!(&inst.core, Core::Planner(c) if format!("{c:?}").contains("debug_panic: 0"))
        );
        // a good multi-value set applies every value
        inst.set_real("set", &[alt, bw], &[1100.0, 100e6]).unwrap();
        inst.get_real("get", &[bw], &mut out).unwrap();
        assert_eq!(out[0], 100e6);
    }
}

#[test]
fn messages_write_extreme_numbers_short() {
    let mut inst = instance(FmiVersion::Fmi2);
    let e = inst.setup_experiment(0.0, Some(-1e308)).unwrap_err();
    assert_eq!(
        e.message,
        "stop time -1e308 must be finite and not before the start time 0"
    );
    let e = inst
        .set_real("set", &[vr("altitude_m")], &[f64::INFINITY])
        .unwrap_err();
    assert_eq!(
        e.message,
        "parameter `altitude_m` = inf: must be a finite number"
    );
    inst.mode = Mode::Step;
    let e = inst.do_step("doStep", 0.0, -1e-12).unwrap_err();
    assert_eq!(
        e.message,
        "doStep: communication step size must be > 0, got -1e-12"
    );
    let e = inst.do_step("doStep", 1e300, 1.0).unwrap_err();
    assert!(
        e.message.contains("communication point 1e300 s"),
        "{}",
        e.message
    );
}
