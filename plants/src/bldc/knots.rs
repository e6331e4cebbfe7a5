//! What the sensing chains see of a step: the terminal and neutral voltages at its ends
//! (a [`Knot`] each), bent by a floating leg's back-EMF rate on long steps, and the shunt
//! current's slope.

use super::{BldcPlant, OMEGA, State, THETA};
use crate::circuit::{self, Circuit, Solution};
use crate::emf;
use crate::sensing::Knot;
use drive_core::{Abc, Phase, Ticks};

/// The longest step over which the comparators see a floating terminal's back-EMF along
/// its chord \[s\]. Near a crossing the chord is off by at most E·ωe³·h³/8, a move of
/// ωe²·h³/4 (21 ticks at 8000 rpm, the bound `tests/integration/step_fidelity.rs` allows; it measures
/// a tick at most, since the sine's curvature vanishes at its crossing). Longer steps add the
/// back-EMF's curvature (see [`Knot`]), which costs a few hundred instructions a step.
pub const CHORD_S: f64 = 40e-6;

impl BldcPlant {
    /// Hands the step from `x0` (derivative `f0`) at `t0` to `x1` (network `s1`, sin θ and
    /// cos θ `sc1`) at `t1`, inside the step that starts at `base`, to the sensing chains:
    /// the comparators, which first forget the toggles no query reaches (`unreported`: the
    /// first watched change not yet reported), and the shunt channel.
    pub(super) fn sense_step(
        &mut self,
        (x0, f0): (&State, &State),
        (x1, s1, sc1): (&State, &Solution, (f64, f64)),
        (t0, t1): (f64, f64),
        base: (f64, f64, f64),
        unreported: Option<Ticks>,
        channels: Abc<bool>,
    ) {
        self.cmp.forget_history(Ticks::at_or_before(t0), unreported);
        let (k0, k1) = self.knots((x0, f0, &self.start), (x1, s1, sc1), t1 - t0, base);
        self.cmp.update(t0, t1, &k0, &k1, channels);
        self.cur.update(
            t0,
            t1,
            (self.start.i_shunt, self.shunt_slope([f0[0], f0[1], f0[2]])),
            (s1.i_shunt, self.shunt_slope(s1.di.to_array())),
        );
    }

    /// d(i_shunt)/dt for the currents' rates `di`: the shunt carries the low-side currents
    /// back.
    fn shunt_slope(&self, di: [f64; 3]) -> f64 {
        let low = circuit::low_legs_at(self.lin);
        Phase::ALL
            .into_iter()
            .filter(|p| low[p.index()])
            .map(|p| -di[p.index()])
            .sum()
    }

    /// dex/dt \[V/s\] at state `x` with derivative `f`, inside the step that starts at `base`:
    /// e = λr·(P/2)·ωm·f(θe), so de/dt = λr·(P/2)·(α·f + ωm·ωe·f′).
    fn emf_rate(&self, x: &State, f: &State, base: (f64, f64, f64)) -> [f64; 3] {
        let th = x[THETA];
        let sc = emf::sin_cos_near(th, base);
        let (shape, rate) = (
            emf::shape_with(&self.shape, th, sc).to_array(),
            emf::shape_rate_with(&self.shape, th, sc).to_array(),
        );
        let kl = self.lambda * self.pp;
        let (a, b) = (kl * f[OMEGA], kl * x[OMEGA] * f[THETA]);
        [0, 1, 2].map(|j| a * shape[j] + b * rate[j])
    }

    /// The comparators' knots at the ends of a step of `h` from `x0` (derivative `f0`,
    /// network `s0`) to `x1` (network `s1`, sin θ and cos θ `sc1`), inside the step that
    /// starts at `base` (see [`Knot`]). Steps up to [`CHORD_S`] keep every voltage on its
    /// chord; longer ones take the end's derivative, made here for them alone.
    #[inline(always)]
    fn knots(
        &self,
        (x0, f0, s0): (&State, &State, &Solution),
        (x1, s1, sc1): (&State, &Solution, (f64, f64)),
        h: f64,
        base: (f64, f64, f64),
    ) -> (Knot, Knot) {
        let follows = Circuit::follows_neutral_at(self.lin);
        // Half a tick of slack: a step of exactly 40 µs is one whatever its rounding.
        let bend = h > CHORD_S + 0.5 * drive_core::TICK_S && follows.contains(&true);
        let knot = |x: &State, f: &State, s: &Solution| {
            let mut k = Knot::driven(s.v_term, s.v_n);
            let de = self.emf_rate(x, f, base);
            k.emf_rate = Abc::from_fn(|p| follows[p.index()].then_some(de[p.index()]));
            k
        };
        if !bend {
            return (
                Knot::driven(s0.v_term, s0.v_n),
                Knot::driven(s1.v_term, s1.v_n),
            );
        }
        let f1 = self.end_derivative(x1, s1, (x1[THETA], sc1.0, sc1.1));
        (knot(x0, f0, s0), knot(x1, &f1, s1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bldc::dynamic;
    use crate::bldc::testing::{driven_with, fine};
    use crate::params::PlantParams;

    /// The back-EMF's rate from the state and its derivative (what bends the comparators'
    /// input, see `knots`) is the back-EMF's change along the trajectory, the rotor
    /// accelerating: against central differences over fine RK4 steps, for every shape.
    #[test]
    fn the_back_emf_rate_follows_the_trajectory() {
        for shape in emf::SAMPLE_SHAPES {
            let mut params = PlantParams::default();
            params.motor.back_emf = shape;
            let pl = driven_with(params, [0.3, -0.3, 0.0], 3000.0, false);
            let x = pl.x;
            let b = BldcPlant::base(&x);
            let f = pl.deriv(&dynamic(&x), b);
            let got = pl.emf_rate(&x, &f, b);
            let d = 1e-7;
            let (ahead, behind) = (fine(&pl, &x, d, 20), fine(&pl, &x, -d, 20));
            let (ea, eb) = (pl.emf_of(&ahead).1, pl.emf_of(&behind).1);
            // The acceleration's share, λr·(P/2)·α·f, is what a locked rotor would miss.
            let (fs, _) = pl.emf_of(&x);
            let accel = pl.lambda * pl.pp * f[OMEGA] * fs.u.abs().max(fs.v.abs());
            assert!(
                accel.abs() > 1.0,
                "{shape:?}: the rotor accelerates ({accel} V/s)"
            );
            for p in Phase::ALL {
                let want = (ea.get(p) - eb.get(p)) / (2.0 * d);
                let k = p.index();
                assert!(
                    (got[k] - want).abs() < 0.05,
                    "{shape:?} {p:?}: {} V/s vs {want} V/s",
                    got[k]
                );
            }
        }
    }
}
