//! The library's integration tests, one module per subject, in one test binary: each
//! binary links the whole library and instantiates the engine anew, and one binary runs
//! its tests on every core where two dozen ran one after another. Run one subject with
//! `cargo test --test integration cli::`. `plugins` and `no_alloc` stay binaries of their
//! own: the first steers a plugin through the process environment, the second counts the
//! process's allocations.

#[path = "../common/mod.rs"]
mod common;

mod calibrate;
mod cli;
mod closed_loop;
mod comparator_glitches;
mod config;
mod declared_reads;
mod docs;
mod drive_clone;
mod floor_drift;
mod fork;
mod load_models;
mod lookahead;
mod params_validation;
mod plant_physics;
mod quiet_loops;
mod range_tops;
mod scenarios;
mod sensitivity;
mod startup;
mod startup_resistance;
mod step_down;
mod step_fidelity;
mod stop;
mod summary;
mod verdicts;
