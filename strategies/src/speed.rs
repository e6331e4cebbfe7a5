//! FG speed measurement (docs/chip.md): count the 2.56 µs clock over k FG periods.
//!
//! One FG period is one electrical turn, i.e. 1/(P/2) of a mechanical turn, so with N counts
//! of 2.56 µs over k periods: ω \[rpm\] = 60·k / ((P/2)·N·2.56 µs) = 23 437 500·k / ((P/2)·N).
//! For P = 12 and k = 10 that is the chip's ω = 39 062 500 / N. The result is an integer
//! (the chip divides), updated once per k periods; the counter saturates at its width, which
//! sets the lowest speed it can read.

use drive_core::{Ticks, clocks};

/// FG-period speed meter.
#[derive(Clone, Debug)]
pub struct SpeedMeter {
    periods: u32,
    max_count: u64,
    numerator: u64,
    start: Option<Ticks>,
    edges: u32,
    rpm: u32,
    measurements: u64,
}

impl SpeedMeter {
    /// A meter over `periods` FG periods with a `bits`-wide counter, for `pole_pairs` (P/2).
    pub fn new(periods: u32, bits: u32, pole_pairs: u32) -> Self {
        SpeedMeter {
            periods: periods.max(1),
            max_count: (1u64 << bits.clamp(1, 63)) - 1,
            numerator: 23_437_500 * u64::from(periods.max(1)) / u64::from(pole_pairs.max(1)),
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
        if self.edges == self.periods {
            let clk = clocks::SPEED_COUNTER.0;
            let n = (now.0 / clk - start.0 / clk).clamp(1, self.max_count);
            self.rpm = (self.numerator / n).min(u64::from(u32::MAX)) as u32;
            self.measurements += 1;
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
});

#[cfg(test)]
mod tests {
    use super::*;

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
}
