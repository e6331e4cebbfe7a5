//! The plant's dynamic state by value (see [`drive_core::state`]): the state vector,
//! time, gates, conduction, load, the step integrated ahead and the sensing chains. The
//! parameters, the network's forms and what follows from the load are never read back.

use super::{BldcPlant, Lookahead, OMEGA, State, THETA};
use crate::circuit::{self, Conduction, Powers, Solution};
use crate::emf;
use crate::load::{Load, MAX_TORQUE_NM};
use crate::params::{BackEmfShape, MAX_SUPPLY_V};
use crate::sensing::comparator::Limits;
use drive_core::state::{Persist, Reader, Writer, check, check_count};
use drive_core::{TICK_S, Ticks, persist_enum, persist_fields};
use std::f64::consts::TAU;

persist_enum!(Conduction {
    SwitchHigh,
    SwitchLow,
    DiodeHigh,
    DiodeLow,
    Open
});
persist_fields!(Powers {
    supply,
    copper,
    switch,
    diode,
    shunt,
    airgap
});
persist_fields!(Solution {
    di,
    v_term,
    v_n,
    i_shunt,
    powers
});
persist_fields!(Load {
    active_nm,
    coulomb_nm,
    viscous_nms,
    fan_nms2,
    inertia_kgm2
});
persist_fields!(crate::bldc::PlantStats {
    steps,
    diode_events,
    retries
});

/// The state vector as a fixed run of floats.
fn save_x(x: &State, w: &mut Writer) {
    x.as_slice().save(w);
}

fn restore_x(r: &mut Reader, name: &str, x: &mut State) -> Result<(), String> {
    r.field(name, x.as_mut_slice())
}

impl Default for Lookahead {
    fn default() -> Self {
        Lookahead {
            x0: State::zeros(),
            f0: State::zeros(),
            base: (0.0, 0.0, 1.0),
            t0: 0.0,
            t1: 0.0,
            x1: State::zeros(),
            s1: Solution::default(),
            sc1: (0.0, 1.0),
            event: None,
        }
    }
}

impl Persist for Lookahead {
    fn save(&self, w: &mut Writer) {
        save_x(&self.x0, w);
        save_x(&self.f0, w);
        self.base.save(w);
        self.t0.save(w);
        self.t1.save(w);
        save_x(&self.x1, w);
        self.s1.save(w);
        // Fixed size: zeros where the end's derivative was kept (it follows from `s1`).
        save_x(&State::zeros(), w);
        self.sc1.save(w);
        self.event.save(w);
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        restore_x(r, "x0", &mut self.x0)?;
        restore_x(r, "f0", &mut self.f0)?;
        r.field("base", &mut self.base)?;
        r.field("t0", &mut self.t0)?;
        r.field("t1", &mut self.t1)?;
        restore_x(r, "x1", &mut self.x1)?;
        r.field("s1", &mut self.s1)?;
        let mut f1 = State::zeros();
        restore_x(r, "f1", &mut f1)?;
        r.field("sc1", &mut self.sc1)?;
        unit_circle("sc1", self.sc1)?;
        zeros("f1", &f1)?;
        r.field("event", &mut self.event)
    }
}

impl Persist for BldcPlant {
    fn save(&self, w: &mut Writer) {
        save_x(&self.x, w);
        self.t.save(w);
        self.tick.save(w);
        self.gates.save(w);
        self.modes.save(w);
        self.load.save(w);
        self.speed_lock.save(w);
        self.start.save(w);
        self.same_instant_events.save(w);
        self.muted.save(w);
        self.lookahead.save(w);
        self.base_hint.save(w);
        // Fixed size: the committed state (the derivative's, see `BldcPlant::fsal`) and
        // zeros where the derivative was kept (it follows from `start` and `end_angle`).
        let zero = State::zeros();
        w.u8(u8::from(self.fsal));
        save_x(if self.fsal { &self.x } else { &zero }, w);
        save_x(&zero, w);
        self.end_angle.save(w);
        self.reported.save(w);
        self.stats.save(w);
        self.cmp.save(w);
        self.cur.save(w);
    }

    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        restore_x(r, "x", &mut self.x)?;
        r.field("t", &mut self.t)?;
        r.field("tick", &mut self.tick)?;
        r.field("gates", &mut self.gates)?;
        r.field("modes", &mut self.modes)?;
        r.field("load", &mut self.load)?;
        self.load.validate().map_err(|e| e.to_string())?;
        r.field("speed_lock", &mut self.speed_lock)?;
        r.field("start", &mut self.start)?;
        r.field("same_instant_events", &mut self.same_instant_events)?;
        r.field("muted", &mut self.muted)?;
        r.field("lookahead", &mut self.lookahead)?;
        r.field("base_hint", &mut self.base_hint)?;
        let mut some = false;
        r.field("fsal", &mut some)?;
        let (mut x, mut f) = (State::zeros(), State::zeros());
        restore_x(r, "fsal.0", &mut x)?;
        restore_x(r, "fsal.1", &mut f)?;
        // As saved: the committed state when the flag is set, zeros otherwise.
        let kept = if some { self.x } else { State::zeros() };
        if let Some(k) = (0..x.len()).find(|&k| x[k] != kept[k]) {
            return Err(format!(
                "fsal.0.[{k}] = {} (rule: {}, as saved: the committed state's when the flag is set, 0 without it)",
                x[k], kept[k]
            ));
        }
        zeros("fsal.1", &f)?;
        self.fsal = some;
        r.field("end_angle", &mut self.end_angle)?;
        if let Some((_, s, c)) = self.end_angle {
            unit_circle("end_angle", (s, c))?;
        }
        r.field("reported", &mut self.reported)?;
        r.field("stats", &mut self.stats)?;
        self.check_times()?;
        // What follows from the restored values, as the setters derive it.
        self.inertia = self.params.motor.inertia_kgm2 + self.load.inertia_kgm2;
        self.inv_inertia = 1.0 / self.inertia;
        self.lin = circuit::state_index(&self.modes);
        self.verify_start = true;
        self.check_bounds()?;
        self.check_solutions()?;
        self.check_lookahead_derivative()?;
        r.field("cmp", &mut self.cmp)?;
        r.field("cur", &mut self.cur)?;
        // The sensing chains at the end of the step integrated ahead, if any.
        let b = self.bounds(self.lookahead.as_ref().map_or(self.t, |la| la.t1));
        self.cmp.check_against(&Limits {
            t: self.t,
            now: self.tick.0.0,
            longest: self.longest_step(),
            volts: b.volts,
            emf_rate: b.emf_rate,
        })?;
        let end = self.lookahead.as_ref().map_or(self.t, |la| la.t1);
        self.cur.check_against(self.t, end, self.longest_step())
    }
}

/// The currents and the speed of a state within `b`.
fn check_dynamic(name: &str, x: &State, t: f64, b: &Bounds) -> Result<(), String> {
    for k in 0..3 {
        check(x[k].abs() <= b.current, || {
            format!(
                "{name}.[{k}] = {} (rule: a winding current |i| <= {} A, what the supply and the back-EMF drive through R, see BldcPlant::bounds)",
                x[k], b.current
            )
        })?;
    }
    check(x[OMEGA].abs() <= b.speed, || {
        format!(
            "{name}.[{OMEGA}] = {} (rule: a rotor speed |ωm| <= {} rad/s, the no-load speed at the largest supply and what the largest torques add since t = 0, see BldcPlant::bounds)",
            x[OMEGA], b.speed
        )
    })?;
    // The integrals since t = 0 of powers and torques within their bounds: the losses
    // (copper, switch, diode, shunt, friction) and ∫Te² dt never negative.
    for j in 0..super::INTEGRALS {
        let k = super::E_SUPPLY + j;
        let (rate, name_j) = match j {
            9 => (b.torque, "∫Te dt, |Te| <="),
            10 => (b.torque * b.torque, "∫Te² dt, Te² <="),
            _ => (b.power, "an energy, |P| <="),
        };
        let lim = rate * t;
        let signed = matches!(j, 1..=5 | 10);
        check(x[k].abs() <= lim && (!signed || x[k] >= 0.0), || {
            format!(
                "{name}.[{k}] = {} (rule: {name_j} {rate} for t = {t} s, so |x| <= {lim}{})",
                x[k],
                if signed { ", never negative" } else { "" }
            )
        })?;
    }
    Ok(())
}

/// A sine and cosine pair of one angle (they are carried from step to step).
fn unit_circle(name: &str, (s, c): (f64, f64)) -> Result<(), String> {
    check((s * s + c * c - 1.0).abs() < 1e-9, || {
        format!("{name} = ({s}, {c}) (rule: a sine and cosine, s² + c² = 1)")
    })
}

/// A state written as zeros, where a derivative that follows from the rest was kept.
fn zeros(name: &str, x: &State) -> Result<(), String> {
    match x.iter().position(|&v| v != 0.0) {
        None => Ok(()),
        Some(k) => Err(format!(
            "{name}.[{k}] = {} (rule: 0, as saved: the derivative follows from the state)",
            x[k]
        )),
    }
}

/// Within 1e-9 of `want`, relative above 1: what the run computed and what a restore
/// computes again from the same values agree to rounding (the sine and cosine carried by
/// rotations drift by less than 9e-12, see `bldc::ANCHOR`).
fn close(got: f64, want: f64) -> bool {
    (got - want).abs() <= 1e-9 * (1.0 + want.abs())
}

/// The bounds physics puts on a plant's state at time t \[s\], from its parameters (see
/// [`BldcPlant::bounds`]). Generous on purpose: a run reaches none of them, and a state
/// beyond them is no run's.
#[derive(Copy, Clone, Debug)]
pub(crate) struct Bounds {
    /// |ωm| [rad/s].
    pub(crate) speed: f64,
    /// |de_x/dt| [V/s].
    pub(crate) emf_rate: f64,
    /// |i_x| of each winding \[A\].
    pub(crate) current: f64,
    /// |Te| [N·m], and |P| of every power the energy integrals sum \[W\].
    pub(crate) torque: f64,
    pub(crate) power: f64,
    /// |v| of every terminal, the neutral, and the sensing filters they drive \[V\].
    pub(crate) volts: f64,
}

impl BldcPlant {
    /// The bounds of a state at time `t` \[s\] (see [`Bounds`]):
    ///
    /// - the bridge puts at most V = [`MAX_SUPPLY_V`] + 2·V_f across a winding (the supply
    ///   may be changed during a run, up to its rule's bound, and what it drove outlasts it);
    /// - the torque that speeds the rotor up is the load's largest, [`MAX_TORQUE_NM`],
    ///   and the motor's while motoring, at most three windings each carrying what V drives
    ///   through R: 3·(P/2)·λr·f̂·V/R (f̂ the back-EMF shape's peak); friction and the passive
    ///   load terms only brake. Over J (a load's inertia only adds to it) that is the
    ///   fastest acceleration, so from the no-load speed at V (the fastest a rotor is set
    ///   to: [`BldcPlant::set_rotor`]) the speed is within
    ///   |ωm| ≤ [`MAX_SUPPLY_V`]/((P/2)·λr) + a·t (an overhauling load spins a light rotor
    ///   far beyond its no-load speed: 6.6e6 rpm after 2 s at −1 N·m on the built-in one);
    /// - the back-EMF is within E = (P/2)·λr·f̂·|ωm|, and its rate
    ///   de/dt = (P/2)·λr·(α·f + ωm·ωe·f′) within (P/2)·λr·(a·f̂ + (P/2)·|ωm|²·f̂′) (f̂′ the
    ///   shape's steepest slope: 1, 1 + 3|h3| + 5|h5|, or 1/ramp);
    /// - a winding's current is what its voltage drives through its resistance (an RL
    ///   circuit's current never exceeds max |v|/R, whatever its inductance), the voltage
    ///   being the bridge's and the neutral's offset by a back-EMF, and its own back-EMF:
    ///   |i| ≤ 2·(V + 2E)/R, with a factor 2 for the integration's error;
    /// - a terminal lies between the rails widened by the drops of that current across a
    ///   switch, a diode and the shunt (three phase currents), the neutral within a
    ///   back-EMF of them, and the sensing filters within what drives them:
    ///   |v| ≤ V + (R_on + R_d + 3·R_sh)·|i|max + E;
    /// - the torque is within 3·(P/2)·λr·f̂·|i|max, and every power the energy integrals
    ///   sum within the electrical ones (supply, copper, switch, diode and shunt losses,
    ///   airgap) and the mechanical ones (the torque, friction and the largest load the
    ///   rules allow, [`Load::MAX`], at the speed bound) added up.
    pub(crate) fn bounds(&self, t: f64) -> Bounds {
        let m = &self.params.motor;
        let ps = &self.params.power_stage;
        let (peak, slope) = match self.shape {
            BackEmfShape::Sinusoidal => (1.0, 1.0),
            BackEmfShape::Harmonic { third, fifth } => (
                1.0 + third.abs() + fifth.abs(),
                1.0 + 3.0 * third.abs() + 5.0 * fifth.abs(),
            ),
            BackEmfShape::Trapezoidal { flat_top_deg } => (
                1.0,
                2.0 / (std::f64::consts::PI - flat_top_deg.to_radians()),
            ),
        };
        let kl = self.pp * self.lambda;
        let drive = MAX_SUPPLY_V + 2.0 * ps.diode_forward_v;
        let torque = MAX_TORQUE_NM + 3.0 * kl * peak * drive / m.resistance_ohm;
        let accel = torque / m.inertia_kgm2;
        let speed = MAX_SUPPLY_V / kl + accel * t.max(0.0);
        let emf = kl * peak * speed;
        let emf_rate = kl * (accel * peak + self.pp * speed * speed * slope);
        let current = 2.0 * (drive + 2.0 * emf) / m.resistance_ohm;
        let drops = ps.switch_on_resistance_ohm + ps.diode_resistance_ohm + 3.0 * ps.shunt_ohm;
        let te = 3.0 * kl * peak * current;
        let i = current;
        let electrical = 3.0 * i * (MAX_SUPPLY_V + ps.diode_forward_v + emf)
            + i * i * (3.0 * (m.resistance_ohm + drops) + 9.0 * ps.shunt_ohm);
        let l = Load::MAX;
        let drag = m.viscous_friction_nms * speed + m.coulomb_friction_nm;
        let load = l.active_nm + l.coulomb_nm + (l.viscous_nms + l.fan_nms2 * speed) * speed;
        Bounds {
            torque: te,
            power: electrical + (te + drag + load) * speed,
            speed,
            emf_rate,
            current,
            volts: drive + drops * current + emf,
        }
    }

    /// The restored state lies within its [`Bounds`]: the committed state and the step
    /// integrated ahead (the currents, the speed and the integrals; the angle is checked
    /// with the times), every angle kept with its sine and cosine is one, and the step
    /// integrated ahead starts at the committed state, at its angle (its derivative there
    /// is checked once the solution there is: `check_lookahead_derivative`).
    fn check_bounds(&self) -> Result<(), String> {
        let b = self.bounds(self.t);
        check_dynamic("x", &self.x, self.t, &b)?;
        // An angle a step reaches from 0..2π, before its wrap: kept with its sine and cosine.
        let reach = TAU + self.pp * b.speed * (self.h_max + TICK_S);
        let triple = |name: &str, (a, s, c): (f64, f64, f64)| {
            let (sa, ca) = a.sin_cos();
            check(a.abs() <= reach && close(s, sa) && close(c, ca), || {
                format!(
                    "{name} = ({a}, {s}, {c}) (rule: an angle within ±{reach} rad with its sine and cosine, within 1e-9)"
                )
            })
        };
        triple("base_hint", self.base_hint)?;
        if let Some(e) = self.end_angle {
            triple("end_angle", e)?;
        }
        if let Some(la) = &self.lookahead {
            if let Some(k) = (0..la.x0.len()).find(|&k| la.x0[k] != self.x[k]) {
                return Err(format!(
                    "lookahead.x0.[{k}] = {} (rule: the committed state's x.[{k}] = {}, where the step integrated ahead starts)",
                    la.x0[k], self.x[k]
                ));
            }
            check(la.base.0 == la.x0[THETA], || {
                format!(
                    "lookahead.base.0 = {} (rule: the angle of lookahead.x0, {})",
                    la.base.0, la.x0[THETA]
                )
            })?;
            triple("lookahead.base", la.base)?;
            check_dynamic("lookahead.x1", &la.x1, la.t1, &self.bounds(la.t1))?;
            let th = la.x1[THETA];
            check(th.abs() <= reach, || {
                format!(
                    "lookahead.x1.[{THETA}] = {th} (rule: an angle a step reaches from 0..2π, within ±{reach} rad)"
                )
            })?;
            triple("lookahead.sc1", (la.x1[THETA], la.sc1.0, la.sc1.1))?;
        }
        Ok(())
    }

    /// The step integrated ahead's derivative at its start, from the network's solution
    /// there (`start`, checked to be x0's first: see [`BldcPlant::check_solutions`]).
    fn check_lookahead_derivative(&self) -> Result<(), String> {
        let Some(la) = &self.lookahead else {
            return Ok(());
        };
        let f0 = self.end_derivative(&la.x0, &self.start, la.base);
        match (0..f0.len()).find(|&k| !close(la.f0[k], f0[k])) {
            None => Ok(()),
            Some(k) => Err(format!(
                "lookahead.f0.[{k}] = {} (rule: the derivative at lookahead.x0, {}, within 1e-9)",
                la.f0[k], f0[k]
            )),
        }
    }

    /// The network's solution at state `x` whose angle with its sine and cosine is
    /// `angle`, compared with the kept `sol` in every field (see [`close`]): the rates of
    /// the currents, terminal and neutral voltages, shunt current, the supply and airgap
    /// powers, and the losses, made (as a solve makes them) or not yet (marked so). The
    /// first field that differs, named with its value and the solution's.
    pub(crate) fn solution_differs(
        &self,
        x: &State,
        angle: (f64, f64, f64),
        sol: &Solution,
    ) -> Option<String> {
        let rule = |name: &str, got: f64, want: String| {
            Some(format!(
                "{name} = {got} (rule: the network's solution at the state, {want}, within 1e-9)"
            ))
        };
        if x.iter().any(|v| !v.is_finite()) {
            return rule("di.u", sol.di.u, "none: the state is not finite".into());
        }
        let f = emf::shape_with(&self.shape, angle.0, (angle.1, angle.2));
        let k = self.lambda * self.pp * x[OMEGA];
        let i = Self::currents(x);
        let plan = &self.form().2;
        let s = self
            .circuit
            .solve_planned_losses_later(plan, &self.modes, &i, &f.map(|v| k * v));
        let (p, q) = (&sol.powers, &s.powers);
        let made = if q.has_losses() {
            *q
        } else {
            self.circuit.with_losses(plan, &i, &s)
        };
        let fields = [
            ("di.u", sol.di.u, s.di.u),
            ("di.v", sol.di.v, s.di.v),
            ("di.w", sol.di.w, s.di.w),
            ("v_term.u", sol.v_term.u, s.v_term.u),
            ("v_term.v", sol.v_term.v, s.v_term.v),
            ("v_term.w", sol.v_term.w, s.v_term.w),
            ("v_n", sol.v_n, s.v_n),
            ("i_shunt", sol.i_shunt, s.i_shunt),
            ("powers.supply", p.supply, q.supply),
            ("powers.airgap", p.airgap, q.airgap),
        ];
        if let Some(&(name, got, want)) = fields.iter().find(|f| !close(f.1, f.2)) {
            return rule(name, got, want.to_string());
        }
        let losses = [
            ("powers.copper", p.copper, made.copper, q.copper),
            ("powers.switch", p.switch, made.switch, q.switch),
            ("powers.diode", p.diode, made.diode, q.diode),
            ("powers.shunt", p.shunt, made.shunt, q.shunt),
        ];
        if p.has_losses() {
            losses
                .iter()
                .find(|l| !close(l.1, l.2))
                .and_then(|&(name, got, want, _)| rule(name, got, want.to_string()))
        } else if q.has_losses() {
            rule("powers.copper", p.copper, format!("{}, made", q.copper))
        } else {
            losses
                .iter()
                .find(|l| l.1.to_bits() != l.3.to_bits())
                .and_then(|&(name, got, _, unmade)| {
                    rule(name, got, format!("{unmade}, not made yet"))
                })
        }
    }

    /// The longest step \[ticks\], with a tick to spare for rounding.
    fn longest_step(&self) -> u64 {
        Ticks::from_seconds(self.h_max).map_or(u64::MAX, |k| k.0 + 1)
    }

    /// The time, its tick and the step integrated ahead describe one instant, and no
    /// step is longer than the parameters allow.
    fn check_times(&self) -> Result<(), String> {
        let t = self.t;
        check((0.0..1e9).contains(&t), || {
            format!("t = {t} (rule: 0 <= t < 1e9 s)")
        })?;
        let k = self.tick.0;
        check((k.seconds() - t).abs() <= TICK_S, || {
            format!("tick = {} (rule: the tick of t = {t} s)", k.0)
        })?;
        check(self.reported <= k, || {
            format!(
                "reported = {} (rule: a clock edge reported by the plant's tick {})",
                self.reported.0, k.0
            )
        })?;
        let s = &self.stats;
        check_count("stats.steps", s.steps)?;
        check_count("stats.diode_events", s.diode_events)?;
        check_count("stats.retries", s.retries)?;
        check(
            self.x[super::THETA] >= 0.0 && self.x[super::THETA] < std::f64::consts::TAU,
            || {
                format!(
                    "x[{}] = {} (rule: an angle in 0..2π)",
                    super::THETA,
                    self.x[super::THETA]
                )
            },
        )?;
        if let Some(la) = &self.lookahead {
            let (slack, h) = (1e-12, self.h_max + TICK_S);
            check(la.t0 <= t + slack && t - la.t0 <= h, || {
                format!(
                    "lookahead.t0 = {} (rule: the start of a step around t = {t} s, at most the longest step {} s)",
                    la.t0, self.h_max
                )
            })?;
            check(t <= la.t1 + slack && la.t1 - la.t0 <= h, || {
                format!(
                    "lookahead.t1 = {} (rule: the end of a step around t = {t} s from lookahead.t0 = {} s, at most the longest step {} s)",
                    la.t1, la.t0, self.h_max
                )
            })?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::PlantParams;
    use drive_core::{Abc, Gates, Plant, Watch};

    fn running() -> BldcPlant {
        let mut pl = BldcPlant::new(PlantParams::default()).unwrap();
        pl.set_rotor(0.3, 2000.0, false);
        pl.set_gates(&Gates {
            high: Abc::from_fn(|p| p == drive_core::Phase::U),
            low: Abc::from_fn(|p| p == drive_core::Phase::V),
        });
        let watch = Watch {
            channels: Abc::splat(true),
            reads: Abc::splat(Ticks::ZERO),
            clock: Ticks(32),
            horizon: Ticks(4000),
        };
        while pl.advance(Ticks(1000), &watch) != drive_core::PlantStop::Reached {}
        pl
    }

    fn bytes(pl: &BldcPlant) -> Vec<u8> {
        pl.to_bytes().unwrap()
    }

    #[test]
    fn a_restored_plant_saves_the_same_bytes() {
        let pl = running();
        assert!(
            pl.lookahead.is_some(),
            "saved inside a step integrated ahead"
        );
        let b = bytes(&pl);
        let mut copy = BldcPlant::new(PlantParams::default()).unwrap();
        copy.restore_from(&b).unwrap();
        assert_eq!(bytes(&copy), b);
    }

    #[test]
    fn out_of_range_values_are_refused_naming_them() {
        let b = bytes(&running());
        let refuse = |at: usize, new: &[u8]| {
            let mut b = b.clone();
            b[at..at + new.len()].copy_from_slice(new);
            let mut pl = BldcPlant::new(PlantParams::default()).unwrap();
            pl.restore(&mut Reader::new(&b)).unwrap_err()
        };
        // The layout: x (16 floats), t, tick (u64 and a flag), gates (6 flags), modes.
        let e = refuse(3 * 8, &f64::INFINITY.to_bits().to_le_bytes());
        assert!(e.starts_with("x.[3] = inf") && e.contains("rule"), "{e}");
        let e = refuse(16 * 8, &(-1.0f64).to_bits().to_le_bytes());
        assert!(e.starts_with("t = -1") && e.contains("rule"), "{e}");
        let e = refuse(17 * 8, &u64::MAX.to_le_bytes());
        assert!(e.starts_with("tick") && e.contains("rule"), "{e}");
        let e = refuse(18 * 8 + 1 + 6, &[9]);
        assert!(
            e.starts_with("modes.u = 9") && e.contains("Conduction"),
            "{e}"
        );
    }

    #[test]
    fn finite_values_beyond_physics_are_refused_naming_them() {
        let pl = running();
        let b = bytes(&pl);
        let refuse = |at: usize, x: f64| {
            let mut b = b.clone();
            b[at..at + 8].copy_from_slice(&x.to_bits().to_le_bytes());
            let mut pl = BldcPlant::new(PlantParams::default()).unwrap();
            pl.restore(&mut Reader::new(&b)).unwrap_err()
        };
        let bound = pl.bounds(pl.t);
        // The built-in motor at 20 µs: the bounds are generous, but finite.
        assert!(bound.speed > 2e5 && bound.speed < 1e6, "{bound:?}");
        assert!(bound.current < 1e5 && bound.volts < 1e5, "{bound:?}");
        for x in [1e300, -1e30, 2.0 * bound.speed] {
            let e = refuse(OMEGA * 8, x);
            assert!(
                e.starts_with(&format!("x.[3] = {x} (rule: a rotor speed |ωm| <=")),
                "{e}"
            );
        }
        for x in [1e300, -1e300, 2.0 * bound.current] {
            let e = refuse(0, x);
            assert!(
                e.starts_with(&format!("x.[0] = {x} (rule: a winding current |i| <=")),
                "{e}"
            );
        }
        // The kept network solution at the state: x (16), t, tick (8 + 1), gates (6),
        // modes (3), load (5 floats), speed_lock (1), then start's di (3), v_term.u.
        let v_term_u = 16 * 8 + 8 + 9 + 6 + 3 + 5 * 8 + 1 + 3 * 8;
        let held = f64::from_bits(u64::from_le_bytes(
            b[v_term_u..v_term_u + 8].try_into().unwrap(),
        ));
        assert_eq!(held, pl.start.v_term.u, "the offset of start.v_term.u");
        for x in [1e300, held + 1e-3] {
            let e = refuse(v_term_u, x);
            assert!(
                e.starts_with(&format!(
                    "start.v_term.u = {x} (rule: the network's solution at the state, {held}"
                )),
                "{e}"
            );
        }
        // The sensing chains come last: the comparators' filter y.u first, then the
        // current sense's filter.
        let cur = pl.cur.to_bytes().unwrap().len();
        let cmp = b.len() - cur - pl.cmp.to_bytes().unwrap().len();
        for x in [1e30, -1e300] {
            let e = refuse(cmp, x);
            assert!(
                e.starts_with(&format!("cmp.front.y.u = {x} (rule: |y| <=")),
                "{e}"
            );
            let e = refuse(b.len() - cur, x);
            assert!(
                e.starts_with(&format!("cur.y = {x} (rule: within the amplifier's swing")),
                "{e}"
            );
        }
    }
}
