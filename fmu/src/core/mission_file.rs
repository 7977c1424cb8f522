//! Finding and reading the mission file (bounded in size) and applying the FMI parameters on
//! top of its `[params]`.

use super::*;

/// Largest mission file the FMU reads (16 MiB): a larger file (or a device such as `/dev/zero`)
/// is refused with an error naming it instead of exhausting the importer's memory.
pub const MAX_MISSION_FILE_BYTES: u64 = 16 * 1024 * 1024;

/// Reads a mission file as UTF-8 text, at most [`MAX_MISSION_FILE_BYTES`]; errors name the file.
pub fn read_mission_text(path: &Path) -> Result<String, FmuError> {
    use std::io::Read as _;
    let shown = path.display();
    let too_large = || {
        FmuError::error(format!(
            "mission file {shown} is larger than the limit of {MAX_MISSION_FILE_BYTES} bytes"
        ))
    };
    let cannot =
        |e: std::io::Error| FmuError::error(format!("cannot read mission file {shown}: {e}"));
    let file = std::fs::File::open(path).map_err(cannot)?;
    if file.metadata().map_err(cannot)?.len() > MAX_MISSION_FILE_BYTES {
        return Err(too_large());
    }
    // devices and growing files report a wrong length: read one byte past the limit to tell
    let mut bytes = Vec::new();
    file.take(MAX_MISSION_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > MAX_MISSION_FILE_BYTES {
        return Err(too_large());
    }
    String::from_utf8(bytes).map_err(|e| {
        FmuError::error(format!(
            "cannot read mission file {shown}: not UTF-8 text ({e})"
        ))
    })
}

impl PlannerCore {
    /// Finds the mission file: absolute as given; relative in `resources`, then in the working
    /// directory.
    pub(super) fn mission_path(&self, resources: Option<&Path>) -> Result<PathBuf, FmuError> {
        let name = self.mission_file.trim();
        if name.is_empty() {
            return Err(FmuError::error(
                "parameter `mission_file` is empty: name a mission file (TOML or JSON)",
            ));
        }
        let given = Path::new(name);
        if given.is_absolute() {
            return Ok(given.to_path_buf());
        }
        let mut tried = Vec::new();
        match resources {
            Some(dir) => {
                let p = dir.join(given);
                if p.is_file() {
                    return Ok(p);
                }
                tried.push(p.display().to_string());
            }
            None => tried.push(
                "<resources>/ (the FMU was instantiated without a usable resource location)"
                    .to_string(),
            ),
        }
        if given.is_file() {
            return Ok(given.to_path_buf());
        }
        tried.push(format!("{} (working directory)", given.display()));
        Err(FmuError::error(format!(
            "mission_file `{name}` not found; looked in: {}",
            tried.join(", ")
        )))
    }

    /// Reads the mission file and applies the parameters set through FMI on top of its `[params]`.
    /// The mission's start velocity is pinned (`start_velocity_mps` given, by the file, by FMI,
    /// or else the value of the mission's rule): a landmark move that rebuilds the mission keeps
    /// the velocity the UAV started with, from which the first slot's acceleration counts.
    pub(super) fn resolve_mission(
        &self,
        resources: Option<&Path>,
    ) -> Result<(Mission, PathBuf), FmuError> {
        let path = self.mission_path(resources)?;
        let shown = path.display().to_string();
        let text = read_mission_text(&path)?;
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        let mut file = if is_json {
            MissionFile::from_json_str(&text)
        } else {
            MissionFile::from_toml_str(&text)
        }
        .map_err(|e| FmuError::error(format!("mission file {shown}: {e}")))?;
        if let Some(v) = self.start_velocity_set()? {
            file.params.start_velocity_mps = Some(v);
        }
        if !self.params_set.is_empty() {
            let mut map = serde_json::to_value(&file.params)
                .map_err(|e| FmuError::error(format!("mission file {shown}: {e}")))?;
            if let Some(obj) = map.as_object_mut() {
                let d = Params::default();
                for name in &self.params_set {
                    // array elements (`start_m[1]`) replace only that element of the file's
                    // array (or of the default when the file has none)
                    let array = [
                        ("start_m", self.params.start_m, d.start_m),
                        ("bs_m", self.params.bs_m, d.bs_m),
                    ]
                    .into_iter()
                    .find_map(|(array, fmi, spec)| {
                        let i = match name.strip_prefix(array)? {
                            "[1]" => 0,
                            "[2]" => 1,
                            _ => return None,
                        };
                        Some((array, i, fmi[i], spec))
                    });
                    match array {
                        Some((array, i, value, spec)) => {
                            let mut v: [f64; 2] = obj
                                .get(array)
                                .and_then(|a| serde_json::from_value(a.clone()).ok())
                                .unwrap_or(spec);
                            v[i] = value;
                            obj.insert(array.to_string(), serde_json::json!(v));
                        }
                        // the jerk limit is optional: set through FMI, it is a number
                        None if name == "max_jerk_mps3" => {
                            obj.insert(name.clone(), serde_json::json!(self.params.max_jerk_mps3));
                        }
                        None => {
                            obj.insert(
                                name.clone(),
                                serde_json::json!(self.params.get_by_name(name)),
                            );
                        }
                    }
                }
            }
            file.params = serde_json::from_value(map)
                .map_err(|e| FmuError::error(format!("parameters set through FMI: {e}")))?;
        }
        let build = |file: &MissionFile| {
            Mission::from_file_struct(file).map_err(|e| {
                let text = match &e {
                    // the planner writes the value in full decimal (309 digits for -1e308)
                    planner::MissionError::Param(planner::ParamError::Invalid {
                        field,
                        value,
                        reason,
                    }) => format!("parameter `{field}` = {}: {reason}", Num(*value)),
                    other => other.to_string(),
                };
                FmuError::error(format!("mission {shown}: {text}"))
            })
        };
        let mut mission = build(&file)?;
        if file.params.start_velocity_mps.is_none() {
            file.params.start_velocity_mps = Some(mission.start_velocity_mps());
            mission = build(&file)?;
        }
        let slots = mission.slots();
        if slots > MAX_FMU_SLOTS {
            let p = mission.params();
            return Err(FmuError::error(format!(
                "mission {shown}: parameters `horizon_s` = {} s and `slot_s` = {} s give {slots} slots, more than the {MAX_FMU_SLOTS} this FMU plans at initialisation (raise `slot_s` or shorten `horizon_s`)",
                Num(p.horizon_s),
                Num(p.slot_s)
            )));
        }
        Ok((mission, path))
    }
}
