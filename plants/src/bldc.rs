//! The published BLDC motor on a six-switch bridge with shunt and comparator sensing.
//!
//! State: phase currents i_u, i_v, i_w \[A\], mechanical speed ωm [rad/s], electrical angle
//! θe [rad, wrapped to 0..2π], plus energy integrals \[J\] and the torque's ∫Te dt,
//! ∫Te² dt. Between events the conduction topology is constant and each step
//! (≤ `solver.max_step_s`) is integrated with it fixed, in closed form over the network's
//! modes (sinusoidal back-EMF) or by RK4; a diode event ends a step early.
//!
//! One concept a module: the step loop (`step`), one step's integration (`integrate`), the
//! state derivative (`dynamics`), the bridge network (`network`), diode events found after
//! a step (`events`) and predicted before it (`predict`), the step integrated ahead
//! (`lookahead`), what the sensing sees of a step (`knots`), the observations and the
//! energy ledger (`observe`), the state by value (`state`).

use crate::circuit::{self, Circuit, Conduction, Solution};
use crate::load::Load;
use crate::params::{BackEmfShape, PlantParams};
use crate::sensing::{ComparatorBank, CurrentSense};
use drive_core::{Abc, Gates, ParamError, Phase, Plant, PlantStop, Sensed, Ticks, Watch};
use nalgebra::SVector;
use std::f64::consts::TAU;
use std::sync::{Arc, OnceLock};

mod dynamics;
mod events;
mod integrate;
mod knots;
mod lookahead;
mod network;
mod observe;
mod predict;
mod state;
mod step;
#[cfg(test)]
mod testing;

pub use knots::CHORD_S;
use lookahead::Lookahead;
use network::Form;
pub use observe::{EnergyLedger, Observation};

/// State size: currents, speed, angle, then the integrals (see [`INTEGRALS`]).
const N: usize = E_SUPPLY + INTEGRALS;
/// The integrals along the run: the nine energies of [`EnergyLedger`], then ∫Te dt and
/// ∫Te² dt (exact time averages of the torque, whatever the sampling).
const INTEGRALS: usize = 11;
type State = SVector<f64, N>;
const OMEGA: usize = 3;
const THETA: usize = 4;
const E_SUPPLY: usize = 5;
/// The dynamic part of the state (currents, speed, angle): what the derivative depends on.
type Dyn = [f64; E_SUPPLY];

fn dynamic(x: &State) -> Dyn {
    std::array::from_fn(|j| x[j])
}

/// Counters of the work done, for performance figures.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct PlantStats {
    /// Integration steps committed.
    pub steps: u64,
    /// Diode events located.
    pub diode_events: u64,
    /// Extra work: steps spent locating clamp events, and steps integrated ahead that
    /// were cut short because the dynamics changed inside them.
    pub retries: u64,
}

/// Motor + bridge + sensing. Build with [`BldcPlant::new`].
#[derive(Clone, Debug)]
pub struct BldcPlant {
    params: PlantParams,
    circuit: Circuit,
    shape: BackEmfShape,
    pp: f64,
    lambda: f64,
    /// J + J_L \[kg·m²\].
    inertia: f64,
    /// 1/(J + J_L) and 1/ω_c: the derivative multiplies rather than divides.
    inv_inertia: f64,
    inv_coulomb_speed: f64,
    friction: f64,
    coulomb: f64,
    inductance: f64,
    h_max: f64,
    x: State,
    t: f64,
    /// The first tick at or after `t`, and whether `t` is on it: asked for several times
    /// per step, converted once.
    tick: (Ticks, bool),
    gates: Gates,
    modes: Abc<Conduction>,
    load: Load,
    speed_lock: bool,
    /// Network solution at the current time (right after any event): start of the next
    /// sensing segment.
    start: Solution,
    cmp: ComparatorBank,
    cur: CurrentSense,
    same_instant_events: u32,
    /// Phases whose events are ignored for one step (see `finish_step`).
    muted: [bool; 3],
    /// The network's affine and modal forms and plans for the 125 conduction states (each
    /// built when first entered, shared by clones), and the index of the present one.
    forms: Arc<[OnceLock<Form>]>,
    lin: usize,
    /// Whether steps use the modal forms' exact currents (sinusoidal back-EMF) where
    /// they exist, rather than RK4.
    modal: bool,
    /// The step integrated ahead of `t`, if any.
    lookahead: Option<Lookahead>,
    /// An angle near the present one, with its sine and cosine: the present step's start,
    /// or the last committed step's end, from which the angle now is reached by angle
    /// addition (any consistent triple is valid).
    base_hint: (f64, f64, f64),
    /// Set by a restore: the first step checks that the kept solution `start` is the
    /// state's and solves it afresh if not (a forged state that passed every rule), so
    /// that the step's own check never meets a restored inconsistency (derived; not saved).
    verify_start: bool,
    /// Whether the committed state `x` is the last step's end, with neither the state nor
    /// the dynamics changed since (whatever changes either clears it): the next step then
    /// takes the derivative there from that step's own network solution (`start`) and
    /// back-EMF at its end angle (`end_angle`, before θ's wrap), first same as last. It is
    /// made when asked for, not at every step's end: most steps end at a gate change or a
    /// diode event, which re-resolves the network first.
    fsal: bool,
    /// The last committed step's end angle with its sine and cosine (from the step's
    /// rotation): the next step starting at that angle takes them as its base instead of a
    /// fresh `sin_cos`.
    end_angle: Option<(f64, f64, f64)>,
    /// Latest clock edge reported as a sensing stop: changes up to it have been sampled.
    reported: Ticks,
    stats: PlantStats,
}

impl BldcPlant {
    /// A plant at rest (θe = 0, ωm = 0, no current, bridge off) with validated parameters.
    pub fn new(params: PlantParams) -> Result<Self, ParamError> {
        params.validate()?;
        let m = &params.motor;
        let circuit = Circuit::new(m, &params.power_stage);
        let x = State::zeros();
        let e = Abc::splat(0.0);
        let (modes, start) = circuit.resolve(&Gates::OFF, &Abc::splat(0.0), &e, None, None);
        let cmp = ComparatorBank::new(
            &params.sensing.comparator,
            params.sensing.seed,
            &start.v_term,
            start.v_n,
        );
        let cur = CurrentSense::new(
            &params.sensing.current,
            params.power_stage.shunt_ohm,
            params.solver.max_step_s,
        );
        Ok(BldcPlant {
            circuit,
            shape: m.back_emf,
            pp: m.pole_pairs(),
            lambda: m.flux_linkage_wb,
            inertia: m.inertia_kgm2,
            inv_inertia: 1.0 / m.inertia_kgm2,
            inv_coulomb_speed: 1.0 / m.coulomb_speed_rad_s,
            friction: m.viscous_friction_nms,
            coulomb: m.coulomb_friction_nm,
            inductance: m.phase_inductance_h(),
            h_max: params.solver.max_step_s,
            x,
            t: 0.0,
            tick: (Ticks::ZERO, true),
            gates: Gates::OFF,
            modes,
            load: Load::default(),
            speed_lock: false,
            start,
            cmp,
            cur,
            same_instant_events: 0,
            muted: [false; 3],
            forms: (0..circuit::STATES).map(|_| OnceLock::new()).collect(),
            lin: circuit::state_index(&modes),
            modal: matches!(m.back_emf, BackEmfShape::Sinusoidal),
            reported: Ticks::ZERO,
            lookahead: None,
            base_hint: (0.0, 0.0, 1.0),
            verify_start: false,
            fsal: false,
            end_angle: None,
            stats: PlantStats::default(),
            params,
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &PlantParams {
        &self.params
    }

    /// Sets the active load torque T_a [N·m] (opposing positive rotation) from now on,
    /// keeping the rest of the load; a non-finite value counts as 0.
    pub fn set_load_torque(&mut self, nm: f64) {
        let nm = if nm.is_finite() { nm } else { 0.0 };
        self.set_load(Load {
            active_nm: nm,
            ..self.load
        });
    }

    /// Sets the whole load from now on (validate it first: see [`Load::validate`]). A
    /// change of J_L keeps the speed (a clutch that couples instantly would not); the
    /// kinetic energy in [`EnergyLedger`] counts the inertia in force.
    pub fn set_load(&mut self, load: Load) {
        self.settle();
        self.fsal = false;
        self.load = load;
        self.inertia = self.params.motor.inertia_kgm2 + load.inertia_kgm2;
        self.inv_inertia = 1.0 / self.inertia;
    }

    /// The load in force.
    pub fn load(&self) -> &Load {
        &self.load
    }

    /// Sets the supply V_DD \[V\] from now on (a sag, a ripple, a battery discharging);
    /// validated by `power_stage.supply_v`'s rule. The network's forms are rebuilt, so a
    /// change costs a few microseconds of wall time per conduction state then entered.
    pub fn set_supply_v(&mut self, v: f64) -> Result<(), ParamError> {
        let mut stage = self.params.power_stage.clone();
        stage.supply_v = v;
        stage.validate()?;
        if v == self.params.power_stage.supply_v {
            return Ok(());
        }
        self.settle();
        self.params.power_stage = stage;
        self.circuit = Circuit::new(&self.params.motor, &self.params.power_stage);
        self.forms = (0..circuit::STATES).map(|_| OnceLock::new()).collect();
        self.refresh_start();
        Ok(())
    }

    /// Sets rotor angle θe \[rad\] and speed \[rpm\]; `lock` holds the speed constant from now on
    /// (a dynamometer), otherwise the rotor is free. A speed up to the motor's no-load
    /// speed at the largest supply the rules allow, [`crate::params::MAX_SUPPLY_V`]/((P/2)·λr)
    /// (2.1e6 rpm for the built-in motor), is one a state restores with: beyond it, what
    /// the largest torques add since t = 0 is all a restored speed may exceed it by. The comparators start afresh, settled
    /// on the terminals of the new state (a rotor that jumps has no filter history): their
    /// toggle history and work counters restart from zero.
    pub fn set_rotor(&mut self, theta_e: f64, speed_rpm: f64, lock: bool) {
        self.settle();
        self.x[THETA] = wrap_angle(theta_e);
        self.x[OMEGA] = speed_rpm * TAU / 60.0;
        self.speed_lock = lock;
        self.refresh_start();
        let (v, vn) = (self.start.v_term, self.start.v_n);
        self.cmp = ComparatorBank::new(
            &self.params.sensing.comparator,
            self.params.sensing.seed,
            &v,
            vn,
        );
    }

    /// The fastest rotor a state at the present time may hold \[rpm\]: the no-load speed
    /// at the largest supply the rules allow, and what the largest torques add since
    /// t = 0 (see [`BldcPlant::set_rotor`]); a restored state beyond it is refused.
    pub fn max_speed_rpm(&self) -> f64 {
        self.bounds(self.t).speed * 60.0 / TAU
    }

    /// Work counters.
    pub fn stats(&self) -> PlantStats {
        self.stats
    }

    /// Comparator toggles found so far (see [`ComparatorBank::toggle_count`]).
    pub fn comparator_toggles(&self) -> u64 {
        self.cmp.toggle_count()
    }

    /// The comparator bank (filters, outputs).
    pub fn comparators(&self) -> &ComparatorBank {
        &self.cmp
    }

    /// The current-sense chain.
    pub fn current_sense(&self) -> &CurrentSense {
        &self.cur
    }
}

impl Plant for BldcPlant {
    fn time_s(&self) -> f64 {
        self.t
    }

    fn set_gates(&mut self, gates: &Gates) {
        self.settle();
        let before = self.start.v_term;
        // Which legs switch, found before the re-resolve so the old gates need not outlive it.
        let old = &self.gates;
        let switched = Abc::from_fn(|p| {
            old.high.get(p) != gates.high.get(p) || old.low.get(p) != gates.low.get(p)
        });
        self.gates = *gates;
        self.refresh_start();
        // Ringing is excited by the largest switching-node step among the legs that switched.
        let mut dv: f64 = 0.0;
        for p in Phase::ALL {
            if switched.get(p) {
                let d = self.start.v_term.get(p) - before.get(p);
                if d.abs() > dv.abs() {
                    dv = d;
                }
            }
        }
        self.cmp.excite(self.t, dv);
    }

    fn advance(&mut self, until: Ticks, watch: &Watch) -> PlantStop {
        let watch = *watch;
        self.cmp.declare(self.tick.0, watch.channels, watch.reads);
        // Unwatched comparators are walked only as far as they are read: at the instant
        // returned, and from now on for the channels watched now.
        self.cmp.watch(watch.channels);
        let stop = self.step_to(until, watch);
        self.cmp.catch_up(self.tick.0);
        stop
    }

    fn sensed(&self, at: Ticks) -> Sensed {
        let decided = self.cmp.decided_at(at);
        Sensed::partly(self.cmp.outputs_at(at), decided, self.cur.code_at(at))
    }
}

/// θe wrapped into its canonical range 0..2π, as it is stored. `rem_euclid` of an
/// angle a hair below 0 (a rotor at rest nudged backwards by a load of 1e-12 N·m) rounds
/// to 2π itself: that is the same angle, stored as 0. NaN stays NaN (a run gone
/// non-finite is reported, not hidden).
fn wrap_angle(theta: f64) -> f64 {
    let w = theta.rem_euclid(TAU);
    if w == TAU { 0.0 } else { w }
}

#[cfg(test)]
mod tests {
    use super::*;
    use testing::restored;

    #[test]
    fn angles_are_wrapped_into_0_to_2pi_with_2pi_itself_as_0() {
        assert_eq!(wrap_angle(-1e-300), 0.0);
        assert_eq!(wrap_angle(-f64::MIN_POSITIVE), 0.0);
        assert_eq!(wrap_angle(TAU), 0.0);
        assert_eq!(wrap_angle(TAU + 1.0), 1.0);
        assert_eq!(wrap_angle(-1.0), TAU - 1.0);
        assert!(wrap_angle(f64::NAN).is_nan());
    }

    /// A rotor at rest nudged backwards by a tiny load: θ = 0 − tiny, which `rem_euclid`
    /// rounds to 2π. The plant must save it as 0 and restore its own bytes.
    #[test]
    fn a_rotor_nudged_below_zero_saves_a_state_it_restores() {
        for load in [1e-12, 1e-200, f64::MIN_POSITIVE, 5e-324] {
            let mut pl = BldcPlant::new(PlantParams::default()).unwrap();
            pl.set_load_torque(load);
            let watch = Watch {
                channels: Abc::splat(true),
                reads: Abc::splat(Ticks::ZERO),
                clock: Ticks(32),
                horizon: Ticks::ZERO,
            };
            while pl.advance(Ticks(50), &watch) != PlantStop::Reached {}
            let th = pl.x[THETA];
            assert!((0.0..TAU).contains(&th), "load {load}: θ = {th}");
            if let Err(e) = restored(&pl) {
                panic!("load {load}: its own state refused: {e}");
            }
        }
        let mut pl = BldcPlant::new(PlantParams::default()).unwrap();
        pl.set_rotor(-1e-300, 0.0, false);
        assert_eq!(pl.x[THETA], 0.0);
    }
}
