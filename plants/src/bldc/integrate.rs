//! One step with the topology fixed. With the sinusoidal back-EMF the currents follow the
//! conduction state's modal form in closed form (see [`crate::modal`]; exact but for the
//! speed's change within the step, taken to first order), and speed, angle and the
//! integrals take RK4's weights on those currents; the other shapes use classical RK4
//! throughout.

use super::{BldcPlant, Dyn, E_SUPPLY, INTEGRALS, OMEGA, State, THETA};
use crate::circuit::Linearised;
use crate::emf;
use crate::modal::{Forcing, Modal, Response};
use drive_core::Abc;

/// A step's modal response as the diode prediction built it, over the step's full length,
/// for the step's integration to reuse.
pub(super) struct StepResponse<'a> {
    pub(super) rsp: Response<'a>,
    /// The modal form it was built on.
    pub(super) md: &'a Modal,
    /// sin θ and cos θ at the step's start.
    pub(super) sc0: (f64, f64),
    /// The forcing's Ω \[rad/s\] (electrical, at the full step's middle).
    pub(super) omega_e: f64,
}

impl BldcPlant {
    /// The state a step of length `h` from `x` reaches, given the derivative there, `k1`;
    /// `base` holds an angle near x's with its sine and cosine (every angle inside the
    /// step is reached from it by angle addition). The modal form's exact currents where
    /// there is one (sinusoidal back-EMF), else RK4.
    #[inline]
    pub(super) fn integrate_from(
        &self,
        x: &State,
        h: f64,
        base: (f64, f64, f64),
        k1: &State,
    ) -> State {
        self.integrate_end(x, h, base, k1).0
    }

    /// [`BldcPlant::integrate_from`], with an angle near the end's with its sine and cosine:
    /// the modal response's own angle there (see [`BldcPlant::flow_with`]), else the end's
    /// own angle, rotated to from `base` by the full series of [`emf::sin_cos_near`] (so
    /// that [`emf::sin_cos_close`] takes it as it is, not by its second-order rotation
    /// from the step's start).
    pub(super) fn integrate_end(
        &self,
        x: &State,
        h: f64,
        base: (f64, f64, f64),
        k1: &State,
    ) -> (State, (f64, f64, f64)) {
        let (lin, md, _) = self.form();
        match md {
            Some(md) if self.modal => self.flow_from(md, lin, x, h, base, k1),
            _ => {
                let x1 = self.rk4_from(x, h, base, k1);
                let (s, c) = emf::sin_cos_near(x1[THETA], base);
                (x1, (x1[THETA], s, c))
            }
        }
    }

    /// A step of `h` from `x` (derivative `k1`) on a modal response already built for it,
    /// with the response's angle at its end (see [`BldcPlant::flow_with`]).
    pub(super) fn flow_built(
        &self,
        x: &State,
        h: f64,
        k1: &State,
        b: &StepResponse,
    ) -> (State, (f64, f64, f64)) {
        self.flow_with(b.md, &self.form().0, x, h, k1, b.sc0, &b.rsp, b.omega_e)
    }

    /// A step by the modal form `md` (see [`crate::modal`]): the currents exactly for the
    /// speed changing at the acceleration in `k1` (to first order in it); speed, angle and
    /// energy integrals by RK4's weights on those currents (for the energies, whose rates
    /// do not depend on them, that is Simpson's rule). `lin` is the same state's affine
    /// form (its loss weights), passed with `md` rather than looked up again.
    fn flow_from(
        &self,
        md: &Modal,
        lin: &Linearised,
        x: &State,
        h: f64,
        base: (f64, f64, f64),
        k1: &State,
    ) -> (State, (f64, f64, f64)) {
        let sc0 = emf::sin_cos_near(x[THETA], base);
        let forcing = self.forcing(x, h, k1, sc0);
        let rsp = Response::new(md, &[x[0], x[1], x[2]], sc0, &forcing);
        self.flow_with(md, lin, x, h, k1, sc0, &rsp, forcing.omega)
    }

    /// [`BldcPlant::flow_from`] on a response already built, `rsp` (sin θ and cos θ at
    /// the start `sc0`, the forcing's Ω `omega_e` [rad/s]); with the state, the response's
    /// angle φ0 + Ω·h at the end with its sine and cosine, which the end's own angle leads
    /// by a small δ (see [`emf::sin_cos_close`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn flow_with(
        &self,
        md: &Modal,
        lin: &Linearised,
        x: &State,
        h: f64,
        k1: &State,
        sc0: (f64, f64),
        rsp: &Response,
        omega_e: f64,
    ) -> (State, (f64, f64, f64)) {
        let (w0, th0) = (x[OMEGA], x[THETA]);
        let kl = self.lambda * self.pp;
        let w2 = w0 + 0.5 * h * k1[OMEGA];
        let half = md.decays(0.5 * h);
        let full = [half[0] * half[0], half[1] * half[1]];
        // The response's angles φ0 + Ω·t at mid-step and at the end, two rotations by
        // Ω·h/2 (the true angle leads them by δ(t); zero at the end of the step the
        // forcing was built for, within pp·|α|·h²/8 on a shorter one).
        let (rs, rc) = emf::rotation(0.5 * h * omega_e);
        let rotate = |(s, c): (f64, f64)| (s * rc + c * rs, c * rc - s * rs);
        let sc_m = rotate(sc0);
        let sc_e = rotate(sc_m);
        let [i_m, i_e] = rsp.currents_pair([0.5 * h, h], [sc_m, sc_e], [half, full]);
        let torque = |i: &[f64; 3], f: Abc<f64>| kl * (i[0] * f.u + i[1] * f.v + i[2] * f.w);
        let (te_m, te_e) = (
            torque(&i_m, emf::sinusoid(sc_m)),
            torque(&i_e, emf::sinusoid(sc_e)),
        );
        // The electrical powers do not depend on the speed; the airgap power is Te·ωm.
        let (p_m, p_e) = lin.drawn(&i_m, &i_e);
        let (r2, a2) = self.stage_rates(&p_m, te_m, w2, te_m * w2);
        let w3 = w0 + 0.5 * h * a2;
        let (r3, a3) = self.stage_rates(&p_m, te_m, w3, te_m * w3);
        let w4 = w0 + h * a3;
        let (r4, a4) = self.stage_rates(&p_e, te_e, w4, te_e * w4);
        let mut x1 = *x;
        for (j, &i) in i_e.iter().enumerate() {
            x1[j] = i;
        }
        x1[OMEGA] = w0 + h / 6.0 * (k1[OMEGA] + 2.0 * (a2 + a3) + a4);
        x1[THETA] = th0 + self.pp * h / 6.0 * (w0 + 2.0 * (w2 + w3) + w4);
        for j in 0..INTEGRALS {
            let k = E_SUPPLY + j;
            x1[k] += h / 6.0 * (k1[k] + 2.0 * (r2[j] + r3[j]) + r4[j]);
        }
        (x1, (th0 + omega_e * h, sc_e.0, sc_e.1))
    }

    /// The back-EMF's forcing of a step of `h` from `x` (derivative `k1`, sin θ and cos θ
    /// `sc0`) for the modal response: it follows the speed through the step, amplitude
    /// λr·(ωm0 + α·t + α′·t²/2), and the angle leads φ0 + Ω·t by pp·α·(t² − h·t)/2, with
    /// Ω the electrical speed at the middle of the step of `h` it is built for.
    #[inline(always)]
    pub(super) fn forcing(&self, x: &State, h: f64, k1: &State, sc0: (f64, f64)) -> Forcing {
        let kl = self.lambda * self.pp;
        let a = k1[OMEGA];
        Forcing {
            omega: self.pp * (x[OMEGA] + 0.5 * h * a),
            amp: kl * x[OMEGA],
            slope: kl * a,
            quad: 0.5 * kl * self.jerk(x, k1, sc0),
            d1: -0.5 * self.pp * a * h,
            d2: 0.5 * self.pp * a,
        }
    }

    /// One RK4 step from `x` with the derivative there, `k1`, known.
    pub(super) fn rk4_from(&self, x: &State, h: f64, base: (f64, f64, f64), k1: &State) -> State {
        let stage = |k: &State, a: f64| -> Dyn { std::array::from_fn(|j| x[j] + k[j] * a) };
        let k2 = self.deriv(&stage(k1, 0.5 * h), base);
        let k3 = self.deriv(&stage(&k2, 0.5 * h), base);
        let k4 = self.deriv(&stage(&k3, h), base);
        x + (k1 + (k2 + k3) * 2.0 + k4) * (h / 6.0)
    }

    /// The modal response of the whole step of `h` from `x0` (derivative `f0`, angle base
    /// `base`), if there is a modal form. A step of any length within it follows the same
    /// back-EMF to first order in the angle's lead (see [`Forcing`]), so the step to a
    /// predicted diode event is integrated on it too.
    #[inline(always)]
    pub(super) fn step_response(
        &self,
        x0: &State,
        f0: &State,
        h: f64,
        base: (f64, f64, f64),
    ) -> Option<StepResponse<'_>> {
        let (_, md, _) = self.form();
        let md = md.as_ref().filter(|_| self.modal)?;
        let sc0 = emf::sin_cos_near(x0[THETA], base);
        let forcing = self.forcing(x0, h, f0, sc0);
        Some(StepResponse {
            rsp: Response::new(md, &[x0[0], x0[1], x0[2]], sc0, &forcing),
            md,
            sc0,
            omega_e: forcing.omega,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bldc::N;
    use crate::bldc::dynamic;
    use crate::bldc::testing::{crawl, driven, fine};
    use crate::params::{BackEmfShape, PlantParams};
    use std::f64::consts::TAU;

    /// The RK4 path (no modal form: a trapezoidal back-EMF) gives the step's end its own
    /// sine and cosine: at 9e-5 rad a step, a second-order rotation from the step's start
    /// would be off by d³/6 ≈ 1.2e-13 at every step; the series is within a few ε a step,
    /// so over `ANCHOR` steps well within 5e-14 of a fresh sin_cos.
    #[test]
    fn the_rk4_step_s_end_angle_follows_a_fresh_sin_cos_over_a_long_crawl() {
        let mut params = PlantParams::default();
        params.motor.back_emf = BackEmfShape::Trapezoidal {
            flat_top_deg: 120.0,
        };
        let d = 9e-5;
        let rpm = d / params.solver.max_step_s / params.motor.pole_pairs() * 60.0 / TAU;
        let mut worst = 0.0f64;
        let mut steps = 0;
        crawl(params, rpm, 100_000, |pl| {
            assert!(pl.form().1.is_none() || !pl.modal, "the RK4 path");
            let (th, s, c) = pl.end_angle.expect("a step's end angle");
            let (ws, wc) = th.sin_cos();
            worst = worst.max((s - ws).abs().max((c - wc).abs()));
            steps += 1;
        });
        assert!(
            worst < 5e-14,
            "sin and cos off by up to {worst:e} over {steps} steps"
        );
    }

    /// A step to a predicted diode zero runs on the response built for the full step (its
    /// forcing's Ω and angle lead are the full step's): over the full step that is the
    /// ordinary step bit for bit; over a shorter one it keeps the modal step's accuracy
    /// and the currents the shorter step's own forcing gives (the angle's lead stays
    /// within pp·|α|·h²/8 either way).
    #[test]
    fn a_shorter_step_on_the_full_step_s_response_follows_the_trajectory() {
        let h = 40e-6;
        let err = |a: &State, b: &State| (0..3).fold(0.0f64, |m, k| m.max((a[k] - b[k]).abs()));
        for rpm in [3000.0, -3000.0] {
            let pl = driven([0.1, -0.5, 0.4], rpm, false);
            let x0 = pl.x;
            let b = BldcPlant::base(&x0);
            let k1 = pl.deriv(&dynamic(&x0), b);
            let built = pl.step_response(&x0, &k1, h, b).expect("a modal form");
            let (full, own) = (
                pl.flow_built(&x0, h, &k1, &built).0,
                pl.integrate_from(&x0, h, b, &k1),
            );
            assert_eq!(full.map(f64::to_bits), own.map(f64::to_bits), "{rpm} rpm");
            for hz in [h / 3.0, 0.7 * h] {
                let got = pl.flow_built(&x0, hz, &k1, &built).0;
                let own = pl.integrate_from(&x0, hz, b, &k1);
                let want = fine(&pl, &x0, hz, 2000);
                let (di, dw) = (err(&got, &want), (got[OMEGA] - want[OMEGA]).abs());
                let case = format!("{rpm} rpm, {hz:e} s: {di:e} A, {dw:e} rad/s");
                // The modal step's accuracy over a full 40 µs step (the next test's bounds).
                assert!(di <= 1e-7 && dw <= 2e-7, "{case}");
                // The currents as the shorter step's own forcing gives them, well within
                // the 1e-9 A an event's end must meet.
                assert!(err(&got, &own) <= 1e-9, "{case}");
                assert!((got[THETA] - want[THETA]).abs() < 1e-9, "{case}");
            }
        }
    }

    /// The modal step against RK4 with 2000 sub-steps, over a 40 µs step (half the default
    /// longest: at 80 µs the three-phase case's freewheeling current would not stay on).
    /// Locked speed: the currents are exact (rounding only). Free rotor, 0.3 A rising: the
    /// rotor accelerates at ≈ 1000 rad/s², and the torque changes that at ≈ 1e7 rad/s³;
    /// the modal step follows both to first order (measured at 3000 rpm: 9e-9 A and 5e-8
    /// rad/s with two phases conducting, 5.4e-8 A with three; one RK4 step errs by 1.6e-7
    /// and 2.9e-7 A, 4e-7 rad/s). Two phases conducting (one mode) and three (two modes, w
    /// freewheeling and staying on); forwards, backwards and from standstill.
    #[test]
    fn the_modal_step_matches_a_fine_rk4_solution() {
        let h = 40e-6;
        let err = |a: &State, b: &State| (0..3).fold(0.0f64, |m, k| m.max((a[k] - b[k]).abs()));
        for i in [[0.3, -0.3, 0.0], [0.1, -0.5, 0.4]] {
            for rpm in [3000.0, -3000.0, 0.0] {
                for lock in [true, false] {
                    let case = format!("{i:?} at {rpm} rpm, lock {lock}");
                    let pl = driven(i, rpm, lock);
                    let n_on = pl.modes.to_array().iter().filter(|m| m.conducts()).count();
                    assert_eq!(n_on, if i[2] == 0.0 { 2 } else { 3 }, "{case}");
                    let (lin, md, _) = *pl.form();
                    let md = md.expect("a modal form");
                    let x0 = pl.x;
                    let b = BldcPlant::base(&x0);
                    let k1 = pl.deriv(&dynamic(&x0), b);
                    let (got, end) = pl.flow_from(&md, &lin, &x0, h, b, &k1);
                    let want = fine(&pl, &x0, h, 2000);
                    // The end's sine and cosine from the response's angle there, which it
                    // leads by pp·h²·(α2 + α3 − 2α1)/6 (1.1e-6 rad here, with the torque's
                    // fast rise), far within the small rotation's 1e-4.
                    assert!((got[THETA] - end.0).abs() < 1e-5, "{case}");
                    let (s, c) = emf::sin_cos_close(got[THETA], end, b);
                    let (ws, wc) = got[THETA].sin_cos();
                    assert!((s - ws).abs() < 1e-12 && (c - wc).abs() < 1e-12, "{case}");
                    let (di, dw) = (err(&got, &want), (got[OMEGA] - want[OMEGA]).abs());
                    let (bi, bw) = if lock { (1e-13, 0.0) } else { (1e-7, 2e-7) };
                    assert!(di <= bi && dw <= bw, "{case}: {di:e} A, {dw:e} rad/s");
                    if !lock {
                        // Fourth order: half the step, a sixteenth of the error (third
                        // order, as without the torque's rate of change, an eighth).
                        let half = pl.flow_from(&md, &lin, &x0, h / 2.0, b, &k1).0;
                        let e2 = err(&half, &fine(&pl, &x0, h / 2.0, 2000));
                        assert!(e2 < di / 12.0, "{case}: {di:e} A, then {e2:e} A at h/2");
                    }
                    assert!((got[THETA] - want[THETA]).abs() < 1e-9, "{case}");
                    // Energy integrals: Simpson's rule on exact currents.
                    for k in E_SUPPLY..N {
                        assert!((got[k] - want[k]).abs() < 1e-9, "{case}: energy {k}");
                    }
                }
            }
        }
    }
}
