//! After a fall (docs/chip.md, "Resuming after a fall"). The speed PI asks no negative
//! torque, so a step down, or a start that runs past a low command, leaves it at its lower
//! limit while the rotor coasts on its friction and the error drains both integrators.
//! `control.speed_resume`: on leaving the limit, the PIs resume the current the load needed
//! before the fall. `control.start_descent_rpm_s`: after a start that ran past the command,
//! where no current was held yet to resume, the speed PI's reference follows the rotor
//! down no faster than a rate below its coast, so the PI asks current all the way down.

use super::Chip;
use super::cascade::scheduled_duty;
use crate::params::ControlParams;
use drive_core::clocks;

/// The duty d = a + i_ph/I_lr a speed `rpm` needs with a phase current `i_phase_a`:
/// [`scheduled_duty`] for a phase current rather than a shunt current, clamped alike.
fn phase_duty(c: &ControlParams, rpm: f64, i_phase_a: f64) -> f64 {
    let a = rpm.max(0.0) / c.supervisor_no_load_rpm;
    (a + i_phase_a.max(0.0) / c.supervisor_locked_rotor_a).clamp(c.schedule_min_duty, 1.0)
}

impl Chip {
    /// The speed PI's reference at an update after the start: the command, or the descent
    /// while it is above the command. Through the meter's second reading after the start
    /// the descent only follows the measured speed `rpm` up (from 0, the start's reset),
    /// because the first reading averages a rotor that was accelerating hard (661 rpm with
    /// the rotor at 990 on the built-in drive, the second 1003); from the third on it falls by `start_descent_rpm_s` per second,
    /// whatever the rotor does, and ends at the command: at the third reading for a start
    /// whose readings stayed at or below it, and (peak − command)/rate later at most. (A
    /// rotor lost before the third reading is the supervisor's, whose restart disarms it.)
    fn speed_reference(&mut self, rpm: f64) -> f64 {
        let rate = self.control.start_descent_rpm_s;
        if rate > 0.0 && self.speed.measurements() <= 2 {
            self.descent_rpm = self.descent_rpm.max(rpm);
        } else if self.descent_rpm > 0.0 {
            self.descent_rpm -= rate * clocks::PI_UPDATE.seconds();
            if self.descent_rpm <= self.speed_ref_rpm {
                self.descent_rpm = 0.0;
            }
        }
        self.speed_ref_rpm.max(self.descent_rpm)
    }

    /// Whether `control.speed_resume` acts: only with a guard without a linear region.
    pub(super) fn resumes(&self) -> bool {
        self.control.speed_resume && self.guard.linear_window_deg(0).is_none()
    }

    /// The speed PI's update after the start, with `control.speed_resume`'s preset on leaving the lower limit (a positive error after
    /// an update at the limit), for the guards without a linear region (raw and DF).
    /// A window's full-voltage time drives the rotor beside the PI's current (a 1° window
    /// alone holds ≈ 550 rpm on the built-in drive), so there the current held before the
    /// fall says nothing about what is needed after it; preset anyway, the current's short
    /// PWM on-times lengthened the windows and kicked the rotor above the command
    /// (calibrate-lm's ωm rose from 551 to 715 rpm).
    pub(super) fn speed_update(&mut self, d: f64) -> f64 {
        let rpm = f64::from(self.speed.rpm());
        let speed_error = self.speed_reference(rpm) - rpm;
        let lo = self.speed_pi.gains.lo;
        let resume = self.resumes();
        if resume && self.speed_pi.output() <= lo && speed_error > 0.0 {
            let i_ph = self.held_phase_a;
            let d_held = phase_duty(&self.control, rpm, i_ph);
            if d_held * i_ph > self.speed_pi.integrator() {
                self.speed_pi.set_integrator(d_held * i_ph);
                // The duty that current needs, as the schedule models it: the current PI
                // drained towards no duty in the coast.
                let cv = d_held * f64::from(self.top);
                if cv > self.current_pi.integrator() {
                    self.current_pi.set_integrator(cv);
                }
            }
        }
        let out = self.speed_pi.update(speed_error * d);
        // A current the limit capped was the limit's, not the load's.
        if resume && out > lo && out < self.speed_pi.gains.hi {
            let ui = self.speed_pi.integrator();
            self.held_phase_a = ui / scheduled_duty(&self.control, rpm, ui);
        }
        out
    }
}
