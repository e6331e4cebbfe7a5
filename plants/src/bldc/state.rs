//! The plant's dynamic state by value (see [`drive_core::state`]): the state vector,
//! time, gates, conduction, load, the step integrated ahead and the sensing chains. The
//! parameters, the network's forms and what follows from the load are never read back.

use super::{BldcPlant, Lookahead, State};
use crate::circuit::{self, Conduction, Powers, Solution};
use crate::load::Load;
use drive_core::state::{Persist, Reader, Writer, check};
use drive_core::{TICK_S, Ticks, persist_enum, persist_fields};

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
        self.load
            .validate()
            .map_err(|e| format!("{} = {} (rule: {})", e.field, e.value, e.rule))?;
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
        // A derivative saved for another state than the committed one is not used.
        self.fsal = some && x == self.x;
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
        check(self.start_is_fresh(), || {
            "start (rule: the network's solution at the restored state, within 1e-9)".into()
        })?;
        r.field("cmp", &mut self.cmp)?;
        r.field("cur", &mut self.cur)?;
        self.cmp.check_against(self.tick.0.0, self.longest_step())?;
        self.cur.check_against(self.t, self.longest_step())
    }
}

/// A sine and cosine pair of one angle (they are carried from step to step).
fn unit_circle(name: &str, (s, c): (f64, f64)) -> Result<(), String> {
    check((s * s + c * c - 1.0).abs() < 1e-9, || {
        format!("{name} = ({s}, {c}) (rule: a sine and cosine, s² + c² = 1)")
    })
}

impl BldcPlant {
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
            let slack = 1e-12;
            check(
                la.t0 <= t + slack && t <= la.t1 + slack && la.t1 - la.t0 <= self.h_max + TICK_S,
                || {
                    format!(
                        "lookahead from {} s to {} s (rule: around t = {t} s, at most the longest step {} s)",
                        la.t0, la.t1, self.h_max
                    )
                },
            )?;
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
}
