//! Which legs conduct: the conduction states the gates and the currents give, with the
//! diodes a floating terminal at a clamp switches on.

use super::states::OPEN_LEGS;
use super::{Circuit, Conduction, Solution, state_index};
use drive_core::{Abc, Gates, Phase};

impl Circuit {
    /// Conduction states for `gates` and currents `i`: a switched-on leg conducts; an off
    /// leg with current freewheels through the diode its current direction selects; an
    /// off leg without current is open unless its terminal would leave the clamps, in
    /// which case its diode starts conducting (if the network lets current flow that way).
    ///
    /// `at_clamp` names a phase whose terminal has just been located at a clamp (an event):
    /// its diode is tried whatever the (rounding-size) violation. Elsewhere a violation below
    /// 1 nV is a graze and does not switch a diode on. A diode is accepted only if its current
    /// would grow in its conducting direction, so a terminal resting on a clamp cannot chatter.
    ///
    /// `keep_open` names a phase whose diode was just found not to conduct after all (its
    /// current would reverse at once): it stays open at this instant.
    ///
    /// Also returns the network's solution in the resolved state (it is found on the way).
    pub fn resolve(
        &self,
        gates: &Gates,
        i: &Abc<f64>,
        e: &Abc<f64>,
        at_clamp: Option<Phase>,
        keep_open: Option<Phase>,
    ) -> (Abc<Conduction>, Solution) {
        let mut sol = Solution::default();
        let (modes, _) = self.resolve_with(
            gates,
            i,
            e,
            (at_clamp, keep_open),
            |_, m, out| *out = self.solve(m, i, e),
            &mut sol,
        );
        (modes, sol)
    }

    /// [`Circuit::resolve`] with the network solved in each conduction state tried by
    /// `solve`, which is given the state's [`state_index`] and the state and must write
    /// [`Circuit::solve`]'s solution for currents `i` and back-EMFs `e` to its third
    /// argument (a caller holding [`Plan`](super::Plan)s by index uses `Circuit::solve_planned_into`);
    /// `(at_clamp, keep_open)` as there. The resolved state's solution is written to `sol`
    /// (the caller's own, e.g. a plant's start: a returned solution was moved twice more);
    /// the state is returned with its index.
    pub fn resolve_with(
        &self,
        gates: &Gates,
        i: &Abc<f64>,
        e: &Abc<f64>,
        (at_clamp, keep_open): (Option<Phase>, Option<Phase>),
        solve: impl Fn(usize, &Abc<Conduction>, &mut Solution),
        sol: &mut Solution,
    ) -> (Abc<Conduction>, usize) {
        let mut modes = Abc::from_fn(|p| {
            if gates.high.get(p) {
                Conduction::SwitchHigh
            } else if gates.low.get(p) {
                Conduction::SwitchLow
            } else if i.get(p) > 0.0 {
                Conduction::DiodeLow
            } else if i.get(p) < 0.0 {
                Conduction::DiodeHigh
            } else {
                Conduction::Open
            }
        });
        let mut k = state_index(&modes);
        solve(k, &modes, sol);
        // Only an open leg not kept open may start conducting: the others' terminals need
        // no judging. As a mask of the legs (bit 0 for u), walked in phase order: most
        // re-resolves have one such leg or none.
        let kept = keep_open.map_or(0, |p| 1u8 << p.index());
        let judged = |k: usize| OPEN_LEGS[k] & !kept;
        let mut legs = judged(k);
        if legs == 0 {
            return (modes, k);
        }
        // Most judged legs sit inside the clamps, none located on one: the first round
        // would find nothing to try (a terminal inside, or NaN, violates by 0), so it is
        // not walked. Any other leg goes on to the rounds as before.
        let (lo, hi) = self.clamps(sol.i_shunt);
        let out = |v: f64, p: Phase| u8::from(v > hi || v < lo) << p.index();
        let v = &sol.v_term;
        let suspect = out(v.u, Phase::U)
            | out(v.v, Phase::V)
            | out(v.w, Phase::W)
            | at_clamp.map_or(0, |p| 1u8 << p.index());
        if legs & suspect == 0 {
            return (modes, k);
        }
        for round in 0..3 {
            let mut worst: Option<(Phase, f64)> = None;
            let mut rest = legs;
            while rest != 0 {
                let p = Phase::ALL[rest.trailing_zeros() as usize];
                rest &= rest - 1;
                let mut viol = self.clamp_violation(sol.v_term.get(p), sol.i_shunt);
                if round == 0 && at_clamp == Some(p) && viol.abs() <= 1e-9 {
                    // Located on the clamp: the nearer clamp is the one it reached.
                    let v = sol.v_term.get(p);
                    let (lo, hi) = self.clamps(sol.i_shunt);
                    let mid = 0.5 * (lo + hi);
                    viol = if v < mid { -2e-9 } else { 2e-9 };
                }
                if viol.abs() > 1e-9 && worst.is_none_or(|(_, w)| viol.abs() > w.abs()) {
                    worst = Some((p, viol));
                }
            }
            let Some((p, viol)) = worst else { break };
            let diode = if viol < 0.0 {
                Conduction::DiodeLow
            } else {
                Conduction::DiodeHigh
            };
            let mut trial = modes;
            *trial.get_mut(p) = diode;
            let conducting = Phase::ALL
                .iter()
                .filter(|&&q| trial.get(q).conducts())
                .count();
            if conducting < 2 && !rectifier_pair(e, &modes, keep_open, &mut trial) {
                break;
            }
            let mut s = Solution::default();
            let k_trial = state_index(&trial);
            solve(k_trial, &trial, &mut s);
            let consistent = Phase::ALL
                .iter()
                .all(|&q| match (modes.get(q), trial.get(q)) {
                    (Conduction::Open, Conduction::DiodeLow) => s.di.get(q) > 0.0,
                    (Conduction::Open, Conduction::DiodeHigh) => s.di.get(q) < 0.0,
                    _ => true,
                });
            if !consistent {
                break;
            }
            modes = trial;
            k = k_trial;
            *sol = s;
            legs = judged(k);
        }
        (modes, k)
    }
}

/// The rectifier case of [`Circuit::resolve_with`], where only a diode pair can carry
/// current (|e spread| > V_DD + 2V_f): the pair of the extreme back-EMFs set in `trial`
/// unless either is kept open or conducts in `modes` already (then false). Cold and out of
/// line, so that a common re-resolve does not find the extremes ahead of its loop.
#[cold]
#[inline(never)]
fn rectifier_pair(
    e: &Abc<f64>,
    modes: &Abc<Conduction>,
    keep_open: Option<Phase>,
    trial: &mut Abc<Conduction>,
) -> bool {
    let (hi_p, lo_p) = extreme_phases(e);
    let kept = keep_open == Some(hi_p) || keep_open == Some(lo_p);
    if kept || modes.get(hi_p).conducts() || modes.get(lo_p).conducts() {
        return false;
    }
    *trial.get_mut(hi_p) = Conduction::DiodeHigh;
    *trial.get_mut(lo_p) = Conduction::DiodeLow;
    true
}

fn extreme_phases(e: &Abc<f64>) -> (Phase, Phase) {
    let mut hi = Phase::U;
    let mut lo = Phase::U;
    for p in Phase::ALL {
        if e.get(p) > e.get(hi) {
            hi = p;
        }
        if e.get(p) < e.get(lo) {
            lo = p;
        }
    }
    (hi, lo)
}
