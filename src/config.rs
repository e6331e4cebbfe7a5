//! The whole drive in one TOML document: `[motor]`, `[power_stage]`, `[sensing]`,
//! `[solver]` (plant), `[control]` and `[strategy]` (chip). Every key is optional and
//! defaults to the documented value; unknown keys and broken rules are errors that name
//! the key.

use drive_core::error::ParamError;
use plants::{MotorParams, PlantParams, PowerStageParams, SensingParams, SolverParams};
use serde::{Deserialize, Serialize};
use strategies::{ControlParams, StrategyParams};

/// Plant + chip configuration.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DriveConfig {
    /// Motor (docs/model.md).
    pub motor: MotorParams,
    /// Bridge and supply (docs/model.md).
    pub power_stage: PowerStageParams,
    /// Current sense and comparators (docs/model.md).
    pub sensing: SensingParams,
    /// Plant integrator.
    pub solver: SolverParams,
    /// Speed/current control, start-up, supervision (docs/chip.md).
    pub control: ControlParams,
    /// Commutation strategy and zero-crossing guard (docs/chip.md).
    pub strategy: StrategyParams,
}

/// A config that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// Not valid TOML, an unknown key, or a value of the wrong type.
    #[error("config: {0}")]
    Parse(#[from] toml::de::Error),
    /// A value that breaks its rule.
    #[error("config: {0}")]
    Param(#[from] ParamError),
}

impl DriveConfig {
    /// Parses and validates a TOML document.
    pub fn from_toml(text: &str) -> Result<Self, ConfigError> {
        let c: DriveConfig = toml::from_str(text)?;
        c.validate()?;
        Ok(c)
    }

    /// Builds and validates a config from a table of keys, as a config file's: an error
    /// names the key's path (a table has no lines to point at).
    pub fn from_table(table: toml::Table) -> Result<Self, ConfigError> {
        let c: DriveConfig = toml::Value::Table(table).try_into()?;
        c.validate()?;
        Ok(c)
    }

    /// Reads and validates the config file at `path`; an error names the file.
    pub fn from_file(path: &std::path::Path) -> Result<Self, String> {
        let named = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
        let text = std::fs::read_to_string(path).map_err(|e| named(&e))?;
        Self::from_toml(&text).map_err(|e| named(&e))
    }

    /// The config as a TOML document (every key, with its value).
    pub fn to_toml(&self) -> String {
        // Serialising plain structs of numbers, strings and tables cannot fail.
        toml::to_string(self).unwrap_or_default()
    }

    /// [`DriveConfig::to_toml`] with each key's unit, bounds and meaning as a comment,
    /// from the variable table ([`crate::variables`]): what `drive-bench config` prints.
    pub fn to_toml_documented(&self) -> String {
        crate::variables::documented::to_toml_documented(self)
    }

    /// The config as a JSON object: the keys and values of [`DriveConfig::to_toml`].
    pub fn to_json(&self) -> String {
        // Through a TOML table, so that an absent option is left out rather than null.
        let table = toml::Table::try_from(self).unwrap_or_default();
        serde_json::to_string(&table).unwrap_or_default()
    }

    /// Checks every rule of every section.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.plant_params().validate()?;
        self.control.validate()?;
        self.strategy.validate()?;
        self.check_current_limit()
    }

    /// The current loop limits only what it can read: a limit at or above the current
    /// sense's full scale (amplifier swing or ADC range, whichever is lower, over gain ×
    /// shunt) reads as a clipped value that never exceeds it, and the loop stops limiting.
    fn check_current_limit(&self) -> Result<(), ParamError> {
        let s = &self.sensing.current;
        let full_scale_a = s.amplifier_max_v.min(s.adc_full_scale_v)
            / (s.amplifier_gain * self.power_stage.shunt_ohm);
        if self.control.current_limit_a < full_scale_a {
            Ok(())
        } else {
            Err(ParamError::new(
                "control.current_limit_a",
                self.control.current_limit_a,
                format!(
                    "must be below the current sense's full scale, \
                     min(sensing.current.amplifier_max_v, sensing.current.adc_full_scale_v) / \
                     (sensing.current.amplifier_gain · power_stage.shunt_ohm), here {full_scale_a} A \
                     (0.5 A by default)"
                ),
            ))
        }
    }

    /// The plant's part.
    pub fn plant_params(&self) -> PlantParams {
        PlantParams {
            motor: self.motor.clone(),
            power_stage: self.power_stage.clone(),
            sensing: self.sensing.clone(),
            solver: self.solver.clone(),
        }
    }
}
