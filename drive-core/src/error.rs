//! Parameter validation errors shared by every crate.

/// A parameter that breaks its rule. `field` is the dotted config path (`motor.resistance_ohm`).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("invalid parameter `{field}` = {value}: {rule}")]
pub struct ParamError {
    /// Dotted path of the offending field.
    pub field: String,
    /// The value that was given, as written in a config file.
    pub value: String,
    /// The rule it breaks.
    pub rule: &'static str,
}

impl ParamError {
    /// Builds an error for `field`.
    pub fn new(
        field: impl Into<String>,
        value: impl std::fmt::Display,
        rule: &'static str,
    ) -> Self {
        ParamError {
            field: field.into(),
            value: value.to_string(),
            rule,
        }
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
    if value.is_finite() && value >= min && value <= max {
        Ok(())
    } else {
        Err(ParamError::new(field, value, rule))
    }
}

/// Checks that `value` is finite and strictly positive.
pub fn check_positive(field: &str, value: f64) -> Result<(), ParamError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(ParamError::new(field, value, "must be finite and > 0"))
    }
}

/// Checks that `value` is finite, > 0 and <= `max`, naming `field` and `rule` otherwise.
pub fn check_positive_max(
    field: &str,
    value: f64,
    max: f64,
    rule: &'static str,
) -> Result<(), ParamError> {
    if value.is_finite() && value > 0.0 && value <= max {
        Ok(())
    } else {
        Err(ParamError::new(field, value, rule))
    }
}

/// Checks that `value` is finite and not negative.
pub fn check_non_negative(field: &str, value: f64) -> Result<(), ParamError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(ParamError::new(field, value, "must be finite and >= 0"))
    }
}
