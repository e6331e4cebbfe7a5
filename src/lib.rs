//! bldc-drive: simulation of sensorless brushless-DC motor drives.
//!
//! A facade over the workspace crates: [`drive_core`] (engine and traits), [`plants`]
//! (motor, bridge, sensing) and [`strategies`] (commutation strategies), plus the whole
//! drive's TOML [`config`] and a [`drive`] builder; one run named by its inputs is a
//! [`case`], and many of them a [`sweep`].
#![forbid(unsafe_code)]

pub mod bench;
pub mod case;
pub mod config;
pub mod drive;
pub mod metrics;
pub mod plots;
pub mod profile;
pub mod scenario;
pub mod scenario_file;
pub mod sweep;
pub mod tune;
pub mod variables;
pub mod verdict;

pub use config::{ConfigError, DriveConfig};
pub use drive_core;
pub use plants;
pub use strategies;
