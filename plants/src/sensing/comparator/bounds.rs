//! Bounds on a channel's input over a run of ticks (filter transients at the ends, the
//! stationary point between, the ringing's envelope, the noise's range): whether the output
//! may toggle there, or is certain.

use super::front::{Channel, Front};
use super::tick_instant;

impl Front {
    /// Whether `c`'s output, now `out`, may toggle at a tick in `a..=b` of its step, with
    /// noise in [n_lo, n_hi]: the filter decays at both ends, the ringing's envelope at `a`.
    /// Inlined, as the bounds it calls: a scan's loop runs it 8 times on average, and out
    /// of line its arguments and results go through memory.
    #[inline(always)]
    pub(super) fn may_toggle_over(
        &self,
        c: &Channel,
        out: bool,
        a: u64,
        b: u64,
        n_lo: f64,
        n_hi: f64,
    ) -> bool {
        let (ta, tb, w, env) = self.over(c, a, b);
        self.may_toggle(c, out, ta, tb, w, env, n_lo, n_hi)
    }

    /// Whether `c`'s output, now `out`, may toggle at its step's first tick, with the noise
    /// anywhere in its range (the filter transients and the ringing from their values
    /// there alone: the cheapest bound).
    #[inline(always)]
    pub(super) fn may_toggle_at_start(&self, c: &Channel, out: bool) -> bool {
        let ta = tick_instant(c.k_s) - c.t0;
        let w = [c.base.0, c.base.1, c.base.0, c.base.1];
        let env = self.ring_envelope_at(c.k_s);
        let (lo, hi) = Self::range_ends(c, ta, ta, w, env);
        self.can_toggle(out, lo, hi, -self.noise_a, self.noise_a)
    }

    /// Ticks `a..=b` of `c`'s step as the bounds take them: τ at both ends, the filter
    /// decays there, and the ringing's envelope at `a` (it only decays after).
    #[inline(always)]
    pub(super) fn over(&self, c: &Channel, a: u64, b: u64) -> (f64, f64, [f64; 4], f64) {
        let (ta, tb) = (tick_instant(a) - c.t0, tick_instant(b) - c.t0);
        let (pa, na) = self.decay(c, a);
        let (pb, nb) = if a == b { (pa, na) } else { self.decay(c, b) };
        (ta, tb, [pa, na, pb, nb], self.ring_envelope_at(a))
    }

    /// The output over ticks `a..=b` of `c`'s step if the comparator input is beyond a
    /// threshold there whatever the noise and ringing: then it does not depend on the
    /// ticks before.
    pub(super) fn certain_over(&self, c: &Channel, a: u64, b: u64) -> Option<bool> {
        let (ta, tb, w, env) = self.over(c, a, b);
        let (lo, hi) = self.range(c, ta, tb, w, env);
        if lo - self.noise_a > self.half_h {
            Some(true)
        } else if hi + self.noise_a < -self.half_h {
            Some(false)
        } else {
            None
        }
    }

    /// Whether the output, now `out`, may toggle somewhere in τ ∈ [ta, tb], given noise in
    /// [n_lo, n_hi].
    /// `w` holds the decay factors (e^{−ta/τp}, e^{−ta/τn}, e^{−tb/τp}, e^{−tb/τn}); `env`
    /// bounds the ringing from ta on.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn may_toggle(
        &self,
        c: &Channel,
        out: bool,
        ta: f64,
        tb: f64,
        w: [f64; 4],
        env: f64,
        n_lo: f64,
        n_hi: f64,
    ) -> bool {
        // The ends first: the stationary point can only widen the range.
        let (lo, hi) = Self::range_ends(c, ta, tb, w, env);
        if self.can_toggle(out, lo, hi, n_lo, n_hi) {
            return true;
        }
        match self.stationary_within(c, w) {
            Some(g) => self.can_toggle(out, lo.min(lo + g), hi.max(hi + g), n_lo, n_hi),
            None => false,
        }
    }

    /// Whether a noise-free signal range [lo, hi] plus noise in [n_lo, n_hi] can cross the
    /// threshold the output, now `out`, is waiting for.
    #[inline(always)]
    fn can_toggle(&self, out: bool, lo: f64, hi: f64, n_lo: f64, n_hi: f64) -> bool {
        if out {
            lo + n_lo < -self.half_h
        } else {
            hi + n_hi > self.half_h
        }
    }

    /// Range of the noise-free signal (offset and ringing envelope included) over
    /// τ ∈ [ta, tb]; `w` and `env` as in [`Front::may_toggle`].
    pub(super) fn range(&self, c: &Channel, ta: f64, tb: f64, w: [f64; 4], env: f64) -> (f64, f64) {
        let (lo, hi) = Self::range_ends(c, ta, tb, w, env);
        match self.stationary_within(c, w) {
            Some(g) => (lo.min(lo + g), hi.max(hi + g)),
            None => (lo, hi),
        }
    }

    /// [`Front::range`] from the interval's ends only: exact for P's chord, widened
    /// by P's deviation from it, and for the transients unless their stationary point lies
    /// inside.
    #[inline(always)]
    fn range_ends(c: &Channel, ta: f64, tb: f64, w: [f64; 4], env: f64) -> (f64, f64) {
        let (l1, l2) = (c.poly[0] + c.beta * ta, c.poly[0] + c.beta * tb);
        let (ga, gb) = (c.a * w[0] - c.b * w[1], c.a * w[2] - c.b * w[3]);
        let (l_lo, l_hi) = min_max(l1, l2);
        let (g_lo, g_hi) = min_max(ga, gb);
        (l_lo + c.dev.0 + g_lo - env, l_hi + c.dev.1 + g_hi + env)
    }

    /// How far g(τ) = A·e^{−τ/τp} − B·e^{−τ/τn} reaches beyond its values at the ends of
    /// the interval whose decay factors are `w` (signed), if its one stationary point is
    /// inside: that is where g′ changes sign, so no logarithm is needed to rule it out.
    #[inline(always)]
    fn stationary_within(&self, c: &Channel, w: [f64; 4]) -> Option<f64> {
        let (ap, bn) = (c.ap, c.bn);
        let (da, db) = (bn * w[1] - ap * w[0], bn * w[3] - ap * w[2]);
        if da * db >= 0.0 {
            return None;
        }
        let gts = c
            .stationary
            .get()
            .unwrap_or_else(|| self.stationary_value(c));
        let (ga, gb) = (c.a * w[0] - c.b * w[1], c.a * w[2] - c.b * w[3]);
        Some(if gts > ga.max(gb) {
            gts - ga.max(gb)
        } else if gts < ga.min(gb) {
            gts - ga.min(gb)
        } else {
            0.0
        })
    }

    /// g at its stationary point (see [`Front::stationary_within`]), computed once per
    /// channel and step: out of line, so that the bounds inlined in the scans stay short.
    #[cold]
    #[inline(never)]
    pub(super) fn stationary_value(&self, c: &Channel) -> f64 {
        // g′(ts) = 0: e^{(1/τp − 1/τn)·ts} = (A·τn)/(B·τp), and there
        // B·e^{−ts/τn} = (τn/τp)·A·e^{−ts/τp}: one exp for both terms.
        let (inv_p, inv_n) = self.inv_tau;
        let ts = (c.ap / c.bn).ln() / (inv_p - inv_n);
        let g = c.a * (-ts * inv_p).exp() * (1.0 - self.tau_n * inv_p);
        c.stationary.set(Some(g));
        g
    }
}

/// (min, max) of two finite values, as plain selects: `f64::min` and `max` also order
/// NaNs, which costs a handful of instructions a call in the bounds.
#[inline(always)]
fn min_max(a: f64, b: f64) -> (f64, f64) {
    if a < b { (a, b) } else { (b, a) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ComparatorParams;
    use crate::sensing::comparator::ComparatorBank;
    use crate::sensing::comparator::front::Ring;
    use crate::sensing::comparator::records::Bend;
    use crate::sensing::foh::Foh;
    use crate::sensing::rc::{CubicRc, hermite, horner};
    use drive_core::{Abc, Phase, TICK_S, Ticks};
    use std::f64::consts::TAU;

    /// The bounds a scan rules ticks out by hold at every tick they cover: over spans of a
    /// step with filter transients, a floating leg's bend and ringing, the range a bound
    /// gives contains the noise-free signal (ringing included) evaluated tick by tick with
    /// `exp` and `sin`, and a span ruled out with the noise anywhere in its range holds no
    /// tick where the output could toggle.
    #[test]
    fn the_bounds_hold_at_every_tick_they_cover() {
        let p = ComparatorParams {
            ring_decay_s: 0.4e-6,
            ..ComparatorParams::default()
        };
        let (tp, tn, tr) = (p.phase_filter_tau_s, p.neutral_filter_tau_s, p.ring_decay_s);
        let w = TAU * p.ring_frequency_hz;
        let (half_h, noise) = (p.hysteresis_v / 2.0, p.noise_v);
        // Ringing excited at tick 90; the step from 0.4 ticks before tick 100, 30 µs long.
        let (rk, z) = (90u64, (0.05, -0.12));
        let (t0, h) = (99.6 * TICK_S, 30e-6);
        let mut f = ComparatorBank::new(&p, 3, &Abc::splat(0.0), 0.0).front;
        f.ring = Ring {
            z,
            t: tick_instant(rk),
            k: rk,
            mag: z.0.hypot(z.1),
        };
        let taus = ((tp, tn), (1.0 / tp, 1.0 / tn));
        // A floating leg's bend (a cubic from rest through the phase filter), and none.
        let q = hermite(1.0 / h, (0.0, 3e3), (0.0, -5e3));
        let bend = Bend::new(&CubicRc::new(0.0, 0.0, q, tp));
        let (mut ruled_out, mut spans) = (0, 0);
        for (fx, fn_) in [
            // A common-mode step's filter spike about a rising back-EMF.
            (
                Foh::ramp(0.2, 6.0, 2e3, tp),
                Foh::ramp(0.2, 6.0 - 4e-3, 0.0, tn),
            ),
            // Falling through the thresholds.
            (
                Foh::ramp(0.01, 0.01, -1.5e3, tp),
                Foh::ramp(0.0, 0.0, 0.0, tn),
            ),
        ] {
            for b in [None, Some(&bend)] {
                let mut c = Channel::new(Phase::U, t0, (&fx, b, &fn_), taus, 1e-3, h);
                c.k_s = 100;
                let ta = tick_instant(c.k_s) - t0;
                c.base = ((-ta / tp).exp(), (-ta / tn).exp());
                let k_end = Ticks::at_or_before(t0 + h).0;
                let s = |k: u64| {
                    let tau = tick_instant(k) - t0;
                    let dt = (k - rk) as f64 * TICK_S;
                    horner(&c.poly, tau) + c.a * (-tau / tp).exp() - c.b * (-tau / tn).exp()
                        + (-dt / tr).exp() * (z.0 * (w * dt).sin() + z.1 * (w * dt).cos())
                };
                // Spans of 1 to 1024 ticks from ticks spread over the step.
                for (i, a) in (c.k_s..=k_end).step_by(37).enumerate() {
                    for len in [1, 2, 7, 25, 64, 200, 1024] {
                        let b = (a + len - 1).min(k_end);
                        let (ta, tb, wd, env) = f.over(&c, a, b);
                        let (lo, hi) = f.range(&c, ta, tb, wd, env);
                        let tol = 1e-12 * (c.a.abs() + c.b.abs() + c.poly[0].abs() + 1.0);
                        for k in a..=b {
                            let v = s(k);
                            assert!(
                                lo - tol <= v && v <= hi + tol,
                                "tick {k} in {a}..={b}: {v} outside [{lo}, {hi}]"
                            );
                        }
                        for out in [false, true] {
                            spans += 1;
                            if !f.may_toggle_over(&c, out, a, b, -noise, noise) {
                                ruled_out += 1;
                                let crossing = (a..=b).any(|k| {
                                    let v = s(k);
                                    if out {
                                        v - noise < -half_h + tol
                                    } else {
                                        v + noise > half_h - tol
                                    }
                                });
                                assert!(!crossing, "span {a}..={b} (out {out}, {i}) ruled out");
                            }
                        }
                    }
                }
            }
        }
        // Both kinds of span occur: some ruled out, some not.
        assert!(
            ruled_out > spans / 10 && ruled_out < spans,
            "{ruled_out} of {spans}"
        );
    }
}
