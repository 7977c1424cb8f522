//! [`Core`]: one model core of either kind, dispatching get/set/step by value reference.

use super::*;

/// What a step did, for the FMI layer.
#[derive(Debug, Clone, Default)]
pub struct StepReport {
    /// A warning to return (the step itself succeeded).
    pub warning: Option<String>,
}

/// A model core.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub enum Core {
    /// The planner.
    Planner(Box<PlannerCore>),
    /// The landmark mover.
    Mover(MoverCore),
}

impl Core {
    /// A fresh core with every variable at its start value.
    pub fn new(kind: ModelKind) -> Self {
        match kind {
            ModelKind::Planner => Core::Planner(Box::default()),
            ModelKind::Mover => Core::Mover(MoverCore::default()),
        }
    }

    /// The model's static description.
    pub fn info(&self) -> &'static ModelInfo {
        match self {
            Core::Planner(_) => &PLANNER_INFO,
            Core::Mover(_) => &MOVER_INFO,
        }
    }

    /// Reads a Real element at mission time `tau_s`.
    pub fn get_real(&self, var: &Var, elem: usize, tau_s: f64) -> Result<f64, FmuError> {
        match self {
            Core::Planner(c) => c.get_real(var, elem, tau_s),
            Core::Mover(c) => c.get_real(var, tau_s),
        }
    }

    /// Checks that a Real element may be set to `value`, without setting it (multi-value sets
    /// check every value first, so a refused set changes nothing).
    pub fn check_real(&self, var: &Var, elem: usize, value: f64) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => c.check_real(var, elem, value),
            Core::Mover(c) => c.check_real(var, value),
        }
    }

    /// Sets a Real element (after [`Core::check_real`]; it checks again).
    pub fn set_real(&mut self, var: &Var, elem: usize, value: f64) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => c.set_real(var, elem, value),
            Core::Mover(c) => c.set_real(var, value),
        }
    }

    /// Reads an Integer.
    pub fn get_int(&self, var: &Var) -> Result<i32, FmuError> {
        let count = |n: usize| i32::try_from(n).unwrap_or(i32::MAX);
        match (self, var.vr) {
            (Core::Planner(c), pv::REPLAN_COUNT) => Ok(c
                .run
                .as_ref()
                .map_or(0, |r| i32::try_from(r.replans).unwrap_or(i32::MAX))),
            (Core::Planner(c), pv::SLOTS_OUT_OF_VIEW) => Ok(c
                .run
                .as_ref()
                .map_or(0, |r| count(r.eval.slots_out_of_view))),
            // the initial plan is for the parameter `resolution`; a re-plan for the paper's
            (Core::Planner(c), pv::PLAN_RESOLUTION) => Ok(crate::planning::resolution_code(
                match c.run.as_ref().map_or(0, |r| r.replans) {
                    0 => c.initial.resolution,
                    _ => crate::planning::REPLAN_RESOLUTION,
                },
            )),
            _ => Err(unknown(var)),
        }
    }

    /// Checks that an Integer may be set by value reference, without setting it.
    pub fn check_int(&self, vr: u32) -> Result<(), FmuError> {
        match (self, vr) {
            #[cfg(feature = "test-hooks")]
            (Core::Planner(_), pv::DEBUG_INJECT_PANIC) => Ok(()),
            _ => Err(FmuError::error(format!(
                "value reference {vr} is not a settable Integer"
            ))),
        }
    }

    /// Sets an Integer by value reference (only the hidden debug variable, with the
    /// `test-hooks` feature: no model has a settable Integer otherwise).
    pub fn set_int(&mut self, vr: u32, value: i32) -> Result<(), FmuError> {
        self.check_int(vr)?;
        #[cfg(feature = "test-hooks")]
        if let Core::Planner(c) = self {
            c.debug_panic = value;
        }
        #[cfg(not(feature = "test-hooks"))]
        let _ = value;
        Ok(())
    }

    /// Reads a Boolean at mission time `tau_s`.
    pub fn get_bool(&self, var: &Var, tau_s: f64) -> Result<bool, FmuError> {
        match self {
            Core::Planner(c) => c.get_bool(var, tau_s),
            Core::Mover(c) => c.get_bool(var, tau_s),
        }
    }

    /// Checks that a Boolean may be set, without setting it.
    pub fn check_bool(&self, var: &Var) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => c.check_bool(var),
            Core::Mover(_) => Err(unknown(var)),
        }
    }

    /// Sets a Boolean (after [`Core::check_bool`]; it checks again).
    pub fn set_bool(&mut self, var: &Var, value: bool) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => c.set_bool(var, value),
            Core::Mover(_) => Err(unknown(var)),
        }
    }

    /// Reads a String.
    pub fn get_string(&self, var: &Var) -> Result<String, FmuError> {
        match self {
            Core::Planner(c) => c.get_string(var),
            Core::Mover(_) => Err(unknown(var)),
        }
    }

    /// Checks that a String may be set to `value`, without setting it.
    pub fn check_string(&self, var: &Var, value: &str) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => c.check_string(var, value),
            Core::Mover(_) => Err(unknown(var)),
        }
    }

    /// Sets a String (after [`Core::check_string`]; it checks again).
    pub fn set_string(&mut self, var: &Var, value: &str) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => {
                c.check_string(var, value)?;
                c.set_string(var, value)
            }
            Core::Mover(_) => Err(unknown(var)),
        }
    }

    /// True when the outputs can be computed (the plan exists).
    pub fn is_ready(&self) -> bool {
        match self {
            Core::Planner(c) => c.run.is_some(),
            Core::Mover(_) => true,
        }
    }

    /// Computes what initialisation needs (loads and plans the mission).
    pub fn initialize(&mut self, resources: Option<&Path>, log: &dyn Log) -> Result<(), FmuError> {
        match self {
            Core::Planner(c) => c.initialize(resources, log),
            Core::Mover(_) => Ok(()),
        }
    }

    /// The mission horizon, s, once known (a step past it is refused).
    pub fn horizon_s(&self) -> Option<f64> {
        match self {
            Core::Planner(c) => c.run.as_ref().map(|r| r.mission.params().horizon_s),
            Core::Mover(_) => None,
        }
    }

    /// Runs the step from mission time `tau_s` to `tau_s + h_s`, with the inputs as set now.
    pub fn step(&mut self, tau_s: f64, h_s: f64, log: &dyn Log) -> Result<StepReport, FmuError> {
        match self {
            Core::Planner(c) => c.step(tau_s, log),
            Core::Mover(c) => {
                c.step(tau_s + h_s)?;
                Ok(StepReport::default())
            }
        }
    }

    /// Called before a get: panics when the test hook asks for it (`test-hooks` feature).
    pub fn before_get(&self) {
        #[cfg(feature = "test-hooks")]
        if let Core::Planner(c) = self {
            if c.debug_panic == PANIC_IN_GET {
                panic!("injected panic in a get call (debug_inject_panic = {PANIC_IN_GET})");
            }
        }
    }
}

pub(super) fn unknown(var: &Var) -> FmuError {
    FmuError::error(format!(
        "variable `{}` (value reference {}) cannot be accessed this way",
        var.name, var.vr
    ))
}
