//! Back-EMF shape functions f(θx): e_x = λr·ωe·f(θx), and Te = (P/2)·λr·Σ i_x·f(θx).

use crate::params::BackEmfShape;
use drive_core::Abc;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

const SIN_120: f64 = 0.866_025_403_784_438_6;

/// Evaluates the shape for the three phases at electrical angle `theta` \[rad\]
/// (θu = θ, θv = θ − 120°, θw = θ + 120°).
pub fn shape(kind: &BackEmfShape, theta: f64) -> Abc<f64> {
    shape_with(kind, theta, theta.sin_cos())
}

/// sin and cos of `theta` from those of a nearby `base` angle by angle addition; the
/// correction uses Taylor series, accurate to 1e-12 for |θ − base| ≤ 0.5 rad (else exact).
pub fn sin_cos_near(theta: f64, base: (f64, f64, f64)) -> (f64, f64) {
    let (b, sb, cb) = base;
    let d = theta - b;
    if d == 0.0 {
        return (sb, cb); // a step's own start: common, and exact
    }
    if d.abs() > 0.5 {
        return theta.sin_cos();
    }
    let (sd, cd) = taylor(d);
    (sb * cd + cb * sd, cb * cd - sb * sd)
}

/// The largest |θ − near| for which [`sin_cos_close`] rotates by sin d = d and
/// cos d = 1 − d²/2: within d³/6 < 1.7e-13 and d⁴/24 of them.
const CLOSE: f64 = 1e-4;

/// sin and cos of `theta` from those of an angle `near` it (a step's end from its modal
/// response's angle there) by a rotation to second order in their difference d, where
/// |d| ≤ 1e-4 rad; else [`sin_cos_near`] from `base`.
#[inline(always)]
pub fn sin_cos_close(theta: f64, near: (f64, f64, f64), base: (f64, f64, f64)) -> (f64, f64) {
    let (n, sn, cn) = near;
    let d = theta - n;
    if d.abs() > CLOSE {
        return sin_cos_near(theta, base);
    }
    let cd = 1.0 - 0.5 * d * d;
    (sn * cd + cn * d, cn * cd - sn * d)
}

/// sin and cos of a small angle `d` \[rad\]: [`sin_cos_near`] from the base angle 0 (the
/// same values bit for bit), without its angle addition's products with sin 0 and cos 0.
pub fn rotation(d: f64) -> (f64, f64) {
    if d == 0.0 {
        return (0.0, 1.0);
    }
    if d.abs() > 0.5 {
        return d.sin_cos();
    }
    taylor(d)
}

/// sin d and cos d by their Taylor series to d¹¹ and d¹², within 1e-12 for |d| ≤ 0.5.
#[inline(always)]
fn taylor(d: f64) -> (f64, f64) {
    // Taylor coefficients as constants: Horner by multiplication alone (no division in
    // the hot path).
    const S: [f64; 5] = [
        -1.0 / 6.0,
        1.0 / 120.0,
        -1.0 / 5040.0,
        1.0 / 362_880.0,
        -1.0 / 39_916_800.0,
    ];
    const C: [f64; 6] = [
        -1.0 / 2.0,
        1.0 / 24.0,
        -1.0 / 720.0,
        1.0 / 40_320.0,
        -1.0 / 3_628_800.0,
        1.0 / 479_001_600.0,
    ];
    let d2 = d * d;
    let sd = d * (1.0 + d2 * (S[0] + d2 * (S[1] + d2 * (S[2] + d2 * (S[3] + d2 * S[4])))));
    let cd = 1.0 + d2 * (C[0] + d2 * (C[1] + d2 * (C[2] + d2 * (C[3] + d2 * (C[4] + d2 * C[5])))));
    (sd, cd)
}

/// The sinusoidal shape from sin θ and cos θ: sin θ, sin(θ − 120°), sin(θ + 120°).
#[inline(always)]
pub fn sinusoid((s, c): (f64, f64)) -> Abc<f64> {
    Abc {
        u: s,
        v: -0.5 * s - SIN_120 * c,
        w: -0.5 * s + SIN_120 * c,
    }
}

/// Like [`shape`], with sin θ and cos θ already known.
#[inline(always)]
pub fn shape_with(kind: &BackEmfShape, theta: f64, sc: (f64, f64)) -> Abc<f64> {
    if let BackEmfShape::Sinusoidal = kind {
        return sinusoid(sc);
    }
    shaped(kind, theta, sinusoid(sc))
}

/// The harmonic and trapezoidal shapes (out of line: the hot path is the sinusoid).
#[inline(never)]
fn shaped(kind: &BackEmfShape, theta: f64, sin: Abc<f64>) -> Abc<f64> {
    match *kind {
        BackEmfShape::Sinusoidal => sin,
        BackEmfShape::Harmonic { third, fifth } => sin.map(|s| {
            let s2 = s * s;
            let s3 = s * (3.0 - 4.0 * s2); // sin 3θ
            let s5 = s * (5.0 - 20.0 * s2 + 16.0 * s2 * s2); // sin 5θ
            s + third * s3 + fifth * s5
        }),
        BackEmfShape::Trapezoidal { flat_top_deg } => {
            let ramp = ramp_of(flat_top_deg);
            per_phase(theta, |th| trapezoid(th, ramp))
        }
    }
}

/// `f` at each phase's angle: θu = θ, θv = θ − 120°, θw = θ + 120°.
fn per_phase(theta: f64, f: impl Fn(f64) -> f64) -> Abc<f64> {
    Abc {
        u: f(theta),
        v: f(theta - TAU / 3.0),
        w: f(theta + TAU / 3.0),
    }
}

/// df/dθ of the shape for the three phases, with sin θ and cos θ known (for the rate of
/// the back-EMF, de_x/dt = λr·(P/2)·(dωm/dt·f + ωm·ωe·df/dθ)).
pub fn shape_rate_with(kind: &BackEmfShape, theta: f64, (s, c): (f64, f64)) -> Abc<f64> {
    // cos θx: the sinusoid a quarter-turn ahead.
    let cos = sinusoid((c, -s));
    match *kind {
        BackEmfShape::Sinusoidal => cos,
        BackEmfShape::Harmonic { third, fifth } => cos.map(|c| {
            let c2 = c * c;
            let c3 = c * (4.0 * c2 - 3.0); // cos 3θ
            let c5 = c * (16.0 * c2 * c2 - 20.0 * c2 + 5.0); // cos 5θ
            c + 3.0 * third * c3 + 5.0 * fifth * c5
        }),
        BackEmfShape::Trapezoidal { flat_top_deg } => {
            let ramp = ramp_of(flat_top_deg);
            per_phase(theta, |th| trapezoid_rate(th, ramp))
        }
    }
}

/// The trapezoid's ramp width \[rad\] for a flat top of `flat_top_deg`.
fn ramp_of(flat_top_deg: f64) -> f64 {
    (PI - flat_top_deg.to_radians()) / 2.0
}

/// θ folded onto the trapezoid's symmetry: the distance from the nearest crossing \[rad\],
/// the half-wave's sign, and whether the distance grows with θ (+1) or shrinks (−1).
fn fold(theta: f64) -> (f64, f64, f64) {
    let x = theta.rem_euclid(TAU);
    let (x, sign) = if x < PI { (x, 1.0) } else { (x - PI, -1.0) };
    if x < FRAC_PI_2 {
        (x, sign, 1.0)
    } else {
        (PI - x, sign, -1.0)
    }
}

/// d/dθ of [`trapezoid`]: ±1/ramp on the ramps, 0 on the plateaus.
fn trapezoid_rate(theta: f64, ramp: f64) -> f64 {
    let (d, sign, rising) = fold(theta);
    if d < ramp { sign * rising / ramp } else { 0.0 }
}

/// Odd, half-wave symmetric trapezoid of peak 1 with linear ramps of width `ramp` \[rad\]
/// centred on the crossings at 0 and π.
fn trapezoid(theta: f64, ramp: f64) -> f64 {
    let (d, sign, _) = fold(theta);
    sign * (d / ramp).min(1.0)
}

/// One shape of each kind, for tests.
#[cfg(test)]
pub(crate) const SAMPLE_SHAPES: [BackEmfShape; 3] = [
    BackEmfShape::Sinusoidal,
    BackEmfShape::Harmonic {
        third: 0.1,
        fifth: -0.05,
    },
    BackEmfShape::Trapezoidal {
        flat_top_deg: 120.0,
    },
];

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
    fn angle_addition_matches_sin_cos() {
        let base = (1.0f64, 1.0f64.sin(), 1.0f64.cos());
        for k in -50..=50 {
            let th = 1.0 + k as f64 * 0.01;
            let (s, c) = sin_cos_near(th, base);
            assert!(
                (s - th.sin()).abs() < 1e-13 && (c - th.cos()).abs() < 1e-13,
                "{th}"
            );
        }
        assert_eq!(sin_cos_near(3.0, base), 3.0f64.sin_cos());
        for d in [0.0, -0.0, 1e-300, 1e-3, -0.2, 0.5, 0.7, -3.0] {
            let want = sin_cos_near(d, (0.0, 0.0, 1.0));
            assert_eq!(rotation(d), want, "{d}");
        }
    }

    /// A small rotation from a nearby angle holds sin and cos within 1e-12 up to |d| = 1e-4
    /// (the bound of its error terms, far above their 1.7e-13), and beyond it the angle
    /// addition from the base is taken as it is.
    #[test]
    fn a_close_angle_s_rotation_matches_sin_cos() {
        let base = (0.9f64, 0.9f64.sin(), 0.9f64.cos());
        for th in [0.9f64, 1.0, 2.5, -1.3] {
            let near = (th, th.sin(), th.cos());
            for d in [0.0, -0.0, 1e-12, -3e-7, 5e-5, -1e-4, 1e-4] {
                let (s, c) = sin_cos_close(th + d, near, base);
                let (ws, wc) = (th + d).sin_cos();
                assert!((s - ws).abs() < 1e-12 && (c - wc).abs() < 1e-12, "{th} {d}");
            }
        }
        let near = (1.0, 1.0f64.sin(), 1.0f64.cos());
        for th in [1.00011, 0.9998, 1.2] {
            assert_eq!(
                sin_cos_close(th, near, base),
                sin_cos_near(th, base),
                "{th}"
            );
        }
    }

    #[test]
    fn shape_rates_are_the_derivatives_of_the_shapes() {
        for kind in &SAMPLE_SHAPES {
            // Off the trapezoid's corners (every 30° from 0°, and 60° + multiples).
            for k in 0..72 {
                let th = (k as f64 * 5.0 + 2.5).to_radians();
                let d = 1e-6;
                let (a, b) = (shape(kind, th + d), shape(kind, th - d));
                let r = shape_rate_with(kind, th, th.sin_cos());
                for p in drive_core::Phase::ALL {
                    let fd = (a.get(p) - b.get(p)) / (2.0 * d);
                    assert!((r.get(p) - fd).abs() < 1e-6, "{kind:?} at {th}: {r:?}");
                }
            }
        }
    }

    #[test]
    fn harmonic_identities_and_trapezoid_plateau() {
        let h = BackEmfShape::Harmonic {
            third: 0.1,
            fifth: -0.05,
        };
        for k in 0..72 {
            let th = (k as f64 * 5.0).to_radians();
            let f = shape(&h, th).u;
            let want = th.sin() + 0.1 * (3.0 * th).sin() - 0.05 * (5.0 * th).sin();
            assert!((f - want).abs() < 1e-12);
        }
        let t = BackEmfShape::Trapezoidal {
            flat_top_deg: 120.0,
        };
        assert!((shape(&t, 15f64.to_radians()).u - 0.5).abs() < 1e-12);
        assert!((shape(&t, 90f64.to_radians()).u - 1.0).abs() < 1e-12);
        assert!((shape(&t, 200f64.to_radians()).u + 0.666_666_666_666_666_6).abs() < 1e-9);
        // v lags u by 120°: θv = 15° is half-way up the ramp
        assert!((shape(&t, 135f64.to_radians()).v - 0.5).abs() < 1e-12);
    }
}
