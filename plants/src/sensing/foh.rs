//! Exact response of a first-order low-pass to a linearly varying input (first-order hold).

/// `y(τ) = a + b·(τ − T) + c·e^{−τ/T}` for τ ∈ [0, h]: the solution of
/// `T·dy/dτ = u(τ) − y` with `u(τ) = a + b·τ` and `y(0) = y0`. The time constant T is the
/// filter's, given at each evaluation rather than kept: the comparators keep several of
/// these a step, all of one of two filters.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Foh {
    /// Input at τ = 0 \[V\].
    pub a: f64,
    /// Input slope [V/s].
    pub b: f64,
    /// Amplitude of the decaying transient \[V\].
    pub c: f64,
}

impl Foh {
    /// The segment from filter state `y0` with input going from `u0` to `u1` over `h`
    /// seconds, through a filter of time constant `tau` \[s\].
    pub fn new(y0: f64, u0: f64, u1: f64, h: f64, tau: f64) -> Self {
        Foh::ramp(y0, u0, if h > 0.0 { (u1 - u0) / h } else { 0.0 }, tau)
    }

    /// The segment from filter state `y0` with input `u0 + slope·τ` [V, V/s], through a
    /// filter of time constant `tau` \[s\].
    pub fn ramp(y0: f64, u0: f64, slope: f64, tau: f64) -> Self {
        Foh {
            a: u0,
            b: slope,
            c: y0 - u0 + slope * tau,
        }
    }

    /// Filter output at τ seconds into the segment, given `decay` = e^{−τ/tau} (`tau` the
    /// filter's time constant \[s\], as built).
    pub fn at_decayed(&self, t: f64, decay: f64, tau: f64) -> f64 {
        self.a + self.b * (t - tau) + self.c * decay
    }

    /// Filter output at τ seconds into the segment (`tau` the filter's time constant \[s\],
    /// as built).
    pub fn at(&self, t: f64, tau: f64) -> f64 {
        self.a + self.b * (t - tau) + self.c * (-t / tau).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_ode_and_its_step_response() {
        // Step input (b = 0): y = u + (y0 − u)·e^{−t/τ}.
        let f = Foh::new(0.0, 1.0, 1.0, 1e-6, 1e-6);
        assert!((f.at(1e-6, 1e-6) - (1.0 - (-1.0f64).exp())).abs() < 1e-15);
        // Ramp: residual of τ·y' − (u − y) by central differences.
        let f = Foh::new(0.3, 0.0, 2.0, 1e-5, 2e-6);
        for k in 1..9 {
            let t = k as f64 * 1e-6;
            let d = 1e-10;
            let dy = (f.at(t + d, 2e-6) - f.at(t - d, 2e-6)) / (2.0 * d);
            let u = 2.0 * t / 1e-5;
            assert!((2e-6 * dy - (u - f.at(t, 2e-6))).abs() < 1e-6);
        }
    }
}
