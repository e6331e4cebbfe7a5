//! strategies: the chip's commutation strategies as [`drive_core::Controller`]s.
//!
//! The chip ([`Chip`]) is composed of small parts, each testable against the published chip on its own:
//! the commutation [`table`]s, the phase [`shifter`], the zero-crossing [`guard`]s and the
//! digital [`filter`], the FG [`speed`] meter, the [`pi`] controllers, the plausibility
//! [`supervisor`], and the start-up and supervision logic in [`chip`]. [`params`] holds the `[control]` and `[strategy]` config.
#![deny(unsafe_code)] // allowed only in `plugin`, the C boundary

pub mod chip;
pub mod filter;
pub mod guard;
pub mod params;
pub mod pi;
#[allow(unsafe_code)]
pub mod plugin;
pub mod shifter;
pub mod speed;
pub mod strategy;
pub mod supervisor;
pub mod table;

pub use chip::{Chip, ChipStatus, Mode};
pub use params::{ControlParams, GuardKind, StrategyName, StrategyParams, UnknownStrategy};
pub use plugin::{PluginError, PluginLibrary, PluginStrategy};
pub use strategy::Strategy;
pub use table::Table;
