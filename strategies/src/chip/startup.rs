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
        self.held_phase_a = 0.0;
        self.descent_rpm = 0.0;
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

#[cfg(test)]
mod tests {
    use super::super::tests::{chip, next, next_edge};
    use super::super::*;
    use crate::table::{OFF_FLAG, flag_of};

    #[test]
    fn start_is_debounced_for_31_master_clocks() {
        let mut c = chip(5);
        c.set_start(Ticks::ZERO, false);
        let cmd = c.tick(Ticks::ZERO, &Sensed::default());
        assert_eq!(cmd.wake_at, Ticks::NEVER);
        c.set_start(Ticks(100), true);
        let cmd = c.tick(Ticks(128), &Sensed::default());
        assert_eq!(c.status().mode, Mode::Off, "held 28 clocks only");
        assert_eq!(cmd.wake_at, Ticks(131));
        c.tick(Ticks(160), &Sensed::default());
        assert!(matches!(c.status().mode, Mode::Aligning { step: 0, .. }));
    }

    #[test]
    fn alignment_runs_the_three_steps_for_their_durations_then_hands_over() {
        // The published alignment: a fixed duty, no PI updates before the hand-over.
        let control = ControlParams {
            align_current_a: 0.0,
            ..ControlParams::default()
        };
        let mut c = Chip::new(control, StrategyParams::default(), 6, 0.5 / 4095.0, 2000).unwrap();
        let mut now = Ticks::ZERO;
        let mut cmd = c.tick(now, &Sensed::default());
        assert_eq!(cmd.pattern, ALL_FLOAT);
        // Debounce ends at 31 → first 0.64 µs edge 32: step 0 (u→v, flag 0100).
        cmd = next(&mut c, &mut now, &cmd);
        assert_eq!(now, Ticks(32));
        assert_eq!(flag_of(&cmd.pattern), Some(0b0100));
        assert_eq!(cmd.duty, 400, "startup duty 0.2 of 2000");
        // Durations on the 327.68 µs align clock: round(0.7 s) = 2136, round(38 ms) = 116,
        // round(15 ms) = 46 periods, each step starting at the next align edge.
        let a = clocks::ALIGN.0;
        let ends = [
            a * (1 + 2136),
            a * (1 + 2136 + 116),
            a * (1 + 2136 + 116 + 46),
        ];
        let flags = [0b0000, 0b0001];
        for (k, &end) in ends.iter().enumerate() {
            cmd = next(&mut c, &mut now, &cmd);
            assert_eq!(now, Ticks(end), "end of step {k}");
            if k < 2 {
                assert_eq!(flag_of(&cmd.pattern), Some(flags[k]), "step {}", k + 1);
            }
        }
        // Hand-over: closed loop in state 12 (w→v, u floating), the state for 330..360°,
        // where the last alignment pattern v→u holds the rotor (its zero-torque point).
        assert_eq!(c.status().mode, Mode::Running);
        assert_eq!(c.status().state, 12);
        assert_eq!(flag_of(&cmd.pattern), Some(0b0011));
        assert!(cmd.watch.u && !cmd.watch.v && !cmd.watch.w);
        let total_s = Ticks(ends[2]).seconds();
        assert!(
            (total_s - (0.7 + 0.038 + 0.015)).abs() < 0.5e-3,
            "{total_s}"
        );
    }

    #[test]
    fn a_step_miss_forces_off_restarts_and_gives_up_after_the_limit() {
        let mut c = chip(1);
        let mut now = Ticks::ZERO;
        let mut cmd = c.tick(now, &Sensed::default());
        while c.status().mode != Mode::Running {
            cmd = next(&mut c, &mut now, &cmd);
        }
        let handover = now;
        // No crossing ever comes (w stays below neutral): FG_c never changes.
        while c.status().restarts == 0 {
            cmd = next(&mut c, &mut now, &cmd);
        }
        // 0.05 s on the 40.96 µs clock: round(1220.7) = 1221 periods after the first edge.
        let deadline = handover.next_edge(clocks::STEP_MISS).0 + 1221 * clocks::STEP_MISS.0;
        assert_eq!(now, Ticks(deadline));
        assert!(matches!(c.status().mode, Mode::Aligning { step: 0, .. }));
        assert_eq!(flag_of(&cmd.pattern), Some(0b0100), "restarted alignment");
        while c.status().restarts == 1 {
            cmd = next(&mut c, &mut now, &cmd);
        }
        assert_eq!(c.status().mode, Mode::GaveUp);
        assert_eq!(c.status().restarts, 2);
        assert_eq!(cmd.pattern, ALL_FLOAT);
        assert_eq!(c.status().flag, OFF_FLAG);
        assert_eq!(cmd.wake_at, Ticks::NEVER);
        // Reset clears it; releasing reset starts again after the debounce.
        c.set_reset(true);
        c.tick(Ticks(now.0 + 32), &Sensed::default());
        assert_eq!(c.status().mode, Mode::Off);
        assert_eq!(c.status().restarts, 0);
        c.set_reset(false);
        c.set_start(Ticks(now.0 + 64), false);
        c.set_start(Ticks(now.0 + 64), true);
        c.tick(Ticks(now.0 + 128), &Sensed::default());
        assert!(matches!(c.status().mode, Mode::Aligning { .. }));
    }

    /// Alignment by current on a locked 0.4 Ω winding: phase current (d·12.7 − 0.7)/1.2 A,
    /// shunt current d times that. The first step regulates the inferred phase current to
    /// `align_current_a` from zero duty; the duty reached is held for the other two steps.
    #[test]
    fn alignment_by_current_regulates_the_phase_current_then_holds_the_duty() {
        let mut c = chip(5);
        let amps_per_code = 0.5 / 4095.0;
        let phase = |d: f64| ((d * 12.7 - 0.7) / 1.2).max(0.0);
        let mut now = Ticks::ZERO;
        let mut cmd = c.tick(now, &Sensed::default());
        let mut duties = Vec::new();
        while c.status().mode != Mode::Running {
            let d = f64::from(cmd.duty) / 2000.0;
            let code = (d * phase(d) / amps_per_code).round() as u16;
            now = next_edge(now, &cmd);
            cmd = c.tick(now, &Sensed::new(Abc::splat(false), code));
            if let Mode::Aligning { step, .. } = c.status().mode {
                duties.push((step, cmd.duty));
            }
        }
        assert_eq!(duties[0], (0, 0), "starts at zero duty");
        let held: Vec<u32> = duties.iter().filter(|x| x.0 > 0).map(|x| x.1).collect();
        let end = held[0];
        assert!(held.iter().all(|&d| d == end), "held through steps 1 and 2");
        let i = phase(f64::from(end) / 2000.0);
        assert!((i - 0.39).abs() < 0.02, "phase current {i} A at duty {end}");
        // Far below the fixed 20 % duty, which would drive 1.5 A into this winding.
        assert!(end < 200, "duty {end}");
    }

    #[test]
    fn start_current_is_a_phase_current_times_the_duty() {
        let mut c = chip(5);
        c.cv = 200;
        assert!((c.start_current() - 0.055).abs() < 1e-12);
        c.cv = 2000;
        assert_eq!(
            c.start_current(),
            c.control.current_limit_a,
            "capped at the limit"
        );
        c.control.start_phase_current_a = 0.0;
        assert_eq!(c.start_current(), c.control.start_current_a, "published");
    }
}
