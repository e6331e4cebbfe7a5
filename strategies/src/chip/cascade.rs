//! The speed/current cascade: the current reads before a PI update, their spacing, the PI
//! update itself, and the duty schedule its gains assume.

use super::Chip;
use crate::params::ControlParams;
use crate::supervisor::Update;
use crate::table::Table;
use drive_core::{Ticks, clocks};

/// The spacing of `reads` current reads before a PI update, for a carrier of top `top`
/// (one count per master tick, so a period P of 2·top ticks): (m + 1/n)·P on the chip's
/// 0.64 µs clock, with m the most whole periods that keep the n reads inside one PI
/// period. Consecutive reads then fall 1/n of a carrier period apart in its phase, so the n
/// of an update take every carrier phase once (no PWM alias), and are spread over the
/// update's interval, so the commutation ripple is sampled at n instants of it rather
/// than one (its alias is shrunk, not removed).
pub(super) fn read_spacing(top: u32, reads: u32) -> Ticks {
    let period = 2 * u64::from(top);
    let clock = clocks::COMMUTATION.0;
    let n = u64::from(reads.max(1));
    // n·(m + 1/n)·P ≤ PI period  ⇔  m ≤ (PI period − P)/(n·P).
    let m = clocks::PI_UPDATE.0.saturating_sub(period) / (n * period);
    let ticks = m * period + period / n;
    Ticks(((ticks + clock / 2) / clock).max(1) * clock)
}

/// The duty d̂ a speed of `rpm` needs with a mean shunt current `i_shunt_a`, for the gain
/// schedule: d = a + i_ph/I_lr with a = n/ω0 (the back-EMF's share of the supply) and the
/// resistive drop i_ph·R_ll/V_DD = i_ph/I_lr, where the phase current i_ph = i_shunt/d
/// (the shunt carries it in the on-time alone); so d² − a·d − i_shunt/I_lr = 0. ω0 and
/// I_lr are the supervisor's datasheet figures. Clamped to [`schedule_min_duty`, 1].
///
/// [`schedule_min_duty`]: ControlParams::schedule_min_duty
pub fn scheduled_duty(c: &ControlParams, rpm: f64, i_shunt_a: f64) -> f64 {
    let a = rpm.max(0.0) / c.supervisor_no_load_rpm;
    let drop = 4.0 * i_shunt_a.max(0.0) / c.supervisor_locked_rotor_a;
    (0.5 * (a + (a * a + drop).sqrt())).clamp(c.schedule_min_duty, 1.0)
}

impl Chip {
    pub(super) fn clear_reads(&mut self) {
        self.read_slot = 0;
        self.read_sum = 0;
        self.read_count = 0;
    }

    /// When the next current read before the coming PI update is due (the update itself
    /// takes the last read).
    pub(super) fn next_read(&self) -> Option<Ticks> {
        let left = self.control.current_reads.checked_sub(self.read_slot + 1)?;
        (left > 0 && self.next_pi != Ticks::NEVER).then(|| {
            Ticks(
                self.next_pi
                    .0
                    .saturating_sub(u64::from(left) * self.read_spacing.0),
            )
        })
    }

    /// Takes the current reads due by `now` before the coming PI update; a slot that
    /// passed before `now` reached it (the chip was off or starting) is skipped.
    pub(super) fn take_reads(&mut self, now: Ticks, code: u16) {
        while let Some(at) = self.next_read()
            && at <= now
        {
            if now.0 < at.0 + self.read_spacing.0 {
                self.read_sum += u32::from(code);
                self.read_count += 1;
            }
            self.read_slot += 1;
        }
    }

    /// Speed PI → current command; current PI → voltage command (docs/chip.md).
    ///
    /// Which one saturates: the current PI only where `current_limit_a` needs more than
    /// full voltage (near top speed, ≈ 9000 rpm and up on the built-in motor); below that
    /// it has duty to spare, so the chip's anti-windup (on it alone) cannot act. The speed
    /// PI saturates at `current_limit_a` when Kp·e + ui exceeds it (errors beyond ≈ 5000
    /// rpm, or a load held long), and at 0 on every step down; its integrator is clamped
    /// at both, so it winds only up to the limit, and `speed_anti_windup` trims that.
    ///
    /// Until the first FG speed measurement (10 FG periods after hand-over) there is no
    /// speed to control; the current command is held at `start_current_a`, and the speed PI
    /// starts from zero when the first measurement arrives.
    ///
    /// Returns whether the supervisor found this update's current sample implausible
    /// enough to restart; it judges the sample against the duty that produced it.
    pub(super) fn pi_update(&mut self, current_code: u16) -> bool {
        // The mean of this read and those taken before it for this update.
        let sum = self.read_sum + u32::from(current_code);
        let i = f64::from(sum) / f64::from(self.read_count + 1) * self.amps_per_code;
        self.clear_reads();
        // The believed speed from the last 60° interval: it exists two crossings after the
        // hand-over, long before the FG meter's first reading.
        let (t60, measured) = self.shifter.t60();
        let shifter_rpm = measured.then(|| {
            let sector_s = t60.max(1) as f64 * clocks::COMMUTATION.seconds();
            60.0 / (6.0 * sector_s * f64::from(self.pole_pairs))
        });
        let new_reading = self.speed.measurements() != self.measurements_seen;
        self.measurements_seen = self.speed.measurements();
        let tripped = shifter_rpm.is_some_and(|shifter_rpm| {
            // A linear region since the last update applied full voltage, and the sampled
            // current may come from it (it outlasts the window by several L/R).
            let duty_eff = if self.linear_seen {
                1.0
            } else {
                f64::from(self.cv) / f64::from(self.top)
            };
            self.supervisor.update(&Update {
                shifter_rpm,
                meter_rpm: (new_reading && self.speed.measurements() > 0)
                    .then(|| f64::from(self.speed.rpm())),
                duty_eff,
                current_a: i,
                torque_asked: self.i_ref > 0.0,
                twelve_step: matches!(self.table, Table::TwelveStep { .. }),
            })
        });
        self.linear_seen = self.linear;
        // The duty the believed speed needs at the last current command (1 without the
        // schedule): scaling an error by it scales that PI's gains, and its integrator, in
        // output units, keeps its value.
        // Until the first speed reading the current command is the start current.
        let start = self.starting().then(|| self.start_current());
        let d = if self.control.gain_schedule {
            let rpm = if self.speed.measurements() > 0 {
                f64::from(self.speed.rpm())
            } else {
                shifter_rpm.unwrap_or(0.0)
            };
            scheduled_duty(&self.control, rpm, start.unwrap_or(self.i_ref))
        } else {
            1.0
        };
        let i_ref = match start {
            Some(i) => i,
            None => self.speed_update(d),
        };
        self.i_ref = i_ref;
        let u = self.current_pi.update((i_ref - i) / d);
        self.cv = (u.round() as u32).min(self.top);
        tripped
    }
}
