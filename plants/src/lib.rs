//! plants: the published BLDC motor, its six-switch bridge, and the sensing front end.
#![forbid(unsafe_code)]

pub mod bldc;
pub mod circuit;
pub mod emf;
pub mod load;
pub mod modal;
pub mod params;
pub mod sensing;

pub use bldc::{BldcPlant, EnergyLedger, Observation, PlantStats};
pub use circuit::Conduction;
pub use load::Load;
pub use params::{
    BackEmfShape, ComparatorParams, CurrentSenseParams, MotorParams, PlantParams, PowerStageParams,
    SensingParams, SolverParams,
};
