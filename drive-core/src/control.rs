//! The controller side of the engine: what a strategy reads and what it returns.

use crate::abc::Abc;
use crate::bridge::{ALL_FLOAT, Pattern, SIX_STEP_120, floating_phase};
use crate::pwm::DutyCounts;
use crate::time::Ticks;

/// Signals a controller can read at one of its clock edges.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct Sensed {
    /// Comparator outputs u_d, v_d, w_d (true: terminal above neutral), as seen at the
    /// controller's input, i.e. after the comparators' propagation delay.
    pub zc: Abc<bool>,
    /// Latest completed ADC conversion of the shunt-current channel \[codes\].
    pub current_code: u16,
}

/// What a controller returns at each of its ticks. It never touches the bridge itself.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Command {
    /// Leg states to apply (the PWM scheme turns them into gates).
    pub pattern: Pattern,
    /// Voltage command in carrier counts (duty = cv / carrier top).
    pub duty: DutyCounts,
    /// Comparator channels whose changes must wake the controller at its next clock edge.
    pub watch: Abc<bool>,
    /// The next instant the controller must run even if no watched input changes
    /// ([`Ticks::NEVER`] for none). Rounded up to the controller's clock by the engine.
    pub wake_at: Ticks,
}

impl Command {
    /// Everything off, nothing watched, no wake-up.
    pub const OFF: Command = Command {
        pattern: ALL_FLOAT,
        duty: 0,
        watch: Abc::splat(false),
        wake_at: Ticks::NEVER,
    };
}

/// A clocked controller (commutation strategy, speed/current control, supervision).
///
/// Contract: the engine calls [`Controller::tick`] only on edges of [`Controller::clock`],
/// at least at every edge where a watched comparator output has changed since the previous
/// call and at every edge the controller asked for through `wake_at`. Between calls the
/// inputs it watches are constant, so a controller that models a chip clocked at every edge
/// must catch up from `now` (counters advance by the number of elapsed edges). This is what
/// lets a 0.64 µs clock run without simulating every edge.
pub trait Controller {
    /// Clock period in master ticks (e.g. 32 = 0.64 µs).
    fn clock(&self) -> Ticks;

    /// Runs the controller at the clock edge `now` with the signals it sees there.
    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command;

    /// Why the controller cannot go on (e.g. a plugin that failed or returned a command
    /// the host refused). The engine stops with an error after a tick that set it.
    fn fault(&self) -> Option<&str> {
        None
    }
}

impl<C: Controller + ?Sized> Controller for &mut C {
    fn clock(&self) -> Ticks {
        (**self).clock()
    }
    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command {
        (**self).tick(now, sensed)
    }
    fn fault(&self) -> Option<&str> {
        (**self).fault()
    }
}

impl<C: Controller + ?Sized> Controller for Box<C> {
    fn clock(&self) -> Ticks {
        (**self).clock()
    }
    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command {
        (**self).tick(now, sensed)
    }
    fn fault(&self) -> Option<&str> {
        (**self).fault()
    }
}

/// A controller that holds one command forever (tests, locked-rotor runs, coasting).
#[derive(Copy, Clone, Debug)]
pub struct Hold(pub Command);

impl Controller for Hold {
    fn clock(&self) -> Ticks {
        Ticks(1)
    }
    fn tick(&mut self, _now: Ticks, _sensed: &Sensed) -> Command {
        Command {
            wake_at: Ticks::NEVER,
            ..self.0
        }
    }
}

/// Open-loop six-step stepping: the 120° table advanced every `step` ticks at a fixed duty,
/// the way a drive is started before back-EMF can be sensed. It watches the floating
/// phase's comparator and counts the edges it sees (an observer of the crossings).
#[derive(Copy, Clone, Debug)]
pub struct OpenLoopSixStep {
    /// Ticks per 60° state.
    pub step: Ticks,
    /// Voltage command [carrier counts].
    pub duty: crate::pwm::DutyCounts,
    /// Table index of the first state (0 = state 1).
    pub first_state: usize,
    /// Controller clock (default 0.64 µs).
    pub clock: Ticks,
    last: Option<(usize, bool)>,
    /// Floating-phase comparator edges seen so far.
    pub zc_edges: u64,
}

impl OpenLoopSixStep {
    /// Steps every `step` ticks at `duty`, starting in table index `first_state`.
    pub fn new(step: Ticks, duty: crate::pwm::DutyCounts, first_state: usize) -> Self {
        OpenLoopSixStep {
            step,
            duty,
            first_state,
            clock: crate::time::clocks::COMMUTATION,
            last: None,
            zc_edges: 0,
        }
    }

    /// Table index (0..5) in force at `now`.
    pub fn state_at(&self, now: Ticks) -> usize {
        let n = now.0.checked_div(self.step.0).unwrap_or(0);
        ((self.first_state as u64 + n) % 6) as usize
    }
}

impl Controller for OpenLoopSixStep {
    fn clock(&self) -> Ticks {
        self.clock
    }

    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command {
        let k = self.state_at(now);
        let pattern = SIX_STEP_120[k];
        let floating = floating_phase(&pattern);
        let level = floating.map(|x| sensed.zc.get(x)).unwrap_or(false);
        if let Some((k0, l0)) = self.last {
            if k0 == k && l0 != level {
                self.zc_edges += 1;
            }
        }
        self.last = Some((k, level));
        let watch = Abc::from_fn(|x| Some(x) == floating);
        let next = now
            .0
            .checked_div(self.step.0)
            .map_or(Ticks::NEVER, |n| Ticks((n + 1) * self.step.0));
        Command {
            pattern,
            duty: self.duty,
            watch,
            wake_at: next,
        }
    }
}
