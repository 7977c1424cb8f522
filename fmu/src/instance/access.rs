//! Variable access: value-reference lookup, the get/set rules of each mode and causality,
//! and the typed get/set calls.

use super::*;

/// The modes in which values can be read.
const GET_MODES: &[Mode] = &[
    Mode::Initialization,
    Mode::Step,
    Mode::Terminated,
    Mode::Error,
];

impl Instance {
    fn lookup(&self, func: &str, vr: u32) -> Result<(&'static Var, usize), FmuError> {
        table::lookup(self.core.info().vars, vr, self.version == FmiVersion::Fmi2).ok_or_else(
            || {
                FmuError::error(format!(
                    "{func}: unknown value reference {vr} (model {})",
                    self.core.info().identifier
                ))
            },
        )
    }

    fn check_get(&mut self, func: &str, var: &Var, ty: VarType) -> Result<(), FmuError> {
        self.require(func, GET_MODES)?;
        if var.ty != ty {
            return Err(FmuError::error(format!(
                "{func}: variable `{}` (value reference {}) is a {}",
                var.name,
                var.vr,
                var.ty.fmi2_name()
            )));
        }
        self.core.before_get();
        if var.is_calculated() && !self.core.is_ready() {
            if self.mode == Mode::Initialization {
                // initial unknowns are computed on demand
                self.core
                    .initialize(self.resources.as_deref(), &self.logger)?;
            } else {
                return Err(FmuError::error(format!(
                    "{func}: `{}` is not available: the mission was not planned",
                    var.name
                )));
            }
        }
        Ok(())
    }

    fn check_set(&self, func: &str, var: &Var, ty: VarType) -> Result<(), FmuError> {
        self.require(
            func,
            &[Mode::Instantiated, Mode::Initialization, Mode::Step],
        )?;
        if var.ty != ty {
            return Err(FmuError::error(format!(
                "{func}: variable `{}` (value reference {}) is a {}",
                var.name,
                var.vr,
                var.ty.fmi2_name()
            )));
        }
        match var.causality {
            Causality::Input => Ok(()),
            Causality::Parameter if self.mode != Mode::Step => Ok(()),
            Causality::Parameter => Err(FmuError::error(format!(
                "{func}: parameter `{}` is fixed: set it before ExitInitializationMode",
                var.name
            ))),
            _ => Err(FmuError::error(format!(
                "{func}: `{}` is an {} and cannot be set",
                var.name,
                var.causality.name()
            ))),
        }
    }

    fn tau(&self) -> f64 {
        self.time - self.start_time
    }

    /// Reads Real values (FMI 2: one per value reference; FMI 3: arrays take several).
    pub fn get_real(&mut self, func: &str, vrs: &[u32], out: &mut [f64]) -> Result<(), FmuError> {
        let mut k = 0;
        let len = out.len();
        for &vr in vrs {
            if vr == 0 && self.version == FmiVersion::Fmi3 {
                self.require(func, GET_MODES)?;
                *out.get_mut(k).ok_or_else(|| too_few(func, len))? = self.time;
                k += 1;
                continue;
            }
            let (var, elem) = self.lookup(func, vr)?;
            self.check_get(func, var, VarType::Real)?;
            let n = if self.version == FmiVersion::Fmi3 {
                var.len
            } else {
                1
            };
            for i in 0..n {
                let v = self.core.get_real(var, elem + i, self.tau())?;
                *out.get_mut(k).ok_or_else(|| too_few(func, len))? = v;
                k += 1;
            }
        }
        if k != out.len() {
            return Err(FmuError::error(format!(
                "{func}: {} values requested for {} value references (expected {k})",
                out.len(),
                vrs.len()
            )));
        }
        Ok(())
    }

    /// Sets Real values, all or nothing: every value reference and value is checked before the
    /// first one is set, so a refused call leaves the instance as it was.
    pub fn set_real(&mut self, func: &str, vrs: &[u32], values: &[f64]) -> Result<(), FmuError> {
        let mut todo = Vec::with_capacity(values.len());
        for &vr in vrs {
            let (var, elem) = self.lookup(func, vr)?;
            self.check_set(func, var, VarType::Real)?;
            let n = if self.version == FmiVersion::Fmi3 {
                var.len
            } else {
                1
            };
            for i in 0..n {
                let v = *values
                    .get(todo.len())
                    .ok_or_else(|| too_few(func, values.len()))?;
                self.core.check_real(var, elem + i, v)?;
                todo.push((var, elem + i, v));
            }
        }
        if todo.len() != values.len() {
            return Err(FmuError::error(format!(
                "{func}: {} values given for {} value references (expected {})",
                values.len(),
                vrs.len(),
                todo.len()
            )));
        }
        for (var, elem, v) in todo {
            self.core.set_real(var, elem, v)?;
        }
        Ok(())
    }

    /// Reads one scalar of type `ty` per value reference with `read`: the lookup and the
    /// mode and type checks that every typed Get of a scalar makes.
    fn get_scalars<T>(
        &mut self,
        func: &str,
        vrs: &[u32],
        out: &mut [T],
        ty: VarType,
        read: impl Fn(&mut Self, &'static Var) -> Result<T, FmuError>,
    ) -> Result<(), FmuError> {
        same_len(func, vrs.len(), out.len())?;
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            let (var, _) = self.lookup(func, vr)?;
            self.check_get(func, var, ty)?;
            *o = read(self, var)?;
        }
        Ok(())
    }

    /// Reads Integer values.
    pub fn get_int(&mut self, func: &str, vrs: &[u32], out: &mut [i32]) -> Result<(), FmuError> {
        self.get_scalars(func, vrs, out, VarType::Integer, |inst, var| {
            inst.core.get_int(var)
        })
    }

    /// Sets Integer values (also the hidden test variable), all or nothing.
    pub fn set_int(&mut self, func: &str, vrs: &[u32], values: &[i32]) -> Result<(), FmuError> {
        same_len(func, vrs.len(), values.len())?;
        self.require(
            func,
            &[Mode::Instantiated, Mode::Initialization, Mode::Step],
        )?;
        for &vr in vrs {
            if vr != table::planner_vr::DEBUG_INJECT_PANIC {
                let (var, _) = self.lookup(func, vr)?;
                self.check_set(func, var, VarType::Integer)?;
            }
            self.core.check_int(vr)?;
        }
        for (&vr, &v) in vrs.iter().zip(values) {
            self.core.set_int(vr, v)?;
        }
        Ok(())
    }

    /// Reads Boolean values into the C type of the FMI version (`bool` converts into either).
    pub fn get_bool<B: From<bool>>(
        &mut self,
        func: &str,
        vrs: &[u32],
        out: &mut [B],
    ) -> Result<(), FmuError> {
        self.get_scalars(func, vrs, out, VarType::Boolean, |inst, var| {
            let tau = inst.tau();
            inst.core.get_bool(var, tau).map(B::from)
        })
    }

    /// Sets Boolean values given in the C type of the FMI version (any non-zero value is
    /// true), all or nothing.
    pub fn set_bool<B: Copy + Into<i64>>(
        &mut self,
        func: &str,
        vrs: &[u32],
        values: &[B],
    ) -> Result<(), FmuError> {
        same_len(func, vrs.len(), values.len())?;
        let mut todo = Vec::with_capacity(vrs.len());
        for (&vr, &v) in vrs.iter().zip(values) {
            let (var, _) = self.lookup(func, vr)?;
            self.check_set(func, var, VarType::Boolean)?;
            self.core.check_bool(var)?;
            todo.push((var, v.into() != 0));
        }
        for (var, v) in todo {
            self.core.set_bool(var, v)?;
        }
        Ok(())
    }

    /// Reads String values; the pointers stay valid until the next GetString call.
    pub fn get_string(
        &mut self,
        func: &str,
        vrs: &[u32],
        out: &mut [*const c_char],
    ) -> Result<(), FmuError> {
        same_len(func, vrs.len(), out.len())?;
        self.strings.clear();
        for &vr in vrs {
            let (var, _) = self.lookup(func, vr)?;
            self.check_get(func, var, VarType::String)?;
            let s = self.core.get_string(var)?;
            self.strings.push(c_string(&s));
        }
        for (o, s) in out.iter_mut().zip(&self.strings) {
            *o = s.as_ptr();
        }
        Ok(())
    }

    /// Sets String values, all or nothing.
    pub fn set_string(
        &mut self,
        func: &str,
        vrs: &[u32],
        values: &[String],
    ) -> Result<(), FmuError> {
        same_len(func, vrs.len(), values.len())?;
        let mut todo = Vec::with_capacity(vrs.len());
        for (&vr, v) in vrs.iter().zip(values) {
            let (var, _) = self.lookup(func, vr)?;
            self.check_set(func, var, VarType::String)?;
            self.core.check_string(var, v)?;
            todo.push(var);
        }
        for (var, v) in todo.into_iter().zip(values) {
            self.core.set_string(var, v)?;
        }
        Ok(())
    }
}

fn too_few(func: &str, n: usize) -> FmuError {
    FmuError::error(format!("{func}: the value array (length {n}) is too short"))
}

fn same_len(func: &str, a: usize, b: usize) -> Result<(), FmuError> {
    if a == b {
        Ok(())
    } else {
        Err(FmuError::error(format!(
            "{func}: {a} value references but {b} values"
        )))
    }
}
