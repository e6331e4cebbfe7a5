//! The scan for toggles over a step: noise segments ruled out in blocks where the bounds
//! allow, and ticks walked one by one (two lanes at a time) where they do not.

use super::front::{Channel, Front};
use super::records::Record;
use super::tick_instant;
use crate::sensing::noise;
use crate::sensing::rc::horner;
use drive_core::{Phase, TICK_S};

/// One channel's scan of one step, resumable: the next tick to decide. A channel nobody
/// watches is scanned only as far as someone reads it.
#[derive(Clone, Debug)]
pub(super) struct Cursor {
    pub(super) c: Channel,
    pub(super) k: u64,
    pub(super) k_end: u64,
}

impl Front {
    /// Puts in `slot` a scan of channel `x` over recorded step `rec`, unless nothing can
    /// happen in it (then `slot` is left empty); returns whether it did. The scan is built
    /// in its slot and bounded there: a scan is large, and most steps are ruled out whole.
    pub(super) fn open(&self, rec: &Record, x: Phase, slot: &mut Option<Cursor>) -> bool {
        if rec.k_start > rec.k_end {
            *slot = None;
            return false;
        }
        let cur = slot.insert(Cursor {
            c: self.channel(rec, x),
            k: rec.k_start,
            k_end: rec.k_end,
        });
        // From the first tick on, as the scan's bounds: the step's start instant is the
        // last one's, and a PWM edge's ringing has decayed by a tick there (10 % at 0.2 µs).
        let ta = tick_instant(rec.k_start) - rec.t0;
        let w = [rec.first.0, rec.first.1, rec.eh.0, rec.eh.1];
        let (a, env) = (self.noise_a, rec.env_first);
        let open = self.may_toggle(&cur.c, self.out.get(x), ta, rec.h, w, env, -a, a);
        if !open {
            *slot = None;
        }
        open
    }

    /// Walks the ticks of `cur`'s step up to `k_stop` (at most its last) where a toggle is
    /// possible, and leaves `cur` at the next tick.
    ///
    /// Blocks of noise segments are ruled out whole where the bounds allow (with the noise
    /// anywhere in its range), the block doubling after each one ruled out and halving
    /// after each one that is not; a single segment is bounded with its own noise sample
    /// and walked tick by tick if that fails. So the segments where a toggle is possible
    /// are found with a number of bounds logarithmic in the step's length. A block may
    /// reach past `k_stop`: ticks ruled out there need no walk when the scan resumes.
    pub(super) fn scan_to(&mut self, cur: &mut Cursor, k_stop: u64) {
        let c = &cur.c;
        let x = c.x;
        let ch = x.index();
        let key = noise::channel_key(self.seed, ch as u64);
        self.work.scans += 1;
        let (k_end, stop) = (cur.k_end, k_stop.min(cur.k_end));
        let (a, n) = (self.noise_a, self.noise_n);
        let mut k = cur.k;
        // A scan resumed mid-step tries the rest of the step first: usually ruled out at
        // once. A fresh one was opened because the whole step was not (see
        // `Front::open`), mostly for the filters' transient right after its start: it
        // starts with a block of 4 segments and doubles from there (or with those 4
        // one by one, below).
        let m_end = k_end / n; // the step's last noise segment
        // k's noise sample index, one per segment: divided once, then counted (a block
        // or segment ends at a segment's end, or past `stop`).
        let mut m = k / n;
        let rest = m_end - m + 1;
        // The output changes only in a walk: read once, not at every bound.
        let mut out = self.out.get(x);
        let mut walked = false;
        // The end of the last small block that may toggle: its segments are bounded one
        // by one up to there, unless a walk comes first.
        let mut singles_to = 0;
        let mut span = rest;
        if k == c.k_s {
            span = rest.min(4);
            // Where the first tick alone may toggle (a cheap bound: 45 % of the first
            // blocks that fail, measured), so would the first block: its segments are
            // bounded one by one at once.
            if self.may_toggle_at_start(c, out) {
                span = 1;
                singles_to = ((m + 4) * n - 1).min(k_end);
            }
        }
        while k <= stop {
            debug_assert_eq!(m, k / n);
            if span > 1 {
                self.work.blocks += 1;
                // The block as far as the step goes: halving a span beyond the step's end
                // would bound the same block again.
                let span_in = span.min(m_end - m + 1);
                let e = ((m + span_in) * n - 1).min(k_end);
                if self.may_toggle_over(c, out, k, e, -a, a) {
                    // A small block that may toggle is usually busy at its start (a filter
                    // transient or ringing dying away): its first segment is tried with its
                    // own noise at once, rather than halves of the block first.
                    span = if span_in <= 8 { 1 } else { span_in / 2 };
                    singles_to = e;
                } else {
                    k = e + 1;
                    m += span_in;
                    span = 2 * span_in;
                }
                continue;
            }
            let seg_end = ((m + 1) * n - 1).min(stop);
            let noise = noise::uniform_keyed(key, m, a);
            self.work.segments += 1;
            if self.may_toggle_over(c, out, k, seg_end, noise, noise) {
                out = self.walk(c, k, seg_end, noise);
                span = 1; // the next segment is likely busy too
                walked = true;
                singles_to = 0;
            } else {
                // Quiet here: the rest of the step likely is too. Restarting at 8 segments
                // rather than 2 costs fewer bounds (measured); the ticks walked are the same.
                // But inside a small block that may toggle, a block from here fails again
                // (98 times in 100 at the default drive: the signal nears a threshold over
                // it), so its other segments are bounded alone first.
                span = if seg_end < singles_to { 1 } else { 8 };
                // Quiet right after a walk: what was walked (mostly a PWM edge's ringing
                // and filter spike) has died away, and the rest of the step is usually
                // ruled out at once (3 times in 4 at the default drive), where doubling from
                // 8 segments takes 3–5 bounds. Where it is not, the doubling goes on.
                if walked && seg_end < k_end {
                    walked = false;
                    self.work.blocks += 1;
                    if !self.may_toggle_over(c, out, seg_end + 1, k_end, -a, a) {
                        k = k_end + 1;
                        break;
                    }
                }
            }
            k = seg_end + 1;
            m += 1;
        }
        cur.k = k;
    }

    /// Decides ticks `k..=last` of `c`'s step one by one, with per-tick factors instead of
    /// an exp and a sincos at every tick, recording each toggle; returns the output after.
    pub(super) fn walk(&mut self, c: &Channel, k: u64, last: u64, noise: f64) -> bool {
        let x = c.x;
        self.work.ticks_scanned += last - k + 1;
        let (dp, dn) = self.decay(c, k);
        let e = (c.a * dp, c.b * dn);
        let zk = self.ring_at(k);
        let poly = [c.poly[0] + noise, c.poly[1], c.poly[2], c.poly[3]];
        let tau = tick_instant(k) - c.t0;
        let from = (k, tau, e, zk);
        // Without ringing the phasor stays 0 and adds nothing to the signal (but the sign
        // of a zero, which no threshold test sees): a loop without it. Likewise P is
        // linear but for a floating leg's bend on a long step, and its cubic terms then
        // add only zeros.
        let linear = poly[2] == 0.0 && poly[3] == 0.0;
        let out = match (zk == (0.0, 0.0), linear) {
            (true, true) => self.walk_ticks::<false, true>(x, from, last, &poly),
            (true, false) => self.walk_ticks::<false, false>(x, from, last, &poly),
            (false, true) => self.walk_ticks::<true, true>(x, from, last, &poly),
            (false, false) => self.walk_ticks::<true, false>(x, from, last, &poly),
        };
        *self.out.get_mut(x) = out;
        out
    }

    /// [`Front::walk`]'s loop over channel `x`'s ticks `k..=last` from τ, the transients
    /// (A·e^{−τ/τp}, B·e^{−τ/τn}) and the ringing phasor there (`from`), with P's
    /// coefficients `poly` (noise included), `RING` if the phasor is not 0, `LINEAR` if
    /// P's τ² and τ³ coefficients are zero; returns the output after the last tick.
    #[inline(always)]
    pub(super) fn walk_ticks<const RING: bool, const LINEAR: bool>(
        &mut self,
        x: Phase,
        (k, tau, (ep, en), zk): (u64, f64, (f64, f64), (f64, f64)),
        last: u64,
        poly: &[f64; 4],
    ) -> bool {
        let (half_h, qp, qn, qr) = (self.half_h, self.q_p, self.q_n, self.q_ring);
        let (ch, mut out) = (x.index(), self.out.get(x));
        // c0 + τ·c1 is what Horner's scheme gives with zero c2 and c3, bit for bit (τ > 0:
        // the zeros it adds are exact; at most a zero's sign differs, which no threshold
        // test sees).
        let p = |tau: f64| {
            if LINEAR {
                poly[0] + tau * poly[1]
            } else {
                horner(poly, tau)
            }
        };
        // The output toggles where sign·s passes h/2: above +h/2 when low, below −h/2
        // when high (a negation is exact, so the test is the same).
        let mut sign = if out { -1.0 } else { 1.0 };
        // Two ticks at a time, as two lanes each stepped by two ticks' factors (the
        // compiler pairs the lanes' operations): the signal at a tick then differs from a
        // tick-by-tick recurrence's by a few ulps, far below anything a threshold test
        // resolves. Toggles are rare: the pair's lanes are tested together, then in turn.
        let (qp2, qn2) = (qp * qp, qn * qn);
        let qr2 = (qr.0 * qr.0 - qr.1 * qr.1, 2.0 * qr.0 * qr.1);
        let mut t2 = [tau, tau + TICK_S];
        let mut ep2 = [ep, ep * qp];
        let mut en2 = [en, en * qn];
        let (mut zr, mut zi) = if RING {
            (
                [zk.0, zk.0 * qr.0 - zk.1 * qr.1],
                [zk.1, zk.0 * qr.1 + zk.1 * qr.0],
            )
        } else {
            ([0.0; 2], [0.0; 2])
        };
        let mut kk = k;
        while kk < last {
            let mut s2 = [p(t2[0]) + ep2[0] - en2[0], p(t2[1]) + ep2[1] - en2[1]];
            if RING {
                s2 = [s2[0] + zi[0], s2[1] + zi[1]];
            }
            if (sign * s2[0] > half_h) | (sign * s2[1] > half_h) {
                for (j, s) in s2.into_iter().enumerate() {
                    if sign * s > half_h {
                        out = !out;
                        sign = -sign;
                        self.hist[ch].push(kk + j as u64, out);
                        self.toggles += 1;
                    }
                }
            }
            ep2 = [ep2[0] * qp2, ep2[1] * qp2];
            en2 = [en2[0] * qn2, en2[1] * qn2];
            if RING {
                (zr, zi) = (
                    [zr[0] * qr2.0 - zi[0] * qr2.1, zr[1] * qr2.0 - zi[1] * qr2.1],
                    [zr[0] * qr2.1 + zi[0] * qr2.0, zr[1] * qr2.1 + zi[1] * qr2.0],
                );
            }
            t2 = [t2[0] + 2.0 * TICK_S, t2[1] + 2.0 * TICK_S];
            kk += 2;
        }
        // An odd tick left: the first lane's.
        if kk == last {
            let mut s = p(t2[0]) + ep2[0] - en2[0];
            if RING {
                s += zi[0];
            }
            if sign * s > half_h {
                out = !out;
                self.hist[ch].push(kk, out);
                self.toggles += 1;
            }
        }
        out
    }

    /// Sets channel `cur`'s output to `level` from tick `k` on (a toggle there if it
    /// differs) and moves the cursor past `k`.
    pub(super) fn settle_at(&mut self, cur: &mut Cursor, k: u64, level: bool) {
        self.set_output(cur.c.x, k, level);
        cur.k = k + 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ComparatorParams;
    use crate::sensing::comparator::front::Ring;
    use crate::sensing::comparator::{ComparatorBank, tick_instant};
    use drive_core::Abc;
    use std::f64::consts::TAU;

    /// The tick walk ([`Front::walk`]: two ticks a step on two lanes, stepped by two ticks'
    /// factors) decides every tick as the signal evaluated tick by tick with exp and sin does:
    /// s(τ) = P(τ) + noise + A·e^{−τ/τp} − B·e^{−τ/τn} + Im(z·e^{(−1/τr + jω)(t − t_z)}) \[V\]
    /// against ±h/2, over noise segments of 7 and 8 ticks (so pairs start on either parity)
    /// with filter transients and ringing. The brute-force test above walks mostly single
    /// ticks (its noise changes every tick); this one walks long segments, with a pair whose
    /// two ticks both toggle. And the LINEAR loop (P as c0 + τ·c1) records what the cubic
    /// one does for a P without τ² and τ³ terms.
    #[test]
    fn the_paired_tick_walk_decides_each_tick_as_a_scalar_evaluation_does() {
        // Without hysteresis and with ringing near Nyquist (2.2 ticks a period), a tick
        // between two of the other sign toggles twice in a row; with a 2 mV band and slower
        // ringing, the band matters.
        let mut both_in_pair = 0;
        for (hyst, ring_hz) in [(0.0, 23e6), (2e-3, 3.1e6)] {
            let p = ComparatorParams {
                offset_v: Abc::splat(0.0),
                hysteresis_v: hyst,
                ring_frequency_hz: ring_hz,
                ring_decay_s: 2e-6, // 100 ticks: the ringing lasts over the whole walk
                ..ComparatorParams::default()
            };
            let (tp, tn, tr) = (p.phase_filter_tau_s, p.neutral_filter_tau_s, p.ring_decay_s);
            let w = TAU * ring_hz;
            // Ringing excited at tick 40 [V], the step from 0.37 ticks before tick 50 [s].
            let (rk, z) = (40u64, (4e-3, -7e-3));
            let (k_s, t0) = (50u64, 49.63 * TICK_S);
            let front = || {
                let mut f = ComparatorBank::new(&p, 3, &Abc::splat(0.0), 0.0).front;
                f.ring = Ring {
                    z,
                    t: tick_instant(rk),
                    k: rk,
                    mag: z.0.hypot(z.1),
                };
                f
            };
            let tau_s = tick_instant(k_s) - t0;
            // A and B [V] at τ = 0: their difference decays slowly (τp ≠ τn).
            let (a, b) = (0.02, 0.015);
            // P [V, V/s, V/s², V/s³]: −4 mV rising by 12 mV over the walk's 6 µs, bent.
            for poly in [[-4e-3, 2e3, -2e8, 1e13], [-4e-3, 2e3, 0.0, 0.0]] {
                let c = Channel {
                    x: Phase::U,
                    t0,
                    k_s,
                    base: ((-tau_s / tp).exp(), (-tau_s / tn).exp()),
                    poly,
                    beta: 0.0,
                    dev: (0.0, 0.0),
                    a,
                    b,
                    ap: a / tp,
                    bn: b / tn,
                    stationary: std::cell::Cell::new(None),
                };
                // 40 segments of 7 and 8 ticks, each with its own noise sample (±1 mV).
                let key = noise::channel_key(5, 0);
                let mut segs = Vec::new();
                let mut k = k_s;
                for m in 0..40 {
                    let n = 7 + m % 2;
                    segs.push((k, k + n - 1, noise::uniform_keyed(key, m, 1e-3)));
                    k += n;
                }
                let mut f = front();
                for &(k, last, noise) in &segs {
                    f.walk(&c, k, last, noise);
                }
                let hist: Vec<_> = f.hist[0].toggles.iter().copied().collect();
                let out_at = |k: u64| hist.iter().rev().find(|t| t.0 <= k).is_some_and(|t| t.1);
                assert!(hist.len() > 10, "few toggles: {}", hist.len());
                assert!(hist.iter().all(|t| (k_s..k).contains(&t.0)));
                assert_eq!(f.out.u, out_at(k));
                // Each tick from the walk's output before it: a tick too close to call (the
                // lanes' rounding differs from this evaluation's) is skipped without letting
                // the comparison drift.
                let mut skipped = 0;
                for &(k0, last, noise) in &segs {
                    for k in k0..=last {
                        let tau = k as f64 * TICK_S - t0;
                        let dt = (k - rk) as f64 * TICK_S;
                        let terms = [
                            horner(&poly, tau) + noise,
                            a * (-tau / tp).exp(),
                            -b * (-tau / tn).exp(),
                            (-dt / tr).exp() * (z.0 * (w * dt).sin() + z.1 * (w * dt).cos()),
                        ];
                        let s: f64 = terms.iter().sum();
                        let before = out_at(k - 1);
                        let margin = if before { -s } else { s } - hyst / 2.0;
                        if margin.abs() <= 1e-12 * terms.iter().map(|t| t.abs()).sum::<f64>() {
                            skipped += 1;
                            continue;
                        }
                        let want = before != (margin > 0.0);
                        assert_eq!(out_at(k), want, "tick {k}, h {hyst} V, P {poly:?}");
                    }
                    // Pairs start at the segment's first tick.
                    both_in_pair += (k0..last)
                        .step_by(2)
                        .filter(|&j| out_at(j) != out_at(j - 1) && out_at(j + 1) != out_at(j))
                        .count();
                }
                assert!(skipped < 3, "{skipped} ticks too close to call");
            }
            // A linear P: both loops, with and without ringing, over 301 ticks (an odd one
            // left after the pairs), record the same toggles.
            let poly = [-4e-3, 2e3, 0.0, 0.0];
            let f = front();
            let e = (a * (-tau_s / tp).exp(), b * (-tau_s / tn).exp());
            for zk in [f.ring_at(k_s), (0.0, 0.0)] {
                let from = (k_s, tau_s, e, zk);
                let last = k_s + 300;
                let (mut lin, mut cub) = (f.clone(), f.clone());
                let (o_lin, o_cub) = if zk == (0.0, 0.0) {
                    (
                        lin.walk_ticks::<false, true>(Phase::U, from, last, &poly),
                        cub.walk_ticks::<false, false>(Phase::U, from, last, &poly),
                    )
                } else {
                    (
                        lin.walk_ticks::<true, true>(Phase::U, from, last, &poly),
                        cub.walk_ticks::<true, false>(Phase::U, from, last, &poly),
                    )
                };
                assert_eq!(o_lin, o_cub);
                assert!(!lin.hist[0].toggles.is_empty());
                assert_eq!(lin.hist[0].toggles, cub.hist[0].toggles, "ringing {zk:?}");
            }
        }
        assert!(both_in_pair > 0, "no pair with both ticks toggling");
    }
}
