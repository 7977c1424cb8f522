//! FMI 3 functions outside co-simulation without event mode (derivatives, configuration mode,
//! clock intervals and shifts, model exchange, scheduled execution): each returns an error
//! with a log message, or OK for an empty request.

use super::*;

/// `fmi3GetDirectionalDerivative`: not supported.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetDirectionalDerivative(
    instance: Fmi3Instance,
    _unknowns: *const Vr,
    _n_unknowns: usize,
    _knowns: *const Vr,
    _n_knowns: usize,
    _seed: *const f64,
    _n_seed: usize,
    _sensitivity: *mut f64,
    _n_sensitivity: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetDirectionalDerivative", |_| {
        unsupported(
            "fmi3GetDirectionalDerivative",
            "providesDirectionalDerivatives is false",
        )
    })
}

/// `fmi3GetAdjointDerivative`: not supported.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetAdjointDerivative(
    instance: Fmi3Instance,
    _unknowns: *const Vr,
    _n_unknowns: usize,
    _knowns: *const Vr,
    _n_knowns: usize,
    _seed: *const f64,
    _n_seed: usize,
    _sensitivity: *mut f64,
    _n_sensitivity: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetAdjointDerivative", |_| {
        unsupported(
            "fmi3GetAdjointDerivative",
            "providesAdjointDerivatives is false",
        )
    })
}

/// `fmi3EnterConfigurationMode`: not supported (no structural parameters).
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterConfigurationMode(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3EnterConfigurationMode", |_| {
        unsupported(
            "fmi3EnterConfigurationMode",
            "the model has no structural parameters",
        )
    })
}

/// `fmi3ExitConfigurationMode`: not supported (no structural parameters).
#[no_mangle]
pub unsafe extern "C" fn fmi3ExitConfigurationMode(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3ExitConfigurationMode", |_| {
        unsupported(
            "fmi3ExitConfigurationMode",
            "the model has no structural parameters",
        )
    })
}

/// `fmi3GetIntervalDecimal`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetIntervalDecimal(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _intervals: *mut f64,
    _qualifiers: *mut c_int,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetIntervalDecimal", |_| {
        unsupported("fmi3GetIntervalDecimal", NO_CLOCKS)
    })
}

/// `fmi3GetIntervalFraction`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetIntervalFraction(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _counters: *mut u64,
    _resolutions: *mut u64,
    _qualifiers: *mut c_int,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetIntervalFraction", |_| {
        unsupported("fmi3GetIntervalFraction", NO_CLOCKS)
    })
}

/// `fmi3GetShiftDecimal`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetShiftDecimal(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _shifts: *mut f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetShiftDecimal", |_| {
        unsupported("fmi3GetShiftDecimal", NO_CLOCKS)
    })
}

/// `fmi3GetShiftFraction`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetShiftFraction(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _counters: *mut u64,
    _resolutions: *mut u64,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetShiftFraction", |_| {
        unsupported("fmi3GetShiftFraction", NO_CLOCKS)
    })
}

/// `fmi3SetIntervalDecimal`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetIntervalDecimal(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _intervals: *const f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetIntervalDecimal", |_| {
        unsupported("fmi3SetIntervalDecimal", NO_CLOCKS)
    })
}

/// `fmi3SetIntervalFraction`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetIntervalFraction(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _counters: *const u64,
    _resolutions: *const u64,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetIntervalFraction", |_| {
        unsupported("fmi3SetIntervalFraction", NO_CLOCKS)
    })
}

/// `fmi3SetShiftDecimal`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetShiftDecimal(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _shifts: *const f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetShiftDecimal", |_| {
        unsupported("fmi3SetShiftDecimal", NO_CLOCKS)
    })
}

/// `fmi3SetShiftFraction`: no clocks.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetShiftFraction(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _counters: *const u64,
    _resolutions: *const u64,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetShiftFraction", |_| {
        unsupported("fmi3SetShiftFraction", NO_CLOCKS)
    })
}

/// `fmi3EvaluateDiscreteStates`: no event mode.
#[no_mangle]
pub unsafe extern "C" fn fmi3EvaluateDiscreteStates(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3EvaluateDiscreteStates", |_| {
        unsupported("fmi3EvaluateDiscreteStates", NO_EVENT_MODE)
    })
}

/// `fmi3UpdateDiscreteStates`: no event mode.
#[no_mangle]
pub unsafe extern "C" fn fmi3UpdateDiscreteStates(
    instance: Fmi3Instance,
    _discrete_states_need_update: *mut Fmi3Boolean,
    _terminate_simulation: *mut Fmi3Boolean,
    _nominals_changed: *mut Fmi3Boolean,
    _values_changed: *mut Fmi3Boolean,
    _next_event_time_defined: *mut Fmi3Boolean,
    _next_event_time: *mut f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3UpdateDiscreteStates", |_| {
        unsupported("fmi3UpdateDiscreteStates", NO_EVENT_MODE)
    })
}

/// `fmi3EnterContinuousTimeMode`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3EnterContinuousTimeMode(instance: Fmi3Instance) -> Fmi3Status {
    with_instance(instance, "fmi3EnterContinuousTimeMode", |_| {
        unsupported("fmi3EnterContinuousTimeMode", CS_ONLY)
    })
}

/// `fmi3CompletedIntegratorStep`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3CompletedIntegratorStep(
    instance: Fmi3Instance,
    _no_set_fmu_state_prior_to_current_point: Fmi3Boolean,
    _enter_event_mode: *mut Fmi3Boolean,
    _terminate_simulation: *mut Fmi3Boolean,
) -> Fmi3Status {
    with_instance(instance, "fmi3CompletedIntegratorStep", |_| {
        unsupported("fmi3CompletedIntegratorStep", CS_ONLY)
    })
}

/// `fmi3SetTime`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetTime(instance: Fmi3Instance, _time: f64) -> Fmi3Status {
    with_instance(instance, "fmi3SetTime", |_| {
        unsupported("fmi3SetTime", CS_ONLY)
    })
}

/// `fmi3SetContinuousStates`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3SetContinuousStates(
    instance: Fmi3Instance,
    _states: *const f64,
    _n: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3SetContinuousStates", |_| {
        unsupported("fmi3SetContinuousStates", CS_ONLY)
    })
}

/// `fmi3GetContinuousStateDerivatives`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetContinuousStateDerivatives(
    instance: Fmi3Instance,
    _derivatives: *mut f64,
    _n: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetContinuousStateDerivatives", |_| {
        unsupported("fmi3GetContinuousStateDerivatives", CS_ONLY)
    })
}

/// `fmi3GetEventIndicators`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetEventIndicators(
    instance: Fmi3Instance,
    _indicators: *mut f64,
    _n: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetEventIndicators", |_| {
        unsupported("fmi3GetEventIndicators", CS_ONLY)
    })
}

/// `fmi3GetContinuousStates`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetContinuousStates(
    instance: Fmi3Instance,
    _states: *mut f64,
    _n: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetContinuousStates", |_| {
        unsupported("fmi3GetContinuousStates", CS_ONLY)
    })
}

/// `fmi3GetNominalsOfContinuousStates`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetNominalsOfContinuousStates(
    instance: Fmi3Instance,
    _nominals: *mut f64,
    _n: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetNominalsOfContinuousStates", |_| {
        unsupported("fmi3GetNominalsOfContinuousStates", CS_ONLY)
    })
}

/// `fmi3GetNumberOfEventIndicators`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetNumberOfEventIndicators(
    instance: Fmi3Instance,
    _n: *mut usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetNumberOfEventIndicators", |_| {
        unsupported("fmi3GetNumberOfEventIndicators", CS_ONLY)
    })
}

/// `fmi3GetNumberOfContinuousStates`: model exchange only.
#[no_mangle]
pub unsafe extern "C" fn fmi3GetNumberOfContinuousStates(
    instance: Fmi3Instance,
    _n: *mut usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetNumberOfContinuousStates", |_| {
        unsupported("fmi3GetNumberOfContinuousStates", CS_ONLY)
    })
}

/// `fmi3GetOutputDerivatives`: not supported (maxOutputDerivativeOrder = 0).
#[no_mangle]
pub unsafe extern "C" fn fmi3GetOutputDerivatives(
    instance: Fmi3Instance,
    _vr: *const Vr,
    _nvr: usize,
    _orders: *const i32,
    _values: *mut f64,
    _n_values: usize,
) -> Fmi3Status {
    with_instance(instance, "fmi3GetOutputDerivatives", |_| {
        unsupported("fmi3GetOutputDerivatives", "maxOutputDerivativeOrder is 0")
    })
}

/// `fmi3ActivateModelPartition`: scheduled execution only.
#[no_mangle]
pub unsafe extern "C" fn fmi3ActivateModelPartition(
    instance: Fmi3Instance,
    _clock_reference: Vr,
    _activation_time: f64,
) -> Fmi3Status {
    with_instance(instance, "fmi3ActivateModelPartition", |_| {
        unsupported(
            "fmi3ActivateModelPartition",
            "scheduled execution is not supported",
        )
    })
}
