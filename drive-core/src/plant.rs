//! The plant side of the engine: motor + bridge + sensing as one continuous system.

use crate::abc::Abc;
use crate::bridge::Gates;
use crate::control::Sensed;
use crate::time::Ticks;

/// Why [`Plant::advance`] returned.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum PlantStop {
    /// The requested instant was reached.
    Reached,
    /// A diode started or stopped conducting (at a time between ticks); integration
    /// restarted there with the new conduction state.
    Diode,
    /// A watched comparator output changed (after propagation delay); this is the clock edge
    /// at which the controller samples it, and the plant stopped there.
    Sensing(Ticks),
}

/// Which comparator outputs must wake the controller, and the clock that samples them.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Watch {
    /// Channels whose changes matter.
    pub channels: Abc<bool>,
    /// From which instant each channel is read at the controller's ticks besides the
    /// watched ones (see [`crate::Command::reads`]): the plant may leave a channel
    /// undecided until then (see [`crate::Sensed`]).
    pub reads: Abc<Ticks>,
    /// Sampling clock period: a change is reported at the first clock edge at or after it.
    pub clock: Ticks,
    /// The next instant at which the engine already knows the gates will change (PWM edge,
    /// dead-time release, the controller's planned change). Only a hint: the plant may
    /// integrate ahead up to it and serve earlier instants from that step, since a
    /// controller tick usually changes nothing. Whatever changes the dynamics sooner
    /// (`set_gates`, load, rotor) still takes effect exactly at its instant.
    pub horizon: Ticks,
}

/// Continuous dynamics driven by six gate signals and a load torque, producing the
/// signals a controller senses.
pub trait Plant {
    /// Plant time \[s\]. Equals an engine tick instant except right after a diode event.
    fn time_s(&self) -> f64;

    /// Applies the effective gate states from the current instant on.
    fn set_gates(&mut self, gates: &Gates);

    /// Integrates up to the instant `until`, stopping early at a diode event or at the clock
    /// edge that samples a change of a watched comparator output. A change is reported once;
    /// reporting it again is allowed (it only costs an extra controller tick).
    /// `watch` by reference: the engine keeps it, and a copy per step costs more than the
    /// plant's reads of it.
    fn advance(&mut self, until: Ticks, watch: &Watch) -> PlantStop;

    /// What a controller sampling at instant `at` (not later than the plant time) sees.
    fn sensed(&self, at: Ticks) -> Sensed;
}
