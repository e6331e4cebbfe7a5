//! The chip's inputs and registers as seen from outside: start and reset pins, the speed
//! command, the conduction angle, and the status read back.

use super::{Chip, ChipStatus, Mode};
use crate::params::{GuardKind, StrategyParams};
use crate::table::{OFF_FLAG, Table, flag_of};
use drive_core::Ticks;
use drive_core::error::ParamError;

impl Chip {
    /// Sets the start input at instant `now` (it must stay high for 31 master clocks).
    pub fn set_start(&mut self, now: Ticks, level: bool) {
        if level && !self.start {
            self.start_since = now;
        }
        self.start = level;
    }

    /// Sets the reset input: while high, everything is off and the restart count clears.
    pub fn set_reset(&mut self, level: bool) {
        self.reset = level;
    }

    /// Sets the speed command \[rpm\], clamped to the 14-bit register (0..16383).
    pub fn set_speed_ref(&mut self, rpm: f64) {
        if rpm.is_finite() {
            self.speed_ref_rpm = rpm.clamp(0.0, crate::params::SPEED_CMD_MAX_RPM);
        }
    }

    /// The speed command in force \[rpm\].
    pub fn speed_ref_rpm(&self) -> f64 {
        self.speed_ref_rpm
    }

    /// Changes the twelve-step conduction angle [electrical degrees], effective from the
    /// first crossing after the chip's next tick (a crossing at that tick still takes the
    /// old angle; [`Chip::table`] reports the new one at once). Rule: 120 ≤ x < 180,
    /// twelve-step strategies only.
    pub fn set_conduction_angle(&mut self, deg: f64) -> Result<(), ParamError> {
        let strategy = StrategyParams {
            name: self.name,
            conduction_angle_deg: Some(deg),
            ..StrategyParams::default()
        };
        strategy.validate()?;
        self.table = Table::TwelveStep {
            conduction_deg: strategy.conduction_deg(),
        };
        self.run_table = self.table;
        self.pending_table = Some(self.table);
        Ok(())
    }

    /// The commutation table in use.
    pub fn table(&self) -> Table {
        self.table
    }

    /// Times the plausibility supervisor restarted the drive (counted in the restarts too).
    pub fn supervisor_trips(&self) -> u32 {
        self.supervisor.trips()
    }

    /// The guard in use.
    pub fn guard_kind(&self) -> GuardKind {
        self.guard.kind
    }

    /// Everything observable.
    pub fn status(&self) -> ChipStatus {
        ChipStatus {
            mode: self.mode,
            state: if self.mode == Mode::Running {
                self.shifter.state()
            } else {
                0
            },
            flag: flag_of(&self.pattern).unwrap_or(OFF_FLAG),
            zd: self.zd,
            zdf: self.zdf,
            linear: self.linear,
            duty: self.duty(),
            speed_est_rpm: self.speed.rpm(),
            current_ref_a: self.i_ref,
            current_integrator: self.current_pi.integrator(),
            restarts: self.restarts,
            crossings: self.crossings,
            forced_crossings: self.shifter.forced_crossings(),
        }
    }
}
