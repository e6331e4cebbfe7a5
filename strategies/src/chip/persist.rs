//! The chip's state saved and restored: its status, mode and registers, and the rules
//! restored registers must keep.

use super::{ALIGN_PATTERNS, Chip, ChipStatus, Mode};
use crate::params::StrategyName;
use crate::table::Table;
use drive_core::Ticks;

drive_core::persist_fields!(ChipStatus {
    mode,
    state,
    flag,
    zd,
    zdf,
    linear,
    duty,
    speed_est_rpm,
    current_ref_a,
    current_integrator,
    restarts,
    crossings,
    forced_crossings
});

/// Off, aligning (with its step and end), running, given up: codes 0..=3.
impl drive_core::Persist for Mode {
    fn save(&self, w: &mut drive_core::Writer) {
        // Fixed size: the alignment's step and end, zero in the other modes.
        let (code, step, until) = match *self {
            Mode::Off => (0, 0, Ticks::ZERO),
            Mode::Aligning { step, until } => (1, step, until),
            Mode::Running => (2, 0, Ticks::ZERO),
            Mode::GaveUp => (3, 0, Ticks::ZERO),
        };
        w.u8(code);
        drive_core::Persist::save(&step, w);
        drive_core::Persist::save(&until, w);
    }
    fn restore(&mut self, r: &mut drive_core::Reader) -> Result<(), String> {
        let code = r.u8()?;
        let (mut step, mut until) = (0u8, Ticks::ZERO);
        r.field("step", &mut step)?;
        r.field("until", &mut until)?;
        *self = match code {
            0 => Mode::Off,
            1 if usize::from(step) < ALIGN_PATTERNS.len() => Mode::Aligning { step, until },
            1 => {
                return Err(format!(
                    "step = {step} (rule: an alignment step 0..{})",
                    ALIGN_PATTERNS.len()
                ));
            }
            2 => Mode::Running,
            3 => Mode::GaveUp,
            k => return Err(format!("= {k} (rule: a mode code 0..=3)")),
        };
        Ok(())
    }
}

// The chip's registers, counters and sub-blocks; its parameters (control, strategy,
// pole pairs, ADC scale, carrier) are never read back.
drive_core::persist_fields!(Chip {
    table,
    run_table,
    pending_table,
    guard,
    shifter,
    speed,
    speed_pi,
    held_phase_a,
    descent_rpm,
    current_pi,
    supervisor,
    measurements_seen,
    linear_seen,
    start,
    start_since,
    reset,
    speed_ref_rpm,
    mode,
    restarts,
    fg,
    fg_since,
    cv,
    i_ref,
    linear,
    zd,
    zdf,
    next_pi,
    read_slot,
    read_sum,
    read_count,
    crossings,
    pattern
} then Chip::check_restored);

impl Chip {
    /// Restored registers agree with the parameters: tables of the strategy's kind, a
    /// speed command the register holds, a voltage command within the carrier.
    pub(super) fn check_restored(&self) -> Result<(), String> {
        let six = self.name == StrategyName::SixStep120;
        for t in [Some(self.table), Some(self.run_table), self.pending_table]
            .into_iter()
            .flatten()
        {
            if six != matches!(t, Table::SixStep) {
                return Err(format!(
                    "table {t:?} (rule: the table kind of strategy `{}`)",
                    self.name.as_str()
                ));
            }
        }
        let max = crate::params::SPEED_CMD_MAX_RPM;
        if !(0.0..=max).contains(&self.speed_ref_rpm) {
            return Err(format!(
                "speed_ref_rpm = {} (rule: 0..={max} rpm)",
                self.speed_ref_rpm
            ));
        }
        let n = self.control.current_reads;
        if self.read_slot >= n.max(1) || self.read_count > self.read_slot {
            return Err(format!(
                "read_slot = {}, read_count = {} (rule: count ≤ slot < control.current_reads = {n})",
                self.read_slot, self.read_count
            ));
        }
        if self.read_sum > self.read_count * 65535 {
            return Err(format!(
                "read_sum = {} (rule: at most {} reads of a 16-bit code)",
                self.read_sum, self.read_count
            ));
        }
        if self.cv > self.top {
            return Err(format!(
                "cv = {} (rule: at most the carrier top {})",
                self.cv, self.top
            ));
        }
        self.check_registers()
    }

    /// The registers and counts as the chip leaves them: the current command from the
    /// start-up current or the speed PI (within the current limit), the restart count up
    /// to the most allowed (one more once given up), the measurements seen no more than
    /// made, the confirmation angle the parameter's (while starting) or none, and the
    /// supervisor as its updates leave it.
    pub(super) fn check_registers(&self) -> Result<(), String> {
        use drive_core::state::{check, check_count};
        let c = &self.control;
        let top = c.current_limit_a.max(c.start_current_a);
        check((0.0..=top).contains(&self.i_ref), || {
            format!(
                "i_ref = {} (rule: 0..={top} A, the start-up current or the speed PI's output within the current limit)",
                self.i_ref
            )
        })?;
        // ui/d̂: the integrator's clamp over the schedule's least duty; nothing is held where
        // nothing is resumed.
        let held = if self.resumes() {
            self.speed_pi.gains.ui_hi.max(self.speed_pi.gains.hi) / c.schedule_min_duty
        } else {
            0.0
        };
        check((0.0..=held).contains(&self.held_phase_a), || {
            format!(
                "held_phase_a = {} (rule: 0..={held} A, the speed PI's integrator over the least scheduled duty; always 0 without control.speed_resume or with a linear-region guard)",
                self.held_phase_a
            )
        })?;
        // The descent only ever takes a meter reading, or falls from one, and only with a
        // rate to fall at.
        let top = if c.start_descent_rpm_s > 0.0 {
            self.speed.max_rpm() as f64
        } else {
            0.0
        };
        check((0.0..=top).contains(&self.descent_rpm), || {
            format!(
                "descent_rpm = {} (rule: 0..={top} rpm, at most the meter's highest reading; 0 for none, and always 0 with control.start_descent_rpm_s = 0)",
                self.descent_rpm
            )
        })?;
        let max = c.max_restarts;
        check(
            self.restarts <= max || (self.restarts == max + 1 && self.mode == Mode::GaveUp),
            || {
                format!(
                    "restarts = {} (rule: at most control.max_restarts = {max}, one more once given up)",
                    self.restarts
                )
            },
        )?;
        check(self.measurements_seen <= self.speed.measurements(), || {
            format!(
                "measurements_seen = {} (rule: at most the {} measurements made)",
                self.measurements_seen,
                self.speed.measurements()
            )
        })?;
        check_count("crossings", self.crossings)?;
        let deg = c.startup_confirm_deg;
        let confirm = self.shifter.confirmation();
        check(confirm.is_none() || confirm == Some(deg), || {
            format!(
                "shifter.confirm = {confirm:?} (rule: none, or control.startup_confirm_deg = {deg} while starting)"
            )
        })?;
        self.supervisor.check_restored_with(self.speed.max_rpm())
    }
}
