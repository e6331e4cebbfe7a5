//! Start-up: alignment (timed, or regulated by current), hand-over to closed loop, and
//! restarts.

use super::{ALIGN_GAIN, ALIGN_PATTERNS, Chip, HANDOVER_SECTOR, Mode, counts};
use crate::shifter::COUNTER_MAX;
use crate::table::Table;
use drive_core::{Ticks, clocks};

impl Chip {
    pub(super) fn begin_align(&mut self, now: Ticks) {
        self.mode = Mode::Aligning {
            step: 0,
            until: self.align_end(now, 0),
        };
        self.pattern = ALIGN_PATTERNS[0];
        self.linear = false;
        self.clear_reads();
        if self.align_by_current() {
            // From zero duty, regulated at every PI update of the first step.
            self.cv = 0;
            self.next_pi = Ticks(now.0 + 1).next_edge(clocks::PI_UPDATE);
        } else {
            self.cv = (self.control.startup_duty * f64::from(self.top)).round() as u32;
            self.next_pi = Ticks::NEVER;
        }
        self.speed.reset();
        self.measurements_seen = 0;
        self.linear_seen = false;
        self.supervisor.reset();
        self.speed_pi.set_integrator(0.0);
        self.i_ref = 0.0;
        self.guard.filter.reset();
    }

    /// Whether the alignment regulates its phase current (`control.align_current_a`).
    pub(super) fn align_by_current(&self) -> bool {
        self.control.align_current_a > 0.0
    }

    /// A PI update of the alignment by current: the phase current inferred from the
    /// averaged shunt reads, î = i_shunt/d, moves the duty by [`ALIGN_GAIN`] per ampere
    /// of error from `align_current_a`, within (0, 1].
    pub(super) fn align_update(&mut self, current_code: u16) {
        let sum = self.read_sum + u32::from(current_code);
        let i = f64::from(sum) / f64::from(self.read_count + 1) * self.amps_per_code;
        self.clear_reads();
        let top = f64::from(self.top);
        let d = f64::from(self.cv) / top;
        let i_phase = if self.cv > 0 { i / d } else { 0.0 };
        let d = (d + ALIGN_GAIN * (self.control.align_current_a - i_phase)).clamp(0.0, 1.0);
        self.cv = ((d * top).round() as u32).clamp(1, self.top);
    }

    /// The current command from the hand-over to the first speed measurement [A of shunt
    /// current]: `start_current_a`, or with `start_phase_current_a` that phase current
    /// times the duty in force (the shunt carries it in the on-time), within the limit.
    pub(super) fn start_current(&self) -> f64 {
        if self.control.start_phase_current_a > 0.0 {
            (self.control.start_phase_current_a * f64::from(self.cv) / f64::from(self.top))
                .min(self.control.current_limit_a)
        } else {
            self.control.start_current_a
        }
    }

    pub(super) fn align_end(&self, now: Ticks, step: usize) -> Ticks {
        let n = counts(self.control.align_s[step], clocks::ALIGN);
        Ticks(now.next_edge(clocks::ALIGN).0 + n * clocks::ALIGN.0)
    }

    /// The table from the hand-over until the first speed measurement: twelve-step no
    /// wider than `startup_conduction_deg`.
    pub(super) fn startup_table(&self) -> Table {
        match self.run_table {
            Table::TwelveStep { conduction_deg } => Table::TwelveStep {
                conduction_deg: conduction_deg.min(self.control.startup_conduction_deg),
            },
            t => t,
        }
    }

    pub(super) fn hand_over(&mut self, now: Ticks) {
        self.table = self.startup_table();
        self.pending_table = None;
        self.shifter.set_table(self.table);
        let t60 = counts(self.control.handover_t60_s, clocks::COMMUTATION).min(COUNTER_MAX);
        // u was driven by the last alignment pattern: it may still carry current.
        self.shifter.hand_over(HANDOVER_SECTOR, now, t60, false);
        self.mode = Mode::Running;
        self.crossings = 0;
        self.fg = self.table.fg(self.shifter.state());
        self.fg_since = now;
        self.current_pi.set_integrator(f64::from(self.cv));
        self.next_pi = Ticks(now.0 + 1).next_edge(clocks::PI_UPDATE);
        self.clear_reads();
    }

    pub(super) fn restart(&mut self, now: Ticks) {
        self.restarts += 1;
        if self.restarts > self.control.max_restarts {
            self.switch_off();
            self.mode = Mode::GaveUp;
        } else {
            self.begin_align(now);
        }
    }
}
