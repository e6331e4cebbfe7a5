//! Exact response of a first-order low-pass, `T·dy/dτ + y = u`, to a cubic input
//! `u(τ) = c0 + c1·τ + c2·τ² + c3·τ³` (both sensing chains' filters are of this kind).
//!
//! `y(τ) = p(τ) + (y_a − p(τa))·e^{−(τ − τa)/T}` from `y(τa) = y_a`, where
//! `p = u − T·u′ + T²·u″ − T³·u‴` is the polynomial particular solution.

use drive_core::TICK_S;

/// The filter over one piece of input, from τa on.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CubicRc {
    /// p's coefficients \[V, V/s, V/s², V/s³\].
    pub p: [f64; 4],
    /// τa \[s\]: where the transient is referred to.
    pub from: f64,
    /// y_a − p(τa) \[V\]: the transient's amplitude at τa.
    pub transient: f64,
    /// T \[s\].
    pub tau: f64,
}

impl CubicRc {
    /// The filter of time constant `tau` at `y_from` at τ = `from`, driven by the cubic with
    /// coefficients `c` (in τ, not τ − τa).
    pub fn new(from: f64, y_from: f64, c: [f64; 4], tau: f64) -> Self {
        Self::with_terms(from, y_from, c, &TauTerms::new(tau))
    }

    /// [`CubicRc::new`] with the time constant's terms computed once for many pieces.
    #[inline(always)]
    pub fn with_terms(from: f64, y_from: f64, c: [f64; 4], k: &TauTerms) -> Self {
        let p = [
            c[0] - k.t * c[1] + k.two_t2 * c[2] - k.six_t3 * c[3],
            c[1] - k.two_t * c[2] + k.six_t2 * c[3],
            c[2] - k.three_t * c[3],
            c[3],
        ];
        let mut s = CubicRc {
            p,
            from,
            transient: 0.0,
            tau: k.t,
        };
        s.transient = y_from - s.poly(from);
        s
    }

    /// The particular solution p(τ).
    pub fn poly(&self, t: f64) -> f64 {
        horner(&self.p, t)
    }

    /// y(τ).
    pub fn at(&self, t: f64) -> f64 {
        self.poly(t) + self.transient * (-(t - self.from) / self.tau).exp()
    }

    /// y(τ) with the transient's decay e^{−(τ − τa)/T} given (from a table).
    pub fn at_decayed(&self, t: f64, decay: f64) -> f64 {
        self.poly(t) + self.transient * decay
    }
}

/// The products of a time constant T that p's coefficients take (see [`CubicRc::new`]):
/// T, 2·T, 3·T, 2·T², 6·T², 6·T³, each rounded as there.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TauTerms {
    t: f64,
    two_t: f64,
    three_t: f64,
    two_t2: f64,
    six_t2: f64,
    six_t3: f64,
}

impl TauTerms {
    /// The terms of `tau` \[s\].
    pub fn new(tau: f64) -> Self {
        let (t, t2, t3) = (tau, tau * tau, tau * tau * tau);
        TauTerms {
            t,
            two_t: 2.0 * t,
            three_t: 3.0 * t,
            two_t2: 2.0 * t2,
            six_t2: 6.0 * t2,
            six_t3: 6.0 * t3,
        }
    }

    /// T \[s\].
    pub fn tau(&self) -> f64 {
        self.t
    }
}

/// e^{r·t} for t ≥ 0 at K fixed rates r [1/s] (one lookup serves all), without a libm
/// call and within a few ulps of `exp`: t = n·s + d with n whole and |d| ≤ s/2, where
/// e^{r·n·s} = lo[n mod 64]·hi[n div 64] from directly computed powers (as in the
/// comparators' tick powers) and e^{r·d} is a Taylor polynomial. The step s is the master
/// tick, or finer for a rate fast enough that |r|·s/2 would exceed 2^-9; t beyond the
/// table's 64² steps (82 µs at the tick) takes `exp`. A cache of its rates: rebuilt with them.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ExpTable<const K: usize> {
    rate: [f64; K],
    /// s and 1/s \[s, 1/s\].
    step: f64,
    inv_step: f64,
    lo: [[f64; K]; SPLIT],
    hi: [[f64; K]; SPLIT],
}

const SPLIT: usize = 64;

/// The largest |r·d| the polynomial is used for.
const REDUCED_MAX: f64 = 1.0 / 512.0;

impl<const K: usize> ExpTable<K> {
    /// The table of e^{r·t} for each of `rate` [1/s].
    pub fn new(rate: [f64; K]) -> Self {
        let fastest = rate.iter().fold(0.0f64, |m, r| m.max(r.abs()));
        // A zero rate gives an infinite bound, so the tick.
        let step = TICK_S.min(2.0 * REDUCED_MAX / fastest);
        let pow = |n: usize| rate.map(|r| (r * (n as f64 * step)).exp());
        ExpTable {
            rate,
            step,
            inv_step: 1.0 / step,
            lo: std::array::from_fn(pow),
            hi: std::array::from_fn(|j| pow(j * SPLIT)),
        }
    }

    /// e^{r·t} for each rate, `t` \[s\] ≥ 0 (anything else takes `exp`).
    #[inline]
    pub fn at(&self, t: f64) -> [f64; K] {
        // t/s rounded to the nearest whole n by adding 2^52 (the sum's ulp is 1), which
        // leaves n in the low bits: no conversion instruction, and a negative, NaN or huge
        // t/s gives bits outside 0..64² (another exponent), sent to `exp`.
        let r = t * self.inv_step + ROUND;
        let n = r.to_bits().wrapping_sub(ROUND.to_bits()) as usize;
        match self.hi.get(n / SPLIT) {
            Some(hi) => {
                let (lo, d) = (&self.lo[n % SPLIT], t - (r - ROUND) * self.step);
                std::array::from_fn(|j| lo[j] * hi[j] * exp_reduced(self.rate[j] * d))
            }
            None => self.rate.map(|r| (r * t).exp()),
        }
    }
}

/// 2^52: added to a non-negative x below 2^51, it rounds x to a whole number.
const ROUND: f64 = 4_503_599_627_370_496.0;

impl<const K: usize> Default for ExpTable<K> {
    /// Rates of zero.
    fn default() -> Self {
        ExpTable::new([0.0; K])
    }
}

/// e^x for |x| ≤ 2^-9 by Taylor to degree 5: the remainder, ≤ x⁶/720 < 1e-19, is far
/// below an ulp.
#[inline(always)]
fn exp_reduced(x: f64) -> f64 {
    1.0 + x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0)))))
}

/// Σ c_k·τ^k.
#[inline(always)]
pub fn horner(c: &[f64; 4], t: f64) -> f64 {
    c[0] + t * (c[1] + t * (c[2] + t * c[3]))
}

/// The cubic Hermite interpolant over [0, h] of values `y0`, `y1` and slopes `d0`, `d1` at
/// its ends, as coefficients in τ; `inv_h` = 1/h.
pub fn hermite(inv_h: f64, (y0, d0): (f64, f64), (y1, d1): (f64, f64)) -> [f64; 4] {
    let secant = (y1 - y0) * inv_h;
    [
        y0,
        d0,
        (3.0 * secant - 2.0 * d0 - d1) * inv_h,
        (d0 + d1 - 2.0 * secant) * inv_h * inv_h,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terms_computed_once_give_the_pieces_bit_for_bit() {
        // p's coefficients as written out with T's powers at each piece, from a fixed LCG.
        let mut z = 0x9e37_79b9_7f4a_7c15_u64;
        let mut unit = || {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..10_000 {
            let tau = 1e-7 + 1e-5 * unit().abs();
            let c = [unit() * 10.0, unit() * 1e6, unit() * 1e11, unit() * 1e16];
            let (from, y) = (4e-5 * unit().abs(), unit() * 10.0);
            let (t, t2, t3) = (tau, tau * tau, tau * tau * tau);
            let p = [
                c[0] - t * c[1] + 2.0 * t2 * c[2] - 6.0 * t3 * c[3],
                c[1] - 2.0 * t * c[2] + 6.0 * t2 * c[3],
                c[2] - 3.0 * t * c[3],
                c[3],
            ];
            let s = CubicRc::with_terms(from, y, c, &TauTerms::new(tau));
            assert_eq!(s.p.map(f64::to_bits), p.map(f64::to_bits), "{tau} {c:?}");
            assert_eq!(s.transient.to_bits(), (y - horner(&p, from)).to_bits());
            assert_eq!(s.tau.to_bits(), tau.to_bits());
        }
    }

    #[test]
    fn matches_the_ode_and_its_step_response() {
        // A step input: 1 − e^{−τ/T}.
        let f = CubicRc::new(0.0, 0.0, [1.0, 0.0, 0.0, 0.0], 1e-6);
        assert!((f.at(1e-6) - (1.0 - (-1.0f64).exp())).abs() < 1e-15);
        // A cubic input from a later start: T·y′ = u − y by central differences.
        let c = [0.3, 2e5, -4e10, 1e15];
        let f = CubicRc::new(2e-6, 0.7, c, 2e-6);
        assert_eq!(f.at(2e-6), 0.7);
        for k in 3..12 {
            let t = k as f64 * 1e-6;
            let d = 1e-10;
            let dy = (f.at(t + d) - f.at(t - d)) / (2.0 * d);
            assert!(
                (2e-6 * dy - (horner(&c, t) - f.at(t))).abs() < 1e-6,
                "τ = {t}"
            );
        }
    }

    #[test]
    fn table_exp_matches_exp() {
        // The current sense's filter (τ = 6.37 µs) and a fast rate that needs a finer
        // step; on and off the tick, at the table's seams, beyond it and below zero.
        for rate in [-1.0 / 6.366e-6, -2.5e3, -3e7, 0.0] {
            let e = ExpTable::new([rate, 0.5 * rate]);
            for t in [
                0.0, 1e-9, 20e-9, 30e-9, 1.28e-6, 1.3e-6, 17.123e-6, 40e-6, 81.9e-6, 90e-6, -1e-9,
            ] {
                let got = e.at(t);
                for (g, r) in got.into_iter().zip([rate, 0.5 * rate]) {
                    // exp of a rounded argument errs by |x|·ε itself; the table by a few ulps.
                    let want = (r * t).exp();
                    let tol = (4.0 + (r * t).abs()) * f64::EPSILON * want;
                    assert!((g - want).abs() <= tol, "rate {r}, t {t}: {g} vs {want}");
                }
            }
        }
    }

    #[test]
    fn hermite_reproduces_ends_and_cubics() {
        let c = [0.5, -3e3, 7e7, -2e12];
        let d = |t: f64| c[1] + t * (2.0 * c[2] + 3.0 * t * c[3]);
        let h = 40e-6;
        let got = hermite(1.0 / h, (horner(&c, 0.0), d(0.0)), (horner(&c, h), d(h)));
        for k in 0..4 {
            assert!(
                (got[k] - c[k]).abs() <= 1e-9 * c[k].abs(),
                "{got:?} vs {c:?}"
            );
        }
    }
}
