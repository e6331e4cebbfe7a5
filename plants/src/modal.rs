//! The network's modal form for one conduction state, and the exact current response over
//! a step for the sinusoidal back-EMF.
//!
//! Between events the currents obey di/dt = c + K·i + Q·e (see [`Linearised`]) and stay in
//! the subspace S where open phases carry nothing and the currents sum to zero. L is the
//! same for every phase, so K restricted to S is −1/L times a symmetric positive-definite
//! resistance matrix: it has an orthonormal eigenbasis w_j with eigenvalues λ_j < 0, at
//! most two of them (two phases conducting: one mode; three: two). In modal coordinates
//! z_j = w_j·i each mode is a scalar linear ODE,
//!
//! ```text
//! dz/dt = λ·z + a + ws·sin φ + wc·cos φ,   φ = φ0 + Ω·t,
//! z(t) = z_c + P·sin φ + R·cos φ + e^{λt}·(z(0) − z_c − P·sin φ0 − R·cos φ0)
//! ```
//!
//! with z_c = −a/λ, P = (Ω·wc − λ·ws)/(λ² + Ω²) and R = −(λ·wc + Ω·ws)/(λ² + Ω²). The
//! sinusoidal back-EMF is e = λr·ωm·(sin φ, sin(φ − 120°), sin(φ + 120°)), so ws and wc are
//! λr·ωm times this state's weights `gs`, `gc`. Within a step the speed changes a little;
//! [`Response`] follows that to first order, with P and R polynomials in t.

use crate::circuit::{Conduction, Linearised};
use crate::emf;
use crate::sensing::rc::ExpTable;
use drive_core::Abc;

/// Eigenvalues, eigenvectors and forcing weights of one conduction state.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Modal {
    /// Number of modes: 0 (nothing flows), 1 or 2.
    pub m: usize,
    /// Unit eigenvectors in current space.
    pub w: [[f64; 3]; 2],
    /// Eigenvalues λ_j < 0 [1/s].
    pub lambda: [f64; 2],
    /// Equilibrium of the constant forcing, −(w_j·c)/λ_j \[A\].
    pub zc: [f64; 2],
    /// Forcing of mode j per volt of back-EMF amplitude, for sin φ [A/(V·s)].
    pub gs: [f64; 2],
    /// The same for cos φ [A/(V·s)].
    pub gc: [f64; 2],
    /// e^{λ_j·t} by table (a cache of `lambda`; a missing mode's rate is 0).
    decay: ExpTable<2>,
}

impl Modal {
    /// The modal form of conduction state `modes` with affine form `lin`, or `None` where
    /// the decomposition does not check out (then the caller integrates numerically).
    /// Allocates nothing: forms are built when a drive first enters a conduction state.
    pub fn new(modes: &Abc<Conduction>, lin: &Linearised) -> Option<Modal> {
        let m_arr = modes.to_array();
        let mut on = [0usize; 3];
        let mut n_on = 0;
        for (k, m) in m_arr.iter().enumerate() {
            if m.conducts() {
                on[n_on] = k;
                n_on += 1;
            }
        }
        let (c, k, q) = lin.parts();
        // An orthonormal basis of the subspace the currents stay in.
        let (basis, m) = match n_on {
            0 | 1 => return Some(Modal::default()),
            2 => {
                let mut u = [0.0; 3];
                u[on[0]] = std::f64::consts::FRAC_1_SQRT_2;
                u[on[1]] = -std::f64::consts::FRAC_1_SQRT_2;
                ([u, [0.0; 3]], 1)
            }
            _ => {
                let (a, b) = (1.0 / 2f64.sqrt(), 1.0 / 6f64.sqrt());
                ([[a, -a, 0.0], [b, b, -2.0 * b]], 2)
            }
        };
        let kx = |v: &[f64; 3]| -> [f64; 3] { std::array::from_fn(|r| dot(&k[r], v)) };
        let (w, lambda) = if m == 1 {
            let u = basis[0];
            ([u, [0.0; 3]], [dot(&u, &kx(&u)), 0.0])
        } else {
            // The symmetric 2×2 restriction [[a, b], [b, d]], diagonalised by one rotation.
            let (u1, u2) = (basis[0], basis[1]);
            let (ku1, ku2) = (kx(&u1), kx(&u2));
            let (a, b, b2, d) = (
                dot(&u1, &ku1),
                dot(&u1, &ku2),
                dot(&u2, &ku1),
                dot(&u2, &ku2),
            );
            if (b - b2).abs() > 1e-9 * a.abs().max(d.abs()) {
                return None;
            }
            let b = 0.5 * (b + b2);
            let t = 0.5 * (2.0 * b).atan2(a - d);
            let (s, co) = t.sin_cos();
            let w1: [f64; 3] = std::array::from_fn(|i| co * u1[i] + s * u2[i]);
            let w2: [f64; 3] = std::array::from_fn(|i| -s * u1[i] + co * u2[i]);
            ([w1, w2], [dot(&w1, &kx(&w1)), dot(&w2, &kx(&w2))])
        };
        let scale = lambda[..m].iter().fold(0.0f64, |x, l| x.max(l.abs()));
        for j in 0..m {
            // An eigenpair with a decaying mode, or no modal form.
            let r = kx(&w[j]);
            let off = (0..3).fold(0.0f64, |x, i| x.max((r[i] - lambda[j] * w[j][i]).abs()));
            if lambda[j].partial_cmp(&0.0) != Some(std::cmp::Ordering::Less) || off > 1e-9 * scale {
                return None;
            }
        }
        // The forcing must lie in the modes' span (it does: di/dt sums to zero and is zero
        // on open phases), else the modal form would drop part of it.
        // Q·(the sinusoid's weights of sin φ, then of cos φ).
        let qm = |sin_cos: (f64, f64)| -> [f64; 3] {
            let f = emf::sinusoid(sin_cos).to_array();
            std::array::from_fn(|r| dot(&q[r], &f))
        };
        let (qs, qc) = (qm((1.0, 0.0)), qm((0.0, 1.0)));
        for v in [c, &qs, &qc] {
            let mut rest = *v;
            for wj in &w[..m] {
                let p = dot(wj, v);
                for i in 0..3 {
                    rest[i] -= p * wj[i];
                }
            }
            // Relative, with a floor far below any physical rate (A/s, A/(V·s)): a vector that
            // is rounding noise is not held to its own size.
            let size = v.iter().fold(0.0f64, |x, y| x.max(y.abs()));
            if rest.iter().any(|r| r.abs() > 1e-9 * size + 1e-9) {
                return None;
            }
        }
        let mut out = Modal {
            m,
            w,
            lambda,
            decay: ExpTable::new(lambda),
            ..Modal::default()
        };
        for j in 0..m {
            out.zc[j] = -dot(&w[j], c) / lambda[j];
            out.gs[j] = dot(&w[j], &qs);
            out.gc[j] = dot(&w[j], &qc);
        }
        Some(out)
    }

    /// e^{λ_j·t} for the modes, `t` \[s\] ≥ 0, by table (a missing mode's is 1; the
    /// caller squares these to double t).
    pub fn decays(&self, t: f64) -> [f64; 2] {
        self.decay.at(t)
    }
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The current response of one conduction state over a step from currents `i0` at angle
/// φ0 (sine and cosine given), exact for a back-EMF whose forcing of each mode is
/// `(ws0 + ws1·t + ws2·t²)·sin φ + (wc0 + wc1·t + wc2·t²)·cos φ` with φ = φ0 + Ω·t.
///
/// Within a step the speed changes: ωm(t) ≈ ωm0 + α·t + α′·t²/2, where α′ follows the
/// torque, which follows the currents (on this light rotor α′ reaches 1e7 rad/s³ while a
/// current rises). The amplitude λr·ωm(t) is then quadratic in t, and the true angle runs
/// ahead of the linear φ by δ(t) = pp·α·(t² − h·t)/2 (pp pole pairs) when Ω is the
/// mid-step electrical speed. To first order in δ (below 1e-5 rad), the back-EMF
/// λr·ωm(t)·f(φ + δ) is such a forcing (see [`Forcing`]). Holding the speed constant
/// instead errs by ≈ λr·α′·h³/(6L) per step, 5e-7 A at h = 40 µs: more than RK4's.
#[derive(Copy, Clone, Debug)]
pub struct Response<'a> {
    /// The state's modes (eigenvectors, eigenvalues, equilibria), borrowed: not copied
    /// for every step.
    md: &'a Modal,
    /// The part of i0 outside the modes (rounding-size; carried unchanged, as by RK4).
    perp: [f64; 3],
    /// The particular solution Σ_k t^k·(P_k·sin φ + R_k·cos φ) of each mode.
    p: [[f64; 3]; 2],
    r: [[f64; 3]; 2],
    /// Transient amplitudes z(0) − z_c − P_0·sin φ0 − R_0·cos φ0.
    tr: [f64; 2],
}

/// The back-EMF over a step: amplitude per unit shape λr·(ωm0 + α·t + α′·t²/2) =
/// `amp + slope·t + quad·t²` \[V\], and the true angle's lead over φ0 + Ω·t,
/// δ(t) = d1·t + d2·t² \[rad\]. Only the split between Ω and δ depends on the step's
/// length h: Ω·t + δ(t) = pp·(ωm0·t + α·t²/2) whatever h, and |δ| ≤ pp·|α|·h²/8 on
/// [0, h]; so a forcing built for h serves any shorter step within it to first order in
/// δ, as the step to a diode's predicted zero uses it.
#[derive(Copy, Clone, Debug)]
pub struct Forcing {
    /// Ω [rad/s].
    pub omega: f64,
    /// λr·ωm0 \[V\].
    pub amp: f64,
    /// λr·α [V/s].
    pub slope: f64,
    /// λr·α′/2 [V/s²].
    pub quad: f64,
    /// d1 [rad/s].
    pub d1: f64,
    /// d2 [rad/s²].
    pub d2: f64,
}

impl<'a> Response<'a> {
    /// The response to forcing `f` from currents `i0` at the angle whose sine and cosine
    /// are given.
    pub fn new(md: &'a Modal, i0: &[f64; 3], (s0, c0): (f64, f64), f: &Forcing) -> Self {
        let mut rsp = Response {
            md,
            perp: *i0,
            p: [[0.0; 3]; 2],
            r: [[0.0; 3]; 2],
            tr: [0.0; 2],
        };
        let om = f.omega;
        for j in 0..md.m {
            let z0 = dot(&md.w[j], i0);
            for i in 0..3 {
                rsp.perp[i] -= z0 * md.w[j][i];
            }
            // f(φ + δ) ≈ f(φ) + δ·f′(φ): sin φ·(a − δ·b) + cos φ·(b + δ·a) where f = a·sin φ +
            // b·cos φ, times the amplitude; terms beyond t² dropped.
            let (gs, gc) = (md.gs[j], md.gc[j]);
            let d2 = f.amp * f.d2 + f.slope * f.d1; // δ's weight on t², amplitude included
            let ws = [
                f.amp * gs,
                f.slope * gs - f.amp * f.d1 * gc,
                f.quad * gs - d2 * gc,
            ];
            let wc = [
                f.amp * gc,
                f.slope * gc + f.amp * f.d1 * gs,
                f.quad * gc + d2 * gs,
            ];
            // (λ, Ω; −Ω, λ)·(P_k, R_k) = ((k+1)·P_{k+1} − ws_k, (k+1)·R_{k+1} − wc_k).
            let l = md.lambda[j];
            let inv = 1.0 / (l * l + om * om);
            let solve = |b1: f64, b2: f64| ((l * b1 - om * b2) * inv, (om * b1 + l * b2) * inv);
            let (p2, r2) = solve(-ws[2], -wc[2]);
            let (p1, r1) = solve(2.0 * p2 - ws[1], 2.0 * r2 - wc[1]);
            let (p0, r0) = solve(p1 - ws[0], r1 - wc[0]);
            rsp.p[j] = [p0, p1, p2];
            rsp.r[j] = [r0, r1, r2];
            rsp.tr[j] = z0 - md.zc[j] - p0 * s0 - r0 * c0;
        }
        rsp
    }

    /// The currents at time `t` into the step, where the angle's sine and cosine are
    /// (`s`, `c`) and the modes have decayed by `decays` (see [`Modal::decays`]).
    pub fn currents(&self, t: f64, (s, c): (f64, f64), decays: [f64; 2]) -> [f64; 3] {
        let mut i = self.perp;
        for (j, d) in decays.iter().enumerate().take(self.md.m) {
            let (p, r) = (self.p[j], self.r[j]);
            let ps = p[0] + t * (p[1] + t * p[2]);
            let rc = r[0] + t * (r[1] + t * r[2]);
            let z = self.md.zc[j] + ps * s + rc * c + d * self.tr[j];
            for (ik, wk) in i.iter_mut().zip(&self.md.w[j]) {
                *ik += z * wk;
            }
        }
        i
    }

    /// [`Response::currents`] at two instants side by side, `t[l]` with sine and cosine
    /// `sc[l]` and decays `decays[l]`: the same values bit for bit, made lane by lane.
    // The mode's index picks from five arrays.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    pub fn currents_pair(
        &self,
        t: [f64; 2],
        sc: [(f64, f64); 2],
        decays: [[f64; 2]; 2],
    ) -> [[f64; 3]; 2] {
        let mut i = [self.perp; 2];
        for j in 0..self.md.m {
            let (p, r, w) = (self.p[j], self.r[j], self.md.w[j]);
            let mut z = [0.0; 2];
            for l in 0..2 {
                let ps = p[0] + t[l] * (p[1] + t[l] * p[2]);
                let rc = r[0] + t[l] * (r[1] + t[l] * r[2]);
                z[l] = self.md.zc[j] + ps * sc[l].0 + rc * sc[l].1 + decays[l][j] * self.tr[j];
            }
            for k in 0..3 {
                for l in 0..2 {
                    i[l][k] += z[l] * w[k];
                }
            }
        }
        i
    }

    /// The first and second time derivatives [A/s, A/s²] of phase `k`'s current at the
    /// step's start, where the angle's sine and cosine are (`s`, `c`), advancing at
    /// `omega` [rad/s]: with ps = P0 + P1·t + P2·t² and rc likewise, z″ = (ps″ − 2Ω·rc′ −
    /// Ω²·ps)·sin φ + (rc″ + 2Ω·ps′ − Ω²·rc)·cos φ + λ²·e^{λt}·tr, at t = 0.
    pub fn start_rates(&self, k: usize, (s, c): (f64, f64), omega: f64) -> (f64, f64) {
        let (mut di, mut ddi) = (0.0, 0.0);
        for j in 0..self.md.m {
            let (p, r, l, tr) = (self.p[j], self.r[j], self.md.lambda[j], self.tr[j]);
            let dz = (p[1] - omega * r[0]) * s + (r[1] + omega * p[0]) * c + l * tr;
            let ddz = (2.0 * p[2] - 2.0 * omega * r[1] - omega * omega * p[0]) * s
                + (2.0 * r[2] + 2.0 * omega * p[1] - omega * omega * r[0]) * c
                + l * l * tr;
            di += dz * self.md.w[j][k];
            ddi += ddz * self.md.w[j][k];
        }
        (di, ddi)
    }

    /// Phase `k`'s current \[A\] and its rate [A/s] at time `t` into the step, where the
    /// angle's sine and cosine are (`s`, `c`), advancing at `omega` [rad/s] (the forcing's
    /// Ω), and the modes have decayed by `decays`: [`Response::currents`] and its time
    /// derivative, for Newton's method on one current.
    pub fn current_and_rate(
        &self,
        k: usize,
        t: f64,
        (s, c): (f64, f64),
        omega: f64,
        decays: [f64; 2],
    ) -> (f64, f64) {
        let (mut i, mut di) = (self.perp[k], 0.0);
        for (j, d) in decays.iter().enumerate().take(self.md.m) {
            let (p, r) = (self.p[j], self.r[j]);
            let ps = p[0] + t * (p[1] + t * p[2]);
            let rc = r[0] + t * (r[1] + t * r[2]);
            let (dps, drc) = (p[1] + 2.0 * t * p[2], r[1] + 2.0 * t * r[2]);
            let z = self.md.zc[j] + ps * s + rc * c + d * self.tr[j];
            // d/dt of ps·sin φ + rc·cos φ + e^{λt}·tr, with dφ/dt = Ω.
            let dz = (dps - omega * rc) * s
                + (drc + omega * ps) * c
                + self.md.lambda[j] * d * self.tr[j];
            i += z * self.md.w[j][k];
            di += dz * self.md.w[j][k];
        }
        (i, di)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::circuit::Circuit;
    use crate::params::{MotorParams, PowerStageParams};

    /// A speed-varying forcing (Ω = 2000 rad/s, every term of the back-EMF and of the
    /// angle's lead non-zero) that the response tests share.
    const SPEEDING_UP: Forcing = Forcing {
        omega: 2000.0,
        amp: 1.5,
        slope: 300.0,
        quad: 4e5,
        d1: -0.01,
        d2: 500.0,
    };

    /// Every conduction state of the default drive has a modal form (else its steps would
    /// quietly fall back to RK4): orthonormal eigenvectors of K with decaying eigenvalues,
    /// as many as conducting phases less one.
    #[test]
    fn every_conduction_state_has_a_modal_form() {
        let c = Circuit::new(&MotorParams::default(), &PowerStageParams::default());
        for k in 0..crate::circuit::STATES {
            let modes = crate::circuit::state_at(k);
            let lin = c.linearise(&modes);
            let md = Modal::new(&modes, &lin).unwrap_or_else(|| panic!("{modes:?}"));
            let on = modes.to_array().iter().filter(|m| m.conducts()).count();
            assert_eq!(md.m, on.saturating_sub(1), "{modes:?}");
            let (_, kk, _) = lin.parts();
            for j in 0..md.m {
                let w = md.w[j];
                assert!(md.lambda[j] < 0.0);
                for r in 0..3 {
                    let kw = dot(&kk[r], &w);
                    assert!((kw - md.lambda[j] * w[r]).abs() < 1e-9 * md.lambda[j].abs());
                }
                for i in 0..md.m {
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((dot(&md.w[i], &w) - want).abs() < 1e-12);
                }
            }
        }
    }

    /// A phase's current and its first two time derivatives, as Newton's method on a
    /// diode's zero takes them, match the response's own currents and their central differences in
    /// a freewheeling state (three phases, two modes) under a speed-varying forcing.
    #[test]
    fn a_phase_current_s_rates_match_the_response_s_differences() {
        let c = Circuit::new(&MotorParams::default(), &PowerStageParams::default());
        let modes = Abc {
            u: Conduction::SwitchHigh,
            v: Conduction::SwitchLow,
            w: Conduction::DiodeLow,
        };
        let md = Modal::new(&modes, &c.linearise(&modes)).expect("a modal form");
        assert_eq!(md.m, 2);
        let th0: f64 = 0.7;
        let f = SPEEDING_UP;
        let sc0 = th0.sin_cos();
        let rsp = Response::new(&md, &[0.3, -0.5, 0.2], sc0, &f);
        // The current of phase k at t [s], from the response at the angle φ0 + Ω·t.
        let at = |k: usize, t: f64| {
            let (s, c) = (th0 + f.omega * t).sin_cos();
            rsp.currents(t, (s, c), md.decays(t))[k]
        };
        let dt = 1e-7;
        for k in 0..3 {
            let (d1, d2) = rsp.start_rates(k, sc0, f.omega);
            let rate = |t: f64| {
                let (s, c) = (th0 + f.omega * t).sin_cos();
                rsp.current_and_rate(k, t, (s, c), f.omega, md.decays(t)).1
            };
            // Central differences (the response extends to t < 0 by its formula).
            let fd1 = (at(k, dt) - at(k, -dt)) / (2.0 * dt);
            let fd2 = (rate(dt) - rate(-dt)) / (2.0 * dt);
            let near = |x: f64, y: f64, rel: f64| (x - y).abs() <= rel * x.abs().max(1.0);
            assert!(near(d1, rate(0.0), 1e-9), "{k}: {d1} vs {}", rate(0.0));
            assert!(near(d1, fd1, 1e-4), "{k}: {d1} vs {fd1}");
            assert!(near(d2, fd2, 1e-4), "{k}: {d2} vs {fd2}");
            for t in [3e-6, 2e-5] {
                let (s, c) = (th0 + f.omega * t).sin_cos();
                let (i, di) = rsp.current_and_rate(k, t, (s, c), f.omega, md.decays(t));
                assert_eq!(i, at(k, t));
                let fd = (at(k, t + dt) - at(k, t - dt)) / (2.0 * dt);
                assert!(near(di, fd, 1e-4), "{k} at {t}: {di} vs {fd}");
            }
        }
    }

    /// The currents at two instants side by side equal those at each alone bit for bit, with
    /// one mode and with two.
    #[test]
    fn paired_currents_equal_single_ones_bit_for_bit() {
        let c = Circuit::new(&MotorParams::default(), &PowerStageParams::default());
        let f = SPEEDING_UP;
        for w in [Conduction::Open, Conduction::DiodeLow] {
            let modes = Abc {
                u: Conduction::SwitchHigh,
                v: Conduction::SwitchLow,
                w,
            };
            let md = Modal::new(&modes, &c.linearise(&modes)).expect("a modal form");
            let rsp = Response::new(&md, &[0.3, -0.5, 0.2], 0.7f64.sin_cos(), &f);
            for (a, b) in [(1e-6f64, 3e-6f64), (2e-5, 4e-5), (0.0, 7e-5)] {
                let sc = [(0.7 + 2000.0 * a).sin_cos(), (0.7 + 2000.0 * b).sin_cos()];
                let d = [md.decays(a), md.decays(b)];
                let pair = rsp.currents_pair([a, b], sc, d);
                let one = [rsp.currents(a, sc[0], d[0]), rsp.currents(b, sc[1], d[1])];
                assert_eq!(
                    pair.map(|i| i.map(f64::to_bits)),
                    one.map(|i| i.map(f64::to_bits))
                );
            }
        }
    }

    /// One phase switched high and one low: a single series loop, so the mode decays at
    /// −(2R + 2R_on + R_sh)/(2L), L = Lp + M (the low leg returns through the shunt).
    #[test]
    fn a_series_pair_decays_at_its_loop_time_constant() {
        let (m, p) = (MotorParams::default(), PowerStageParams::default());
        let c = Circuit::new(&m, &p);
        let modes = Abc {
            u: Conduction::SwitchHigh,
            v: Conduction::SwitchLow,
            w: Conduction::Open,
        };
        let md = Modal::new(&modes, &c.linearise(&modes)).expect("a modal form");
        let r_loop = 2.0 * m.resistance_ohm + 2.0 * p.switch_on_resistance_ohm + p.shunt_ohm;
        let want = -r_loop / (2.0 * m.phase_inductance_h());
        assert_eq!(md.m, 1);
        assert!(
            (md.lambda[0] - want).abs() < 1e-9 * want.abs(),
            "{} vs {want}",
            md.lambda[0]
        );
    }
}
