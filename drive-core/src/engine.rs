//! The simulation engine: owns time, schedules every discrete instant, integrates the plant
//! between them.
//!
//! Discrete instants are whole master ticks: controller clock edges, PWM edges, dead-time
//! releases, trace samples. Between two of them the plant integrates continuously and may
//! stop early for a diode event or a watched comparator change. Each call to
//! [`Engine::step`] reports why it stopped. The step loop allocates nothing.

use crate::bridge::{Gates, ShootThrough};
use crate::control::{Command, Controller};
use crate::gate_driver::GateDriver;
use crate::plant::{Plant, PlantStop};
use crate::pwm::{Carrier, PwmScheme};
use crate::time::Ticks;

/// Why a step ended.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum StopReason {
    /// The controller ran at one of its clock edges.
    ControllerTick,
    /// The PWM output changed.
    PwmEdge,
    /// A delayed turn-on (dead time) took effect.
    DeadTime,
    /// A diode started or stopped conducting (between ticks).
    Diode,
    /// A watched comparator output changed; the controller runs at its next clock edge.
    Sensing,
    /// A requested sampling instant (see [`Engine::set_sample_period`]).
    Sample,
    /// The requested end time was reached.
    End,
}

/// Errors that stop the engine.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EngineError {
    /// The controller asked for a pattern that shorts a leg; it is refused, never simulated.
    #[error("at t = {time_s} s the controller commanded a shoot-through: {source}")]
    ShootThrough {
        /// When it was commanded [s].
        time_s: f64,
        /// Which leg.
        source: ShootThrough,
    },
}

/// Plant + controller + PWM scheme on one master clock.
pub struct Engine<P, C, S> {
    /// The continuous system.
    pub plant: P,
    /// The controller (strategy).
    pub controller: C,
    scheme: S,
    carrier: Carrier,
    driver: GateDriver,
    now: Ticks,
    cmd: Command,
    pwm_on: bool,
    wake: Ticks,
    sample_period: Ticks,
    started: bool,
}

impl<P: Plant, C: Controller, S: PwmScheme> Engine<P, C, S> {
    /// Assembles an engine at t = 0 with the bridge off; the controller first runs at t = 0.
    pub fn new(plant: P, controller: C, scheme: S, carrier: Carrier, dead_time: Ticks) -> Self {
        Engine {
            plant,
            controller,
            scheme,
            carrier,
            driver: GateDriver::new(dead_time),
            now: Ticks::ZERO,
            cmd: Command::OFF,
            pwm_on: false,
            wake: Ticks::ZERO,
            sample_period: Ticks::NEVER,
            started: false,
        }
    }

    /// Adds a stop at every multiple of `period` (for traces); `Ticks::NEVER` disables it.
    pub fn set_sample_period(&mut self, period: Ticks) {
        self.sample_period = if period.0 == 0 { Ticks::NEVER } else { period };
    }

    /// The last engine instant (a whole tick).
    pub fn now(&self) -> Ticks {
        self.now
    }

    /// The command in force.
    pub fn command(&self) -> &Command {
        &self.cmd
    }

    /// Whether the PWM output is on.
    pub fn pwm_on(&self) -> bool {
        self.pwm_on
    }

    /// The gates the bridge sees (after dead time).
    pub fn gates(&self) -> Gates {
        self.driver.effective()
    }

    /// The PWM carrier.
    pub fn carrier(&self) -> &Carrier {
        &self.carrier
    }

    /// Advances to the next stop, never beyond `end`.
    pub fn step(&mut self, end: Ticks) -> Result<StopReason, EngineError> {
        if !self.started {
            self.started = true;
            return self.act(self.now, true, false).map(|_| StopReason::ControllerTick);
        }
        if self.now >= end {
            return Ok(StopReason::End);
        }
        let pwm_edge = self.carrier.next_edge(self.now, self.cmd.duty).unwrap_or(Ticks::NEVER);
        let release = self.driver.next_release();
        let sample = if self.sample_period == Ticks::NEVER {
            Ticks::NEVER
        } else {
            Ticks(self.now.0 + 1).next_edge(self.sample_period)
        };
        let target = end.min(pwm_edge).min(self.wake).min(release).min(sample);
        match self.plant.advance(target, self.cmd.watch) {
            PlantStop::Diode => Ok(StopReason::Diode),
            PlantStop::Sensing(at) => {
                self.wake = self.wake.min(at.next_edge(self.controller.clock()));
                Ok(StopReason::Sensing)
            }
            PlantStop::Reached => {
                self.now = target;
                let tick = target == self.wake;
                let released = target == release;
                self.act(target, tick, released)?;
                Ok(if tick {
                    StopReason::ControllerTick
                } else if target == pwm_edge {
                    StopReason::PwmEdge
                } else if released {
                    StopReason::DeadTime
                } else if target == sample {
                    StopReason::Sample
                } else {
                    StopReason::End
                })
            }
        }
    }

    /// Steps until `end`, calling `on_step` after every stop.
    pub fn run_until(&mut self, end: Ticks, mut on_step: impl FnMut(&Self, StopReason)) -> Result<(), EngineError> {
        loop {
            let r = self.step(end)?;
            on_step(self, r);
            if r == StopReason::End {
                return Ok(());
            }
        }
    }

    /// Everything due at instant `t`: controller tick, PWM state, gate-driver releases.
    fn act(&mut self, t: Ticks, tick: bool, released: bool) -> Result<(), EngineError> {
        if tick {
            let sensed = self.plant.sensed(t);
            self.cmd = self.controller.tick(t, &sensed);
            let clock = self.controller.clock();
            let asked = self.cmd.wake_at.max(Ticks(t.0 + 1));
            self.wake = if self.cmd.wake_at == Ticks::NEVER { Ticks::NEVER } else { asked.next_edge(clock) };
        }
        self.pwm_on = self.carrier.is_on(t, self.cmd.duty);
        let before = self.driver.effective();
        let commanded = self.scheme.gates(&self.cmd.pattern, self.pwm_on);
        self.driver
            .command(t, commanded)
            .map_err(|source| EngineError::ShootThrough { time_s: t.seconds(), source })?;
        if released {
            self.driver.release(t);
        }
        let after = self.driver.effective();
        if after != before {
            self.plant.set_gates(&after);
        }
        Ok(())
    }
}
