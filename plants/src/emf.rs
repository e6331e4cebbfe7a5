//! Back-EMF shape functions f(θx): e_x = λr·ωe·f(θx), and Te = (P/2)·λr·Σ i_x·f(θx).

use crate::params::BackEmfShape;
use drive_core::Abc;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

const SIN_120: f64 = 0.866_025_403_784_438_6;

/// Evaluates the shape for the three phases at electrical angle `theta` [rad]
/// (θu = θ, θv = θ − 120°, θw = θ + 120°).
pub fn shape(kind: &BackEmfShape, theta: f64) -> Abc<f64> {
    let (s, c) = theta.sin_cos();
    let sin = Abc { u: s, v: -0.5 * s - SIN_120 * c, w: -0.5 * s + SIN_120 * c };
    match *kind {
        BackEmfShape::Sinusoidal => sin,
        BackEmfShape::Harmonic { third, fifth } => sin.map(|s| {
            let s2 = s * s;
            let s3 = s * (3.0 - 4.0 * s2); // sin 3θ
            let s5 = s * (5.0 - 20.0 * s2 + 16.0 * s2 * s2); // sin 5θ
            s + third * s3 + fifth * s5
        }),
        BackEmfShape::Trapezoidal { flat_top_deg } => {
            let ramp = (PI - flat_top_deg.to_radians()) / 2.0;
            Abc {
                u: trapezoid(theta, ramp),
                v: trapezoid(theta - TAU / 3.0, ramp),
                w: trapezoid(theta + TAU / 3.0, ramp),
            }
        }
    }
}

/// Odd, half-wave symmetric trapezoid of peak 1 with linear ramps of width `ramp` [rad]
/// centred on the crossings at 0 and π.
fn trapezoid(theta: f64, ramp: f64) -> f64 {
    let x = theta.rem_euclid(TAU);
    let (x, sign) = if x < PI { (x, 1.0) } else { (x - PI, -1.0) };
    let d = if x < FRAC_PI_2 { x } else { PI - x }; // distance from the nearest crossing
    sign * (d / ramp).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sinusoid_phases_are_120_degrees_apart_and_balanced() {
        for k in 0..360 {
            let th = (k as f64).to_radians();
            let f = shape(&BackEmfShape::Sinusoidal, th);
            assert!((f.u - th.sin()).abs() < 1e-12);
            assert!((f.v - (th - TAU / 3.0).sin()).abs() < 1e-12);
            assert!((f.w - (th + TAU / 3.0).sin()).abs() < 1e-12);
            assert!((f.u + f.v + f.w).abs() < 1e-12);
        }
    }

    #[test]
    fn harmonic_identities_and_trapezoid_plateau() {
        let h = BackEmfShape::Harmonic { third: 0.1, fifth: -0.05 };
        for k in 0..72 {
            let th = (k as f64 * 5.0).to_radians();
            let f = shape(&h, th).u;
            let want = th.sin() + 0.1 * (3.0 * th).sin() - 0.05 * (5.0 * th).sin();
            assert!((f - want).abs() < 1e-12);
        }
        let t = BackEmfShape::Trapezoidal { flat_top_deg: 120.0 };
        assert!((shape(&t, 15f64.to_radians()).u - 0.5).abs() < 1e-12);
        assert!((shape(&t, 90f64.to_radians()).u - 1.0).abs() < 1e-12);
        assert!((shape(&t, 200f64.to_radians()).u + 0.666_666_666_666_666_6).abs() < 1e-9);
        // v lags u by 120°: θv = 15° is half-way up the ramp
        assert!((shape(&t, 135f64.to_radians()).v - 0.5).abs() < 1e-12);
    }
}
