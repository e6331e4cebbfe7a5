//! The master time base: integer ticks of the chip's 50 MHz clock (20 ns).
//!
//! Every discrete instant of the drive (PWM edges, controller clocks, ADC conversions,
//! comparator decisions) falls on a whole tick, so clocks never drift against each other.
//! Continuous plant time is `f64` seconds; it meets the tick grid at every engine instant.

use serde::{Deserialize, Serialize};
use std::ops::{Add, AddAssign, Sub};

/// Length of one master tick in seconds (50 MHz master clock).
pub const TICK_S: f64 = 20e-9;

/// Ticks per second, to convert instants by multiplication.
const PER_S: f64 = 1.0 / TICK_S;

/// 2^52: added to a non-negative x below 2^51, it rounds x to a whole number (ties to even).
const ROUND: f64 = 4_503_599_627_370_496.0;

/// How far (in ticks) an instant may miss a tick and still be that tick: a millionth of a
/// tick, or a few ulps of the tick count where that is more (beyond ≈ 100 s of drive time
/// an ulp of the instant exceeds a millionth of a tick).
fn allowance(k: f64) -> f64 {
    (k * 1e-15).max(1e-6)
}

/// `k` truncated to a tick count, through i64: the unsigned conversion is a branchy
/// sequence on baseline x86-64, the signed one an instruction. Like `k as u64` (negative
/// and NaN give 0) but saturating at 2^63 − 1 ticks (5800 years): the plant's instants are
/// far below.
fn to_count(k: f64) -> u64 {
    (k as i64).max(0) as u64
}

/// `k` as f64 for a count beyond i64 (see [`Ticks::count_f64`]).
#[cold]
#[inline(never)]
fn beyond_i64(k: u64) -> f64 {
    k as f64
}

/// An instant or a duration counted in master ticks (20 ns).
#[derive(
    Copy, Clone, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(transparent)]
pub struct Ticks(pub u64);

impl Ticks {
    /// Time zero.
    pub const ZERO: Ticks = Ticks(0);
    /// "Never": later than any reachable instant.
    pub const NEVER: Ticks = Ticks(u64::MAX);

    /// This instant in seconds.
    pub fn seconds(self) -> f64 {
        self.count_f64() * TICK_S
    }

    /// The number of whole ticks nearest to `seconds`, or `None` if negative, non-finite or
    /// beyond the range of the counter.
    pub fn from_seconds(seconds: f64) -> Option<Ticks> {
        let t = (seconds / TICK_S).round();
        (t.is_finite() && (0.0..1.8e19).contains(&t)).then_some(Ticks(t as u64))
    }

    /// The last tick at or before the instant `seconds` (≥ 0), an instant within rounding
    /// short of a tick counting as that tick: plant times are sums of tick instants and step
    /// lengths, off by rounding. By cast, not `floor`, which is a library call on baseline
    /// x86-64; the plant converts several times per step.
    pub fn at_or_before(seconds: f64) -> Ticks {
        let k = seconds * PER_S;
        Ticks(to_count(k + allowance(k)))
    }

    /// The first tick at or after the instant `seconds` (≥ 0), and whether `seconds` is that
    /// tick (within rounding either way).
    pub fn at_or_after(seconds: f64) -> (Ticks, bool) {
        let k = seconds * PER_S;
        // The nearest tick n by adding 2^52 (the sum's ulp is 1, n in its low bits), not by
        // a saturating cast: below 2^48 ticks (65 days), where the allowance is under 0.3,
        // a tick within it is the one `to_count(k + 0.5)` finds. Anything else (negative
        // beyond rounding, NaN, later) leaves bits outside 0..2^48 and takes the cast.
        let r = k + ROUND;
        let n = r.to_bits().wrapping_sub(ROUND.to_bits());
        if n < 1 << 48 {
            if (k - (r - ROUND)).abs() < allowance(k) {
                return (Ticks(n), true);
            }
        } else {
            let near = to_count(k + 0.5); // the nearest tick, for k ≥ 0
            if (k - Ticks(near).count_f64()).abs() < allowance(k) {
                return (Ticks(near), true);
            }
        }
        let below = to_count(k);
        (
            Ticks(if Ticks(below).count_f64() < k {
                below + 1
            } else {
                below
            }),
            false,
        )
    }

    /// The count as f64, through i64 where it fits: baseline x86-64 converts signed
    /// integers in one instruction, unsigned ones in a sequence of six. Counts beyond i64
    /// ([`Ticks::NEVER`]) go out of line: with both conversions inline the compiler sees
    /// that they agree and emits the unsigned sequence for every count.
    #[inline(always)]
    fn count_f64(self) -> f64 {
        let k = self.0 as i64;
        let f = k as f64;
        if k < 0 { beyond_i64(self.0) } else { f }
    }

    /// The first instant `>= self` that is a whole multiple of `period` (a clock edge).
    /// A zero period means "every tick".
    pub fn next_edge(self, period: Ticks) -> Ticks {
        if period.0 <= 1 {
            return self;
        }
        let rem = self.0 % period.0;
        if rem == 0 {
            self
        } else {
            Ticks(self.0.saturating_add(period.0 - rem))
        }
    }
}

impl Add for Ticks {
    type Output = Ticks;
    fn add(self, rhs: Ticks) -> Ticks {
        Ticks(self.0.saturating_add(rhs.0))
    }
}

impl AddAssign for Ticks {
    fn add_assign(&mut self, rhs: Ticks) {
        *self = *self + rhs;
    }
}

impl Sub for Ticks {
    type Output = Ticks;
    fn sub(self, rhs: Ticks) -> Ticks {
        Ticks(self.0.saturating_sub(rhs.0))
    }
}

/// The chip's clocks (docs/chip.md), as periods in master ticks.
pub mod clocks {
    use super::Ticks;
    /// PWM counter: one count per master tick (20 ns).
    pub const PWM_COUNTER: Ticks = Ticks(1);
    /// Closed-loop commutation logic and the digital filter: 0.64 µs.
    pub const COMMUTATION: Ticks = Ticks(32);
    /// Speed (FG period) counter: 2.56 µs.
    pub const SPEED_COUNTER: Ticks = Ticks(128);
    /// Step-miss detector: 40.96 µs.
    pub const STEP_MISS: Ticks = Ticks(2048);
    /// Alignment / start sequencer: 327.68 µs.
    pub const ALIGN: Ticks = Ticks(16_384);
    /// PI update (integrator delay clock): 2^18 ticks = 5.242 88 ms.
    pub const PI_UPDATE: Ticks = Ticks(262_144);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_through_i64_match_the_unsigned_ones_below_2_pow_63() {
        for k in [
            -1e300,
            -3.5,
            -0.5,
            -0.0,
            0.0,
            0.4,
            0.6,
            1.0,
            2.5e9,
            9.2e18,
            f64::NEG_INFINITY,
            f64::NAN,
        ] {
            assert_eq!(to_count(k), k as u64, "{k}");
        }
        for k in [9.3e18, 2e19, f64::INFINITY] {
            assert_eq!(to_count(k), i64::MAX as u64, "{k}");
        }
        for t in [
            0,
            1,
            1 << 40,
            i64::MAX as u64,
            i64::MAX as u64 + 1,
            u64::MAX,
        ] {
            assert_eq!(Ticks(t).count_f64(), t as f64, "{t}");
        }
    }

    #[test]
    fn instants_to_ticks_match_floor_and_ceil_with_the_rounding_allowance() {
        // Up to 10⁴ s of drive time (5·10¹¹ ticks), where an ulp of the instant is 10⁻⁴ tick.
        for k in [
            0u64,
            1,
            2,
            31,
            1000,
            150_000_000,
            4_000_000_000,
            500_000_000_000,
        ] {
            let t = k as f64 * TICK_S;
            // An instant on a tick, or a few ulps off it, is that tick.
            let (up, down) = (t.next_up().next_up(), t.next_down().next_down());
            for x in [t, up, down] {
                assert_eq!(Ticks::at_or_before(x), Ticks(k), "{x}");
                assert_eq!(Ticks::at_or_after(x), (Ticks(k), true), "{x}");
            }
            // A third of a tick later: floor and ceil proper.
            let x = t + TICK_S / 3.0;
            assert_eq!(Ticks::at_or_before(x), Ticks(k));
            assert_eq!(Ticks::at_or_after(x), (Ticks(k + 1), false));
            let x = t + 0.999 * TICK_S;
            assert_eq!(Ticks::at_or_before(x), Ticks(k));
            assert_eq!(Ticks::at_or_after(x), (Ticks(k + 1), false));
        }
    }

    /// `Ticks::at_or_after` as it was before its nearest tick came from adding 2^52.
    fn at_or_after_by_casts(seconds: f64) -> (Ticks, bool) {
        let k = seconds * PER_S;
        let near = to_count(k + 0.5);
        if (k - near as f64).abs() < allowance(k) {
            return (Ticks(near), true);
        }
        let below = to_count(k);
        (
            Ticks(if (below as f64) < k { below + 1 } else { below }),
            false,
        )
    }

    #[test]
    fn the_nearest_tick_by_adding_2_pow_52_is_the_casts_one() {
        // Ticks and halves of them, each nudged by up to a few allowances and ulps, across
        // the fast range's end (2^48), negative ones, non-finite ones, from a fixed LCG.
        let mut z = 0x2545_f491_4f6c_dd1d_u64;
        let mut unit = || {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (z >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut seen = [0usize; 2];
        for j in 0..200_000 {
            let k = match j % 5 {
                0 => (unit() * 1e4).floor(),
                1 => (unit() * 3e9).floor(),
                2 => (unit() * 2f64.powi(49)).floor(),
                3 => (unit() * 2f64.powi(62)).floor(),
                _ => -(unit() * 4.0).floor(),
            } + if j % 3 == 0 { 0.5 } else { 0.0 };
            let nudge = match j % 7 {
                0 => 0.0,
                1 | 2 => (unit() - 0.5) * 4.0 * allowance(k.abs()),
                3 => (unit() - 0.5) * 1e-3,
                4 => (unit() - 0.5) * 16.0 * f64::EPSILON * k.abs(),
                _ => unit() - 0.5,
            };
            let t = (k + nudge) * TICK_S;
            let got = Ticks::at_or_after(t);
            assert_eq!(
                got,
                at_or_after_by_casts(t),
                "{t:e} s ({k} + {nudge:e} ticks)"
            );
            seen[usize::from(got.1)] += 1;
        }
        assert!(seen[0] > 50_000 && seen[1] > 50_000, "{seen:?}");
        for t in [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            -0.0,
            1e300,
            -1e-300,
        ] {
            assert_eq!(Ticks::at_or_after(t), at_or_after_by_casts(t), "{t}");
        }
    }

    #[test]
    fn chip_clock_periods_match_spec() {
        assert!((clocks::COMMUTATION.seconds() - 0.64e-6).abs() < 1e-15);
        assert!((clocks::SPEED_COUNTER.seconds() - 2.56e-6).abs() < 1e-15);
        assert!((clocks::STEP_MISS.seconds() - 40.96e-6).abs() < 1e-15);
        assert!((clocks::ALIGN.seconds() - 327.68e-6).abs() < 1e-12);
        assert!((clocks::PI_UPDATE.seconds() - 5.24288e-3).abs() < 1e-12);
    }

    #[test]
    fn next_edge_rounds_up_to_multiples() {
        let p = Ticks(32);
        assert_eq!(Ticks(0).next_edge(p), Ticks(0));
        assert_eq!(Ticks(1).next_edge(p), Ticks(32));
        assert_eq!(Ticks(32).next_edge(p), Ticks(32));
        assert_eq!(Ticks(33).next_edge(p), Ticks(64));
        assert_eq!(Ticks(7).next_edge(Ticks(1)), Ticks(7));
    }

    #[test]
    fn from_seconds_rejects_bad_values() {
        assert_eq!(Ticks::from_seconds(1e-6), Some(Ticks(50)));
        assert_eq!(Ticks::from_seconds(-1e-6), None);
        assert_eq!(Ticks::from_seconds(f64::NAN), None);
        assert_eq!(Ticks::from_seconds(f64::INFINITY), None);
    }
}
