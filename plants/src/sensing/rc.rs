//! Exact response of a first-order low-pass, `T·dy/dτ + y = u`, to a cubic input
//! `u(τ) = c0 + c1·τ + c2·τ² + c3·τ³` (both sensing chains' filters are of this kind).
//!
//! `y(τ) = p(τ) + (y_a − p(τa))·e^{−(τ − τa)/T}` from `y(τa) = y_a`, where
//! `p = u − T·u′ + T²·u″ − T³·u‴` is the polynomial particular solution.

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
        let (t, t2, t3) = (tau, tau * tau, tau * tau * tau);
        let p = [
            c[0] - t * c[1] + 2.0 * t2 * c[2] - 6.0 * t3 * c[3],
            c[1] - 2.0 * t * c[2] + 6.0 * t2 * c[3],
            c[2] - 3.0 * t * c[3],
            c[3],
        ];
        let mut s = CubicRc {
            p,
            from,
            transient: 0.0,
            tau,
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
