//! Missions shared by the planner's integration tests.

use planner::{Mission, Params, Preset};

/// The default 30 landmarks and windows, started at (342, 940) m: slot 1 sees landmark 1 with
/// a heading near 330°, at the far end of the allowed arc, from where every landmark slot can
/// be resolved under the general cell (`missions/default-30m-far-start.toml`).
pub fn far_start_mission() -> Mission {
    let mut p = Params::default();
    p.start_m = [342.0, 940.0];
    let spec = planner::LandmarksSpec {
        preset: Some(Preset::Default),
        spacing_m: Some(30.0),
        ..Default::default()
    };
    Mission::new("default 30 m from (342, 940)", p, &spec).expect("the far-start mission")
}
