//! strategies: commutation strategies as [`drive_core::Controller`] implementations.
//!
//! The chip's 120° six-step and 150° twelve-step strategies arrive with their own issue;
//! this crate holds the pieces they share.
#![forbid(unsafe_code)]
