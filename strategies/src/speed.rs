//! FG speed measurement (docs/chip.md): count the 2.56 µs clock over k FG periods.
//!
//! One FG period is one electrical turn, i.e. 1/(P/2) of a mechanical turn, so with N counts
//! of 2.56 µs over k periods: ω \[rpm\] = 60·k / ((P/2)·N·2.56 µs) = 23 437 500·k / ((P/2)·N).
//! For P = 12 and k = 10 that is the chip's ω = 39 062 500 / N. The result is an integer
//! (the chip divides), updated once per k periods; the counter saturates at its width, which
//! sets the lowest speed it can read.
//!
//! With a window (`control.speed_window_s`, not the published chip's) a measurement also
//! ends at the first FG edge at which the window has passed, so it spans
//! k' = min(k, ⌈window / T_FG⌉) periods: ω = 23 437 500·k' / ((P/2)·N). Below the speed
//! at which k periods fill the window the reading then comes every period or few, and its
//! delay, ≈ half the measured span plus the wait for the next reading, stops growing as
//! k/ω: the speed loop's phase lag at low speed is what limits it there (docs/chip.md).

use drive_core::{Ticks, clocks};

/// FG-period speed meter.
#[derive(Clone, Debug)]
pub struct SpeedMeter {
    periods: u32,
    max_count: u64,
    numerator: u64,
    /// The window in speed-counter clocks (`u64::MAX`: none).
    window: u64,
    pole_pairs: u64,
    start: Option<Ticks>,
    edges: u32,
    rpm: u32,
    measurements: u64,
}

impl SpeedMeter {
    /// A meter over `periods` FG periods with a `bits`-wide counter, for `pole_pairs` (P/2).
    pub fn new(periods: u32, bits: u32, pole_pairs: u32) -> Self {
        Self::windowed(periods, bits, pole_pairs, None)
    }

    /// Like [`SpeedMeter::new`], a measurement also ending at the first FG edge at or after
    /// `window` since it began (`None`: only after `periods`).
    pub fn windowed(periods: u32, bits: u32, pole_pairs: u32, window: Option<Ticks>) -> Self {
        let clk = clocks::SPEED_COUNTER.0;
        SpeedMeter {
            periods: periods.max(1),
            max_count: (1u64 << bits.clamp(1, 63)) - 1,
            numerator: 23_437_500 * u64::from(periods.max(1)) / u64::from(pole_pairs.max(1)),
            window: window.map_or(u64::MAX, |w| w.0.div_ceil(clk)),
            pole_pairs: u64::from(pole_pairs.max(1)),
            start: None,
            edges: 0,
            rpm: 0,
            measurements: 0,
        }
    }

    /// A rising FG_c edge at clock edge `now`.
    pub fn fg_rising(&mut self, now: Ticks) {
        let Some(start) = self.start else {
            self.start = Some(now);
            return;
        };
        self.edges += 1;
        let clk = clocks::SPEED_COUNTER.0;
        // Saturating: a restored start later than now (a forged state) reads as no time.
        let elapsed = (now.0 / clk).saturating_sub(start.0 / clk);
        if self.edges == self.periods || elapsed >= self.window {
            let n = elapsed.clamp(1, self.max_count);
            let numerator = if self.edges == self.periods {
                self.numerator
            } else {
                23_437_500 * u64::from(self.edges) / self.pole_pairs
            };
            self.rpm = (numerator / n).min(u64::from(u32::MAX)) as u32;
            self.measurements = self.measurements.saturating_add(1);
            self.start = Some(now);
            self.edges = 0;
        }
    }

    /// Latest measured speed \[rpm\] (0 before the first measurement).
    pub fn rpm(&self) -> u32 {
        self.rpm
    }

    /// Completed measurements.
    pub fn measurements(&self) -> u64 {
        self.measurements
    }

    /// Forgets everything (after a restart).
    pub fn reset(&mut self) {
        self.start = None;
        self.edges = 0;
        self.rpm = 0;
        self.measurements = 0;
    }
}

// The measurement under way and the last result; the scaling is a parameter.
drive_core::persist_fields!(SpeedMeter {
    start,
    edges,
    rpm,
    measurements
} then SpeedMeter::check_restored);

impl SpeedMeter {
    /// The fastest reading \[rpm\]: a measurement over one counter clock.
    pub fn max_rpm(&self) -> u64 {
        self.numerator
    }

    /// A measurement under way counts fewer edges than it spans (none before it begins);
    /// a reading is one the counter gives (none before the first measurement).
    fn check_restored(&self) -> Result<(), String> {
        use drive_core::state::check;
        let (edges, periods) = (self.edges, self.periods);
        check(
            edges < periods && (self.start.is_some() || edges == 0),
            || {
                format!(
                    "edges = {edges} (rule: fewer than the {periods} periods a measurement spans, 0 before its first edge)"
                )
            },
        )?;
        let max = self.numerator;
        check(
            u64::from(self.rpm) <= max && (self.measurements > 0 || self.rpm == 0),
            || {
                format!(
                    "rpm = {} (rule: a reading of at least one counter clock, at most {max} rpm; 0 before the first)",
                    self.rpm
                )
            },
        )?;
        drive_core::state::check_count("measurements", self.measurements)
    }

    /// A restored measurement began by the engine's instant `now`.
    pub(crate) fn check_at(&self, now: Ticks) -> Result<(), String> {
        drive_core::state::check(self.start.is_none_or(|s| s <= now), || {
            format!(
                "speed.start = {:?} (rule: an FG edge by now = {})",
                self.start, now.0
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_restored_measurement_keeps_the_meter_s_rules() {
        use drive_core::Persist;
        let mut m = SpeedMeter::new(10, 15, 6);
        let period = Ticks::from_seconds(1.0 / 300.0).unwrap();
        for k in 0..=13 {
            m.fg_rising(Ticks(period.0 * k));
        }
        let fresh = || SpeedMeter::new(10, 15, 6);
        fresh().restore_from(&m.to_bytes().unwrap()).unwrap();
        let refused = |f: SpeedMeter, want: &str| {
            let e = fresh().restore_from(&f.to_bytes().unwrap()).unwrap_err();
            assert!(e.starts_with(want), "{e}");
        };
        refused(
            SpeedMeter {
                edges: 10,
                ..m.clone()
            },
            "edges = 10 (rule: fewer than the 10",
        );
        // One counter clock over ten FG periods at P = 12: 39 062 500 rpm at most.
        refused(
            SpeedMeter {
                rpm: 39_062_501,
                ..m.clone()
            },
            "rpm = 39062501 (rule:",
        );
        refused(
            SpeedMeter {
                measurements: 0,
                ..m.clone()
            },
            "rpm = 3000 (rule:",
        );
        refused(
            SpeedMeter {
                measurements: u64::MAX,
                ..m.clone()
            },
            "measurements = ",
        );
        let late = SpeedMeter {
            start: Some(Ticks(1 << 40)),
            ..m.clone()
        };
        assert!(
            late.check_at(Ticks(1 << 39))
                .unwrap_err()
                .starts_with("speed.start = ")
        );
        late.check_at(Ticks(1 << 40)).unwrap();
    }

    #[test]
    fn chip_formula_for_12_poles_and_10_periods() {
        // 3000 rpm: one electrical turn = 1/(6·50) s = 3.333 ms; 10 turns = 33.33 ms =
        // 13020.8 counts of 2.56 µs → the chip reads 39 062 500 / 13020 = 3000 rpm.
        let mut m = SpeedMeter::new(10, 15, 6);
        let period = Ticks::from_seconds(1.0 / 300.0).unwrap();
        for k in 0..=10 {
            m.fg_rising(Ticks(period.0 * k));
        }
        let n = (period.0 * 10) / 128;
        assert_eq!(n, 13020);
        assert_eq!(m.rpm() as u64, 39_062_500 / n);
        assert_eq!(m.rpm(), 3000);
        assert_eq!(m.measurements(), 1);
    }

    #[test]
    fn the_15_bit_counter_sets_the_lowest_readable_speed() {
        let mut m = SpeedMeter::new(10, 15, 6);
        // 500 rpm: 10 periods = 0.2 s = 78125 counts > 32767.
        let period = Ticks::from_seconds(1.0 / 50.0).unwrap();
        for k in 0..=10 {
            m.fg_rising(Ticks(period.0 * k));
        }
        assert_eq!(m.rpm(), 39_062_500 / 32_767);
        let mut wide = SpeedMeter::new(10, 20, 6);
        for k in 0..=10 {
            wide.fg_rising(Ticks(period.0 * k));
        }
        assert_eq!(wide.rpm(), 500);
    }

    #[test]
    fn a_window_ends_a_measurement_at_the_first_fg_edge_past_it() {
        // 300 rpm, P = 12: one FG period = 1/30 s = 13020.8 counts, past a 20 ms window at
        // the first edge: one period per reading, ω = 23 437 500·1/(6·13020) = 300 rpm
        // (integer division), within the 15-bit counter that 10 periods would overflow.
        let mut m = SpeedMeter::windowed(10, 15, 6, Some(Ticks::from_seconds(0.02).unwrap()));
        let period = Ticks::from_seconds(1.0 / 30.0).unwrap();
        m.fg_rising(Ticks::ZERO);
        m.fg_rising(period);
        assert_eq!(m.measurements(), 1);
        let n = period.0 / 128;
        assert_eq!(m.rpm() as u64, 23_437_500 / 6 / n);
        assert_eq!(m.rpm(), 300);
        // 3000 rpm: 3.33 ms per period, so a 19 ms window ends a reading at the 6th edge
        // (20.0 ms), before the 10 of the published meter.
        let mut m = SpeedMeter::windowed(10, 15, 6, Some(Ticks::from_seconds(0.019).unwrap()));
        let period = Ticks::from_seconds(1.0 / 300.0).unwrap();
        for k in 0..=5 {
            m.fg_rising(Ticks(period.0 * k));
        }
        assert_eq!(
            m.measurements(),
            0,
            "5 periods (16.7 ms) are inside the window"
        );
        m.fg_rising(Ticks(period.0 * 6));
        assert_eq!(m.measurements(), 1);
        assert_eq!(m.rpm(), 3000);
    }
}
