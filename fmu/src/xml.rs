//! `modelDescription.xml` for FMI 2.0 and FMI 3.0, generated from the variable table; start values
//! are read from a freshly created model core (the code that defines them).

use std::fmt::Write as _;

use crate::core::{guid, Core, FmiVersion, ModelInfo};
use crate::table::{fmi2_name, Causality, Var, VarType, LOG_CATEGORIES, UNITS};

/// Escapes text for an XML attribute value.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// An `xs:double` literal that parses back to the same value (`NaN`, `INF`, `-INF` included).
pub fn double(v: f64) -> String {
    if v.is_nan() {
        "NaN".into()
    } else if v == f64::INFINITY {
        "INF".into()
    } else if v == f64::NEG_INFINITY {
        "-INF".into()
    } else {
        format!("{v:?}")
    }
}

/// A start value.
#[derive(Debug, Clone, PartialEq)]
enum Start {
    Reals(Vec<f64>),
    Str(String),
    Bool(bool),
}

fn start_value(core: &Core, var: &Var) -> Option<Start> {
    if !matches!(var.causality, Causality::Parameter | Causality::Input) {
        return None;
    }
    match var.ty {
        VarType::Real => (0..var.len)
            .map(|i| core.get_real(var, i, 0.0).ok())
            .collect::<Option<Vec<f64>>>()
            .map(Start::Reals),
        VarType::String => core.get_string(var).ok().map(Start::Str),
        VarType::Boolean => core.get_bool(var, 0.0).ok().map(Start::Bool),
        VarType::Integer => None,
    }
}

fn header(out: &mut String, info: &ModelInfo, version: FmiVersion) {
    let token_attr = match version {
        FmiVersion::Fmi2 => "guid",
        FmiVersion::Fmi3 => "instantiationToken",
    };
    let _ = writeln!(out, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        out,
        r#"<fmiModelDescription fmiVersion="{}" modelName="{}" {token_attr}="{}" description="{}" generationTool="cellsar fmu {}" variableNamingConvention="structured"{}>"#,
        version.as_str(),
        info.identifier,
        guid(info, version),
        escape(info.description),
        env!("CARGO_PKG_VERSION"),
        if version == FmiVersion::Fmi2 {
            r#" numberOfEventIndicators="0""#
        } else {
            ""
        }
    );
    match version {
        FmiVersion::Fmi2 => {
            let _ = writeln!(
                out,
                r#"  <CoSimulation modelIdentifier="{}" canHandleVariableCommunicationStepSize="true" canInterpolateInputs="false" maxOutputDerivativeOrder="0" canRunAsynchronuously="false" canBeInstantiatedOnlyOncePerProcess="false" canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="true" canSerializeFMUstate="true" providesDirectionalDerivative="false"/>"#,
                info.identifier
            );
        }
        FmiVersion::Fmi3 => {
            let _ = writeln!(
                out,
                r#"  <CoSimulation modelIdentifier="{}" canHandleVariableCommunicationStepSize="true" canGetAndSetFMUState="true" canSerializeFMUState="true" canBeInstantiatedOnlyOncePerProcess="false" providesDirectionalDerivatives="false" providesAdjointDerivatives="false" hasEventMode="false" providesIntermediateUpdate="false" canReturnEarlyAfterIntermediateUpdate="false" maxOutputDerivativeOrder="0"/>"#,
                info.identifier
            );
        }
    }
    let used: Vec<&str> = info.vars.iter().filter_map(|v| v.unit).collect();
    let _ = writeln!(out, "  <UnitDefinitions>");
    for u in UNITS.iter().filter(|u| used.contains(&u.name)) {
        let mut exps = String::new();
        for (name, e) in [("kg", u.kg), ("m", u.m), ("s", u.s), ("rad", u.rad)] {
            if e != 0 {
                let _ = write!(exps, r#" {name}="{e}""#);
            }
        }
        let _ = writeln!(
            out,
            r#"    <Unit name="{}"><BaseUnit{exps}/></Unit>"#,
            escape(u.name)
        );
    }
    let _ = writeln!(out, "  </UnitDefinitions>");
    let _ = writeln!(out, "  <LogCategories>");
    for c in LOG_CATEGORIES {
        let _ = writeln!(
            out,
            r#"    <Category name="{}" description="{}"/>"#,
            c.name,
            escape(c.description)
        );
    }
    let _ = writeln!(out, "  </LogCategories>");
    let (start, stop, step) = info.default_experiment;
    let _ = writeln!(
        out,
        r#"  <DefaultExperiment startTime="{}" stopTime="{}" stepSize="{}"/>"#,
        double(start),
        double(stop),
        double(step)
    );
}

fn common_attrs(var: &Var, name: &str, vr: u32) -> String {
    let mut a = format!(
        r#"name="{}" valueReference="{vr}" causality="{}" variability="{}""#,
        escape(name),
        var.causality.name(),
        var.variability.name()
    );
    if var.is_calculated() {
        a.push_str(r#" initial="calculated""#);
    }
    if !var.description.is_empty() {
        let _ = write!(a, r#" description="{}""#, escape(var.description));
    }
    a
}

/// The FMI 2.0 model description.
pub fn fmi2(info: &ModelInfo) -> String {
    let core = Core::new(info.kind);
    let mut out = String::new();
    header(&mut out, info, FmiVersion::Fmi2);
    let _ = writeln!(out, "  <ModelVariables>");
    let mut index = 0usize;
    let mut outputs = Vec::new();
    let mut initial_unknowns = Vec::new();
    for var in info.vars.iter().filter(|v| !v.fmi3_only()) {
        let start = start_value(&core, var);
        for i in 0..var.len {
            index += 1;
            let name = fmi2_name(var, i);
            let mut typed = format!("<{}", var.ty.fmi2_name());
            match &start {
                Some(Start::Reals(v)) => {
                    let _ = write!(typed, r#" start="{}""#, double(v[i]));
                }
                Some(Start::Str(s)) => {
                    let _ = write!(typed, r#" start="{}""#, escape(s));
                }
                Some(Start::Bool(b)) => {
                    let _ = write!(typed, r#" start="{b}""#);
                }
                None => {}
            }
            if let Some(u) = var.unit {
                let _ = write!(typed, r#" unit="{}""#, escape(u));
            }
            typed.push_str("/>");
            let _ = writeln!(
                out,
                "    <ScalarVariable {}>{typed}</ScalarVariable>",
                common_attrs(var, &name, var.vr + i as u32)
            );
            if var.causality == Causality::Output {
                outputs.push(index);
                initial_unknowns.push(index);
            }
        }
    }
    let _ = writeln!(out, "  </ModelVariables>");
    let _ = writeln!(out, "  <ModelStructure>");
    let _ = writeln!(out, "    <Outputs>");
    for i in &outputs {
        let _ = writeln!(out, r#"      <Unknown index="{i}"/>"#);
    }
    let _ = writeln!(out, "    </Outputs>");
    let _ = writeln!(out, "    <InitialUnknowns>");
    for i in &initial_unknowns {
        let _ = writeln!(out, r#"      <Unknown index="{i}"/>"#);
    }
    let _ = writeln!(out, "    </InitialUnknowns>");
    let _ = writeln!(out, "  </ModelStructure>");
    let _ = writeln!(out, "</fmiModelDescription>");
    out
}

/// The FMI 3.0 model description.
pub fn fmi3(info: &ModelInfo) -> String {
    let core = Core::new(info.kind);
    let mut out = String::new();
    header(&mut out, info, FmiVersion::Fmi3);
    let _ = writeln!(out, "  <ModelVariables>");
    for var in info.vars {
        let elem = var.ty.fmi3_name();
        let mut attrs = common_attrs(var, var.name, var.vr);
        let start = start_value(&core, var);
        match &start {
            Some(Start::Reals(v)) => {
                let list: Vec<String> = v.iter().map(|x| double(*x)).collect();
                let _ = write!(attrs, r#" start="{}""#, list.join(" "));
            }
            Some(Start::Bool(b)) => {
                let _ = write!(attrs, r#" start="{b}""#);
            }
            Some(Start::Str(_)) | None => {}
        }
        if let Some(u) = var.unit {
            let _ = write!(attrs, r#" unit="{}""#, escape(u));
        }
        let mut children = String::new();
        if let Some(Start::Str(s)) = &start {
            let _ = write!(children, r#"<Start value="{}"/>"#, escape(s));
        }
        if var.len > 1 {
            let _ = write!(children, r#"<Dimension start="{}"/>"#, var.len);
        }
        if children.is_empty() {
            let _ = writeln!(out, "    <{elem} {attrs}/>");
        } else {
            let _ = writeln!(out, "    <{elem} {attrs}>{children}</{elem}>");
        }
    }
    let _ = writeln!(out, "  </ModelVariables>");
    let _ = writeln!(out, "  <ModelStructure>");
    for var in info
        .vars
        .iter()
        .filter(|v| v.causality == Causality::Output)
    {
        let _ = writeln!(out, r#"    <Output valueReference="{}"/>"#, var.vr);
    }
    for var in info
        .vars
        .iter()
        .filter(|v| v.causality == Causality::Output)
    {
        let _ = writeln!(out, r#"    <InitialUnknown valueReference="{}"/>"#, var.vr);
    }
    let _ = writeln!(out, "  </ModelStructure>");
    let _ = writeln!(out, "</fmiModelDescription>");
    out
}

/// The model description of `info` for `version`.
pub fn model_description(info: &ModelInfo, version: FmiVersion) -> String {
    match version {
        FmiVersion::Fmi2 => fmi2(info),
        FmiVersion::Fmi3 => fmi3(info),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::PLANNER_INFO;

    #[test]
    fn doubles_round_trip() {
        for v in [
            0.1,
            150e6,
            -1000.0,
            std::f64::consts::FRAC_PI_4,
            1e-300,
            5e300,
        ] {
            assert_eq!(double(v).parse::<f64>().unwrap(), v);
        }
        assert_eq!(double(f64::NAN), "NaN");
        assert_eq!(double(f64::INFINITY), "INF");
    }

    #[test]
    fn fmi2_lists_flattened_arrays_and_spec_defaults() {
        let x = fmi2(&PLANNER_INFO);
        assert!(
            x.contains(r#"name="start_m[1]" valueReference="10""#),
            "{x}"
        );
        assert!(x.contains(r#"name="start_m[2]" valueReference="11""#));
        assert!(x.contains(r#"<Real start="-1000.0" unit="m"/>"#));
        assert!(x.contains(r#"<Real start="150000000.0" unit="Hz"/>"#));
        assert!(x.contains(r#"<String start="default_mission.toml"/>"#));
        assert!(!x.contains(r#"name="time""#));
        assert!(x.contains(r#"<Real start="NaN" unit="m"/>"#)); // landmark inputs
                                                                // the initial plan's options at the library's defaults (NaN: no cap)
        assert!(x.contains(r#"<String start="general"/>"#), "{x}");
        assert!(x.contains(r#"<Boolean start="false"/>"#), "{x}");
        assert!(x.contains(r#"name="max_extra_energy_pct" valueReference="103" causality="parameter" variability="fixed""#));
    }

    #[test]
    fn fmi3_has_time_and_arrays() {
        let x = fmi3(&PLANNER_INFO);
        assert!(x.contains(r#"<Float64 name="time" valueReference="0" causality="independent""#));
        assert!(
            x.contains(r#"start="-1000.0 -500.0" unit="m"><Dimension start="2"/></Float64>"#),
            "{x}"
        );
        assert!(x.contains(r#"<Start value="default_mission.toml"/>"#));
        assert!(x.contains(r#"<Start value="general"/>"#));
        assert!(
            x.contains(r#"<Boolean name="strict_resolution" valueReference="102" causality="parameter" variability="fixed""#)
                && x.contains(r#" start="false"/>"#),
            "{x}"
        );
    }
}
