//! Closed-loop running: the linear-region window around the expected crossing, the
//! step-miss deadline, and one run step of the shifter, guard and supervisor.

use super::Chip;
use crate::guard::window_counts;
use crate::shifter::ShiftEvent;
use drive_core::{Sensed, Ticks, clocks};

impl Chip {
    /// Start of the linear-region window before the expected crossing (ND/LM, once t_60
    /// and the speed are measured).
    ///
    /// Not while starting: the window holds full voltage from the *expected* crossing to
    /// the detected one, and near standstill the expected instant is a poor guess (t_60
    /// changes by tens of % per sector), so a late crossing would put the whole supply on
    /// a winding of a few ohms for tens of degrees (≈ 2.5 A on the built-in motor, five
    /// times the start-up current) and throw the rotor out of step.
    ///
    /// Returns the start and, when the guard caps the region (`lm_window_capped`), its end
    /// θZC later; otherwise it lasts until the detected crossing.
    pub(super) fn window(&self) -> Option<(Ticks, Option<Ticks>)> {
        if self.starting() {
            return None;
        }
        let deg = self.guard.linear_window_deg(self.speed.rpm())?;
        let expected = self.shifter.expected_crossing()?;
        let (t60, _) = self.shifter.t60();
        let low = window_counts(t60, deg) * clocks::COMMUTATION.0;
        let start = Ticks(expected.0.saturating_sub(low));
        Some((start, self.guard.capped.then_some(Ticks(start.0 + low))))
    }

    /// Whether the linear region is in force at `now`.
    pub(super) fn in_window(&self, now: Ticks) -> bool {
        self.window()
            .is_some_and(|(start, end)| now >= start && end.is_none_or(|e| now < e))
    }

    pub(super) fn step_miss_deadline(&self) -> Ticks {
        let n = self.step_miss_clocks;
        Ticks(self.fg_since.next_edge(clocks::STEP_MISS).0 + n * clocks::STEP_MISS.0)
    }

    /// Whether the chip is still starting: closed loop, but no speed measured yet.
    pub(super) fn starting(&self) -> bool {
        self.speed.measurements() == 0
    }

    pub(super) fn run(&mut self, now: Ticks, sensed: &Sensed) {
        self.shifter
            .set_confirmation(self.starting().then_some(self.control.startup_confirm_deg));
        self.shifter.poll(now);
        let z = sensed.zc(self.shifter.zd_phase());
        let level = self.guard.detect_level(now, z);
        self.zd = z;
        self.zdf = level;
        let forced = self.shifter.forced_crossings();
        if self.shifter.observe(now, level) == ShiftEvent::Crossing {
            self.crossings += 1;
            // With an empty post part the sensed phase changed at this same edge.
            let z = sensed.zc(self.shifter.zd_phase());
            self.guard.filter.retarget(z);
            let seen = self.shifter.forced_crossings() == forced;
            if self.supervisor.crossing(seen) {
                self.restart(now);
                return;
            }
        }
        self.pattern = self.shifter.pattern();
        self.linear = self.in_window(now);
        self.linear_seen |= self.linear;
        let fg = self.table.fg(self.shifter.state());
        if fg != self.fg {
            if fg {
                self.speed.fg_rising(now);
            }
            self.fg = fg;
            self.fg_since = now;
        }
        if !self.starting() && self.table != self.run_table {
            // Start-up is over: widen to the configured angle (from the next crossing).
            self.table = self.run_table;
            self.pending_table = Some(self.table);
        }
        self.take_reads(now, sensed.current_code);
        if now >= self.next_pi {
            let implausible = self.pi_update(sensed.current_code);
            while self.next_pi <= now {
                self.next_pi += clocks::PI_UPDATE;
            }
            if implausible {
                self.restart(now);
                return;
            }
        }
        if now >= self.step_miss_deadline() {
            self.restart(now);
        }
    }
}
