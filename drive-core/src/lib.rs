//! drive-core: the traits that separate plant, PWM scheme and controller, and the engine
//! that runs them on the chip's 20 ns master clock.
#![forbid(unsafe_code)]

pub mod abc;
pub mod bridge;
pub mod control;
pub mod engine;
pub mod error;
pub mod gate_driver;
pub mod plant;
pub mod pwm;
pub mod state;
pub mod time;

pub use abc::{Abc, Phase};
pub use bridge::{GateMask, Gates, LegState, Pattern, SIX_STEP_120, ShootThrough, floating_phase};
pub use control::{Command, Controller, Hold, OpenLoopSixStep, Sensed};
pub use engine::{Engine, EngineError, StopReason};
pub use error::ParamError;
pub use plant::{Plant, PlantStop, Watch};
pub use pwm::{Carrier, DutyCounts, PwmScheme};
pub use state::{Persist, Reader, Writer};
pub use time::{TICK_S, Ticks, clocks};
