//! The published BLDC motor on a six-switch bridge with shunt and comparator sensing.
//!
//! State: phase currents i_u, i_v, i_w [A], mechanical speed ωm [rad/s], electrical angle
//! θe [rad, wrapped to 0..2π], plus energy integrals [J]. Between events the state is
//! integrated with classical RK4 (step ≤ `solver.max_step_s`); the conduction topology is
//! constant within a step. Mechanics: J·dωm/dt = Te − Bm·ωm − Tc·tanh(ωm/ω0) − TL, dθe/dt = (P/2)·ωm,
//! Te = (P/2)·λr·Σ i_x·f(θx) so that Te·ωm = Σ e_x·i_x exactly.
//!
//! Events located in time (Illinois regula falsi on the RK4 solution, to 0.1 ns): a freewheeling
//! diode's current reaching zero (the current is then set to exactly zero and the phase
//! floats), and an open terminal reaching a diode clamp (the diode starts conducting).

use crate::circuit::{Circuit, Conduction, Linearised, Solution};
use crate::emf;
use crate::params::{BackEmfShape, PlantParams};
use crate::sensing::{ComparatorBank, CurrentSense};
use drive_core::{Abc, Gates, ParamError, Phase, Plant, PlantStop, Sensed, TICK_S, Ticks, Watch};
use nalgebra::SVector;
use std::f64::consts::TAU;

const N: usize = 14;
type State = SVector<f64, N>;
const OMEGA: usize = 3;
const THETA: usize = 4;
const E_SUPPLY: usize = 5;

/// Energies integrated along the run [J].
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
    /// Time [s].
    pub t_s: f64,
    /// Electrical angle θe [rad], 0..2π, with e_u = λr·ωe·sin θe for the sinusoidal shape.
    pub theta_e: f64,
    /// Mechanical speed [rad/s].
    pub omega_m: f64,
    /// Mechanical speed [rpm].
    pub speed_rpm: f64,
    /// Phase currents into the windings [A].
    pub i: Abc<f64>,
    /// Terminal voltages to ground [V].
    pub v_term: Abc<f64>,
    /// Neutral voltage to ground [V].
    pub v_n: f64,
    /// Back-EMFs [V].
    pub emf: Abc<f64>,
    /// Electromagnetic torque [N·m].
    pub torque_nm: f64,
    /// Conduction state of each leg.
    pub conduction: Abc<Conduction>,
    /// Shunt current, positive to ground [A].
    pub i_shunt: f64,
}

/// Counters of the work done, for performance figures.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct PlantStats {
    /// RK4 steps committed.
    pub steps: u64,
    /// Diode events located.
    pub diode_events: u64,
    /// Extra work: RK4 steps spent locating clamp events, and steps integrated ahead that
    /// were cut short because the dynamics changed inside them.
    pub retries: u64,
}

/// Cubic Hermite interpolation of one RK4 step (states and derivatives at both ends).
#[derive(Copy, Clone, Debug)]
struct Dense {
    x0: State,
    f0: State,
    x1: State,
    f1: State,
    h: f64,
}

impl Dense {
    /// The state at fraction `s` ∈ [0, 1] of the step.
    fn at(&self, s: f64) -> State {
        let (s2, s3) = (s * s, s * s * s);
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = (s3 - 2.0 * s2 + s) * self.h;
        let h01 = 3.0 * s2 - 2.0 * s3;
        let h11 = (s3 - s2) * self.h;
        self.x0 * h00 + self.f0 * h10 + self.x1 * h01 + self.f1 * h11
    }

    /// One component of [`Dense::at`].
    fn component(&self, k: usize, s: f64) -> f64 {
        let (s2, s3) = (s * s, s * s * s);
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = (s3 - 2.0 * s2 + s) * self.h;
        let h01 = 3.0 * s2 - 2.0 * s3;
        let h11 = (s3 - s2) * self.h;
        self.x0[k] * h00 + self.f0[k] * h10 + self.x1[k] * h01 + self.f1[k] * h11
    }
}

/// A step integrated beyond the reported time. Instants inside it are served from its dense
/// output (a watched comparator change usually changes nothing in the drive), until
/// something changes the dynamics: then the plant settles at the present time.
#[derive(Clone, Debug)]
struct Lookahead {
    dense: Dense,
    t0: f64,
    t1: f64,
    x1: State,
    s1: Solution,
    /// How far the current-sense chain has been advanced (it follows the served time, so
    /// ADC readings never come from beyond it): time and shunt current there.
    cur_t: f64,
    cur_i: f64,
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
    inertia: f64,
    friction: f64,
    coulomb: f64,
    coulomb_speed: f64,
    inductance: f64,
    h_max: f64,
    x: State,
    t: f64,
    gates: Gates,
    modes: Abc<Conduction>,
    load_nm: f64,
    speed_lock: bool,
    /// Network solution at the current time (right after any event): start of the next
    /// sensing segment.
    start: Solution,
    cmp: ComparatorBank,
    cur: CurrentSense,
    same_instant_events: u32,
    /// Phases whose events are ignored for one step (see `finish_step`).
    muted: [bool; 3],
    /// The network's affine form for the present conduction state, and a cache of all 125.
    lin: Linearised,
    lin_cache: Vec<Option<Linearised>>,
    /// The step integrated ahead of `t`, if any.
    lookahead: Option<Lookahead>,
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
        let modes = circuit.resolve(&Gates::OFF, &Abc::splat(0.0), &e, None, None);
        let start = circuit.solve(&modes, &Abc::splat(0.0), &e);
        let cmp = ComparatorBank::new(
            &params.sensing.comparator,
            params.sensing.seed,
            &start.v_term,
            start.v_n,
        );
        let cur = CurrentSense::new(&params.sensing.current, params.power_stage.shunt_ohm);
        Ok(BldcPlant {
            circuit,
            shape: m.back_emf,
            pp: m.pole_pairs(),
            lambda: m.flux_linkage_wb,
            inertia: m.inertia_kgm2,
            friction: m.viscous_friction_nms,
            coulomb: m.coulomb_friction_nm,
            coulomb_speed: m.coulomb_speed_rad_s,
            inductance: m.phase_inductance_h(),
            h_max: params.solver.max_step_s,
            x,
            t: 0.0,
            gates: Gates::OFF,
            modes,
            load_nm: 0.0,
            speed_lock: false,
            start,
            cmp,
            cur,
            same_instant_events: 0,
            muted: [false; 3],
            lin: circuit.linearise(&modes),
            lin_cache: vec![None; 125],
            reported: Ticks::ZERO,
            lookahead: None,
            stats: PlantStats::default(),
            params,
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &PlantParams {
        &self.params
    }

    /// Sets the load torque TL [N·m] (opposing positive rotation) from now on.
    pub fn set_load_torque(&mut self, nm: f64) {
        self.settle();
        self.load_nm = if nm.is_finite() { nm } else { 0.0 };
    }

    /// Sets rotor angle θe [rad] and speed [rpm]; `lock` holds the speed constant from now on
    /// (a dynamometer), otherwise the rotor is free.
    pub fn set_rotor(&mut self, theta_e: f64, speed_rpm: f64, lock: bool) {
        self.settle();
        self.x[THETA] = theta_e.rem_euclid(TAU);
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

    /// Work counters.
    pub fn stats(&self) -> PlantStats {
        self.stats
    }

    /// Total comparator toggles so far.
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

    fn emf_of(&self, x: &State) -> (Abc<f64>, Abc<f64>) {
        let f = emf::shape(&self.shape, x[THETA]);
        let k = self.lambda * self.pp * x[OMEGA];
        (f, f.map(|v| k * v))
    }

    fn solve_at(&self, x: &State) -> Solution {
        let (_, e) = self.emf_of(x);
        self.circuit.solve(&self.modes, &Self::currents(x), &e)
    }

    fn deriv(&self, x: &State, base: (f64, f64, f64)) -> State {
        let f = emf::shape_with(&self.shape, x[THETA], emf::sin_cos_near(x[THETA], base));
        let k = self.lambda * self.pp * x[OMEGA];
        let e = [k * f.u, k * f.v, k * f.w];
        let i = [x[0], x[1], x[2]];
        let (di, p) = self.lin.eval(&i, &e);
        let wm = x[OMEGA];
        let te = self.pp * self.lambda * (i[0] * f.u + i[1] * f.v + i[2] * f.w);
        let drag = self.friction * wm + self.coulomb * (wm / self.coulomb_speed).tanh();
        let net = te - drag - self.load_nm;
        // A locked rotor is held by a dynamometer, which absorbs the net torque.
        let (dw, p_dyno) = if self.speed_lock {
            (0.0, net * wm)
        } else {
            (net / self.inertia, 0.0)
        };
        State::from([
            di[0],
            di[1],
            di[2],
            dw,
            self.pp * wm,
            p.supply,
            p.copper,
            p.switch,
            p.diode,
            p.shunt,
            drag * wm,
            self.load_nm * wm,
            p.airgap,
            p_dyno,
        ])
    }

    fn rk4(&self, x: &State, h: f64) -> State {
        self.rk4_k1(x, h).0
    }

    /// One RK4 step; also returns the derivative at the start (for dense output).
    fn rk4_k1(&self, x: &State, h: f64) -> (State, State) {
        // One sin/cos per step; the stages' angles are reached by angle addition.
        let (s, c) = x[THETA].sin_cos();
        let base = (x[THETA], s, c);
        let k1 = self.deriv(x, base);
        let k2 = self.deriv(&(x + k1 * (0.5 * h)), base);
        let k3 = self.deriv(&(x + k2 * (0.5 * h)), base);
        let k4 = self.deriv(&(x + k3 * h), base);
        (x + (k1 + (k2 + k3) * 2.0 + k4) * (h / 6.0), k1)
    }

    fn deriv_at(&self, x: &State) -> State {
        let (s, c) = x[THETA].sin_cos();
        self.deriv(x, (x[THETA], s, c))
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
        for _ in 0..48 {
            let m = 0.5 * (a + b);
            if g(m) > 0.0 { a = m } else { b = m }
        }
        b
    }

    /// Earliest h in (0, h_full] where phase p's event function reaches zero.
    fn locate(&mut self, x0: &State, h_full: f64, p: Phase) -> f64 {
        let g = |pl: &Self, h: f64| {
            let x = pl.rk4(x0, h);
            let s = pl.solve_at(&x);
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

    fn refresh_start(&mut self) {
        self.refresh_start_at(None, None);
    }

    /// Re-resolves the conduction state after an event (see [`Circuit::resolve`]).
    fn refresh_start_at(&mut self, at_clamp: Option<Phase>, keep_open: Option<Phase>) {
        let (_, e) = self.emf_of(&self.x);
        self.modes = self.circuit.resolve(
            &self.gates,
            &Self::currents(&self.x),
            &e,
            at_clamp,
            keep_open,
        );
        let m = self.modes.map(|c| c as usize);
        let idx = m.u * 25 + m.v * 5 + m.w;
        self.lin = match self.lin_cache[idx] {
            Some(l) => l,
            None => {
                let l = self.circuit.linearise(&self.modes);
                self.lin_cache[idx] = Some(l);
                l
            }
        };
        self.start = self
            .circuit
            .solve(&self.modes, &Self::currents(&self.x), &e);
    }

    /// The first tick at or after `t`, and whether `t` is (within rounding) that tick.
    fn ceil_tick(t: f64) -> (Ticks, bool) {
        let k = t / TICK_S;
        let r = k.round();
        if (k - r).abs() < 1e-6 {
            (Ticks(r as u64), true)
        } else {
            (Ticks(k.ceil() as u64), false)
        }
    }

    /// The clock edge (not before `now`) at which the first watched change not yet reported
    /// must be sampled.
    fn pending_sample(&self, watch: Watch, now: Ticks) -> Option<Ticks> {
        self.unreported(watch)
            .map(|tv| Self::sample_edge(tv, watch, now))
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
        let (f, e) = self.emf_of(&self.x);
        let i = Self::currents(&self.x);
        let s = self.circuit.solve(&self.modes, &i, &e);
        Observation {
            t_s: self.t,
            theta_e: self.x[THETA],
            omega_m: self.x[OMEGA],
            speed_rpm: self.x[OMEGA] * 60.0 / TAU,
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
        let x = &self.x;
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

    fn commit(&mut self, x: State, t: f64) {
        self.x = x;
        self.t = t;
        if !(0.0..TAU).contains(&self.x[THETA]) {
            self.x[THETA] = self.x[THETA].rem_euclid(TAU);
        }
        self.stats.steps += 1;
    }
    /// Commits a step ending at `t1` (handling its diode event, if any).
    fn finish_step(
        &mut self,
        x1: State,
        t0: f64,
        t1: f64,
        s1: Solution,
        event: Option<Phase>,
    ) -> Option<PlantStop> {
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
                self.same_instant_events + 1
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
        None
    }

    fn wrap_theta(&mut self) {
        if !(0.0..TAU).contains(&self.x[THETA]) {
            self.x[THETA] = self.x[THETA].rem_euclid(TAU);
        }
    }

    /// Moves the reported time to `t` inside the lookahead step (interpolated state).
    fn serve_at(&mut self, t: f64) {
        let Some(la) = &self.lookahead else { return };
        self.x = la.dense.at((t - la.t0) / la.dense.h);
        self.wrap_theta();
        self.t = t;
        let i_sh = self.solve_at(&self.x).i_shunt;
        if let Some(la) = &mut self.lookahead {
            self.cur.update(la.cur_t, t, la.cur_i, i_sh);
            (la.cur_t, la.cur_i) = (t, i_sh);
        }
    }

    /// Serves a stop from the step already integrated ahead, or finishes that step.
    fn serve_lookahead(&mut self, t_end: f64, watch: Watch) -> Option<PlantStop> {
        let t1 = self.lookahead.as_ref()?.t1;
        let (now, _) = Self::ceil_tick(self.t);
        if let Some(p) = self.pending_sample(watch, now) {
            let ps = p.seconds();
            if ps < t1 - 1e-15 && ps <= t_end + 1e-15 {
                self.serve_at(ps);
                self.reported = p;
                return Some(PlantStop::Sensing(p));
            }
        }
        if t_end < t1 - 1e-15 {
            if t_end <= self.t {
                return Some(PlantStop::Reached);
            }
            self.serve_at(t_end);
            if let Some(la) = &self.lookahead {
                // An engine instant: take the state from RK4 itself, so the energy
                // integrals are exactly consistent with the currents there.
                self.x = self.rk4(&la.dense.x0, self.t - la.t0);
                self.wrap_theta();
            }
            return Some(PlantStop::Reached);
        }
        let la = self.lookahead.take()?;
        self.cur.update(la.cur_t, la.t1, la.cur_i, la.s1.i_shunt);
        self.finish_step(la.x1, la.t0, la.t1, la.s1, la.event)
    }

    /// Ends any lookahead at the present time, before the dynamics change.
    fn settle(&mut self) {
        if let Some(la) = self.lookahead.take() {
            let (now, _) = Self::ceil_tick(self.t);
            self.cmp.truncate_at(now);
            // The current sense already stands at the present time (see `serve_at`); the
            // state is taken from RK4 itself, as at any instant where the dynamics change.
            debug_assert!((la.cur_t - self.t).abs() < 1e-15);
            self.x = self.rk4(&la.dense.x0, self.t - la.t0);
            self.wrap_theta();
            self.start = self.solve_at(&self.x);
            self.same_instant_events = 0;
            self.stats.retries += 1;
        }
    }
}

impl Plant for BldcPlant {
    fn time_s(&self) -> f64 {
        self.t
    }

    fn set_gates(&mut self, gates: &Gates) {
        self.settle();
        let before = self.start.v_term;
        let old = self.gates;
        self.gates = *gates;
        self.refresh_start();
        // Ringing is excited by the largest switching-node step among the legs that switched.
        let mut dv: f64 = 0.0;
        for p in Phase::ALL {
            if old.high.get(p) != gates.high.get(p) || old.low.get(p) != gates.low.get(p) {
                let d = self.start.v_term.get(p) - before.get(p);
                if d.abs() > dv.abs() {
                    dv = d;
                }
            }
        }
        self.cmp.excite(self.t, dv);
    }

    fn advance(&mut self, until: Ticks, watch: Watch) -> PlantStop {
        let t_end = until.seconds();
        loop {
            if let Some(stop) = self.serve_lookahead(t_end, watch) {
                return stop;
            }
            let t0 = self.t;
            let (now, on_tick) = Self::ceil_tick(t0);
            let unreported = self.unreported(watch);
            let pending = unreported.map(|tv| Self::sample_edge(tv, watch, now));
            if on_tick && pending == Some(now) {
                self.reported = now;
                return PlantStop::Sensing(now);
            }
            if t0 >= t_end - 1e-15 {
                self.t = self.t.max(t_end);
                return PlantStop::Reached;
            }
            let mut t1 = t_end.min(t0 + self.h_max);
            if let Some(e) = pending {
                t1 = t1.min(e.seconds());
            }
            let x0 = self.x;
            let (mut x1, f0) = self.rk4_k1(&x0, t1 - t0);
            let mut s1 = self.solve_at(&x1);
            let mut event = None;
            let mut dense = None;
            {
                let mut hit = self.triggered(&x0, &x1, &s1);
                for (h, m) in hit.iter_mut().zip(self.muted) {
                    *h &= !m;
                }
                if hit.contains(&true) {
                    // Locate every event of the step and keep the earliest.
                    let h_full = t1 - t0;
                    let d = Dense {
                        x0,
                        f0,
                        x1,
                        f1: self.deriv_at(&x1),
                        h: h_full,
                    };
                    let mut first: Option<(f64, Phase)> = None;
                    for p in Phase::ALL.into_iter().filter(|p| hit[p.index()]) {
                        let h = if self.modes.get(p).is_diode() {
                            // The dense output's root is usually exact enough; where the
                            // current approaches zero slowly it is not, and RK4 decides.
                            let mut h = self.locate_diode(&d, p) * h_full;
                            let k = p.index();
                            let mut done = false;
                            for _ in 0..3 {
                                // Newton on the RK4 solution itself, from the dense guess.
                                let x = self.rk4(&x0, h);
                                if x[k].abs() < 1e-9 {
                                    done = true;
                                    break;
                                }
                                let slope = self.deriv_at(&x)[k];
                                if slope == 0.0 {
                                    break;
                                }
                                h = (h - x[k] / slope).clamp(0.0, h_full);
                            }
                            if done { h } else { self.locate(&x0, h_full, p) }
                        } else {
                            self.locate(&x0, h_full, p)
                        };
                        if first.is_none_or(|(h0, _)| h < h0) {
                            first = Some((h, p));
                        }
                    }
                    let (h, p) = first.expect("at least one event");
                    // The step to the event is taken again with RK4 (not interpolated), so
                    // the energy integrals stay consistent with the currents.
                    x1 = self.rk4(&x0, h);
                    let d = Dense {
                        x0,
                        f0,
                        x1,
                        f1: self.deriv_at(&x1),
                        h,
                    };
                    t1 = t0 + h;
                    s1 = self.solve_at(&x1);
                    event = Some(p);
                    dense = Some(d);
                }
            }
            self.cmp
                .forget_history(Ticks((t0 / TICK_S + 1e-6).floor() as u64), unreported);
            self.cmp.update(
                t0,
                t1,
                &self.start.v_term,
                self.start.v_n,
                &s1.v_term,
                s1.v_n,
            );
            if let Some(e) = self.pending_sample(watch, now) {
                if e.seconds() < t1 - 1e-15 {
                    // A watched output changed inside the step: report it at the clock edge
                    // that samples it, keeping the rest of the step for later.
                    let dense = match dense {
                        Some(d) => d,
                        None => Dense {
                            x0,
                            f0,
                            x1,
                            f1: self.deriv_at(&x1),
                            h: t1 - t0,
                        },
                    };
                    self.lookahead = Some(Lookahead {
                        dense,
                        t0,
                        t1,
                        x1,
                        s1,
                        cur_t: t0,
                        cur_i: self.start.i_shunt,
                        event,
                    });
                    self.serve_at(e.seconds());
                    self.reported = e;
                    return PlantStop::Sensing(e);
                }
            }
            self.cur.update(t0, t1, self.start.i_shunt, s1.i_shunt);
            if let Some(stop) = self.finish_step(x1, t0, t1, s1, event) {
                return stop;
            }
        }
    }

    fn sensed(&self, at: Ticks) -> Sensed {
        Sensed {
            zc: self.cmp.outputs_at(at),
            current_code: self.cur.code_at(at),
        }
    }
}
