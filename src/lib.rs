//! bldc-drive: simulation of sensorless brushless-DC motor drives.
//!
//! A facade over the workspace crates: [`drive_core`] (engine and traits), [`plants`]
//! (motor, bridge, sensing) and [`strategies`] (commutation strategies).
#![forbid(unsafe_code)]

pub use drive_core;
pub use plants;
pub use strategies;
