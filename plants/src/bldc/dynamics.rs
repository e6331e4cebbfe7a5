//! The state derivative: back-EMF, electromagnetic torque, the mechanics and the rates of
//! the energy integrals, from the network's di/dt and powers.
//!
//! Mechanics: (J + J_L)·dωm/dt = Te − Bm·ωm − Tc·tanh(ωm/ω0) − TL(ωm), dθe/dt = (P/2)·ωm,
//! with the driven machine's torque TL and inertia J_L from [`Load`](crate::load::Load),
//! Te = (P/2)·λr·Σ i_x·f(θx) so that Te·ωm = Σ e_x·i_x exactly.

use super::{BldcPlant, Dyn, E_SUPPLY, INTEGRALS, OMEGA, State, THETA, dynamic};
use crate::circuit::{Powers, Solution};
use crate::emf;
use drive_core::Abc;

impl BldcPlant {
    pub(super) fn currents(x: &State) -> Abc<f64> {
        Abc {
            u: x[0],
            v: x[1],
            w: x[2],
        }
    }

    /// The back-EMF shape values and the back-EMFs \[V\] at `x`; inlined, so a caller
    /// that takes the back-EMFs alone does not make the shape's values.
    #[inline(always)]
    pub(super) fn emf_of(&self, x: &State) -> (Abc<f64>, Abc<f64>) {
        let sc = emf::sin_cos_near(x[THETA], self.base_hint);
        let f = emf::shape_with(&self.shape, x[THETA], sc);
        let k = self.lambda * self.pp * x[OMEGA];
        (f, f.map(|v| k * v))
    }

    /// The state derivative at a state whose dynamic part (currents, speed, angle) is `x`:
    /// nothing depends on the energy integrals, so RK4's stages carry only that part.
    pub(super) fn deriv(&self, x: &Dyn, base: (f64, f64, f64)) -> State {
        let f = emf::shape_with(&self.shape, x[THETA], emf::sin_cos_near(x[THETA], base));
        let k = self.lambda * self.pp * x[OMEGA];
        let e = [k * f.u, k * f.v, k * f.w];
        let (di, p) = self.form().0.eval(&[x[0], x[1], x[2]], &e);
        self.assemble(x, &f, di, &p)
    }

    /// The state derivative at `x`, whose network solution is `s` and whose angle with its
    /// sine and cosine is `(θ, sin θ, cos θ)`: the solution's di/dt and powers make it, so
    /// the back-EMF and the network are not evaluated again (the losses, where the planned
    /// solve left them out, from the currents alone).
    #[inline(always)]
    pub(super) fn end_derivative(
        &self,
        x: &State,
        s: &Solution,
        (th, sn, cs): (f64, f64, f64),
    ) -> State {
        let f = emf::shape_with(&self.shape, th, (sn, cs));
        let p = if s.powers.has_losses() {
            s.powers
        } else {
            self.circuit
                .with_losses(&self.form().2, &Self::currents(x), s)
        };
        self.assemble(&dynamic(x), &f, s.di.to_array(), &p)
    }

    /// The state derivative from the network's di/dt and powers `p` at state `x`, whose
    /// back-EMF shape values are `f`: the mechanics and the energy integrals' rates.
    fn assemble(&self, x: &Dyn, f: &Abc<f64>, di: [f64; 3], p: &Powers) -> State {
        let wm = x[OMEGA];
        let te = self.pp * self.lambda * (x[0] * f.u + x[1] * f.v + x[2] * f.w);
        let (r, dw) = self.stage_rates(p, te, wm, p.airgap);
        let head = [di[0], di[1], di[2], dw, self.pp * wm];
        State::from_fn(|k, _| {
            if k < E_SUPPLY {
                head[k]
            } else {
                r[k - E_SUPPLY]
            }
        })
    }

    /// dα/dt [rad/s³] at state `x` (its angle's sine and cosine given) with derivative
    /// `k1`: the torque's rate of change (currents and angle moving) less the friction's,
    /// over J; zero when locked.
    pub(super) fn jerk(&self, x: &State, k1: &State, (s, c): (f64, f64)) -> f64 {
        if self.speed_lock {
            return 0.0;
        }
        let f = emf::sinusoid((s, c));
        // d/dθ of sin θ, sin(θ − 120°), sin(θ + 120°).
        let fp = emf::sinusoid((c, -s));
        let we = self.pp * x[OMEGA];
        let dte = self.lambda
            * self.pp
            * (k1[0] * f.u
                + k1[1] * f.v
                + k1[2] * f.w
                + we * (x[0] * fp.u + x[1] * fp.v + x[2] * fp.w));
        // d(drag)/dωm: viscous, and the Coulomb term's tanh′ = 1 − tanh².
        let th = smooth_sign(x[OMEGA] * self.inv_coulomb_speed);
        let ds = (1.0 - th * th) * self.inv_coulomb_speed;
        let ddrag = self.friction + self.coulomb * ds + self.load.passive_slope(x[OMEGA], ds);
        (dte - ddrag * k1[OMEGA]) * self.inv_inertia
    }

    /// The integrals' rates (energies, then Te and Te²) and dωm/dt at speed `wm`, torque
    /// `te`, electrical powers `p` and airgap power `airgap` (the same order as in the
    /// state).
    pub(super) fn stage_rates(
        &self,
        p: &Powers,
        te: f64,
        wm: f64,
        airgap: f64,
    ) -> ([f64; INTEGRALS], f64) {
        let s = smooth_sign(wm * self.inv_coulomb_speed);
        let drag = self.friction * wm + self.coulomb * s;
        let load = self.load.active_nm
            + if self.load.has_passive() {
                self.load.passive_nm(wm, s)
            } else {
                0.0
            };
        let net = te - drag - load;
        // A locked rotor is held by a dynamometer, which absorbs the net torque.
        let (dw, p_dyno) = if self.speed_lock {
            (0.0, net * wm)
        } else {
            (net * self.inv_inertia, 0.0)
        };
        let rates = [
            p.supply,
            p.copper,
            p.switch,
            p.diode,
            p.shunt,
            drag * wm,
            load * wm,
            airgap,
            p_dyno,
            te,
            te * te,
        ];
        (rates, dw)
    }
}

/// tanh(x), the smooth sign of the Coulomb friction: ±1 without the call beyond |x| = 20,
/// where tanh rounds to ±1 in f64 anyway (1 − tanh x ≈ 2e^{−2x} < half an ulp from x ≈ 19.1).
fn smooth_sign(x: f64) -> f64 {
    if x.abs() > 20.0 { x.signum() } else { x.tanh() }
}
