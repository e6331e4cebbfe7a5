//! What the controller can sense: shunt current through an ADC, and phase-vs-neutral
//! comparators with a realistic front end.

pub mod comparator;
pub mod current;
pub mod foh;
pub mod noise;
pub mod rc;
mod tick_powers;

pub use comparator::{ComparatorBank, Knot};
pub use current::CurrentSense;
