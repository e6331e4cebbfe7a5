//! The digital filter guard ("DF"): a shift register of N D flip-flops clocked at
//! 0.64 µs and an RS latch.
//!
//! d0 … d(N−1) hold Z_d delayed by 1 … N samples. S = d0·d1·…, R = ¬(d0 + d1 + …), and
//! Z_df = S + ¬R·Z_df: the output follows the input only after N equal samples, so pulses
//! shorter than N samples vanish and every accepted edge is N − 1 to N samples late.
//! The chip has N = 3.

use drive_core::Ticks;

/// N flip-flops + RS latch, clocked every `clock` ticks.
#[derive(Clone, Debug)]
pub struct DigitalFilter {
    samples: u32,
    clock: Ticks,
    /// Bit i = d_i (bit 0 = latest sample).
    reg: u64,
    out: bool,
    last_edge: Option<Ticks>,
    last_in: bool,
}

impl DigitalFilter {
    /// A filter of `samples` (1..=64) flip-flops clocked every `clock` ticks, all cleared.
    pub fn new(samples: u32, clock: Ticks) -> Self {
        DigitalFilter {
            samples: samples.clamp(1, 64),
            clock,
            reg: 0,
            out: false,
            last_edge: None,
            last_in: false,
        }
    }

    fn mask(&self) -> u64 {
        if self.samples == 64 {
            u64::MAX
        } else {
            (1u64 << self.samples) - 1
        }
    }

    fn shift(&mut self, z: bool) {
        self.reg = ((self.reg << 1) | u64::from(z)) & self.mask();
        if self.reg == self.mask() {
            self.out = true;
        } else if self.reg == 0 {
            self.out = false;
        }
    }

    /// [`DigitalFilter::shift`] `n` times (`n` ≤ the sample count) with the same input `z`,
    /// at once: the register only fills further with `z`, so once all `z` it stays so, and
    /// it never reaches the opposite state; the latch sees only where it ends.
    fn shift_held(&mut self, z: bool, n: u64) {
        if n == 0 {
            return;
        }
        // n ≤ 64; shifts by 64 are spelled out (a shift by the width overflows).
        let (kept, filled) = if n >= 64 {
            (0, u64::MAX)
        } else {
            (self.reg << n, (1u64 << n) - 1)
        };
        self.reg = (kept | if z { filled } else { 0 }) & self.mask();
        if self.reg == self.mask() {
            self.out = true;
        } else if self.reg == 0 {
            self.out = false;
        }
    }

    /// Clocks the filter at edge `now` with input `z`. Between the previous call and `now`
    /// the input held its previous value, so the edges in between shift that value in.
    pub fn clock_at(&mut self, now: Ticks, z: bool) -> bool {
        let edges = match self.last_edge {
            Some(t) if now > t => (now.0 - t.0) / self.clock.0.max(1),
            Some(_) => 0,
            None => 1,
        };
        if edges > 0 {
            let held = (edges - 1).min(u64::from(self.samples));
            self.shift_held(self.last_in, held);
            self.shift(z);
            self.last_edge = Some(now);
        }
        self.last_in = z;
        self.out
    }

    /// Changes the input seen since the last clock edge without clocking (the selected
    /// comparator changed at that edge).
    pub fn retarget(&mut self, z: bool) {
        self.last_in = z;
    }

    /// Output Z_df.
    pub fn output(&self) -> bool {
        self.out
    }

    /// The clock edge at which the output will change if the input stays as it is now, or
    /// `None` if it will not change.
    pub fn settles_at(&self) -> Option<Ticks> {
        if self.out == self.last_in {
            return None;
        }
        let want = if self.last_in { self.mask() } else { 0 };
        // Shifts still needed: flip-flops that do not hold the input yet, counted from d0.
        let mut needed = 0u64;
        let mut r = self.reg;
        let mut w = want;
        while (r & self.mask()) != (w & self.mask()) {
            r = (r << 1) | u64::from(self.last_in);
            w = (w << 1) | u64::from(self.last_in);
            needed += 1;
            if needed > 64 {
                break;
            }
        }
        let last = self.last_edge?;
        Some(Ticks(last.0 + needed * self.clock.0))
    }

    /// Clears the register and the latch.
    pub fn reset(&mut self) {
        self.reg = 0;
        self.out = false;
        self.last_edge = None;
        self.last_in = false;
    }
}

// The register and edges; the sample count and clock are parameters.
drive_core::persist_fields!(DigitalFilter {
    reg,
    out,
    last_edge,
    last_in
} then DigitalFilter::check_restored);

impl DigitalFilter {
    /// The register within its flip-flops, the latch set when all hold 1 and clear when
    /// all hold 0, as every shift leaves them.
    fn check_restored(&self) -> Result<(), String> {
        let m = self.mask();
        drive_core::state::check(
            self.reg & !m == 0 && (self.reg != m || self.out) && (self.reg != 0 || !self.out),
            || {
                format!(
                    "filter.reg = {:#x}, out = {} (rule: within its {} flip-flops, the latch set when all are 1 and clear when all are 0)",
                    self.reg, self.out, self.samples
                )
            },
        )
    }

    /// The last clock edge by the engine's instant `now`.
    pub(crate) fn check_at(&self, now: Ticks) -> Result<(), String> {
        drive_core::state::check(self.last_edge.is_none_or(|t| t <= now), || {
            format!(
                "filter.last_edge = {:?} (rule: a clock edge by now = {})",
                self.last_edge, now.0
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const C: Ticks = Ticks(32);

    #[test]
    fn a_restored_register_and_latch_are_ones_the_shifts_leave() {
        use drive_core::Persist;
        let mut f = DigitalFilter::new(4, C);
        for k in 0..6 {
            f.clock_at(Ticks(32 * k), true);
        }
        assert!(f.output());
        let fresh = || DigitalFilter::new(4, C);
        fresh().restore_from(&f.to_bytes().unwrap()).unwrap();
        for (reg, out) in [(0x1f, true), (0xf, false), (0, true)] {
            let forged = DigitalFilter {
                reg,
                out,
                ..f.clone()
            };
            let e = fresh()
                .restore_from(&forged.to_bytes().unwrap())
                .unwrap_err();
            assert!(e.starts_with("filter.reg = "), "{e}");
        }
        assert!(f.check_at(Ticks(32 * 5)).is_ok());
        assert!(f.check_at(Ticks(32 * 5 - 1)).is_err());
    }

    /// Feeds a sampled input (one value per clock edge, every edge) and returns the outputs.
    fn run(samples: u32, input: &[bool]) -> Vec<bool> {
        let mut f = DigitalFilter::new(samples, C);
        input
            .iter()
            .enumerate()
            .map(|(k, &z)| f.clock_at(Ticks(32 * k as u64), z))
            .collect()
    }

    #[test]
    fn a_step_passes_three_samples_late() {
        let mut input = vec![false; 5];
        input.extend([true; 10]);
        let out = run(3, &input);
        // The input is high from edge 5; d0,d1,d2 are all high at edge 7.
        let first = out.iter().position(|&b| b).unwrap();
        assert_eq!(first, 7);
        assert!(out[7..].iter().all(|&b| b));
    }

    #[test]
    fn pulses_shorter_than_the_window_are_removed_and_longer_ones_pass() {
        for width in 1..=2 {
            let mut input = vec![false; 5];
            input.extend(vec![true; width]);
            input.extend([false; 10]);
            assert!(run(3, &input).iter().all(|&b| !b), "width {width}");
        }
        let mut input = vec![false; 5];
        input.extend([true; 3]);
        input.extend([false; 10]);
        let out = run(3, &input);
        assert_eq!(out.iter().filter(|&&b| b).count(), 3, "{out:?}");
        // Negative pulses in a high signal likewise.
        let mut input = vec![true; 8];
        input.extend([false; 2]);
        input.extend([true; 5]);
        let out = run(3, &input);
        assert!(out[2..].iter().all(|&b| b), "{out:?}");
    }

    #[test]
    fn catch_up_between_calls_equals_clocking_every_edge() {
        // Input changes at edges 3, 4, 9, 10, 11, 30; the controller is only called there.
        let changes = [
            (3u64, true),
            (4, false),
            (9, true),
            (10, false),
            (11, true),
            (30, false),
        ];
        let level = |k: u64| {
            changes
                .iter()
                .rev()
                .find(|c| c.0 <= k)
                .map(|c| c.1)
                .unwrap_or(false)
        };
        let every: Vec<bool> = {
            let mut f = DigitalFilter::new(3, C);
            (0..40)
                .map(|k| f.clock_at(Ticks(32 * k), level(k)))
                .collect()
        };
        let mut f = DigitalFilter::new(3, C);
        f.clock_at(Ticks(0), false);
        let mut sparse = vec![(0u64, false)];
        let mut k = 0;
        loop {
            let next_change = changes.iter().map(|c| c.0).find(|&c| c > k);
            let settle = f.settles_at().map(|t| t.0 / 32);
            let next = match (next_change, settle) {
                (Some(a), Some(b)) => a.min(b),
                (a, b) => match a.or(b) {
                    Some(x) => x,
                    None => break,
                },
            };
            k = next;
            let out = f.clock_at(Ticks(32 * k), level(k));
            sparse.push((k, out));
        }
        for &(k, out) in &sparse {
            assert_eq!(out, every[k as usize], "edge {k}");
        }
        // Every output change of the dense run happens at an edge the sparse run visits,
        // so a controller woken at `settles_at` never misses one.
        for k in 1..40u64 {
            if every[k as usize] != every[k as usize - 1] {
                assert!(
                    sparse.iter().any(|s| s.0 == k),
                    "change at edge {k} not visited"
                );
            }
        }
    }

    #[test]
    fn held_shifts_at_once_equal_shifts_one_at_a_time() {
        for samples in [1u32, 2, 3, 5, 63, 64] {
            let f = DigitalFilter::new(samples, C);
            let regs = [
                0,
                1,
                0b10,
                0b101,
                0b110,
                f.mask(),
                f.mask() - 1,
                f.mask() >> 1,
            ];
            for reg in regs {
                for out in [false, true] {
                    for z in [false, true] {
                        for n in 0..=u64::from(samples) {
                            let start = DigitalFilter {
                                reg,
                                out,
                                ..f.clone()
                            };
                            let mut once = start.clone();
                            once.shift_held(z, n);
                            let mut each = start;
                            for _ in 0..n {
                                each.shift(z);
                            }
                            assert_eq!(
                                (once.reg, once.out),
                                (each.reg, each.out),
                                "samples {samples} reg {reg:b} out {out} z {z} n {n}"
                            );
                        }
                    }
                }
            }
        }
    }
}
