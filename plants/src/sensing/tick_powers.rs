//! Powers of a per-tick factor, q^n = e^{n·s·T} for n master ticks (T = 20 ns), by table:
//! q^n = lo[n mod 64]·hi[n div 64]. The comparators evaluate their filter decays and the
//! ringing phasor at tick offsets inside a step many times per step; a table lookup and one
//! product replace an exp (and a sincos). Every entry is computed directly, not by repeated
//! multiplication, so a power is within a few ulps of the exact value. The table covers
//! 64² ticks (82 µs, twice the default longest step); beyond, powers are computed.

use drive_core::TICK_S;

const LO: usize = 64;

/// Powers of a complex per-tick factor e^{(σ + jω)·T}; a real decay has ω = 0.
#[derive(Copy, Clone, Debug)]
pub struct TickPowers {
    sigma: f64,
    omega: f64,
    lo: [(f64, f64); LO],
    hi: [(f64, f64); LO],
}

fn cexp(sigma: f64, omega: f64, t: f64) -> (f64, f64) {
    let m = (sigma * t).exp();
    if omega == 0.0 {
        return (m, 0.0);
    }
    let (s, c) = (omega * t).sin_cos();
    (m * c, m * s)
}

fn cmul(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
}

impl TickPowers {
    /// The powers of e^{(σ + jω)·T} [σ in 1/s, ω in rad/s].
    pub fn new(sigma: f64, omega: f64) -> Self {
        let lo = std::array::from_fn(|i| cexp(sigma, omega, i as f64 * TICK_S));
        let hi = std::array::from_fn(|j| cexp(sigma, omega, (j * LO) as f64 * TICK_S));
        TickPowers {
            sigma,
            omega,
            lo,
            hi,
        }
    }

    /// q^n as (re, im).
    pub fn at(&self, n: u64) -> (f64, f64) {
        let h = (n / LO as u64) as usize;
        match self.hi.get(h) {
            Some(&w) => cmul(self.lo[(n % LO as u64) as usize], w),
            None => cexp(self.sigma, self.omega, n as f64 * TICK_S),
        }
    }

    /// q^n for a real factor (ω = 0).
    pub fn real(&self, n: u64) -> f64 {
        let h = (n / LO as u64) as usize;
        match self.hi.get(h) {
            Some(w) => self.lo[(n % LO as u64) as usize].0 * w.0,
            None => (self.sigma * n as f64 * TICK_S).exp(),
        }
    }
}

/// Two real decays' powers side by side, (q₁ⁿ, q₂ⁿ): one index and one pair of loads
/// for both (the comparators' filter decays are always asked for together). Each power
/// is the one [`TickPowers::real`] gives, to the bit.
#[derive(Copy, Clone, Debug)]
pub struct RealPairPowers {
    sigma: (f64, f64),
    lo: [(f64, f64); LO],
    hi: [(f64, f64); LO],
}

impl RealPairPowers {
    /// The powers of two real decays' tables (ω = 0).
    pub fn new(a: &TickPowers, b: &TickPowers) -> Self {
        debug_assert!(a.omega == 0.0 && b.omega == 0.0, "real decays only");
        RealPairPowers {
            sigma: (a.sigma, b.sigma),
            lo: std::array::from_fn(|i| (a.lo[i].0, b.lo[i].0)),
            hi: std::array::from_fn(|j| (a.hi[j].0, b.hi[j].0)),
        }
    }

    /// (q₁ⁿ, q₂ⁿ), as [`TickPowers::real`] of each.
    #[inline(always)]
    pub fn at(&self, n: u64) -> (f64, f64) {
        let h = (n / LO as u64) as usize;
        match self.hi.get(h) {
            Some(w) => {
                let l = self.lo[(n % LO as u64) as usize];
                (l.0 * w.0, l.1 * w.1)
            }
            None => (
                (self.sigma.0 * n as f64 * TICK_S).exp(),
                (self.sigma.1 * n as f64 * TICK_S).exp(),
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_powers_match_exp_and_sincos() {
        let (sigma, omega) = (-1.0 / 0.2e-6, std::f64::consts::TAU * 5e6);
        let q = TickPowers::new(sigma, omega);
        let d = TickPowers::new(-1.0 / 1.05e-6, 0.0);
        // Inside the table, at its seams and beyond it.
        for n in [0u64, 1, 63, 64, 65, 127, 128, 1000, 2047, 4095, 4096, 5000] {
            let t = n as f64 * TICK_S;
            let (m, (s, c)) = ((sigma * t).exp(), (omega * t).sin_cos());
            let (re, im) = q.at(n);
            // The angle ωt reaches 3000 rad, whose own rounding (an ulp is 5e-13) bounds
            // the agreement of the rotation either way.
            let tol = 1e-12 * m;
            assert!(
                (re - m * c).abs() <= tol && (im - m * s).abs() <= tol,
                "n = {n}"
            );
            // e^x with x rounded: relative error up to |x|·ε either way, plus the products'.
            let x = -t / 1.05e-6;
            let want = x.exp();
            let tol = (4.0 + x.abs()) * f64::EPSILON * want;
            assert!((d.real(n) - want).abs() <= tol, "n = {n}");
        }
        // A pair of real decays gives each one's powers exactly.
        let e = TickPowers::new(-1.0 / 1.0e-6, 0.0);
        let pair = RealPairPowers::new(&d, &e);
        for n in [0u64, 1, 63, 64, 65, 4095, 4096, 5000] {
            assert_eq!(pair.at(n), (d.real(n), e.real(n)), "n = {n}");
        }
    }
}
