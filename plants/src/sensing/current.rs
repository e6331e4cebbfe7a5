//! Shunt-current channel: shunt → ×gain amplifier (clipped to its swing) → first-order
//! low-pass → sample-and-hold ADC converting back to back.
//!
//! Over a plant step the shunt current is the cubic Hermite interpolant of its values and
//! slopes at the step's ends (fourth-order accurate, like the step), clipped to the
//! amplifier's swing, and the filter's response to it is exact piece by piece.
//!
//! Sample k is taken at k·T_conv and becomes readable at (k+1)·T_conv; the reading is
//! `code = floor(v / full_scale · 2^bits)` clipped to 0..2^bits − 1. Negative shunt current
//! (regeneration, diode freewheeling into the supply) clips to code 0, as on a single-supply
//! amplifier.

use super::rc::{CubicRc, ExpTable, TauTerms};
use crate::params::CurrentSenseParams;
use drive_core::{TICK_S, Ticks};
use std::cell::Cell;

mod state;

/// The current-sense chain and its ADC pipeline.
#[derive(Clone, Debug)]
pub struct CurrentSense {
    volts_per_amp: f64,
    max_v: f64,
    /// The filter's time constant T and its products, for each piece.
    tau_terms: TauTerms,
    /// e^{−t/T} by table: the transient's decay at each sample and piece's end.
    decay: ExpTable<1>,
    codes: f64,
    max_code: u16,
    full_scale: f64,
    conv: u64,
    y: f64,
    /// The latest conversions' codes in a ring by sample number n mod its length (sample n
    /// taken at n·T_conv, readable from (n + 1)·T_conv): the `held` newest, n up to
    /// `next_n` − 1, and at most `keep` of them (every one taken over the longest update,
    /// since an update may run ahead of the instants read). Samples are taken back to back,
    /// so the codes alone say which conversion is readable when. Only those below
    /// `coded_to` are in the ring; the later ones are coded from their update's pieces
    /// when read (the controller reads about one in three).
    codes_ring: Box<[u16]>,
    held: usize,
    keep: usize,
    coded_to: u64,
    /// The next sample's number: it is taken at tick `next_n`·T_conv.
    next_n: u64,
    /// The latest updates' pieces in a ring, the newest at `newest` mod its length (to cut
    /// it short, and to code its samples): a reused one's samples still held are coded
    /// first.
    updates: Box<[Update; UPDATES]>,
    newest: usize,
    /// The last sample coded for a read and its code, (`u64::MAX`, 0) for none: the
    /// controller often reads one sample at several ticks within a conversion (derived;
    /// forgotten with the sample by a cut and by a restore).
    read: Cell<(u64, u16)>,
}

/// One update's filter pieces, its start \[s\] and the numbers of the samples it took,
/// `from..to`.
#[derive(Copy, Clone, Debug)]
struct Update {
    pieces: Pieces,
    t0: f64,
    from: u64,
    to: u64,
}

/// No sample coded for a read (see `CurrentSense::read`).
const NO_READ: (u64, u16) = (u64::MAX, 0);

/// Updates kept: a power of two, and more than take place while a sample is held (a
/// few conversions), so that a sample read is seldom coded before it is.
const UPDATES: usize = 16;

/// The pieces of one update: the cubic where it is inside the amplifier's swing, the clip
/// level where it is not (at most three monotone parts, each crossing each level once).
#[derive(Copy, Clone, Debug)]
struct Pieces {
    seg: [CubicRc; 7],
    n: usize,
    /// The filter output at the end of the update \[V\].
    y_end: f64,
}

impl Pieces {
    /// The piece that holds τ, its transient decayed by `decay`'s e^{−(τ − τa)/T}.
    #[inline]
    fn at(&self, t: f64, decay: &ExpTable<1>) -> f64 {
        let k = self.seg[..self.n]
            .iter()
            .rposition(|s| s.from <= t)
            .unwrap_or(0);
        let s = &self.seg[k];
        s.at_decayed(t, decay.at(t - s.from)[0])
    }
}

impl CurrentSense {
    /// A settled chain at zero current with `shunt_ohm` in the power path, advanced by
    /// updates no longer than `longest_update_s`.
    pub fn new(p: &CurrentSenseParams, shunt_ohm: f64, longest_update_s: f64) -> Self {
        let conv = p.conversion().0;
        let per_update = (longest_update_s / TICK_S / conv as f64).ceil() as usize;
        let keep = per_update + 4;
        let tau = 1.0 / (std::f64::consts::TAU * p.filter_cutoff_hz);
        CurrentSense {
            volts_per_amp: shunt_ohm * p.amplifier_gain,
            max_v: p.amplifier_max_v,
            tau_terms: TauTerms::new(tau),
            decay: ExpTable::new([-1.0 / tau]),
            codes: (1u32 << p.adc_bits) as f64,
            max_code: ((1u32 << p.adc_bits) - 1) as u16,
            full_scale: p.adc_full_scale_v,
            conv,
            y: 0.0,
            // A power of two, so that the slot is a mask of the sample number.
            codes_ring: vec![0; keep.next_power_of_two()].into_boxed_slice(),
            held: 0,
            keep,
            coded_to: 1,
            next_n: 1,
            // An array, not a slice: a slot index mod UPDATES needs no bounds check.
            updates: Box::new(
                [Update {
                    pieces: Pieces {
                        seg: [CubicRc::new(0.0, 0.0, [0.0; 4], 1.0); 7],
                        n: 1,
                        y_end: 0.0,
                    },
                    t0: 0.0,
                    from: 1,
                    to: 1,
                }; UPDATES],
            ),
            newest: 0,
            read: Cell::new(NO_READ),
        }
    }

    /// Amplifier output for a shunt current \[V\].
    pub fn amplifier_v(&self, i_shunt: f64) -> f64 {
        (i_shunt * self.volts_per_amp).clamp(0.0, self.max_v)
    }

    fn quantise(&self, v: f64) -> u16 {
        // The cast truncates, which is the floor for the non-negative values that matter
        // (negative ones saturate to code 0 either way), without a library call.
        // Through i64, which baseline x86-64 converts in one instruction (u64 takes a
        // branchy sequence); the clamp gives the same code for every input, NaN included.
        ((v / self.full_scale * self.codes) as i64).clamp(0, self.max_code as i64) as u16
    }

    /// Records as the last update's pieces the filter over [0, h] with the shunt current
    /// the cubic Hermite interpolant of currents `i0`, `i1` \[A\] and slopes `d0`, `d1`
    /// [A/s], clipped to the amplifier's swing: at once when the amplifier's output stays
    /// clear of both clip levels (most updates), else by [`CurrentSense::search_pieces`].
    fn set_pieces(&mut self, h: f64, (i0, d0): (f64, f64), (i1, d1): (f64, f64)) {
        let g = self.volts_per_amp;
        let (y0, y1, m0, m1) = (g * i0, g * i1, g * d0 * h, g * d1 * h);
        let Some(c) = Self::one_side(self.max_v, (y0, m0), (y1, m1), h) else {
            return self.search_pieces(h, (y0, m0), (y1, m1));
        };
        // What the search finds then: no cut, one piece over [0, h].
        let seg = CubicRc::with_terms(0.0, self.y, c, &self.tau_terms);
        let out = &mut self.updates[self.newest % UPDATES].pieces;
        out.y_end = seg.at_decayed(h, self.decay.at(h)[0]);
        out.seg[0] = seg;
        out.n = 1;
    }

    /// [`CurrentSense::set_pieces`] by splitting the cubic into its monotone parts and
    /// finding where each crosses a clip level; the amplifier's output as there, its ends
    /// `y0`, `y1` \[V\] and slopes `m0`, `m1` [V per update].
    fn search_pieces(&mut self, h: f64, (y0, m0): (f64, f64), (y1, m1): (f64, f64)) {
        // In s = τ/h: v(s) = y0 + m0·s + c2·s² + c3·s³ [V].
        let (c2, c3) = Self::hermite_terms((y0, m0), (y1, m1));
        let v = |s: f64| y0 + s * (m0 + s * (c2 + s * c3));
        let coeffs = Self::in_tau(h, y0, m0, (c2, c3));
        // Monotone parts: split at the roots of v′ = m0 + 2·c2·s + 3·c3·s².
        let mut cuts = [0.0, 1.0, 1.0, 1.0];
        let mut n_cuts = 1;
        let (a, b) = (3.0 * c3, 2.0 * c2);
        let mut ext = [f64::NAN; 2];
        if a != 0.0 {
            let disc = b * b - 4.0 * a * m0;
            if disc > 0.0 {
                let r = disc.sqrt();
                ext = [(-b - r) / (2.0 * a), (-b + r) / (2.0 * a)];
            }
        } else if b != 0.0 {
            ext[0] = -m0 / b;
        }
        for e in ext {
            if e > 0.0 && e < 1.0 {
                cuts[n_cuts] = e;
                n_cuts += 1;
            }
        }
        // Ascending (two roots come in either order, by the sign of a).
        if n_cuts == 3 && cuts[2] < cuts[1] {
            cuts.swap(1, 2);
        }
        cuts[n_cuts] = 1.0;
        // Where each monotone part crosses a clip level: the values at the parts' ends,
        // once each; usually all inside the swing (or all below it), and no part crosses.
        let (lo, hi) = (0.0, self.max_v);
        let ends: [f64; 4] = std::array::from_fn(|i| v(cuts[i]));
        let ends = &ends[..=n_cuts];
        let mut bounds = [0.0; 8];
        let mut n_b = 1;
        let inside = |l: f64, u: f64| ends.iter().all(|&e| e - l > 0.0 && e - u < 0.0);
        let parts = if inside(lo, hi) || inside(f64::NEG_INFINITY, lo) {
            0
        } else {
            n_cuts
        };
        for i in 0..parts {
            let w = [cuts[i], cuts[i + 1]];
            for level in [lo, hi] {
                let (mut a, mut b) = (w[0], w[1]);
                let (fa, fb) = (ends[i] - level, ends[i + 1] - level);
                if fa * fb >= 0.0 {
                    continue;
                }
                // Newton on the monotone part, kept inside the bracket by bisection.
                let dv = |s: f64| m0 + s * (2.0 * c2 + 3.0 * s * c3);
                let mut s = a - fa * (b - a) / (fb - fa);
                for _ in 0..60 {
                    let f = v(s) - level;
                    if f * fa > 0.0 {
                        a = s
                    } else {
                        b = s
                    }
                    let next = s - f / dv(s);
                    let next = if next > a && next < b {
                        next
                    } else {
                        0.5 * (a + b)
                    };
                    if (next - s).abs() < 1e-13 || b - a < 1e-13 {
                        s = next;
                        break;
                    }
                    s = next;
                }
                bounds[n_b] = s;
                n_b += 1;
            }
        }
        bounds[1..n_b].sort_by(f64::total_cmp);
        bounds[n_b] = 1.0;
        // Built in place: the pieces are the chain's record of this update.
        let (y0, terms, decay) = (self.y, self.tau_terms, &self.decay);
        let out = &mut self.updates[self.newest % UPDATES].pieces;
        out.n = 0;
        let mut y = y0;
        for w in bounds[..=n_b].windows(2) {
            if w[1] <= w[0] || out.n == out.seg.len() {
                continue;
            }
            let mid = v(0.5 * (w[0] + w[1]));
            let c = if mid < lo {
                [lo, 0.0, 0.0, 0.0]
            } else if mid > hi {
                [hi, 0.0, 0.0, 0.0]
            } else {
                coeffs
            };
            let seg = CubicRc::with_terms(w[0] * h, y, c, &terms);
            y = seg.at_decayed(w[1] * h, decay.at(w[1] * h - w[0] * h)[0]);
            out.seg[out.n] = seg;
            out.n += 1;
        }
        out.y_end = y;
    }

    /// The amplifier's output over an update of `h` \[s\] as a cubic in τ \[V, V/s, V/s²,
    /// V/s³\], from its ends `y0`, `y1` \[V\] and slopes `m0`, `m1` [V per update].
    #[inline(always)]
    fn coefficients(h: f64, (y0, m0): (f64, f64), (y1, m1): (f64, f64)) -> [f64; 4] {
        Self::in_tau(h, y0, m0, Self::hermite_terms((y0, m0), (y1, m1)))
    }

    /// The Hermite cubic's s² and s³ coefficients (c2, c3) \[V\] in s = τ/h, from its
    /// ends and slopes as in [`CurrentSense::coefficients`].
    #[inline(always)]
    fn hermite_terms((y0, m0): (f64, f64), (y1, m1): (f64, f64)) -> (f64, f64) {
        (3.0 * (y1 - y0) - 2.0 * m0 - m1, 2.0 * (y0 - y1) + m0 + m1)
    }

    /// The cubic y0 + m0·s + c2·s² + c3·s³ in s = τ/h as coefficients in τ.
    #[inline(always)]
    fn in_tau(h: f64, y0: f64, m0: f64, (c2, c3): (f64, f64)) -> [f64; 4] {
        [y0, m0 / h, c2 / (h * h), c3 / (h * h * h)]
    }

    /// The one input of a whole update of `h` \[s\] when the amplifier's output v(s), s in
    /// [0, 1], with ends `y0`, `y1` \[V\] and slopes `m0`, `m1` [V per update], provably
    /// stays on one side of each clip level 0 and `hi` \[V\]: the clip level, or the cubic.
    /// The cubic lies in the hull of its Bernstein points y0, y0 + m0/3, y1 − m1/3, y1;
    /// evaluated from rounded coefficients (each up to 3× the sum) it errs by under 100
    /// ulps of |y0| + |y1| + |m0| + |m1|, so a hull clear of a level by 1e-12 of that sum
    /// (outside the subnormal range) leaves every value
    /// [`CurrentSense::search_pieces`] evaluates on the same side: it would find no crossing
    /// and take this input. Otherwise (a hull at or across a level, e.g. a freewheeling
    /// shunt current at zero, or NaN) `None`.
    #[inline(always)]
    fn one_side(hi: f64, (y0, m0): (f64, f64), (y1, m1): (f64, f64), h: f64) -> Option<[f64; 4]> {
        let lo = 0.0;
        let (b1, b2) = (y0 + m0 / 3.0, y1 - m1 / 3.0);
        let slack = 1e-12 * (y0.abs() + y1.abs() + m0.abs() + m1.abs());
        let (min, max) = (y0.min(y1).min(b1.min(b2)), y0.max(y1).max(b1.max(b2)));
        if max < lo - slack {
            Some([lo, 0.0, 0.0, 0.0])
        } else if min > lo + slack && max < hi - slack {
            Some(Self::coefficients(h, (y0, m0), (y1, m1)))
        } else if min > hi + slack {
            Some([hi, 0.0, 0.0, 0.0])
        } else {
            None
        }
    }

    /// Advances over [t0, t1] with the shunt current and its slope (`i` \[A\], `di` [A/s]) at
    /// both ends, taking every ADC sample that falls in (t0, t1].
    pub fn update(&mut self, t0: f64, t1: f64, start: (f64, f64), end: (f64, f64)) {
        let h = t1 - t0;
        if h <= 0.0 {
            return;
        }
        self.newest = self.newest.wrapping_add(1);
        let slot = self.newest % UPDATES;
        // Its samples from `coded_to` on, if any is still held.
        if self.updates[slot].to > self.next_n - self.held as u64 {
            self.code_update(slot);
        }
        self.set_pieces(h, start, end);
        let k_end = Ticks::at_or_before(t1).0;
        let from = self.next_n;
        let next_sample = self.next_n * self.conv;
        if next_sample <= k_end {
            // The samples in (t0, t1], coded when read.
            let taken = (k_end - next_sample) / self.conv + 1;
            self.next_n += taken;
            self.held = (self.held as u64 + taken).min(self.keep as u64) as usize;
        }
        let u = &mut self.updates[slot];
        (u.t0, u.from, u.to) = (t0, from, self.next_n);
        self.y = u.pieces.y_end;
    }

    /// Codes the samples of update `slot` still held into the ring, before the slot is
    /// reused (all of its samples are at or after `coded_to`, the updates' being in order).
    #[cold]
    #[inline(never)]
    fn code_update(&mut self, slot: usize) {
        let (from, to) = (self.updates[slot].from, self.updates[slot].to);
        let mask = self.codes_ring.len() - 1;
        for n in from.max(self.next_n - self.held as u64)..to {
            let code = self.code_in(&self.updates[slot], n);
            self.codes_ring[n as usize & mask] = code;
        }
        self.coded_to = to;
    }

    /// The code of sample `n`, taken in update `u`.
    #[inline]
    fn code_in(&self, u: &Update, n: u64) -> u16 {
        self.quantise(
            u.pieces
                .at(Ticks(n * self.conv).seconds() - u.t0, &self.decay),
        )
    }

    /// The code of held sample `n`: from the ring, or from the update that took it.
    fn code_of(&self, n: u64) -> u16 {
        if n < self.coded_to {
            return self.codes_ring[n as usize & (self.codes_ring.len() - 1)];
        }
        let (read, code) = self.read.get();
        if read == n {
            return code;
        }
        let code = (0..UPDATES)
            .map(|j| &self.updates[self.newest.wrapping_sub(j) % UPDATES])
            .find(|u| u.from <= n && n < u.to)
            .map_or(0, |u| self.code_in(u, n));
        self.read.set((n, code));
        code
    }

    /// Cuts the last update short at `t` \[s\] (inside it): samples after `t` are forgotten
    /// and the filter takes its value at `t`.
    pub fn truncate_at(&mut self, t: f64) {
        let u = &mut self.updates[self.newest % UPDATES];
        self.y = u.pieces.at(t - u.t0, &self.decay);
        let k = Ticks::at_or_before(t).0;
        // The samples after t, n·T_conv > t, are forgotten.
        let next_n = (k / self.conv + 1).min(self.next_n);
        // Every slot, not only the newest: after a restore the others claim up to the
        // restored sample count, and a claim on a forgotten sample would later mark it coded.
        for u in self.updates.iter_mut() {
            (u.from, u.to) = (u.from.min(next_n), u.to.min(next_n));
        }
        let forgotten = self.next_n.saturating_sub(next_n);
        self.held = self
            .held
            .saturating_sub(usize::try_from(forgotten).unwrap_or(usize::MAX));
        self.coded_to = self.coded_to.min(next_n);
        self.next_n = next_n;
        if self.read.get().0 >= next_n {
            self.read.set(NO_READ);
        }
    }

    /// The latest conversion readable at `at` (which may lie a few conversions back), 0
    /// before the first.
    pub fn code_at(&self, at: Ticks) -> u16 {
        // Sample n is readable from (n + 1)·T_conv: the newest readable taken is n = r − 1.
        let r = (at.0 / self.conv).min(self.next_n);
        // Held are the samples next_n − held ..= next_n − 1.
        if r == 0 || r - 1 < self.next_n - self.held as u64 {
            return 0;
        }
        self.code_of(r - 1)
    }

    /// Amperes per ADC code (for converting readings back).
    pub fn amps_per_code(&self) -> f64 {
        self.full_scale / self.codes / self.volts_per_amp
    }

    /// Filter output \[V\].
    pub fn filtered_v(&self) -> f64 {
        self.y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_taken_at_once_equal_the_searched_ones_bit_for_bit() {
        // Currents inside the swing, beyond it, below zero, at zero with rounding-size
        // slopes (the freewheeling shunt), across either level, and within ulps of one,
        // from a fixed LCG.
        let base = CurrentSense::new(&CurrentSenseParams::default(), 0.25, 40e-6);
        let mut z = 0x2545_f491_4f6c_dd1d_u64;
        let mut unit = || {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let top = base.max_v / base.volts_per_amp; // [A]
        let mut at_once = 0;
        for k in 0..20_000 {
            let h = 1e-6 + 39e-6 * unit().abs();
            let (scale, rate) = match k % 4 {
                0 => (0.3, 2e4),
                1 => (0.8, 1e5),
                2 => (1e-15, 1e-11),
                _ => (0.05, 5e3),
            };
            let offset = if k % 4 == 0 { 0.25 } else { 0.0 };
            let mut start = (offset + scale * unit(), rate * unit());
            let mut end = (offset + scale * unit(), rate * unit());
            if k % 5 == 4 {
                // The margin's own case: an end, or the start's inner Bernstein point,
                // within a few ulps of the inputs' size from a clip level (0 or the top).
                let level = if k % 2 == 0 { 0.0 } else { top };
                let size = start.0.abs() + end.0.abs() + level;
                let near = level + unit() * 4.0 * f64::EPSILON * size;
                if k % 3 == 0 {
                    start.1 = 3.0 * (near - start.0) / h;
                } else {
                    end.0 = near;
                }
            }
            let (mut a, mut b) = (base.clone(), base.clone());
            a.y = unit();
            b.y = a.y;
            // The amplifier's ends and slopes per update, as `set_pieces` makes them.
            let g = a.volts_per_amp;
            let (v0, v1) = ((g * start.0, g * start.1 * h), (g * end.0, g * end.1 * h));
            a.set_pieces(h, start, end);
            b.search_pieces(h, v0, v1);
            let (pa, pb) = (&a.updates[0].pieces, &b.updates[0].pieces);
            assert_eq!(pa.n, pb.n, "{start:?} {end:?} {h}");
            assert_eq!(pa.y_end.to_bits(), pb.y_end.to_bits());
            let bits = |s: &CubicRc| {
                [s.p[0], s.p[1], s.p[2], s.p[3], s.from, s.transient].map(f64::to_bits)
            };
            for (sa, sb) in pa.seg[..pa.n].iter().zip(&pb.seg[..pb.n]) {
                assert_eq!(bits(sa), bits(sb));
            }
            at_once += usize::from(CurrentSense::one_side(a.max_v, v0, v1, h).is_some());
        }
        // Both paths were exercised.
        assert!(
            (2_000..18_000).contains(&at_once),
            "{at_once} taken at once"
        );
    }

    #[test]
    fn conversions_coded_when_read_equal_those_coded_at_once() {
        // The default step limit (80 µs: the ring is full) and a shorter one (spare slots).
        for longest in [80e-6, 40e-6] {
            coded_when_read(longest);
        }
    }

    /// Steps of every length up to `longest` (many within one conversion, so that updates
    /// are reused while their samples are held), cut short now and then; each sample coded
    /// at once from its update's pieces, as an eager converter would. A chain restored from
    /// the bytes, at times just before a cut, runs alongside until the next restore.
    fn coded_when_read(longest: f64) {
        use drive_core::state::Persist;
        let p = CurrentSenseParams::default();
        let mut c = CurrentSense::new(&p, 0.25, longest);
        let mut z = 0x9e37_79b9_7f4a_7c15_u64;
        let mut unit = || {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (z >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut eager = std::collections::BTreeMap::new();
        let (mut t, mut i) = (0.0, (0.2, 0.0));
        let mut copy: Option<CurrentSense> = None;
        for k in 0..20_000 {
            let h = match k % 3 {
                0 => longest * unit(),
                1 => 1e-6 * unit(),
                _ => 40e-9 * (1.0 + (8.0 * unit()).floor()),
            };
            let next = (0.6 * unit() - 0.05, 4e4 * (unit() - 0.5));
            c.update(t, t + h, i, next);
            if let Some(r) = copy.as_mut() {
                r.update(t, t + h, i, next);
            }
            let u = &c.updates[c.newest % UPDATES];
            for n in u.from..u.to {
                eager.insert(n, c.code_in(u, n));
            }
            (t, i) = (t + h, next);
            if k % 101 == 0 {
                let mut r = CurrentSense::new(&p, 0.25, longest);
                r.restore_from(&c.to_bytes().unwrap()).unwrap();
                copy = Some(r);
            }
            if k % 7 == 3 {
                t -= h * unit();
                c.truncate_at(t);
                if let Some(r) = copy.as_mut() {
                    r.truncate_at(t);
                }
                let k = Ticks::at_or_before(t).0;
                eager.retain(|&n, _| n * c.conv <= k);
            }
            // Every held sample, n = next_n − held ..= next_n − 1, readable from (n + 1)·T_conv.
            for n in c.next_n - c.held as u64..c.next_n {
                let at = Ticks((n + 1) * c.conv);
                assert_eq!(c.code_at(at), eager[&n], "update {k}, sample {n}");
                if let Some(r) = &copy {
                    assert_eq!(r.code_at(at), eager[&n], "restored, update {k}, sample {n}");
                }
            }
            // Read at or up to two conversions before the plant's time.
            let at = Ticks(
                Ticks::at_or_before(t)
                    .0
                    .saturating_sub((2.0 * c.conv as f64 * unit()) as u64),
            );
            // The newest conversion readable then, sample n with (n + 1)·T_conv <= at, if
            // taken and still among the `held` newest.
            let got = c.code_at(at);
            let n = (at.0 / c.conv).min(c.next_n);
            if n >= 1 && n - 1 + c.held as u64 >= c.next_n {
                assert_eq!(got, eager[&(n - 1)], "update {k}, at {at:?}");
            } else {
                assert_eq!(got, 0, "update {k}, at {at:?}");
            }
            if let Some(r) = &copy {
                assert_eq!(r.code_at(at), got, "restored, update {k}");
                assert_eq!(r.to_bytes().unwrap(), c.to_bytes().unwrap(), "update {k}");
            }
        }
    }

    #[test]
    fn a_restored_code_beyond_the_converter_is_refused() {
        use drive_core::state::{Persist, Writer};
        let p = CurrentSenseParams::default();
        let mut c = CurrentSense::new(&p, 0.25, 80e-6);
        c.update(0.0, 60e-6, (0.3, 0.0), (0.3, 0.0));
        // The chain's bytes as it saves them, with the newest code set to `code`.
        let bytes = |code: Option<u16>| {
            let mut results = c.conversions();
            if let Some(code) = code {
                results.back_mut().unwrap().1 = code;
            }
            let mut w = Writer::new();
            c.y.save(&mut w);
            c.save_results(&results, &mut w);
            (c.next_n * c.conv).save(&mut w);
            let u = &c.updates[c.newest % UPDATES];
            (u.pieces, u.t0).save(&mut w);
            w.finish().unwrap()
        };
        assert_eq!(
            bytes(None),
            c.to_bytes().unwrap(),
            "written as the chain saves"
        );
        let top = (1u16 << p.adc_bits) - 1;
        let mut r = CurrentSense::new(&p, 0.25, 80e-6);
        r.restore_from(&bytes(Some(top))).unwrap();
        let err = r.restore_from(&bytes(Some(top + 1))).unwrap_err();
        assert!(
            err.contains(&format!(
                "= {} (rule: a code of the converter, 0..={top})",
                top + 1
            )),
            "{err}"
        );
    }

    #[test]
    fn a_sample_read_then_cut_or_restored_away_reads_as_taken_again() {
        // A chain that read its newest samples (remembering the last) against one that did
        // not: after a cut before those samples, and after a restore of an earlier state,
        // both take them again from a different current and read the new codes.
        use drive_core::state::Persist;
        let p = CurrentSenseParams::default();
        let fresh = || CurrentSense::new(&p, 0.25, 80e-6);
        let (mut c, mut d) = (fresh(), fresh());
        let mut t = 0.0;
        let mut saved = None;
        let newest = |x: &CurrentSense| Ticks(x.next_n * x.conv);
        for k in 0..30 {
            for x in [&mut c, &mut d] {
                x.update(t, t + 10e-6, (0.2, 0.0), (0.2, 0.0));
            }
            t += 10e-6;
            assert_eq!(c.code_at(newest(&c)), d.code_at(newest(&d)));
            if k == 20 {
                saved = Some(c.to_bytes().unwrap());
            }
        }
        let read = newest(&c);
        assert_eq!(c.code_at(read), 1638, "0.2 A settled: 4 V of 10 V, 12 bits");
        // Cut 25 µs back (the sample just read is forgotten), then 0.4 A: code 3276.
        for x in [&mut c, &mut d] {
            x.truncate_at(t - 25e-6);
            x.update(t - 25e-6, t + 60e-6, (0.4, 0.0), (0.4, 0.0));
        }
        assert_eq!(c.code_at(read), d.code_at(read));
        assert_ne!(c.code_at(read), 1638, "the sample was taken again");
        // Back to an earlier state, then 0.1 A up to the instant read.
        let later = Ticks(read.0 + 2 * c.conv);
        assert_eq!(c.code_at(later), d.code_at(later));
        let saved = saved.expect("saved at update 20");
        let t_saved = 210e-6;
        for x in [&mut c, &mut d] {
            x.restore_from(&saved).unwrap();
            x.update(t_saved, t + 60e-6, (0.1, 0.0), (0.1, 0.0));
        }
        for at in [later, read] {
            assert_eq!(c.code_at(at), d.code_at(at), "{at:?}");
            assert!(c.code_at(at) < 1638, "{at:?}: taken again from 0.1 A");
        }
    }

    #[test]
    fn a_restored_update_cut_short_reads_as_the_uninterrupted_one() {
        // A lookahead past the next gate change, saved, then cut short at the change and
        // followed by another current: the samples after the cut are taken again, from the
        // new update, in both chains.
        use drive_core::state::Persist;
        let p = CurrentSenseParams::default();
        let mut c = CurrentSense::new(&p, 0.25, 80e-6);
        let i = |t: f64| (0.1 + 1e3 * t, 1e3);
        let mut t = 0.0;
        for _ in 0..20 {
            c.update(t, t + 10e-6, i(t), i(t + 10e-6));
            t += 10e-6;
        }
        c.update(t, t + 60e-6, i(t), i(t + 60e-6));
        let mut r = CurrentSense::new(&p, 0.25, 80e-6);
        r.restore_from(&c.to_bytes().unwrap()).unwrap();
        for x in [&mut c, &mut r] {
            x.truncate_at(t + 5e-6);
            x.update(t + 5e-6, t + 45e-6, (0.4, 0.0), (0.4, 0.0));
        }
        assert!(c.held > 2, "samples after the cut were taken again");
        for n in c.next_n - c.held as u64..c.next_n {
            let at = Ticks((n + 1) * c.conv);
            assert_eq!(r.code_at(at), c.code_at(at), "sample {n}");
        }
        assert_eq!(r.to_bytes().unwrap(), c.to_bytes().unwrap());
    }

    #[test]
    fn spec_scaling_half_amp_is_full_scale() {
        let c = CurrentSense::new(&CurrentSenseParams::default(), 0.25, 40e-6);
        assert!((c.amplifier_v(0.5) - 10.0).abs() < 1e-12);
        assert_eq!(c.amplifier_v(-0.1), 0.0);
        assert!((c.amps_per_code() - 0.5 / 4096.0).abs() < 1e-15);
    }

    /// T·y′ = clip(g·i(t)) − y from y = 0 over [0, h] by RK4 with 20 000 steps.
    fn reference(c: &CurrentSense, i: impl Fn(f64) -> f64, h: f64) -> f64 {
        let f = |t: f64, y: f64| (c.amplifier_v(i(t)) - y) / c.tau_terms.tau();
        let (mut y, n) = (0.0, 20_000);
        let dt = h / n as f64;
        for k in 0..n {
            let t = k as f64 * dt;
            let k1 = f(t, y);
            let k2 = f(t + dt / 2.0, y + dt / 2.0 * k1);
            let k3 = f(t + dt / 2.0, y + dt / 2.0 * k2);
            let k4 = f(t + dt, y + dt * k3);
            y += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
        y
    }

    #[test]
    fn the_filter_follows_a_clipped_current_exactly() {
        // From −0.1 A (clipped to 0 V) through the 0.5 A top of the swing and back.
        let i = |t: f64| -0.1 + t * (1e5 + t * (-2e9));
        let di = |t: f64| 1e5 - 4e9 * t;
        let p = CurrentSenseParams::default();
        let mut c = CurrentSense::new(&p, 0.25, 40e-6);
        let h = 40e-6;
        c.update(0.0, h, (i(0.0), di(0.0)), (i(h), di(h)));
        assert!(i(25e-6) > 0.5 && i(0.0) < 0.0, "both clips are visited");
        let y = reference(&c, i, h);
        assert!(
            (c.filtered_v() - y).abs() < 1e-9,
            "{} vs {y}",
            c.filtered_v()
        );
    }

    #[test]
    fn the_filter_follows_a_cubic_current_exactly() {
        // i(t) = 0.2 + 3000·t − 4e7·t² + 5e11·t³ [A] over 20 µs, inside the amplifier's swing.
        let i = |t: f64| 0.2 + t * (3000.0 + t * (-4e7 + t * 5e11));
        let di = |t: f64| 3000.0 + t * (-8e7 + t * 1.5e12);
        let p = CurrentSenseParams::default();
        let mut c = CurrentSense::new(&p, 0.25, 40e-6);
        let h = 20e-6;
        c.update(0.0, h, (i(0.0), di(0.0)), (i(h), di(h)));
        let y = reference(&c, i, h);
        assert!(
            (c.filtered_v() - y).abs() < 1e-9,
            "{} vs {y}",
            c.filtered_v()
        );
        // The straight line between the ends would be off by far more than that.
        let mut lin = CurrentSense::new(&p, 0.25, 40e-6);
        lin.update(
            0.0,
            h,
            (i(0.0), (i(h) - i(0.0)) / h),
            (i(h), (i(h) - i(0.0)) / h),
        );
        assert!((lin.filtered_v() - y).abs() > 1e-4);
    }

    #[test]
    fn dc_current_settles_and_reads_with_one_conversion_latency() {
        let p = CurrentSenseParams::default();
        let mut c = CurrentSense::new(&p, 0.25, 40e-6);
        let i = 0.2; // → 4 V → code floor(4/10·4096) = 1638
        let dt = 1e-6;
        for k in 0..1000 {
            c.update(k as f64 * dt, (k + 1) as f64 * dt, (i, 0.0), (i, 0.0));
        }
        assert_eq!(c.code_at(Ticks(50_000)), 1638);
        // Filter time constant 6.37 µs: one conversion after a step the reading is still 0.
        let mut c = CurrentSense::new(&p, 0.25, 40e-6);
        c.update(0.0, 20e-6, (i, 0.0), (i, 0.0));
        assert_eq!(c.code_at(Ticks(999)), 0);
        let v = 4.0 * (1.0 - (-20e-6 / c.tau_terms.tau()).exp());
        c.update(20e-6, 40e-6, (i, 0.0), (i, 0.0));
        assert_eq!(c.code_at(Ticks(2000)), (v / 10.0 * 4096.0).floor() as u16);
    }
}
