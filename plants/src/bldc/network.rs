//! The bridge network at the plant's state: its forms for each of the 125 conduction
//! states (built when first entered, shared by clones), its solution at a state (di/dt,
//! terminal and neutral voltages, shunt current, powers), and the conduction state
//! re-resolved when the gates change or an event ends a step.

use super::step::ANCHOR;
use super::{BldcPlant, OMEGA, State, THETA};
use crate::circuit::{self, Circuit, Linearised, Plan, Solution};
use crate::emf;
use crate::modal::Modal;
use drive_core::Phase;

/// The network's affine and modal forms for one conduction state, and its legs decoded
/// for the network's solution (see [`Circuit::solve_planned`]).
pub(super) type Form = (Linearised, Option<Modal>, Plan);

/// The forms of the conduction state at index `k` (see [`circuit::state_index`]).
fn form_at(circuit: &Circuit, k: usize) -> Form {
    let modes = circuit::state_at(k);
    let lin = circuit.linearise(&modes);
    (lin, Modal::new(&modes, &lin), circuit.plan(&modes))
}

impl BldcPlant {
    /// Whether the kept network solution `start` is the one the state `x0` (at the angle
    /// `b0`) gives, within 1e-9 (a state gone non-finite has none to compare: NaN ≠ NaN).
    pub(super) fn start_solves(&self, x0: &State, b0: (f64, f64, f64)) -> bool {
        self.solves(x0, b0, &self.start)
    }

    /// Whether `sol` is the network's solution at the state `x` (angle `b`), within 1e-9.
    pub(super) fn solves(&self, x: &State, b: (f64, f64, f64), sol: &Solution) -> bool {
        x.iter().any(|v| !v.is_finite()) || {
            let s = self.solve_near(x, b);
            let (a, b) = (s.di.to_array(), sol.di.to_array());
            (0..3).all(|k| (a[k] - b[k]).abs() <= 1e-9 * (1.0 + a[k].abs()))
                && s.powers.supply == sol.powers.supply
        }
    }

    /// For a restore: the kept solutions are the network's at the states they are kept
    /// for, in every field (see `BldcPlant::solution_differs`): `start` at the committed
    /// state (at the last step's end angle when it carries that step's end derivative,
    /// first same as last), and a step integrated ahead's at its end. `Err` names the
    /// first field that differs.
    pub(crate) fn check_solutions(&self) -> Result<(), String> {
        // A step integrated ahead is committed as it stands: its end solution must be
        // its end state's, as `start` becomes when it is.
        if let Some(la) = &self.lookahead
            && let Some(e) =
                self.solution_differs(&la.x1, (la.x1[THETA], la.sc1.0, la.sc1.1), &la.s1)
        {
            return Err(format!("lookahead.s1.{e}"));
        }
        let x0 = self.x;
        let angle = match self.end_angle {
            Some(e) if self.fsal => e,
            Some(e) if e.0 == x0[THETA] && self.stats.steps % ANCHOR != 0 => e,
            _ => Self::base(&x0),
        };
        match self.solution_differs(&x0, (x0[THETA], angle.1, angle.2), &self.start) {
            Some(_) if self.fsal && self.solution_differs(&x0, angle, &self.start).is_none() => {
                Ok(())
            }
            Some(e) => Err(format!("start.{e}")),
            None => Ok(()),
        }
    }

    /// The network's solution for a state inside the step that starts at `base`.
    pub(super) fn solve_near(&self, x: &State, base: (f64, f64, f64)) -> Solution {
        let f = emf::shape_with(&self.shape, x[THETA], emf::sin_cos_near(x[THETA], base));
        let k = self.lambda * self.pp * x[OMEGA];
        self.circuit.solve_planned_losses_later(
            &self.form().2,
            &self.modes,
            &Self::currents(x),
            &f.map(|v| k * v),
        )
    }

    /// The present conduction state's forms, built on first use: a plant visits a handful
    /// of the 125, and building all would cost as much as milliseconds of simulation.
    pub(super) fn form(&self) -> &Form {
        self.forms[self.lin].get_or_init(|| form_at(&self.circuit, self.lin))
    }

    /// The network's solution at a step's end, whose sin θ and cos θ are `sc`, returned
    /// with it: the derivative follows from them when it is needed (see
    /// [`BldcPlant::end_derivative`]).
    #[inline(always)]
    pub(super) fn solution_at(&self, x: &State, sc: (f64, f64)) -> (Solution, (f64, f64)) {
        let f = emf::shape_with(&self.shape, x[THETA], sc);
        let k = self.lambda * self.pp * x[OMEGA];
        let s = self.circuit.solve_planned_losses_later(
            &self.form().2,
            &self.modes,
            &Self::currents(x),
            &f.map(|v| k * v),
        );
        (s, sc)
    }

    pub(super) fn refresh_start(&mut self) {
        self.refresh_start_at(None, None);
    }

    /// Re-resolves the conduction state after an event (see [`Circuit::resolve`]).
    pub(super) fn refresh_start_at(&mut self, at_clamp: Option<Phase>, keep_open: Option<Phase>) {
        self.fsal = false;
        let (_, e) = self.emf_of(&self.x);
        let i = Self::currents(&self.x);
        (self.modes, self.lin) = self.circuit.resolve_with(
            &self.gates,
            &i,
            &e,
            (at_clamp, keep_open),
            |k, m, out| {
                let plan = &self.forms[k].get_or_init(|| form_at(&self.circuit, k)).2;
                self.circuit.solve_planned_into(plan, m, &i, &e, out)
            },
            &mut self.start,
        );
    }
}
