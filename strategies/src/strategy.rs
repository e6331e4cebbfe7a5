//! What every commutation strategy offers a drive, built-in or loaded from a plugin.

use crate::chip::ChipStatus;
use crate::table::Table;
use drive_core::error::ParamError;
use drive_core::{Controller, Reader, Ticks, Writer};

/// A complete chip-like controller: commutation, guard, start-up and speed/current control
/// behind one [`Controller`], plus the inputs and observables a front end needs.
///
/// The drive holds it as `Box<dyn Strategy>`, so the built-in [`crate::Chip`] and a
/// plugin are interchangeable in the bench, the FMU and the tests.
pub trait Strategy: Controller + Send {
    /// The strategy's name (e.g. `twelve-step-df`).
    fn name(&self) -> &str;
    /// Everything observable (mode, state, Z_d before and after the guard, duty, …).
    fn status(&self) -> ChipStatus;
    /// The commutation table whose state boundaries the strategy aims for (used to
    /// measure the commutation-angle error against the true rotor angle).
    fn table(&self) -> Table;
    /// Sets the start input at `now` (the chip debounces it).
    fn set_start(&mut self, now: Ticks, level: bool);
    /// Sets the reset input (while high: bridge off, restart count cleared).
    fn set_reset(&mut self, level: bool);
    /// Sets the speed command \[rpm\] (clamped to what the strategy can represent).
    fn set_speed_ref(&mut self, rpm: f64);
    /// The speed command in force \[rpm\].
    fn speed_ref_rpm(&self) -> f64;
    /// Changes the twelve-step conduction angle while running [electrical degrees,
    /// 120 ≤ x < 180], effective from the next crossing: the source's future work of moving
    /// the timing gradually toward 180°. Strategies without one refuse (the default).
    fn set_conduction_angle(&mut self, deg: f64) -> Result<(), ParamError> {
        Err(ParamError::new(
            "strategy.conduction_angle_deg",
            deg,
            "this strategy has no adjustable conduction angle",
        ))
    }
    /// An independent copy in the same state, or why there cannot be one.
    fn try_clone(&self) -> Result<Box<dyn Strategy>, String>;

    /// Writes the dynamic state (see [`drive_core::state`]), or records in `w` why it
    /// cannot.
    fn save_state(&self, w: &mut Writer) {
        w.fail(format!(
            "strategy `{}` cannot save its state (rule: a strategy saves and restores its state by value to be serialized)",
            self.name()
        ));
    }

    /// Reads back what [`Strategy::save_state`] wrote into a strategy built from the same
    /// parameters, checking every value.
    fn restore_state(&mut self, r: &mut Reader) -> Result<(), String> {
        let _ = r;
        Err(format!(
            "strategy `{}` cannot restore its state (rule: a strategy saves and restores its state by value to be deserialized)",
            self.name()
        ))
    }
}

/// A strategy's state through [`Strategy::save_state`] and [`Strategy::restore_state`].
impl drive_core::Persist for Box<dyn Strategy> {
    fn save(&self, w: &mut Writer) {
        self.save_state(w);
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        self.restore_state(r)
    }
}
