//! Parameter validation errors shared by every crate.
//!
//! [`ParamError`] is the one wording of a refused value, whatever door it came through
//! (command line, config or scenario file, Python, FMU): `` `key` = value (rule: …) ``.

use std::borrow::Cow;

/// A parameter that breaks its rule. `field` is the dotted config path (`motor.resistance_ohm`).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("`{field}` = {value} (rule: {rule})")]
pub struct ParamError {
    /// Dotted path of the offending field.
    pub field: String,
    /// The value that was given, as written in a config file.
    pub value: String,
    /// The rule it breaks.
    pub rule: Cow<'static, str>,
}

/// The rule of every number that is NaN or infinite, checked before any other: such a
/// value is not out of a range, it is no number at all.
pub const NOT_FINITE: &str = "must be finite";

impl ParamError {
    /// Builds an error for `field`; a number is written as Rust writes an `f64` (`NaN`,
    /// `inf`, `0.001`), the same from every door.
    pub fn new(
        field: impl Into<String>,
        value: impl std::fmt::Display,
        rule: impl Into<Cow<'static, str>>,
    ) -> Self {
        ParamError {
            field: field.into(),
            value: value.to_string(),
            rule: rule.into(),
        }
    }
}

/// Checks that `value` is finite, naming `field` otherwise.
pub fn check_finite(field: &str, value: f64) -> Result<(), ParamError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(ParamError::new(field, value, NOT_FINITE))
    }
}

/// Checks that `value` is finite and in `[min, max]`, naming `field` otherwise.
pub fn check_range(
    field: &str,
    value: f64,
    min: f64,
    max: f64,
    rule: &'static str,
) -> Result<(), ParamError> {
    check_finite(field, value)?;
    if value >= min && value <= max {
        Ok(())
    } else {
        Err(ParamError::new(field, value, rule))
    }
}

/// Checks that `value` is finite and strictly positive.
pub fn check_positive(field: &str, value: f64) -> Result<(), ParamError> {
    check_finite(field, value)?;
    if value > 0.0 {
        Ok(())
    } else {
        Err(ParamError::new(field, value, "must be > 0"))
    }
}

/// Checks that `value` is finite, > 0 and <= `max`, naming `field` and `rule` otherwise.
pub fn check_positive_max(
    field: &str,
    value: f64,
    max: f64,
    rule: &'static str,
) -> Result<(), ParamError> {
    check_finite(field, value)?;
    if value > 0.0 && value <= max {
        Ok(())
    } else {
        Err(ParamError::new(field, value, rule))
    }
}

/// Checks that `value` is finite and not negative.
pub fn check_non_negative(field: &str, value: f64) -> Result<(), ParamError> {
    check_finite(field, value)?;
    if value >= 0.0 {
        Ok(())
    } else {
        Err(ParamError::new(field, value, "must be >= 0"))
    }
}
