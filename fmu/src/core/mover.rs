//! [`MoverCore`]: the landmark-mover model.

use super::*;

/// The landmark mover's state. Its input is meant to be the planner's `landmark_x_m`/`landmark_y_m`
/// (the landmark of [`current_window`]); at the end of the step that reaches `move_at_s` it
/// latches that landmark plus the offset, and the planner applies its output, from the next
/// doStep on, to [`current_window`] at that time: the same window (Gauss-Seidel coupling,
/// planner first).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MoverCore {
    pub(super) move_at_s: f64,
    pub(super) offset_m: [f64; 2],
    pub(super) hold_s: f64,
    pub(super) input_m: [f64; 2],
    /// The moved landmark and when it was latched.
    pub(super) latched: Option<([f64; 2], f64)>,
}

impl Default for MoverCore {
    fn default() -> Self {
        Self {
            // mid-window on the default mission (windows of 10 s): a move at a window boundary
            // would shift the landmark of the window that ends there, which has no slot left
            move_at_s: 65.0,
            offset_m: [100.0, 0.0],
            hold_s: 0.0,
            input_m: [0.0, 0.0],
            latched: None,
        }
    }
}

impl MoverCore {
    pub(super) fn output(&self, tau_s: f64) -> Option<[f64; 2]> {
        let (pos, at) = self.latched?;
        (self.hold_s <= 0.0 || tau_s < at + self.hold_s - 1e-9).then_some(pos)
    }

    pub(super) fn get_real(&self, var: &Var, tau_s: f64) -> Result<f64, FmuError> {
        Ok(match var.vr {
            mover_vr::MOVE_AT => self.move_at_s,
            mover_vr::OFFSET_X => self.offset_m[0],
            mover_vr::OFFSET_Y => self.offset_m[1],
            mover_vr::HOLD => self.hold_s,
            mover_vr::IN_X => self.input_m[0],
            mover_vr::IN_Y => self.input_m[1],
            mover_vr::OUT_X => self.output(tau_s).map_or(f64::NAN, |p| p[0]),
            mover_vr::OUT_Y => self.output(tau_s).map_or(f64::NAN, |p| p[1]),
            _ => return Err(unknown(var)),
        })
    }

    pub(super) fn check_real(&self, var: &Var, value: f64) -> Result<(), FmuError> {
        let bad = |why: &str| {
            Err(FmuError::error(format!(
                "{} `{}` = {}: {why}",
                var.causality.name(),
                var.name,
                Num(value)
            )))
        };
        match var.vr {
            mover_vr::MOVE_AT | mover_vr::OFFSET_X | mover_vr::OFFSET_Y if !value.is_finite() => {
                bad("must be a finite number")
            }
            mover_vr::HOLD if !(value.is_finite() && value >= 0.0) => {
                bad("must be a finite number >= 0 (0: until the end)")
            }
            mover_vr::IN_X | mover_vr::IN_Y if value.is_infinite() => {
                bad("must be a finite number (the planner's landmark) or NaN (none)")
            }
            mover_vr::MOVE_AT
            | mover_vr::OFFSET_X
            | mover_vr::OFFSET_Y
            | mover_vr::HOLD
            | mover_vr::IN_X
            | mover_vr::IN_Y => Ok(()),
            _ => Err(unknown(var)),
        }
    }

    pub(super) fn set_real(&mut self, var: &Var, value: f64) -> Result<(), FmuError> {
        self.check_real(var, value)?;
        match var.vr {
            mover_vr::MOVE_AT => self.move_at_s = value,
            mover_vr::OFFSET_X => self.offset_m[0] = value,
            mover_vr::OFFSET_Y => self.offset_m[1] = value,
            mover_vr::HOLD => self.hold_s = value,
            mover_vr::IN_X => self.input_m[0] = value,
            _ => self.input_m[1] = value,
        }
        Ok(())
    }

    pub(super) fn get_bool(&self, var: &Var, tau_s: f64) -> Result<bool, FmuError> {
        match var.vr {
            mover_vr::MOVED => Ok(self.output(tau_s).is_some()),
            _ => Err(unknown(var)),
        }
    }

    /// At the end of a step: latch the moved landmark once the move time is reached. An input
    /// with one NaN and one finite coordinate is refused (the step is not taken).
    pub(super) fn step(&mut self, end_s: f64) -> Result<(), FmuError> {
        if self.input_m[0].is_nan() != self.input_m[1].is_nan() {
            return Err(FmuError::error(format!(
                "inputs (`landmark_x_m`, `landmark_y_m`) = ({}, {}) m refused: set both to finite numbers or both to NaN; the step was not taken",
                Num(self.input_m[0]),
                Num(self.input_m[1])
            )));
        }
        if self.latched.is_none()
            && end_s >= self.move_at_s - 1e-9
            && self.input_m.iter().all(|v| v.is_finite())
        {
            self.latched = Some((
                [
                    self.input_m[0] + self.offset_m[0],
                    self.input_m[1] + self.offset_m[1],
                ],
                end_s,
            ));
        }
        Ok(())
    }
}
