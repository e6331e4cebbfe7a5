//! The bridge + Y-connected windings as an electrical network with switched topology.
//!
//! Per phase (current i_x into the winding positive, neutral carries no current):
//!
//! ```text
//! v_x − v_n = R·i_x + L·di_x/dt + e_x,   L = Lp + M,   Σ_conducting i_x = 0
//! ```
//!
//! The −M·Σ_{y≠x} di_y/dt term of the motor equation becomes +M·di_x/dt because the currents sum to
//! zero. A conducting leg drives its terminal as a source behind a resistance:
//! `v_x = V_src − R_src·i_x` (+ the shunt drop `R_sh·i_sh` for legs tied to the low rail):
//!
//! | conduction  | V_src          | R_src | current sign |
//! |-------------|----------------|-------|--------------|
//! | high switch | V_DD           | R_on  | any          |
//! | low switch  | 0              | R_on  | any          |
//! | high diode  | V_DD + V_f     | R_d   | i_x < 0      |
//! | low diode   | −V_f           | R_d   | i_x > 0      |
//!
//! Summing the conducting phases' equations gives v_n explicitly, so no matrix is solved.
//! An open phase carries no current and its terminal sits at v_n + e_x. With fewer than two
//! conducting phases nothing fixes v_n: one switched-on phase pins it to V_src − e_x; with
//! none, the neutral rests at −Σe/3 (symmetric parasitic capacitance to ground), moved just
//! enough to keep every terminal inside the diode clamps [−V_f, V_DD + V_f].

mod linearised;
mod resolve;
mod states;

pub use linearised::Linearised;
pub(crate) use states::low_legs_at;
pub use states::{Conduction, STATES, state_at, state_index};

use crate::params::{MotorParams, PowerStageParams};
use drive_core::Abc;
use states::FOLLOWS_NEUTRAL;

/// Instantaneous powers \[W\] (for the energy ledger).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Powers {
    /// Drawn from the supply: V_DD·Σ_high i_x.
    pub supply: f64,
    /// Winding copper loss R·Σi².
    pub copper: f64,
    /// Switch conduction loss R_on·i².
    pub switch: f64,
    /// Diode loss V_f·|i| + R_d·i².
    pub diode: f64,
    /// Shunt loss R_sh·i_sh².
    pub shunt: f64,
    /// Converted to mechanical power: Σ e_x·i_x.
    pub airgap: f64,
}

impl Powers {
    /// Powers whose losses (copper, switch, diode, shunt) are not made yet (see
    /// [`Circuit::solve_planned_losses_later`]): marked by a copper loss of −0.0, which a
    /// made one, a sum from +0.0 of R·i² ≥ 0, never is.
    const LOSSES_LATER: Powers = Powers {
        supply: 0.0,
        copper: -0.0,
        switch: 0.0,
        diode: 0.0,
        shunt: 0.0,
        airgap: 0.0,
    };

    /// Whether the losses are made (see [`Circuit::with_losses`]): the mark's exact bits,
    /// so a made loss gone NaN (whose sign bit may be set) still counts as made.
    pub(crate) fn has_losses(&self) -> bool {
        self.copper.to_bits() != Self::LOSSES_LATER.copper.to_bits()
    }
}

/// The network's state at one instant.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Solution {
    /// di_x/dt [A/s].
    pub di: Abc<f64>,
    /// Terminal voltages to ground \[V\].
    pub v_term: Abc<f64>,
    /// Neutral voltage to ground \[V\].
    pub v_n: f64,
    /// Shunt current, positive towards ground \[A\].
    pub i_shunt: f64,
    /// Powers.
    pub powers: Powers,
}

/// Constant network parameters.
#[derive(Copy, Clone, Debug)]
pub struct Circuit {
    r: f64,
    inv_l: f64,
    vdd: f64,
    r_on: f64,
    vf: f64,
    r_d: f64,
    r_sh: f64,
}

impl Solution {
    /// A solution from per-phase arrays (u, v, w).
    #[inline]
    fn of(di: [f64; 3], v: [f64; 3], v_n: f64, i_shunt: f64, powers: Powers) -> Self {
        Solution {
            di: Abc {
                u: di[0],
                v: di[1],
                w: di[2],
            },
            v_term: Abc {
                u: v[0],
                v: v[1],
                w: v[2],
            },
            v_n,
            i_shunt,
            powers,
        }
    }
}

impl Circuit {
    /// From validated parameters.
    pub fn new(m: &MotorParams, p: &PowerStageParams) -> Self {
        Circuit {
            r: m.resistance_ohm,
            inv_l: 1.0 / m.phase_inductance_h(),
            vdd: p.supply_v,
            r_on: p.switch_on_resistance_ohm,
            vf: p.diode_forward_v,
            r_d: p.diode_resistance_ohm,
            r_sh: p.shunt_ohm,
        }
    }

    /// The diode clamps of an open terminal \[V\]: (low rail − V_f, V_DD + V_f).
    fn clamps(&self, i_shunt: f64) -> (f64, f64) {
        (self.r_sh * i_shunt - self.vf, self.vdd + self.vf)
    }

    fn source(&self, c: Conduction) -> (f64, f64) {
        match c {
            Conduction::SwitchHigh => (self.vdd, self.r_on),
            Conduction::SwitchLow => (0.0, self.r_on),
            Conduction::DiodeHigh => (self.vdd + self.vf, self.r_d),
            Conduction::DiodeLow => (-self.vf, self.r_d),
            Conduction::Open => (0.0, 0.0),
        }
    }

    /// Solves the network for given conduction states, currents and back-EMFs.
    pub fn solve(&self, modes: &Abc<Conduction>, i: &Abc<f64>, e: &Abc<f64>) -> Solution {
        let m = modes.to_array();
        let i = i.to_array();
        let e = e.to_array();
        let mut i_sh = 0.0;
        let mut n_c = 0u32;
        let mut n_switch = 0u32;
        let mut pinned = 0usize;
        for k in 0..3 {
            if m[k].is_low() {
                i_sh -= i[k];
            }
            if m[k].conducts() {
                n_c += 1;
                if !m[k].is_diode() {
                    n_switch += 1;
                    pinned = k;
                }
            }
        }
        let v_lr = self.r_sh * i_sh;
        let mut v = [0.0; 3];
        let mut sum = 0.0;
        let mut pw = Powers {
            shunt: self.r_sh * i_sh * i_sh,
            ..Powers::default()
        };
        for k in 0..3 {
            if !m[k].conducts() {
                continue;
            }
            let ix = i[k];
            let (vs, rs) = self.source(m[k]);
            let vx = vs + if m[k].is_low() { v_lr } else { 0.0 } - rs * ix;
            v[k] = vx;
            sum += vx - self.r * ix - e[k];
            if m[k].is_high() {
                pw.supply += self.vdd * ix;
            }
            if m[k].is_diode() {
                pw.diode += self.vf * ix.abs() + self.r_d * ix * ix;
            } else {
                pw.switch += self.r_on * ix * ix;
            }
            pw.copper += self.r * ix * ix;
            pw.airgap += e[k] * ix;
        }
        let mut di = [0.0; 3];
        let v_n = if n_c >= 2 {
            let v_n = sum / n_c as f64;
            for k in 0..3 {
                if m[k].conducts() {
                    di[k] = (v[k] - v_n - self.r * i[k] - e[k]) * self.inv_l;
                }
            }
            v_n
        } else if n_switch == 1 {
            v[pinned] - e[pinned]
        } else {
            self.floating_neutral(
                &Abc {
                    u: e[0],
                    v: e[1],
                    w: e[2],
                },
                i_sh,
            )
        };
        for k in 0..3 {
            if !m[k].conducts() || (n_c < 2 && m[k].is_diode()) {
                v[k] = v_n + e[k];
            }
        }
        Solution::of(di, v, v_n, i_sh, pw)
    }

    /// [`Circuit::solve`] for the conduction state `plan` was made for (see [`Plan`]): the
    /// same operations in the same order, so the same result bit for bit, without decoding
    /// the legs' states at every call.
    #[inline(never)]
    pub fn solve_planned(
        &self,
        plan: &Plan,
        modes: &Abc<Conduction>,
        i: &Abc<f64>,
        e: &Abc<f64>,
    ) -> Solution {
        self.solve_planned_with::<true>(plan, modes, i, e)
    }

    /// [`Circuit::solve_planned`] into `out` (a re-resolve's, the plant's start): written
    /// there in place rather than returned and copied.
    #[inline(never)]
    pub(crate) fn solve_planned_into(
        &self,
        plan: &Plan,
        modes: &Abc<Conduction>,
        i: &Abc<f64>,
        e: &Abc<f64>,
        out: &mut Solution,
    ) {
        // Written in each arm: one solution assembled from the arms went through the stack.
        match plan.open {
            _ if !plan.shared => *out = self.solve(modes, i, e),
            0 => *out = self.solve_shared::<0, true>(plan, i, e),
            1 => *out = self.solve_shared::<1, true>(plan, i, e),
            2 => *out = self.solve_shared::<2, true>(plan, i, e),
            _ => *out = self.solve_shared::<3, true>(plan, i, e),
        }
    }

    /// [`Circuit::solve_planned`] but, with two or more legs conducting, the losses
    /// (copper, switch, diode, shunt) left to [`Circuit::with_losses`]
    /// ([`Powers::has_losses`] false): they follow from the currents alone, and most
    /// solutions (a step's end, an event's search) are never asked for them.
    #[inline(never)]
    pub(crate) fn solve_planned_losses_later(
        &self,
        plan: &Plan,
        modes: &Abc<Conduction>,
        i: &Abc<f64>,
        e: &Abc<f64>,
    ) -> Solution {
        self.solve_planned_with::<false>(plan, modes, i, e)
    }

    /// [`Circuit::solve_planned`], the losses made if `LOSSES`.
    #[inline(always)]
    fn solve_planned_with<const LOSSES: bool>(
        &self,
        plan: &Plan,
        modes: &Abc<Conduction>,
        i: &Abc<f64>,
        e: &Abc<f64>,
    ) -> Solution {
        // Compiled once per open leg (or none), so the open leg's terms are not computed.
        match plan.open {
            _ if !plan.shared => self.solve(modes, i, e),
            0 => self.solve_shared::<0, LOSSES>(plan, i, e),
            1 => self.solve_shared::<1, LOSSES>(plan, i, e),
            2 => self.solve_shared::<2, LOSSES>(plan, i, e),
            _ => self.solve_shared::<3, LOSSES>(plan, i, e),
        }
    }

    /// [`Circuit::solve_planned_with`] for a state with two or more legs conducting, leg
    /// `OPEN` open (3: none). The terms [`Circuit::solve`] skips are not added at all rather
    /// than added as 0.0: each sum starts at +0.0 and so is never −0.0, and x + 0.0 = x then.
    #[inline(always)]
    fn solve_shared<const OPEN: usize, const LOSSES: bool>(
        &self,
        plan: &Plan,
        i: &Abc<f64>,
        e: &Abc<f64>,
    ) -> Solution {
        let i = i.to_array();
        let e = e.to_array();
        let mut i_sh = 0.0;
        for (&ix, &low) in i.iter().zip(&plan.low) {
            if low {
                i_sh -= ix;
            }
        }
        let v_lr = self.r_sh * i_sh;
        let mut v = [0.0; 3];
        let mut sum = 0.0;
        let mut pw = if LOSSES {
            Powers {
                shunt: self.r_sh * i_sh * i_sh,
                ..Powers::default()
            }
        } else {
            Powers::LOSSES_LATER
        };
        for k in 0..3 {
            if k == OPEN {
                continue;
            }
            let ix = i[k];
            let vx = plan.vs[k] + if plan.low[k] { v_lr } else { 0.0 } - plan.rs[k] * ix;
            v[k] = vx;
            sum += vx - self.r * ix - e[k];
            if plan.high[k] {
                pw.supply += self.vdd * ix;
            }
            if LOSSES {
                if plan.diode[k] {
                    pw.diode += self.vf * ix.abs() + self.r_d * ix * ix;
                } else {
                    pw.switch += self.r_on * ix * ix;
                }
                pw.copper += self.r * ix * ix;
            }
            pw.airgap += e[k] * ix;
        }
        let v_n = sum / plan.n_c;
        let mut di = [0.0; 3];
        for k in 0..3 {
            if k == OPEN {
                v[k] = v_n + e[k];
            } else {
                di[k] = (v[k] - v_n - self.r * i[k] - e[k]) * self.inv_l;
            }
        }
        Solution::of(di, v, v_n, i_sh, pw)
    }

    /// `s`'s powers with the losses (copper, switch, diode, shunt \[W\]) made for currents
    /// `i` in `plan`'s state, as [`Circuit::solve`] makes them (the same operations in the
    /// same order), `s` being [`Circuit::solve_planned_losses_later`]'s solution for `plan`
    /// and `i`. Out of line: the few solutions asked for their losses are the exception.
    #[cold]
    #[inline(never)]
    pub(crate) fn with_losses(&self, plan: &Plan, i: &Abc<f64>, s: &Solution) -> Powers {
        let i = i.to_array();
        let (mut switch, mut diode, mut copper) = (0.0, 0.0, 0.0);
        for (k, &ix) in i.iter().enumerate() {
            if !plan.on[k] {
                continue;
            }
            if plan.diode[k] {
                diode += self.vf * ix.abs() + self.r_d * ix * ix;
            } else {
                switch += self.r_on * ix * ix;
            }
            copper += self.r * ix * ix;
        }
        Powers {
            // R_sh·i_sh², the shunt current being the solution's own.
            shunt: self.r_sh * s.i_shunt * s.i_shunt,
            switch,
            diode,
            copper,
            ..s.powers
        }
    }

    /// The plan of [`Circuit::solve_planned`] for conduction state `modes`.
    pub fn plan(&self, modes: &Abc<Conduction>) -> Plan {
        let m = modes.to_array();
        let n_c = m.iter().filter(|c| c.conducts()).count();
        Plan {
            shared: n_c >= 2,
            open: m.iter().position(|c| !c.conducts()).unwrap_or(3),
            n_c: n_c as f64,
            on: m.map(Conduction::conducts),
            low: m.map(Conduction::is_low),
            high: m.map(Conduction::is_high),
            diode: m.map(Conduction::is_diode),
            vs: m.map(|c| self.source(c).0),
            rs: m.map(|c| self.source(c).1),
        }
    }

    /// The legs whose terminal [`Circuit::solve`] puts at v_n + e_x: the open ones, and with
    /// fewer than two legs conducting the diode ones too (nothing carries their current).
    pub fn follows_neutral(modes: &Abc<Conduction>) -> [bool; 3] {
        FOLLOWS_NEUTRAL[state_index(modes)]
    }

    /// [`Circuit::follows_neutral`] of the conduction state at index `k` (see
    /// [`state_index`]), for a caller that keeps the index: not decoded again at every step.
    pub(crate) fn follows_neutral_at(k: usize) -> [bool; 3] {
        FOLLOWS_NEUTRAL[k]
    }

    /// Neutral voltage with no conducting path: −Σe/3, clamped so that every terminal stays
    /// within the diode clamps.
    fn floating_neutral(&self, e: &Abc<f64>, i_shunt: f64) -> f64 {
        let centre = -(e.u + e.v + e.w) / 3.0;
        let emax = e.u.max(e.v).max(e.w);
        let emin = e.u.min(e.v).min(e.w);
        let (lo, hi) = self.clamps(i_shunt);
        let (lo, hi) = (lo - emin, hi - emax);
        if lo > hi {
            0.5 * (lo + hi)
        } else {
            centre.clamp(lo, hi)
        }
    }

    /// Signed distance of an open terminal from the nearer diode clamp \[V\]: > 0 inside
    /// [low rail − V_f, V_DD + V_f], < 0 outside.
    pub fn clamp_margin(&self, v_term: f64, i_shunt: f64) -> f64 {
        let (lo, hi) = self.clamps(i_shunt);
        (v_term - lo).min(hi - v_term)
    }

    /// How far an open terminal is outside the diode clamps \[V\]: > 0 above V_DD + V_f,
    /// < 0 below the low rail − V_f, 0 inside.
    pub fn clamp_violation(&self, v_term: f64, i_shunt: f64) -> f64 {
        let (lo, hi) = self.clamps(i_shunt);
        if v_term > hi {
            v_term - hi
        } else if v_term < lo {
            v_term - lo
        } else {
            0.0
        }
    }
}

/// One conduction state's legs decoded for [`Circuit::solve_planned`]: whether each leg
/// conducts, is tied to the low rail, to V_DD, through a diode, and its source (V_src,
/// R_src). Only a state with two or more legs conducting (the neutral shared by them) takes
/// the planned path; the others go through [`Circuit::solve`].
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Plan {
    shared: bool,
    /// The open leg's index, 3 with none (with `shared`, at most one leg is open).
    open: usize,
    n_c: f64,
    on: [bool; 3],
    low: [bool; 3],
    high: [bool; 3],
    diode: [bool; 3],
    vs: [f64; 3],
    rs: [f64; 3],
}

#[cfg(test)]
mod tests {
    use super::*;
    use drive_core::{Gates, Phase};

    fn circuit() -> Circuit {
        Circuit::new(&MotorParams::default(), &PowerStageParams::default())
    }

    /// A fixed pseudo-random sequence of signed values from `seed` (xorshift64*): each call
    /// `draw(scale)` is uniform in (−scale, scale), and every eighth value a signed zero.
    fn draws(mut seed: u64) -> impl FnMut(f64) -> f64 {
        move |scale| {
            seed ^= seed >> 12;
            seed ^= seed << 25;
            seed ^= seed >> 27;
            let r = seed.wrapping_mul(0x2545_f491_4f6c_dd1d);
            match r % 8 {
                0 => 0.0,
                1 => -0.0,
                _ => scale * ((r >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0),
            }
        }
    }

    /// The planned solves against `Circuit::solve` bit for bit, in every conduction state:
    /// with the losses, and without them then made by `with_losses`. Currents and
    /// back-EMFs from a fixed pseudo-random sequence, with signed zeros among them.
    #[test]
    fn planned_solves_equal_the_full_solve_bit_for_bit() {
        let c = circuit();
        let mut draw = draws(0x9e37_79b9_7f4a_7c15);
        let bits = |s: &Solution| -> Vec<u64> {
            let p = &s.powers;
            let mut v: Vec<u64> = [s.v_n, s.i_shunt, p.supply, p.copper, p.switch]
                .into_iter()
                .chain([p.diode, p.shunt, p.airgap])
                .map(f64::to_bits)
                .collect();
            for a in [s.di, s.v_term] {
                v.extend(a.to_array().map(f64::to_bits));
            }
            v
        };
        for k in 0..STATES {
            let modes = state_at(k);
            let plan = c.plan(&modes);
            for _ in 0..200 {
                let i = Abc::from_fn(|_| draw(5.0));
                let e = Abc::from_fn(|_| draw(15.0));
                let full = c.solve(&modes, &i, &e);
                let planned = c.solve_planned(&plan, &modes, &i, &e);
                assert_eq!(
                    bits(&planned),
                    bits(&full),
                    "state {k}: {modes:?} i {i:?} e {e:?}"
                );
                let mut into = Solution::default();
                c.solve_planned_into(&plan, &modes, &i, &e, &mut into);
                assert_eq!(
                    bits(&into),
                    bits(&full),
                    "state {k}: {modes:?} i {i:?} e {e:?}"
                );
                let mut later = c.solve_planned_losses_later(&plan, &modes, &i, &e);
                if !later.powers.has_losses() {
                    later.powers = c.with_losses(&plan, &i, &later);
                }
                assert_eq!(
                    bits(&later),
                    bits(&full),
                    "state {k}: {modes:?} i {i:?} e {e:?}"
                );
            }
        }
    }

    /// The modal step's powers (`Linearised::drawn`, two sets of currents at once) against
    /// `Linearised::powers` bit for bit in every conduction state, with signed zeros among
    /// the currents; the airgap power is not made there.
    #[test]
    fn drawn_powers_equal_the_full_powers_bit_for_bit() {
        let c = circuit();
        let mut draw = draws(0x2545_f491_4f6c_dd1d);
        let bits = |p: &Powers| [p.supply, p.copper, p.switch, p.diode, p.shunt].map(f64::to_bits);
        for k in 0..STATES {
            let lin = c.linearise(&state_at(k));
            for _ in 0..100 {
                let (a, b): ([f64; 3], [f64; 3]) = (
                    std::array::from_fn(|_| draw(5.0)),
                    std::array::from_fn(|_| draw(5.0)),
                );
                let (pa, pb) = lin.drawn(&a, &b);
                assert_eq!(
                    bits(&pa),
                    bits(&lin.powers(&a, &[0.0; 3])),
                    "state {k}: {a:?}"
                );
                assert_eq!(
                    bits(&pb),
                    bits(&lin.powers(&b, &[0.0; 3])),
                    "state {k}: {b:?}"
                );
                assert_eq!((pa.airgap, pb.airgap), (0.0, 0.0));
            }
        }
    }

    #[test]
    fn state_indices_round_trip() {
        for k in 0..STATES {
            assert_eq!(state_index(&state_at(k)), k);
        }
    }

    #[test]
    fn the_tables_by_state_index_agree_with_the_states() {
        for (k, &open_legs) in states::OPEN_LEGS.iter().enumerate() {
            let m = state_at(k);
            let open = Phase::ALL
                .iter()
                .map(|&p| u8::from(!m.get(p).conducts()) << p.index())
                .sum::<u8>();
            assert_eq!(open_legs, open, "state {k}");
            assert_eq!(
                low_legs_at(k),
                m.map(Conduction::is_low).to_array(),
                "state {k}"
            );
            assert_eq!(
                Circuit::follows_neutral_at(k),
                Circuit::follows_neutral(&m),
                "state {k}"
            );
        }
    }

    #[test]
    fn two_phase_conduction_splits_supply_symmetrically() {
        let c = circuit();
        let modes = Abc {
            u: Conduction::SwitchHigh,
            v: Conduction::SwitchLow,
            w: Conduction::Open,
        };
        let s = c.solve(&modes, &Abc::splat(0.0), &Abc::splat(0.0));
        // i = 0: v_u = 12, v_v = 0, v_n = 6, di_u = 6/L.
        assert!((s.v_n - 6.0).abs() < 1e-12);
        assert!((s.di.u - 6.0 / 1e-3).abs() < 1e-6);
        assert!((s.di.u + s.di.v).abs() < 1e-9);
        assert!((s.v_term.w - 6.0).abs() < 1e-12);
    }

    #[test]
    fn power_balance_is_algebraic() {
        let c = circuit();
        let modes = Abc {
            u: Conduction::DiodeLow,
            v: Conduction::SwitchLow,
            w: Conduction::SwitchHigh,
        };
        let i = Abc {
            u: 0.3,
            v: -0.5,
            w: 0.2,
        };
        let e = Abc {
            u: 0.4,
            v: -0.1,
            w: -0.3,
        };
        let s = c.solve(&modes, &i, &e);
        let l = MotorParams::default().phase_inductance_h();
        let magnetic = l * (i.u * s.di.u + i.v * s.di.v + i.w * s.di.w);
        let p = s.powers;
        let rhs = p.copper + p.switch + p.diode + p.shunt + p.airgap + magnetic;
        assert!((p.supply - rhs).abs() < 1e-12, "{} vs {}", p.supply, rhs);
    }

    #[test]
    fn the_legs_said_to_follow_the_neutral_do() {
        let c = circuit();
        let i = Abc::splat(0.0);
        let e = Abc {
            u: 0.9,
            v: -0.2,
            w: -0.7,
        };
        for k in 0..STATES {
            let modes = state_at(k);
            let s = c.solve(&modes, &i, &e);
            let follows = Circuit::follows_neutral(&modes);
            let n_c = modes.to_array().iter().filter(|m| m.conducts()).count();
            for p in Phase::ALL {
                let at = (s.v_term.get(p) - s.v_n - e.get(p)).abs() < 1e-12;
                // A lone switched-on leg fixes the neutral at its own terminal less e_x, so
                // it sits there by definition; with these back-EMFs no other driven
                // terminal happens to.
                let m = modes.get(p);
                let pinning = n_c == 1 && m.conducts() && !m.is_diode();
                assert_eq!(follows[p.index()], at && !pinning, "{modes:?}: {p:?}");
            }
        }
    }

    #[test]
    fn linearised_form_matches_the_full_solution() {
        let c = circuit();
        let all = [
            Conduction::SwitchHigh,
            Conduction::SwitchLow,
            Conduction::DiodeHigh,
            Conduction::DiodeLow,
            Conduction::Open,
        ];
        for a in all {
            for b in all {
                for d in all {
                    let modes = Abc { u: a, v: b, w: d };
                    let lin = c.linearise(&modes);
                    let i = Abc {
                        u: 0.31,
                        v: -0.17,
                        w: -0.14,
                    };
                    let i = Abc::from_fn(|p| {
                        if modes.get(p).conducts() {
                            i.get(p)
                        } else {
                            0.0
                        }
                    });
                    let e = Abc {
                        u: 0.9,
                        v: -0.2,
                        w: -0.7,
                    };
                    let full = c.solve(&modes, &i, &e);
                    let (di, p) = lin.eval(&i.to_array(), &e.to_array());
                    for (a, b) in di.iter().zip(full.di.to_array()) {
                        assert!((a - b).abs() < 1e-6, "{modes:?}");
                    }
                    let q = full.powers;
                    for (x, y) in [
                        (p.supply, q.supply),
                        (p.copper, q.copper),
                        (p.switch, q.switch),
                        (p.diode, q.diode),
                        (p.shunt, q.shunt),
                        (p.airgap, q.airgap),
                    ] {
                        assert!((x - y).abs() < 1e-12, "{modes:?}: {p:?} vs {q:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn floating_phase_below_clamp_turns_its_low_diode_on() {
        // High-side chop off-time with u freewheeling, v low, w open and a strongly negative e_w.
        let c = circuit();
        let mut g = Gates::OFF;
        g.low.v = true;
        let i = Abc {
            u: 0.2,
            v: -0.2,
            w: 0.0,
        };
        let e = Abc {
            u: 2.0,
            v: 2.0,
            w: -4.0,
        };
        let (m, _) = c.resolve(&g, &i, &e, None, None);
        assert_eq!(m.u, Conduction::DiodeLow);
        assert_eq!(m.w, Conduction::DiodeLow);
    }
}
