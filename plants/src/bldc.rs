//! The published BLDC motor on a six-switch bridge with shunt and comparator sensing.
//!
//! State: phase currents i_u, i_v, i_w \[A\], mechanical speed ωm [rad/s], electrical angle
//! θe [rad, wrapped to 0..2π], plus energy integrals \[J\] and the torque's ∫Te dt,
//! ∫Te² dt. Between events the conduction topology is constant and each step
//! (≤ `solver.max_step_s`) is integrated: with the sinusoidal back-EMF the currents follow
//! the topology's modal form in closed form (see [`crate::modal`]; exact but for the
//! speed's change within the step, taken to first order), and speed, angle and the
//! integrals take RK4's weights on those currents; the other shapes use classical RK4
//! throughout.
//!
//! Mechanics: (J + J_L)·dωm/dt = Te − Bm·ωm − Tc·tanh(ωm/ω0) − TL(ωm), dθe/dt = (P/2)·ωm,
//! with the driven machine's torque TL and inertia J_L from [`Load`],
//! Te = (P/2)·λr·Σ i_x·f(θx) so that Te·ωm = Σ e_x·i_x exactly.
//!
//! Events located in time (Illinois regula falsi on the step's solution, to 0.1 ns): a freewheeling
//! diode's current reaching zero (the current is then set to exactly zero and the phase
//! floats), and an open terminal reaching a diode clamp (the diode starts conducting).
//! A freewheeling current whose tangent reaches zero within a step is located before the
//! step, on its modal response (Newton's method), and the step is integrated to that zero
//! alone rather than past it.

use crate::circuit::{self, Circuit, Conduction, Linearised, Plan, Powers, Solution};
use crate::emf;
use crate::load::Load;
use crate::modal::{Forcing, Modal, Response};
use crate::params::{BackEmfShape, PlantParams};
use crate::sensing::{ComparatorBank, CurrentSense, Knot};
use drive_core::{Abc, Gates, ParamError, Phase, Plant, PlantStop, Sensed, Ticks, Watch};
use nalgebra::SVector;
use std::f64::consts::TAU;
use std::sync::{Arc, OnceLock};

mod state;

/// The longest step over which the comparators see a floating terminal's back-EMF along
/// its chord \[s\]. Near a crossing the chord is off by at most E·ωe³·h³/8, a move of
/// ωe²·h³/4 (21 ticks at 8000 rpm, the bound `tests/step_fidelity.rs` allows; it measures
/// a tick at most, since the sine's curvature vanishes at its crossing). Longer steps add the
/// back-EMF's curvature (see [`Knot`]), which costs a few hundred instructions a step.
pub const CHORD_S: f64 = 40e-6;

/// A freewheeling current this close to zero \[A\] at the dense output's guess of its zero
/// is taken there by one Newton step along the state's derivative, x + f·dh, rather than a
/// new step from the start, where that errs by less than [`SHORTCUT_ERR_A`].
const NEAR_ZERO_A: f64 = 1e-6;
/// The most the one-step shortcut to a current's zero may err, ½·dh²·|d²i/dt²| \[A\]:
/// three orders below the 1e-9 A the search accepts.
const SHORTCUT_ERR_A: f64 = 1e-12;

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

/// Energies integrated along the run \[J\].
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct EnergyLedger {
    /// Drawn from V_DD (negative when regenerating).
    pub supply: f64,
    /// Winding copper loss.
    pub copper: f64,
    /// Switch conduction loss.
    pub switch: f64,
    /// Diode loss.
    pub diode: f64,
    /// Shunt loss.
    pub shunt: f64,
    /// Friction loss ∫(Bm·ωm + Tc·tanh(ωm/ω0))·ωm.
    pub friction: f64,
    /// Work done on the load ∫TL·ωm.
    pub load: f64,
    /// Electromechanical conversion ∫Σe·i.
    pub airgap: f64,
    /// Absorbed by the dynamometer holding a speed-locked rotor ∫(Te − friction − TL)·ωm.
    pub dynamometer: f64,
    /// Magnetic energy stored now: ½(Lp + M)·Σi².
    pub magnetic: f64,
    /// Kinetic energy now: ½J·ωm².
    pub kinetic: f64,
}

/// A snapshot of the true plant signals (for traces and tests).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Observation {
    /// Time \[s\].
    pub t_s: f64,
    /// Electrical angle θe \[rad\], 0..2π, with e_u = λr·ωe·sin θe for the sinusoidal shape.
    pub theta_e: f64,
    /// Mechanical speed [rad/s].
    pub omega_m: f64,
    /// Mechanical speed \[rpm\].
    pub speed_rpm: f64,
    /// Phase currents into the windings \[A\].
    pub i: Abc<f64>,
    /// Terminal voltages to ground \[V\].
    pub v_term: Abc<f64>,
    /// Neutral voltage to ground \[V\].
    pub v_n: f64,
    /// Back-EMFs \[V\].
    pub emf: Abc<f64>,
    /// Electromagnetic torque [N·m].
    pub torque_nm: f64,
    /// Conduction state of each leg.
    pub conduction: Abc<Conduction>,
    /// Shunt current, positive to ground \[A\].
    pub i_shunt: f64,
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

/// Cubic Hermite interpolation of one step (states and derivatives at both ends), used
/// to find where a freewheeling current crosses zero. It borrows the step's states: a
/// copy of four states per step costs more than the search usually does. Of the end's
/// derivative it takes the currents' alone (the network's di/dt there), which is all the
/// search interpolates.
struct Dense<'a> {
    x0: &'a State,
    f0: &'a State,
    x1: &'a State,
    di1: [f64; 3],
    h: f64,
}

impl Dense<'_> {
    /// Current `k` (0..3) of the interpolated state at fraction `s` ∈ [0, 1] of the step.
    fn component(&self, k: usize, s: f64) -> f64 {
        let (s2, s3) = (s * s, s * s * s);
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = (s3 - 2.0 * s2 + s) * self.h;
        let h01 = 3.0 * s2 - 2.0 * s3;
        let h11 = (s3 - s2) * self.h;
        self.x0[k] * h00 + self.f0[k] * h10 + self.x1[k] * h01 + self.di1[k] * h11
    }
}

/// A step integrated beyond the reported time, up to the next known gate change. Instants
/// inside it (controller ticks, watched comparator changes, trace samples: they usually
/// change nothing in the drive) are served by a step from the step's start, so the trajectory
/// does not depend on how often anyone looks; when something changes the dynamics, the
/// plant settles at the present time.
#[derive(Clone, Debug)]
struct Lookahead {
    /// The state the step starts from, and the derivative there.
    x0: State,
    f0: State,
    /// The step's starting angle with its sine and cosine.
    base: (f64, f64, f64),
    t0: f64,
    t1: f64,
    x1: State,
    s1: Solution,
    /// sin θ, cos θ at the end (see `BldcPlant::end_angle`); with `s1` they make the
    /// derivative there when it is needed (see `BldcPlant::fsal`).
    sc1: (f64, f64),
    event: Option<Phase>,
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

    fn currents(x: &State) -> Abc<f64> {
        Abc {
            u: x[0],
            v: x[1],
            w: x[2],
        }
    }

    /// The back-EMF shape values and the back-EMFs \[V\] at `x`; inlined, so a caller
    /// that takes the back-EMFs alone does not make the shape's values.
    #[inline(always)]
    fn emf_of(&self, x: &State) -> (Abc<f64>, Abc<f64>) {
        let sc = emf::sin_cos_near(x[THETA], self.base_hint);
        let f = emf::shape_with(&self.shape, x[THETA], sc);
        let k = self.lambda * self.pp * x[OMEGA];
        (f, f.map(|v| k * v))
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

    /// The angle, sine and cosine a step starts from: every evaluation inside the step
    /// reaches its own angle from them by angle addition (see [`emf::sin_cos_near`]).
    fn base(x: &State) -> (f64, f64, f64) {
        let (s, c) = x[THETA].sin_cos();
        (x[THETA], s, c)
    }

    /// The network's solution for a state inside the step that starts at `base`.
    /// Whether the kept network solution `start` is the one the state `x0` (at the angle
    /// `b0`) gives, within 1e-9 (a state gone non-finite has none to compare: NaN ≠ NaN).
    fn start_solves(&self, x0: &State, b0: (f64, f64, f64)) -> bool {
        self.solves(x0, b0, &self.start)
    }

    /// Whether `sol` is the network's solution at the state `x` (angle `b`), within 1e-9.
    fn solves(&self, x: &State, b: (f64, f64, f64), sol: &Solution) -> bool {
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

    fn solve_near(&self, x: &State, base: (f64, f64, f64)) -> Solution {
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
    fn form(&self) -> &Form {
        self.forms[self.lin].get_or_init(|| form_at(&self.circuit, self.lin))
    }

    /// The state derivative at a state whose dynamic part (currents, speed, angle) is `x`:
    /// nothing depends on the energy integrals, so RK4's stages carry only that part.
    fn deriv(&self, x: &Dyn, base: (f64, f64, f64)) -> State {
        let f = emf::shape_with(&self.shape, x[THETA], emf::sin_cos_near(x[THETA], base));
        let k = self.lambda * self.pp * x[OMEGA];
        let e = [k * f.u, k * f.v, k * f.w];
        let (di, p) = self.form().0.eval(&[x[0], x[1], x[2]], &e);
        self.assemble(x, &f, di, &p)
    }

    /// The network's solution at a step's end, whose sin θ and cos θ are `sc`, returned
    /// with it: the derivative follows from them when it is needed (see
    /// [`BldcPlant::end_derivative`]).
    #[inline(always)]
    fn solution_at(&self, x: &State, sc: (f64, f64)) -> (Solution, (f64, f64)) {
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

    /// The state derivative at `x`, whose network solution is `s` and whose angle with its
    /// sine and cosine is `(θ, sin θ, cos θ)`: the solution's di/dt and powers make it, so
    /// the back-EMF and the network are not evaluated again (the losses, where the planned
    /// solve left them out, from the currents alone).
    #[inline(always)]
    fn end_derivative(&self, x: &State, s: &Solution, (th, sn, cs): (f64, f64, f64)) -> State {
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

    /// The state a step of length `h` from `x` reaches, given the derivative there, `k1`;
    /// `base` holds an angle near x's with its sine and cosine (every angle inside the
    /// step is reached from it by angle addition). The modal form's exact currents where
    /// there is one (sinusoidal back-EMF), else RK4.
    #[inline]
    fn integrate_from(&self, x: &State, h: f64, base: (f64, f64, f64), k1: &State) -> State {
        self.integrate_end(x, h, base, k1).0
    }

    /// [`BldcPlant::integrate_from`], with an angle near the end's with its sine and cosine:
    /// the modal response's own angle there (see [`BldcPlant::flow_with`]), else the end's
    /// own angle, rotated to from `base` by the full series of [`emf::sin_cos_near`] (so
    /// that [`emf::sin_cos_close`] takes it as it is, not by its second-order rotation
    /// from the step's start).
    fn integrate_end(
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
    fn flow_built(
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
    fn forcing(&self, x: &State, h: f64, k1: &State, sc0: (f64, f64)) -> Forcing {
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

    /// dα/dt [rad/s³] at state `x` (its angle's sine and cosine given) with derivative
    /// `k1`: the torque's rate of change (currents and angle moving) less the friction's,
    /// over J; zero when locked.
    fn jerk(&self, x: &State, k1: &State, (s, c): (f64, f64)) -> f64 {
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
    fn stage_rates(&self, p: &Powers, te: f64, wm: f64, airgap: f64) -> ([f64; INTEGRALS], f64) {
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

    /// One RK4 step from `x` with the derivative there, `k1`, known.
    fn rk4_from(&self, x: &State, h: f64, base: (f64, f64, f64), k1: &State) -> State {
        let stage = |k: &State, a: f64| -> Dyn { std::array::from_fn(|j| x[j] + k[j] * a) };
        let k2 = self.deriv(&stage(k1, 0.5 * h), base);
        let k3 = self.deriv(&stage(&k2, 0.5 * h), base);
        let k4 = self.deriv(&stage(&k3, h), base);
        x + (k1 + (k2 + k3) * 2.0 + k4) * (h / 6.0)
    }

    /// Per-phase event functions: ≥ 0 while nothing happens, < 0 once a diode current has
    /// crossed zero or an open terminal has left the clamps.
    fn event_margin(&self, x: &State, s: &Solution, p: Phase) -> f64 {
        match self.modes.get(p) {
            Conduction::DiodeLow => x[p.index()],
            Conduction::DiodeHigh => -x[p.index()],
            Conduction::Open => self.circuit.clamp_margin(s.v_term.get(p), s.i_shunt),
            _ => f64::INFINITY,
        }
    }

    /// The phases whose event function went negative over the step from `x0` to `x`. An
    /// open terminal already outside the clamps at the start (the network refused the
    /// diode) is not an event.
    fn triggered(&self, x0: &State, x: &State, s: &Solution) -> [bool; 3] {
        Phase::ALL.map(|p| {
            self.event_margin(x, s, p) < 0.0
                && (self.modes.get(p) != Conduction::Open
                    || self.event_margin(x0, &self.start, p) >= 0.0)
        })
    }

    /// Where a freewheeling diode's current crosses zero inside a step, from the step's
    /// cubic Hermite dense output (fourth-order accurate, like the step itself). Returns the
    /// fraction of the step.
    fn locate_diode(&self, d: &Dense, p: Phase) -> f64 {
        let k = p.index();
        let sign = if self.modes.get(p) == Conduction::DiodeLow {
            1.0
        } else {
            -1.0
        };
        let g = |s: f64| sign * d.component(k, s);
        let (mut a, mut b) = (0.0, 1.0);
        if g(0.0) < 0.0 {
            return 0.0;
        }
        if g(0.0) == 0.0 {
            // Switched on at zero current: the pulse may rise and end inside the step.
            match (1..=32).map(|k| k as f64 / 32.0).find(|&s| g(s) > 0.0) {
                Some(s) => a = s,
                None => return 0.0,
            }
        }
        // Regula falsi with the Illinois weighting: superlinear on the smooth cubic, and
        // the bracket keeps the answer on the side where the current has crossed.
        let (mut ga, mut gb) = (g(a), g(b));
        let mut side = 0i8;
        for _ in 0..60 {
            if b - a < 1e-14 || gb >= 0.0 {
                break;
            }
            let m = (a - ga * (b - a) / (gb - ga)).clamp(a, b);
            let gm = g(m);
            if gm > 0.0 {
                (a, ga) = (m, gm);
                if side == 1 {
                    gb *= 0.5;
                }
                side = 1;
            } else {
                (b, gb) = (m, gm);
                if gm == 0.0 {
                    break;
                }
                if side == -1 {
                    ga *= 0.5;
                }
                side = -1;
            }
        }
        b
    }

    /// Earliest h in (0, h_full] where phase p's event function reaches zero, for the
    /// step from `x0` (angle base `base`) whose derivative there is `k1`.
    fn locate(
        &mut self,
        x0: &State,
        k1: State,
        h_full: f64,
        p: Phase,
        base: (f64, f64, f64),
    ) -> f64 {
        let g = |pl: &Self, h: f64| {
            let x = pl.integrate_from(x0, h, base, &k1);
            let s = pl.solve_near(&x, base);
            pl.event_margin(&x, &s, p)
        };
        let (mut a, mut fa) = (0.0, self.event_margin(x0, &self.start, p));
        let (mut b, mut fb) = (h_full, g(self, h_full));
        if fa < 0.0 {
            return 0.0;
        }
        if fa == 0.0 {
            // Starting exactly on the boundary: find where the step first moves inside.
            match (1..8)
                .map(|k| k as f64 * h_full / 8.0)
                .map(|h| (h, g(self, h)))
                .find(|&(_, v)| v > 0.0)
            {
                Some((h, v)) => (a, fa) = (h, v),
                None => return 0.0,
            }
        }
        let mut side = 0i8;
        for _ in 0..60 {
            if b - a < 1e-10 {
                break;
            }
            let c = (b - fb * (b - a) / (fb - fa)).clamp(a + 0.01 * (b - a), b - 0.01 * (b - a));
            let fc = g(self, c);
            self.stats.retries += 1;
            if fc <= 0.0 {
                (b, fb) = (c, fc);
                if fc > -1e-12 {
                    break; // close enough: the state is snapped exactly at the event anyway
                }
                if side == -1 {
                    fa *= 0.5;
                }
                side = -1;
            } else {
                (a, fa) = (c, fc);
                if side == 1 {
                    fb *= 0.5;
                }
                side = 1;
            }
        }
        b
    }

    /// The earliest event of the step `d` (network `s1` at its end, angle base `b0`): its
    /// step length, phase, and the state there when already known. Besides event
    /// functions negative at the end, a freewheeling current that crosses zero and turns
    /// back inside the step is found from the step's cubic Hermite interpolant.
    fn first_event(
        &mut self,
        d: &Dense,
        s1: &Solution,
        b0: (f64, f64, f64),
    ) -> Option<(f64, Phase, Option<State>)> {
        let (x0, x1, h_full) = (d.x0, d.x1, d.h);
        let mut hit = self.triggered(x0, x1, s1);
        for (h, m) in hit.iter_mut().zip(self.muted) {
            *h &= !m;
        }
        let diode_left = Phase::ALL
            .into_iter()
            .any(|p| self.modes.get(p).is_diode() && !hit[p.index()] && !self.muted[p.index()]);
        if !hit.contains(&true) && !diode_left {
            return None;
        }
        // Freewheeling currents that cross zero inside the step but not at its end: the
        // step up to where the interpolant is most negative brackets the crossing.
        let mut bracket = [h_full; 3];
        for p in Phase::ALL {
            let k = p.index();
            if hit[k] || self.muted[k] || !self.modes.get(p).is_diode() {
                continue;
            }
            if let Some(s) = self.interior_reversal(d, p) {
                let h = s * h_full;
                let x = self.integrate_from(x0, h, b0, d.f0);
                if self.event_margin(&x, &self.start, p) < 0.0 {
                    hit[k] = true;
                    bracket[k] = h;
                }
            }
        }
        // Locate every event of the step and keep the earliest.
        let mut first: Option<(f64, Phase, Option<State>)> = None;
        for p in Phase::ALL.into_iter().filter(|p| hit[p.index()]) {
            let k = p.index();
            let mut at = None;
            let h = if self.modes.get(p).is_diode() && bracket[k] == h_full {
                // The dense output's root is usually exact enough; where the current
                // approaches zero slowly it is not, and the step's solution decides.
                let mut h = self.locate_diode(d, p) * h_full;
                let mut done = false;
                for _ in 0..3 {
                    // Newton on the step's solution itself, from the dense guess.
                    let x = self.integrate_from(x0, h, b0, d.f0);
                    if x[k].abs() < 1e-9 {
                        done = true;
                        at = Some(x);
                        break;
                    }
                    let f = self.deriv(&dynamic(&x), b0);
                    if f[k] == 0.0 {
                        break;
                    }
                    let dh = -x[k] / f[k];
                    // The first-order state's error, ½·dh²·|d²i/dt²|, with the current's
                    // curvature taken from its slopes at the step's start and here, h apart
                    // (h = 0 gives no finite estimate, and the loop goes on).
                    let curl = 0.5 * dh * dh * (f[k] - d.f0[k]).abs() / h;
                    if x[k].abs() < NEAR_ZERO_A
                        && curl < SHORTCUT_ERR_A
                        && (0.0..=h_full).contains(&(h + dh))
                    {
                        // So close that the state there is x + f·dh: no second step from x0.
                        done = true;
                        at = Some(x + f * dh);
                        h += dh;
                        break;
                    }
                    h = (h + dh).clamp(0.0, h_full);
                }
                if done {
                    h
                } else {
                    self.locate(x0, *d.f0, h_full, p, b0)
                }
            } else {
                self.locate(x0, *d.f0, bracket[k], p, b0)
            };
            if first.is_none_or(|(h0, _, _)| h < h0) {
                first = Some((h, p, at));
            }
        }
        first
    }

    /// The freewheeling phase whose diode event may end the step of `h` from `x0`
    /// (derivative `f0`): only the phase whose current's tangent reaches zero first within
    /// the step is tried (a freewheeling current's fall slows as its resistive drop fades,
    /// so the tangent reaches zero first); an event the prediction misses is found after
    /// the step as before.
    #[inline(always)]
    fn diode_candidate(&self, x0: &State, f0: &State, h: f64) -> Option<Phase> {
        let mut first: Option<(f64, Phase)> = None;
        for p in Phase::ALL {
            let k = p.index();
            let sign = match self.modes.get(p) {
                Conduction::DiodeLow => 1.0,
                Conduction::DiodeHigh => -1.0,
                _ => continue,
            };
            // The current, conducting (y0 > 0), and its slope g0 \[A, A/s\]: y0 < −g0·h
            // also means g0 < 0.
            let (y0, g0) = (sign * x0[k], sign * f0[k]);
            if !self.muted[k] && y0 > 0.0 && y0 < -g0 * h {
                let t = y0 / -g0;
                if first.is_none_or(|(t1, _)| t < t1) {
                    first = Some((t, p));
                }
            }
        }
        first.map(|(_, p)| p)
    }

    /// The modal response of the whole step of `h` from `x0` (derivative `f0`, angle base
    /// `base`), if there is a modal form. A step of any length within it follows the same
    /// back-EMF to first order in the angle's lead (see [`Forcing`]), so the step to a
    /// predicted diode event is integrated on it too.
    #[inline(always)]
    fn step_response(
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

    /// Where freewheeling phase `p`'s current (`i0` \[A\] at the start) reaches zero on
    /// the step's response `b` within the step of `h` \[s\]: a diode event predicted before
    /// the step is integrated, so that it is not integrated past it. `None` where that
    /// zero or the iteration leaves the step.
    /// Out of line: inlined into the step loop it measured worse.
    #[inline(never)]
    fn diode_zero(b: &StepResponse, i0: f64, p: Phase, h: f64) -> Option<f64> {
        Self::newton_zero(b.md, &b.rsp, i0, p.index(), b.sc0, b.omega_e, h)
    }

    /// The zero of phase `k`'s current on `rsp` (starting at `i0` \[A\], sin θ and cos θ
    /// `sc0`, the forcing's Ω `omega_e` [rad/s]) within a step of `h` \[s\], by Newton's
    /// method from the zero of its quadratic Taylor polynomial at the start.
    #[inline(always)]
    fn newton_zero(
        md: &Modal,
        rsp: &Response,
        i0: f64,
        k: usize,
        sc0: (f64, f64),
        omega_e: f64,
        h: f64,
    ) -> Option<f64> {
        // The zero of i0 + g·t + a·t²/2, the nearer root in its stable form.
        let (g, a) = rsp.start_rates(k, sc0, omega_e);
        let disc = g * g - 2.0 * a * i0;
        let mut t = 2.0 * i0 / (-g + g.signum() * -disc.sqrt());
        let mut last = (0.0, g);
        for _ in 0..8 {
            if !(0.0..=h).contains(&t) {
                return None; // beyond the step (or NaN): the step as usual
            }
            let (rs, rc) = emf::rotation(omega_e * t);
            let sc = (sc0.0 * rc + sc0.1 * rs, sc0.1 * rc - sc0.0 * rs);
            let (i, di) = rsp.current_and_rate(k, t, sc, omega_e, md.decays(t));
            // The curvature [A/s²]: the mean since the last iterate, at least the start's.
            // By the start's alone, a current that dips towards zero where it bends harder
            // and turns back unreversed could pass for a zero. (f64::max drops the NaN of
            // t = last.0; an infinite one stops nothing, and the search gives up.)
            let curv = a.abs().max(((di - last.1) / (t - last.0)).abs());
            last = (t, di);
            let dt = i / di;
            t -= dt;
            // Newton's error after this correction, ≈ curv·dt²/2 in current \[A\]: far
            // below the 1e-9 A the step's end must meet.
            if 0.5 * curv * dt * dt < 1e-12 {
                return (0.0..=h).contains(&t).then_some(t);
            }
        }
        None
    }

    /// Where the interpolated current of freewheeling phase `p` is most reversed inside
    /// the step (fraction of the step), if it reverses there while both ends conduct.
    fn interior_reversal(&self, d: &Dense, p: Phase) -> Option<f64> {
        let k = p.index();
        let sign = if self.modes.get(p) == Conduction::DiodeLow {
            1.0
        } else {
            -1.0
        };
        let (y0, y1) = (sign * d.x0[k], sign * d.x1[k]);
        if y0 <= 0.0 || y1 < 0.0 {
            return None;
        }
        let (g0, g1) = (sign * d.f0[k] * d.h, sign * d.di1[k] * d.h);
        // d/ds of the Hermite cubic: a·s² + b·s + c.
        let a = 6.0 * (y0 - y1) + 3.0 * (g0 + g1);
        let b = 6.0 * (y1 - y0) - 4.0 * g0 - 2.0 * g1;
        let c = g0;
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        let roots = [
            if q != 0.0 { c / q } else { -1.0 },
            if a != 0.0 { q / a } else { -1.0 },
        ];
        roots
            .into_iter()
            .filter(|s| *s > 0.0 && *s < 1.0)
            .map(|s| (s, sign * d.component(k, s)))
            .filter(|(_, v)| *v < 0.0)
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .map(|(s, _)| s)
    }

    fn refresh_start(&mut self) {
        self.refresh_start_at(None, None);
    }

    /// Re-resolves the conduction state after an event (see [`Circuit::resolve`]).
    fn refresh_start_at(&mut self, at_clamp: Option<Phase>, keep_open: Option<Phase>) {
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

    /// When the first watched change not yet reported becomes visible.
    fn unreported(&self, watch: Watch) -> Option<Ticks> {
        self.cmp.next_visible_change(self.reported, watch.channels)
    }

    /// The clock edge (not before `now`) that samples a change visible at `tv`.
    fn sample_edge(tv: Ticks, watch: Watch, now: Ticks) -> Ticks {
        tv.next_edge(watch.clock).max(now.next_edge(watch.clock))
    }

    /// True signals now.
    pub fn observe(&self) -> Observation {
        let x = self.state();
        let (f, e) = self.emf_of(&x);
        let i = Self::currents(&x);
        let s = self.circuit.solve(&self.modes, &i, &e);
        Observation {
            t_s: self.t,
            theta_e: x[THETA],
            omega_m: x[OMEGA],
            speed_rpm: x[OMEGA] * 60.0 / TAU,
            i,
            v_term: s.v_term,
            v_n: s.v_n,
            emf: e,
            torque_nm: self.pp * self.lambda * (i.u * f.u + i.v * f.v + i.w * f.w),
            conduction: self.modes,
            i_shunt: s.i_shunt,
        }
    }

    /// Energy integrals since t = 0 and the energies stored now.
    pub fn energy(&self) -> EnergyLedger {
        let x = &self.state();
        EnergyLedger {
            supply: x[E_SUPPLY],
            copper: x[E_SUPPLY + 1],
            switch: x[E_SUPPLY + 2],
            diode: x[E_SUPPLY + 3],
            shunt: x[E_SUPPLY + 4],
            friction: x[E_SUPPLY + 5],
            load: x[E_SUPPLY + 6],
            airgap: x[E_SUPPLY + 7],
            dynamometer: x[E_SUPPLY + 8],
            magnetic: 0.5 * self.inductance * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]),
            kinetic: 0.5 * self.inertia * x[OMEGA] * x[OMEGA],
        }
    }

    /// ∫Te dt \[N·m·s\] and ∫Te² dt \[N²·m²·s\] since t = 0: differences over a window give
    /// the torque's exact time mean and mean square.
    pub fn torque_integrals(&self) -> (f64, f64) {
        let x = self.state();
        (x[E_SUPPLY + 9], x[E_SUPPLY + 10])
    }

    fn commit(&mut self, x: State, t: f64) {
        self.x = x;
        self.t = t;
        self.tick = Ticks::at_or_after(t);
        if !(0.0..TAU).contains(&self.x[THETA]) {
            self.x[THETA] = wrap_angle(self.x[THETA]);
        }
        self.stats.steps += 1;
    }

    /// Commits a step ending at `t1` with sin θ, cos θ `sc1` there (handling its diode
    /// event, if any).
    #[inline(always)]
    fn finish_step(
        &mut self,
        x1: State,
        sc1: (f64, f64),
        t0: f64,
        t1: f64,
        s1: Solution,
        event: Option<Phase>,
    ) -> Option<PlantStop> {
        self.end_angle = Some((x1[THETA], sc1.0, sc1.1));
        // The back-EMF at the committed state (a re-resolve after a gate change or an
        // event, an observation) then takes this sine and cosine as they are, not by angle
        // addition from the step's start again: the same values, since they were made so.
        self.base_hint = (x1[THETA], sc1.0, sc1.1);
        self.commit(x1, t1);
        if let Some(p) = event {
            if self.modes.get(p).is_diode() {
                // The diode current reached zero: exactly zero, sum kept at zero.
                let k = p.index();
                let residual = self.x[k];
                self.x[k] = 0.0;
                let others = Phase::ALL
                    .iter()
                    .filter(|&&q| q != p && self.modes.get(q).conducts())
                    .count();
                if others == 1 {
                    // Two-phase conduction: the other current is minus this one, zero too.
                    for q in Phase::ALL
                        .into_iter()
                        .filter(|&q| q != p && self.modes.get(q).conducts())
                    {
                        self.x[q.index()] = 0.0;
                    }
                } else if let Some(q) = Phase::ALL
                    .into_iter()
                    .filter(|&q| q != p && self.modes.get(q).conducts())
                    .max_by(|a, b| self.x[a.index()].abs().total_cmp(&self.x[b.index()].abs()))
                {
                    self.x[q.index()] += residual;
                }
            }
            self.same_instant_events = if t1 - t0 < 1e-12 {
                // Saturating: only its reaching 4 matters (a restored count may be any).
                self.same_instant_events.saturating_add(1)
            } else {
                0
            };
            if self.same_instant_events >= 4 {
                // Zero-length events repeating at one instant: this phase's event is ignored
                // for the next step, while every other phase is still watched.
                self.muted[p.index()] = true;
            }
            let was_open = self.modes.get(p) == Conduction::Open;
            // A diode that had just been switched on at zero current and whose current would
            // reverse at once never conducted: it stays open now instead of chattering.
            let never_conducted = !was_open && t1 - t0 < 1e-12;
            self.refresh_start_at(was_open.then_some(p), never_conducted.then_some(p));
            self.stats.diode_events += 1;
            return Some(PlantStop::Diode);
        }
        self.same_instant_events = 0;
        if t1 - t0 >= 1e-12 {
            self.muted = [false; 3];
        }
        self.start = s1;
        self.fsal = true;
        None
    }

    /// Moves the reported time to tick `k` inside the lookahead step. The sensing chains
    /// have been advanced over the whole step already; the state there is computed only
    /// when asked for (see [`BldcPlant::state`]).
    fn serve_at(&mut self, k: Ticks) {
        self.t = k.seconds();
        self.tick = (k, true);
    }

    /// The state at the present time: inside a lookahead step, a step of its own from the
    /// lookahead's start (not an interpolant), so what is observed is the solution to
    /// integrator accuracy and the energy integrals stay consistent with the currents.
    fn state(&self) -> State {
        match &self.lookahead {
            Some(la) => {
                let mut x = self.integrate_from(&la.x0, self.t - la.t0, la.base, &la.f0);
                if !(0.0..TAU).contains(&x[THETA]) {
                    x[THETA] = wrap_angle(x[THETA]);
                }
                x
            }
            None => self.x,
        }
    }

    /// Serves a stop from the step already integrated ahead, or finishes that step; then
    /// `known` gets the first watched change not yet reported (see `BldcPlant::step_to`).
    fn serve_lookahead(
        &mut self,
        until: Ticks,
        watch: Watch,
        known: &mut Option<Option<Ticks>>,
    ) -> Option<PlantStop> {
        let t1 = self.lookahead.as_ref()?.t1;
        let t_end = until.seconds();
        let unreported = self.unreported(watch);
        if let Some(p) = unreported.map(|tv| Self::sample_edge(tv, watch, self.tick.0)) {
            let ps = p.seconds();
            if ps < t1 - 1e-15 && ps <= t_end + 1e-15 {
                self.serve_at(p);
                self.reported = p;
                return Some(PlantStop::Sensing(p));
            }
        }
        if t_end < t1 - 1e-15 {
            if t_end <= self.t {
                return Some(PlantStop::Reached);
            }
            self.serve_at(until);
            return Some(PlantStop::Reached);
        }
        let la = self.lookahead.take()?;
        let stop = self.finish_step(la.x1, la.sc1, la.t0, la.t1, la.s1, la.event);
        *known = Some(unreported);
        stop
    }

    /// Ends any lookahead at the present time, before the dynamics change. The check is
    /// inlined at every gate change; the work (one change in ten) is not.
    #[inline]
    fn settle(&mut self) {
        if self.lookahead.is_some() {
            self.settle_lookahead();
        }
    }

    /// [`BldcPlant::settle`]'s work, with a lookahead present.
    #[inline(never)]
    fn settle_lookahead(&mut self) {
        self.cmp.truncate_at(self.tick.0);
        self.cur.truncate_at(self.t);
        self.x = self.state();
        self.fsal = false;
        let la = self.lookahead.take().expect("checked by settle");
        self.start = self.solve_near(&self.x, la.base);
        self.same_instant_events = 0;
        self.stats.retries += 1;
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

impl BldcPlant {
    /// [`Plant::advance`] without the comparator bookkeeping around it.
    fn step_to(&mut self, until: Ticks, watch: Watch) -> PlantStop {
        let t_end = until.seconds();
        // The first watched change not yet reported, as found at the end of the last step
        // (nothing since has moved the comparators or the report): asked once a step.
        let mut known = None;
        loop {
            if let Some(stop) = self.serve_lookahead(until, watch, &mut known) {
                return stop;
            }
            let t0 = self.t;
            let (now, on_tick) = self.tick;
            let unreported = known.take().unwrap_or_else(|| self.unreported(watch));
            let pending = unreported.map(|tv| Self::sample_edge(tv, watch, now));
            if on_tick && pending == Some(now) {
                self.reported = now;
                return PlantStop::Sensing(now);
            }
            if t0 >= t_end - 1e-15 {
                if t_end > self.t {
                    self.serve_at(until);
                }
                return PlantStop::Reached;
            }
            // Integrate up to the horizon, not just to `until`: instants before it are
            // served from this step (see `Lookahead`) unless the dynamics change first.
            // The horizon's instant is a tick's own time already (as `Ticks::at_or_after`
            // finds it); a step of the longest length that lands on a tick takes that
            // tick's own time, so it ends where a step cut there by the engine would (bit
            // for bit).
            let horizon = watch.horizon.max(until).seconds();
            let mut t1 = if horizon > t0 + self.h_max {
                match Ticks::at_or_after(t0 + self.h_max) {
                    (k, true) => k.seconds(),
                    _ => t0 + self.h_max,
                }
            } else {
                horizon
            };
            if let Some(e) = pending {
                t1 = t1.min(e.seconds());
            }
            let x0 = self.x;
            // The last step's end angle, unless the state moved since (a wrap of θ, a
            // settled lookahead, a set rotor) or the chain has run `ANCHOR` steps: a fresh
            // sin_cos then re-anchors the chain of rotations, at least once a turn and once
            // every `ANCHOR` steps however slowly the rotor turns.
            let b0 = match self.end_angle {
                Some(e) if e.0 == x0[THETA] && self.stats.steps % ANCHOR != 0 => e,
                _ => Self::base(&x0),
            };
            self.base_hint = b0;
            // The derivative here from the network's solution here (`start`): first same
            // as last, the previous step's end derivative when nothing has changed the
            // dynamics since (taken at that step's end angle, before θ's wrap); else the
            // network was just solved here (a gate change, an event, a settled lookahead).
            let angle = match (std::mem::take(&mut self.fsal), self.end_angle) {
                (true, Some(e)) => e,
                _ => {
                    if std::mem::take(&mut self.verify_start) && !self.start_solves(&x0, b0) {
                        self.start = self.solve_near(&x0, b0);
                    }
                    // A state gone non-finite has no solution to compare (NaN ≠ NaN); the
                    // run goes on and its summary reports it.
                    debug_assert!(
                        self.start_solves(&x0, b0),
                        "the network solution at the step's start is stale"
                    );
                    (x0[THETA], b0.1, b0.2)
                }
            };
            let f0 = self.end_derivative(&x0, &self.start, angle);
            // A diode event predicted inside the step: the step ends there when its
            // current is within 1e-9 A of zero (as the search after a step accepts). The
            // step runs on the response Newton searched, so this only catches a search
            // stopped short, with 1000× the room of its 1e-12 A stop.
            let h = t1 - t0;
            let cand = self.diode_candidate(&x0, &f0, h);
            let built = cand.and_then(|_| self.step_response(&x0, &f0, h, b0));
            let zero = match (cand, &built) {
                (Some(p), Some(b)) => Self::diode_zero(b, x0[p.index()], p, h).map(|t| (t, p)),
                _ => None,
            };
            let (mut x1, mut end) = match &built {
                Some(b) => self.flow_built(&x0, zero.map_or(h, |z| z.0), &f0, b),
                None => self.integrate_end(&x0, h, b0, &f0),
            };
            let predicted = zero.filter(|&(_, p)| x1[p.index()].abs() < 1e-9);
            match (zero, predicted, &built) {
                (_, Some((hz, _)), _) => t1 = t0 + hz,
                (Some(_), None, Some(b)) => (x1, end) = self.flow_built(&x0, h, &f0, b),
                _ => {} // no zero predicted (a predicted zero implies a built response)
            }
            let (mut s1, mut sc1) = self.solution_at(&x1, emf::sin_cos_close(x1[THETA], end, b0));
            let mut event = predicted.map(|(_, p)| p);
            let step = Dense {
                x0: &x0,
                f0: &f0,
                x1: &x1,
                di1: s1.di.to_array(),
                h: t1 - t0,
            };
            // The predicted phase's event is the step's end; others may come first.
            let muted = self.muted;
            if let Some((_, p)) = predicted {
                self.muted[p.index()] = true;
            }
            let found = self.first_event(&step, &s1, b0);
            self.muted = muted;
            if let Some((h_ev, p, at)) = found {
                // The step to the event is integrated (not interpolated), so the energy
                // integrals stay consistent with the currents.
                x1 = at.unwrap_or_else(|| self.integrate_from(&x0, h_ev, b0, &f0));
                (s1, sc1) = self.solution_at(&x1, emf::sin_cos_near(x1[THETA], b0));
                t1 = t0 + h_ev;
                event = Some(p);
            }
            self.cmp.forget_history(Ticks::at_or_before(t0), unreported);
            let (k0, k1) = self.knots((&x0, &f0, &self.start), (&x1, &s1, sc1), t1 - t0, b0);
            self.cmp.update(t0, t1, &k0, &k1, watch.channels);
            self.cur.update(
                t0,
                t1,
                (self.start.i_shunt, self.shunt_slope([f0[0], f0[1], f0[2]])),
                (s1.i_shunt, self.shunt_slope(s1.di.to_array())),
            );
            let after = self.unreported(watch);
            let sample = after
                .map(|tv| Self::sample_edge(tv, watch, now))
                .filter(|e| e.seconds() < t1 - 1e-15);
            if sample.is_some() || t_end < t1 - 1e-15 {
                // A watched output changed inside the step, or the step runs past `until`:
                // stop there, keeping the rest of the step for later.
                self.lookahead = Some(Lookahead {
                    x0,
                    f0,
                    base: b0,
                    t0,
                    t1,
                    x1,
                    s1,
                    sc1,
                    event,
                });
                if let Some(e) = sample.filter(|e| e.seconds() <= t_end + 1e-15) {
                    self.serve_at(e);
                    self.reported = e;
                    return PlantStop::Sensing(e);
                }
                self.serve_at(until);
                return PlantStop::Reached;
            }
            if let Some(stop) = self.finish_step(x1, sc1, t0, t1, s1, event) {
                return stop;
            }
            known = Some(after);
        }
    }
}

/// A step's modal response as the diode prediction built it, over the step's full length,
/// for the step's integration to reuse.
struct StepResponse<'a> {
    rsp: Response<'a>,
    /// The modal form it was built on.
    md: &'a Modal,
    /// sin θ and cos θ at the step's start.
    sc0: (f64, f64),
    /// The forcing's Ω \[rad/s\] (electrical, at the full step's middle).
    omega_e: f64,
}

/// The network's affine and modal forms for one conduction state, and its legs decoded
/// for the network's solution (see [`Circuit::solve_planned`]).
type Form = (Linearised, Option<Modal>, Plan);

/// The most steps sin θ and cos θ are carried from step to step by rotations before a
/// fresh `sin_cos` re-anchors them (see `BldcPlant::step_to`; committed steps are
/// counted by `PlantStats::steps`, which a state saves, so a restored run re-anchors
/// where the uninterrupted one does).
///
/// The bound: a step carries the pair by at most three rotations, two by Ω·h/2 (sin and
/// cos by [`emf::rotation`]'s series, whose truncation for |d| <= 0.5 is below d¹³/13! <
/// 2e-14; a larger d takes a fresh `sin_cos`) and one by the end's small δ
/// ([`emf::sin_cos_close`], off by δ⁴/4 < 3e-17 in s² + c², or from the step's base).
/// Each rotation is a 2×2 product whose roundings move s² + c² and the angle by a few ε
/// (ε = 2^-53 ≈ 1.1e-16, say 8ε < 1e-15), so a step moves them by less than
/// 3·(2e-14 + 1e-15) < 7e-14, and `ANCHOR` steps by less than 128 × 7e-14 < 9e-12: more
/// than a hundred times inside the 1e-9 a restored state is held to (`bldc/state.rs`),
/// for any run however long. (Observed at a crawl: under 6e-14 in 128 steps.)
/// A power of two, so the test is a mask; a re-anchor costs one `sin_cos` in 128 steps.
const ANCHOR: u64 = 128;

/// θe wrapped into its canonical range 0..2π, as it is stored. `rem_euclid` of an
/// angle a hair below 0 (a rotor at rest nudged backwards by a load of 1e-12 N·m) rounds
/// to 2π itself: that is the same angle, stored as 0. NaN stays NaN (a run gone
/// non-finite is reported, not hidden).
fn wrap_angle(theta: f64) -> f64 {
    let w = theta.rem_euclid(TAU);
    if w == TAU { 0.0 } else { w }
}

/// The forms of the conduction state at index `k` (see [`circuit::state_index`]).
fn form_at(circuit: &Circuit, k: usize) -> Form {
    let modes = circuit::state_at(k);
    let lin = circuit.linearise(&modes);
    (lin, Modal::new(&modes, &lin), circuit.plan(&modes))
}

/// tanh(x), the smooth sign of the Coulomb friction: ±1 without the call beyond |x| = 20,
/// where tanh rounds to ±1 in f64 anyway (1 − tanh x ≈ 2e^{−2x} < half an ulp from x ≈ 19.1).
fn smooth_sign(x: f64) -> f64 {
    if x.abs() > 20.0 { x.signum() } else { x.tanh() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RK4 with `n` sub-steps, each from its own exact angle: the reference solution.
    fn fine(pl: &BldcPlant, x: &State, h: f64, n: usize) -> State {
        let mut x = *x;
        for _ in 0..n {
            let b = BldcPlant::base(&x);
            x = pl.rk4_from(&x, h / n as f64, b, &pl.deriv(&dynamic(&x), b));
        }
        x
    }

    /// A plant at `rpm` with u switched high, v low and w off, the currents `i`.
    fn driven(i: [f64; 3], rpm: f64, lock: bool) -> BldcPlant {
        driven_with(PlantParams::default(), i, rpm, lock)
    }

    fn driven_with(params: PlantParams, i: [f64; 3], rpm: f64, lock: bool) -> BldcPlant {
        let mut pl = BldcPlant::new(params).expect("valid parameters");
        pl.set_rotor(0.3, rpm, lock);
        pl.gates = Gates {
            high: Abc::from_fn(|p| p == Phase::U),
            low: Abc::from_fn(|p| p == Phase::V),
        };
        for (k, v) in i.into_iter().enumerate() {
            pl.x[k] = v;
        }
        pl.refresh_start();
        pl
    }

    /// A plant with the bridge off and the rotor at `rpm` from θe = 0.3, locked to that
    /// speed, stepped `n` plant steps of the longest length; `each` sees it after each.
    fn crawl(params: PlantParams, rpm: f64, n: u64, mut each: impl FnMut(&BldcPlant)) -> BldcPlant {
        let mut pl = BldcPlant::new(params).expect("valid parameters");
        pl.set_rotor(0.3, rpm, true);
        let watch = Watch {
            channels: Abc::splat(false),
            reads: Abc::splat(Ticks::ZERO),
            clock: Ticks(32),
            horizon: Ticks::ZERO,
        };
        let step = Ticks::from_seconds(pl.h_max).expect("a step in ticks").0;
        for k in 1..=n {
            while pl.advance(Ticks(k * step), &watch) != PlantStop::Reached {}
            each(&pl);
        }
        pl
    }

    /// The plant restored from its own bytes, into one built from the same parameters.
    fn restored(pl: &BldcPlant) -> Result<BldcPlant, String> {
        use drive_core::state::Persist;
        let mut copy = BldcPlant::new(pl.params.clone()).expect("valid parameters");
        copy.restore_from(&pl.to_bytes()?)?;
        Ok(copy)
    }

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

    /// At a crawl θ never wraps, so only the anchor every `ANCHOR` steps bounds the
    /// rounding carried by the chain of rotations: s² + c² and the angle stay within the
    /// bound derived at `ANCHOR`, and the plant's own state restores. (Unanchored, s² + c²
    /// drifted by about 2e-16 a step: 4e-11 here, 1.1e-9 after 5.5 M steps, refused.)
    #[test]
    fn a_long_crawl_keeps_sin_and_cos_within_the_anchor_s_bound_and_restores() {
        let bound = ANCHOR as f64 * 7e-14;
        let mut worst = (0.0f64, 0.0f64);
        let pl = crawl(PlantParams::default(), 0.01, 200_000, |pl| {
            let (th, s, c) = pl.end_angle.expect("a step's end angle");
            let (ws, wc) = th.sin_cos();
            worst.0 = worst.0.max((s * s + c * c - 1.0).abs());
            worst.1 = worst.1.max((s - ws).abs().max((c - wc).abs()));
        });
        assert!(pl.x[THETA] < TAU - 0.3, "θ never wrapped");
        assert!(
            worst.0 < bound && worst.1 < bound,
            "s² + c² − 1 up to {:e}, sin and cos off by up to {:e} (bound {bound:e})",
            worst.0,
            worst.1
        );
        restored(&pl).unwrap();
    }

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
