//! The analog front end over one step: each channel's input in closed form (the RC
//! filters' exact responses to the step's interpolated terminal and neutral voltages, less
//! the offset), and the switching node's ringing on top.

use super::history::History;
use super::records::{Bend, Record};
use super::{ScanWork, tick_instant};
use crate::sensing::Knot;
use crate::sensing::foh::Foh;
use crate::sensing::rc::{CubicRc, ExpTable, hermite};
use crate::sensing::tick_powers::{RealPairPowers, TickPowers};
use drive_core::{Abc, Phase, TICK_S, Ticks};

/// The switching node's ringing, Im(z·e^{(−1/τr + jω)(t − t_k)}) from the excitation
/// on, referred to the tick k at instant t_k.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(super) struct Ring {
    /// The phasor (re, im) \[V\].
    pub(super) z: (f64, f64),
    /// t_k \[s\].
    pub(super) t: f64,
    pub(super) k: u64,
    /// |z| \[V\]: the envelope at t_k.
    pub(super) mag: f64,
}

impl Ring {
    /// |z| by a square root (one instruction; `hypot`, a libm call, guards against
    /// overflow far beyond volts), raised by 4 ulps so that it still bounds |z| whatever
    /// the rounding of its three operations.
    #[inline(always)]
    pub(super) fn magnitude(z: (f64, f64)) -> f64 {
        (z.0 * z.0 + z.1 * z.1).sqrt() * (1.0 + 4.0 * f64::EPSILON)
    }
}

/// The front end and the outputs: everything but the scans left pending, which are kept
/// apart so that a scan can run on its cursor in place.
#[derive(Clone, Debug)]
pub(super) struct Front {
    pub(super) tau_p: f64,
    pub(super) tau_n: f64,
    /// 1/τp, 1/τn [1/s].
    pub(super) inv_tau: (f64, f64),
    pub(super) offset: Abc<f64>,
    pub(super) half_h: f64,
    pub(super) delay: u64,
    pub(super) noise_a: f64,
    pub(super) noise_n: u64,
    pub(super) seed: u64,
    pub(super) ring_gain: f64,
    pub(super) ring_w: f64,
    pub(super) ring_decay: f64,
    /// Per-tick decay factors e^{−T/τp}, e^{−T/τn} and ring rotation e^{(−1/τr + jω)T}.
    pub(super) q_p: f64,
    pub(super) q_n: f64,
    pub(super) q_ring: (f64, f64),
    /// Last step length and its decay factors e^{−h/τp}, e^{−h/τn}.
    pub(super) decay_cache: (f64, f64, f64),
    /// Powers of the per-tick filter decays and ringing rotation.
    pub(super) pow_p: TickPowers,
    pub(super) pow_n: TickPowers,
    /// Both of them side by side, for the decays at a tick (see [`Front::decay`]).
    pub(super) pow_pn: RealPairPowers,
    pub(super) pow_ring: TickPowers,
    /// Powers of the per-tick decay of the ringing's envelope.
    pub(super) pow_env: TickPowers,
    /// e^{−t/τp}, e^{−t/τn} and e^{−t/τr} at any t ≥ 0 (off the tick grid) without libm.
    pub(super) exp_pn: ExpTable<2>,
    pub(super) exp_env: ExpTable<1>,
    pub(super) y: Abc<f64>,
    pub(super) y_n: f64,
    pub(super) out: Abc<bool>,
    pub(super) hist: [History; 3],
    pub(super) ring: Ring,
    pub(super) toggles: u64,
    pub(super) work: ScanWork,
}

/// One channel's noise-free input over the step being processed, in closed form:
/// s(τ) = P(τ) + A·e^{−τ/τp} − B·e^{−τ/τn} with P cubic (ringing and noise come on top).
#[derive(Clone, Debug)]
pub(super) struct Channel {
    pub(super) x: Phase,
    /// Start of the step \[s\].
    pub(super) t0: f64,
    /// The step's first tick and e^{−τ/τp}, e^{−τ/τn} there: the decays at a later tick
    /// follow by table (see [`Front::decay`]).
    pub(super) k_s: u64,
    pub(super) base: (f64, f64),
    /// P's coefficients \[V, V/s, …\]: the paths' particular solutions less the offset,
    /// linear but for a floating leg's back-EMF curvature; A and B \[V\] are the filter
    /// transients at τ = 0.
    pub(super) poly: [f64; 4],
    /// Bounds use P's chord over the step, P(0) + β·τ with β \[V/s\], and how far P strays
    /// from it, within [dev.0, dev.1] \[V\]: as cheap as a linear input, and valid throughout.
    pub(super) beta: f64,
    pub(super) dev: (f64, f64),
    pub(super) a: f64,
    pub(super) b: f64,
    /// A/τp and B/τn [V/s]: the transients' rates at τ = 0 (their derivative's weights).
    pub(super) ap: f64,
    pub(super) bn: f64,
    /// The value of A·e^{−τ/τp} − B·e^{−τ/τn} at its stationary point, once computed: it
    /// depends only on the step, not on the interval being bounded.
    pub(super) stationary: std::cell::Cell<Option<f64>>,
}

impl Channel {
    /// The channel over a step from `t0` (its first tick and the decays there are set when
    /// a scan needs them): the phase path's response `fx` to its chord, plus `bend` to its
    /// back-EMF's curvature (a floating leg), less the neutral path's `fn_`.
    /// `taus` holds τp and τn, the filters' time constants \[s\], `inv_tau` their
    /// inverses; the step is `h`.
    pub(super) fn new(
        x: Phase,
        t0: f64,
        (fx, bend, fn_): (&Foh, Option<&Bend>, &Foh),
        (taus, inv_tau): ((f64, f64), (f64, f64)),
        offset: f64,
        h: f64,
    ) -> Self {
        let p0 = fx.a - fn_.a - fx.b * taus.0 + fn_.b * taus.1 - offset;
        let p1 = fx.b - fn_.b;
        let (poly, a, beta, dev) = match bend {
            // Most steps: P is linear, its own chord. The values are those the general case
            // gives with a zero bend, to the bit (adding +0.0 turns −0.0 into +0.0 alike),
            // without the deviation's arithmetic on zeros (≈ 20 instructions a channel).
            None => {
                let p1 = p1 + 0.0;
                ([p0 + 0.0, p1, 0.0, 0.0], fx.c + 0.0, p1, (-0.0, 0.0))
            }
            Some(bend) => {
                let q = bend.p;
                let poly = [p0 + q[0], p1 + q[1], q[2], q[3]];
                // P − chord = τ·(τ − h)·(p2 + p3·(τ + h)): the first factor lies in
                // [−h²/4, 0], the second is linear in τ, so its values at τ = 0 and h
                // bound it (and fix the sign of the deviation where they agree).
                let (fa, fb) = (poly[2] + poly[3] * h, poly[2] + 2.0 * poly[3] * h);
                let m = 0.25 * h * h * fa.abs().max(fb.abs());
                let dev = if fa > 0.0 && fb > 0.0 {
                    (-m, 0.0)
                } else if fa < 0.0 && fb < 0.0 {
                    (0.0, m)
                } else {
                    (-m, m)
                };
                let beta = poly[1] + h * (poly[2] + h * poly[3]);
                (poly, fx.c + bend.transient, beta, dev)
            }
        };
        Channel {
            k_s: 0,
            base: (1.0, 1.0),
            ap: a * inv_tau.0,
            bn: fn_.c * inv_tau.1,
            x,
            t0,
            poly,
            beta,
            dev,
            a,
            b: fn_.c,
            stationary: std::cell::Cell::new(None),
        }
    }
}

impl Front {
    /// The ringing phasor at tick `k`, not before the last excitation (see
    /// [`ComparatorBank::excite`](super::ComparatorBank::excite)): by table.
    pub(super) fn ring_at(&self, k: u64) -> (f64, f64) {
        if self.ring.z == (0.0, 0.0) {
            return (0.0, 0.0);
        }
        debug_assert!(
            k >= self.ring.k,
            "ringing asked at tick {k}, before its excitation"
        );
        let (wr, wi) = self.pow_ring.at(k.saturating_sub(self.ring.k));
        let z = (
            self.ring.z.0 * wr - self.ring.z.1 * wi,
            self.ring.z.0 * wi + self.ring.z.1 * wr,
        );
        if z.0.abs() + z.1.abs() < 1e-9 {
            return (0.0, 0.0);
        }
        z
    }

    /// e^{−τ/τp}, e^{−τ/τn} at tick `k` (not before the step's first) of `c`'s step.
    #[inline(always)]
    pub(super) fn decay(&self, c: &Channel, k: u64) -> (f64, f64) {
        debug_assert!(k >= c.k_s, "tick {k} before the step's first, {}", c.k_s);
        let (p, q) = self.pow_pn.at(k - c.k_s);
        (c.base.0 * p, c.base.1 * q)
    }

    /// The ringing's envelope at instant `t` (not before the excitation): by table where
    /// `t` is a tick, as the engine's instants mostly are.
    fn ring_envelope(&self, t: f64) -> f64 {
        match Ticks::at_or_after(t) {
            (k, true) if k.0 >= self.ring.k => self.ring_envelope_at(k.0),
            _ if self.ring.mag == 0.0 => 0.0,
            _ => self.ring.mag * self.exp_env.at(t - self.ring.t)[0],
        }
    }

    /// The ringing's envelope at tick `k` (not before the excitation), by table.
    #[inline(always)]
    pub(super) fn ring_envelope_at(&self, k: u64) -> f64 {
        self.envelope_of(&self.ring, k)
    }

    /// The envelope of `ring` at tick `k` (not before its excitation), by table.
    #[inline(always)]
    pub(super) fn envelope_of(&self, ring: &Ring, k: u64) -> f64 {
        if ring.mag == 0.0 {
            return 0.0;
        }
        ring.mag * self.pow_env.real(k.saturating_sub(ring.k))
    }

    /// e^{−h/τp}, e^{−h/τn} over a step of `h` \[s\]: by table for a length of whole
    /// ticks (most are), else by the exponential's table.
    #[inline(always)]
    pub(super) fn decays_of(&self, h: f64) -> (f64, f64) {
        match Ticks::at_or_after(h) {
            (n, true) => (self.pow_p.real(n.0), self.pow_n.real(n.0)),
            _ => {
                let [dp, dn] = self.exp_pn.at(h);
                (dp, dn)
            }
        }
    }

    /// e^{−τ/τp}, e^{−τ/τn} at a step's first tick `k_start`, τ after its start `t0`.
    #[inline(always)]
    pub(super) fn first_decays(&self, t0: f64, k_start: u64) -> (f64, f64) {
        let ta = tick_instant(k_start) - t0;
        if (ta - TICK_S).abs() < 1e-6 * TICK_S {
            (self.q_p, self.q_n)
        } else {
            let [dp, dn] = self.exp_pn.at(ta);
            (dp, dn)
        }
    }

    /// Writes into `rec` the step [t0, t1] with terminal and neutral voltages interpolated
    /// between `k0` and `k1`, from the filters' present state (see [`Record`]). A ringing
    /// decayed below a nanovolt is dropped first, so that bounds skip the envelope.
    pub(super) fn record(&mut self, t0: f64, t1: f64, k0: &Knot, k1: &Knot, rec: &mut Record) {
        let h = t1 - t0;
        let k_start = Ticks::at_or_before(t0).0 + 1;
        // The envelope at the first tick, at most a tick after t0, is below the one at t0
        // (it decays by 2e-5 a tick or more, τr ≤ 1 ms, far beyond rounding): where it is a
        // nanovolt or more, so is the one at t0, which is then not computed.
        let mut env_first = self.ring_envelope_at(k_start);
        if self.ring.mag != 0.0 && env_first < 1e-9 && self.ring_envelope(t0) < 1e-9 {
            self.ring.z = (0.0, 0.0);
            self.ring.mag = 0.0;
            env_first = 0.0;
        }
        // One division per step: the four filter inputs' slopes share 1/h.
        let inv_h = 1.0 / h;
        let dvn = (k1.vn - k0.vn) * inv_h;
        let fn_ = Foh::ramp(self.y_n, k0.vn, dvn, self.tau_n);
        // Steps repeat their lengths (PWM half-periods, the solver's longest step): cache;
        // a length of whole ticks (most are) by table.
        if self.decay_cache.0 != h {
            let (dp, dn) = self.decays_of(h);
            self.decay_cache = (h, dp, dn);
        }
        let first = self.first_decays(t0, k_start);
        let (v0, v1) = (k0.v.to_array(), k1.v.to_array());
        let (r0, r1) = (k0.emf_rate.to_array(), k1.emf_rate.to_array());
        let y = self.y.to_array();
        let chord: [f64; 3] = std::array::from_fn(|j| (v1[j] - v0[j]) * inv_h);
        // Field by field: a whole `Record` assigned is built apart and copied in.
        rec.t0 = t0;
        rec.h = h;
        rec.k_start = k_start;
        rec.k_end = Ticks::at_or_before(t1).0;
        for j in 0..3 {
            rec.fx[j] = Foh::ramp(y[j], v0[j], chord[j], self.tau_p);
        }
        // A floating leg's input is the neutral's chord plus its back-EMF's Hermite
        // cubic: its chord plus a cubic vanishing at both ends, filtered from rest.
        rec.bend = std::array::from_fn(|j| match (r0[j], r1[j]) {
            (Some(d0), Some(d1)) => {
                let (a, b) = (dvn + d0 - chord[j], dvn + d1 - chord[j]);
                let q = hermite(inv_h, (0.0, a), (0.0, b));
                Some(Bend::new(&CubicRc::new(0.0, 0.0, q, self.tau_p)))
            }
            _ => None,
        });
        rec.fn_ = fn_;
        rec.eh = (self.decay_cache.1, self.decay_cache.2);
        rec.first = first;
        rec.env_first = env_first;
        rec.ring = self.ring;
        // Every field above, or the slot keeps an older step's value: this pattern names
        // them all, so a field added to `Record` fails to compile until written here.
        let Record {
            t0: _,
            h: _,
            k_start: _,
            k_end: _,
            fx: _,
            bend: _,
            fn_: _,
            eh: _,
            first: _,
            ring: _,
            env_first: _,
        } = rec;
    }

    /// Channel `x` over recorded step `rec`, its first tick and the decays there set.
    pub(super) fn channel(&self, rec: &Record, x: Phase) -> Channel {
        let j = x.index();
        let paths = (&rec.fx[j], rec.bend[j].as_ref(), &rec.fn_);
        let off = self.offset.get(x);
        let taus = ((self.tau_p, self.tau_n), self.inv_tau);
        let mut c = Channel::new(x, rec.t0, paths, taus, off, rec.h);
        c.k_s = rec.k_start;
        c.base = rec.first;
        c
    }

    /// Runs `op` with `ring` in place of the present ringing (to walk a recorded step).
    pub(super) fn with_ring<R>(&mut self, ring: Ring, op: impl FnOnce(&mut Front) -> R) -> R {
        let now = std::mem::replace(&mut self.ring, ring);
        let r = op(self);
        self.ring = now;
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A channel over a step without a bend (P linear) is built on its own path; it must be
    /// the general path's channel with a zero bend, to the bit, signed zeros included.
    #[test]
    fn a_channel_without_a_bend_is_the_zero_bend_case_to_the_bit() {
        let zero = Bend::default();
        let taus = ((1.0e-6, 1.05e-6), (1.0e6, 1.0 / 1.05e-6));
        let fohs = [
            Foh::ramp(0.3, 0.1, 2e4, 1.0e-6),
            Foh::ramp(-2.0, 12.0, -3e5, 1.05e-6),
            Foh::new(0.0, 0.0, 0.0, 1e-6, 1.0e-6),
            Foh {
                a: -0.0,
                b: -0.0,
                c: -0.0,
            },
        ];
        for fx in &fohs {
            for fn_ in &fohs {
                for offset in [2e-3, 0.0, -0.0, -1.5e-3] {
                    for h in [20e-9, 0.37e-6, 25e-6] {
                        let paths = |b| (fx, b, fn_);
                        let lin = Channel::new(Phase::V, 1e-3, paths(None), taus, offset, h);
                        let general =
                            Channel::new(Phase::V, 1e-3, paths(Some(&zero)), taus, offset, h);
                        let bits = |c: &Channel| {
                            let mut v: Vec<u64> = c.poly.iter().map(|x| x.to_bits()).collect();
                            v.extend(
                                [c.beta, c.dev.0, c.dev.1, c.a, c.b, c.ap, c.bn].map(f64::to_bits),
                            );
                            v
                        };
                        assert_eq!(bits(&lin), bits(&general), "{fx:?} {fn_:?} {offset} {h}");
                    }
                }
            }
        }
    }
}
