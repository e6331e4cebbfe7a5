//! fmu: the complete drive as an FMI 2.0 co-simulation FMU (`bldc_drive`).
//!
//! Layers: [`variables`] (the one table of variables) → [`model`] and [`drive`] (the safe
//! core: state machine, values, exact tick clock, input record) → [`state`] (FMU state
//! bytes) → [`ffi`] and [`exports`] (C types, logger, the 34 `fmi2*` functions).
//! [`xml`] writes `modelDescription.xml` and the GUID from the same table, [`docs`] the
//! variables table of docs/fmu-variables.md.
// The C boundary needs raw pointers; every unsafe block says why it holds (SAFETY lines).
#![allow(unsafe_code)]

pub mod docs;
pub mod drive;
pub mod exports;
pub mod ffi;
pub mod model;
pub mod state;
/// The variable table, kept in the library (`drive-bench config` reads it too).
pub use bldc_drive::variables;
pub mod xml;
