//! Scenario files: a whole experiment in one TOML document, read by
//! `drive-bench run --scenario FILE` and by [`ScenarioFile::from_toml`].
//!
//! ```toml
//! description = "speed step under a fan load"
//! strategy = "twelve-step-df"        # optional: the config's strategy
//! duration_s = 5.0                   # required
//! steady_from_s = 4.0                # optional: the last third, at least 0.5 s
//! seed = 7                           # optional: the config's sensing.seed
//! speed_rpm = [[0, 3000], [2, 3000], [2, 6000]]   # required, a profile
//! supply_v = [[0, 12], [3, 12], [3.05, 10.8]]      # optional profile: the config's
//! profile_update_s = 1e-3            # optional: stair of the ramps
//! torque_lowpass_hz = 2000           # optional: cut-off of the vibration figure
//!
//! [load]                             # optional: no load (see `LoadProfile`)
//! fan_nms2 = 2e-10
//! coulomb_nm = [[0, 0], [3, 0], [3, 1e-3]]
//!
//! [config.motor]                     # optional overrides of the drive config
//! resistance_ohm = 2.4
//! ```
//!
//! Profiles are described in [`crate::profile`]. The `[config]` table takes the sections
//! and keys of a config file (`drive-bench config` prints them all); it overrides the base
//! config key by key. Unknown keys are errors, as are values that break their rule.

use crate::config::{ConfigError, DriveConfig};
use crate::profile::{LoadProfile, Profile};
use crate::scenario::{Scenario, Summary};
use serde::{Deserialize, Serialize};
use strategies::{PluginLibrary, StrategyName};

/// A scenario file as written. Build the [`Scenario`] with [`ScenarioFile::scenario`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    /// What the experiment is for (free text).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub description: String,
    /// Strategy name: built in (`drive-bench list`) or a loaded plugin's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strategy: Option<String>,
    /// Simulated time \[s\].
    pub duration_s: f64,
    /// Start of the steady-state window \[s\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steady_from_s: Option<f64>,
    /// Comparator-noise seed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Speed command \[rpm\].
    pub speed_rpm: Profile,
    /// Supply V_DD \[V\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supply_v: Option<Profile>,
    /// Stair length of the profiles' ramps \[s\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile_update_s: Option<f64>,
    /// Cut-off of the low-frequency torque ripple \[Hz\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub torque_lowpass_hz: Option<f64>,
    /// The driven machine.
    #[serde(default)]
    pub load: LoadProfile,
    /// Overrides of the drive config, as in a config file.
    #[serde(default, skip_serializing_if = "toml::Table::is_empty")]
    pub config: toml::Table,
}

/// One run as JSON (`drive-bench run --json`): what produced it, completely enough to
/// run it again, and what it gave.
#[derive(Clone, Debug, Serialize)]
pub struct RunRecord {
    /// Version of this layout; it changes when a key changes meaning or goes away.
    pub schema_version: u32,
    /// The program and its version.
    pub tool: String,
    /// The complete scenario: every config key, the seed, the profiles.
    pub scenario: ScenarioFile,
    /// The run's summary (see [`Summary`] for every figure's unit and window).
    pub summary: Summary,
}

impl RunRecord {
    /// The present layout.
    pub const SCHEMA_VERSION: u32 = 1;

    /// The record of a run of `sc` that gave `summary`: what `drive-bench run --json`
    /// writes and `bldc_drive.simulate` returns.
    pub fn of(sc: &Scenario, summary: Summary) -> Self {
        Self::new(ScenarioFile::of(sc), summary)
    }

    /// The record as JSON, as `drive-bench run --json` writes it.
    pub fn to_json(&self) -> String {
        // Plain structs of numbers and strings always serialise.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// A record of `summary`, produced by `scenario`.
    pub fn new(scenario: ScenarioFile, summary: Summary) -> Self {
        RunRecord {
            schema_version: Self::SCHEMA_VERSION,
            tool: format!("drive-bench {}", env!("CARGO_PKG_VERSION")),
            scenario,
            summary,
        }
    }
}

/// A scenario file that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// Not valid TOML, an unknown key, a missing one, or a value of the wrong type.
    #[error("scenario: {0}")]
    Parse(#[from] toml::de::Error),
    /// The `[config]` overrides do not make a valid config.
    #[error("scenario [config]: {0}")]
    Config(#[from] ConfigError),
    /// A value that breaks its rule.
    #[error("scenario: {0}")]
    Param(#[from] drive_core::error::ParamError),
    /// The strategy is neither built in nor a loaded plugin's.
    #[error("scenario: unknown strategy `{name}` (rule: one of {known})")]
    Strategy {
        /// The name given.
        name: String,
        /// The names that would do.
        known: String,
    },
}

impl ScenarioFile {
    /// Parses a document (the scenario is checked by [`ScenarioFile::scenario`]). The
    /// `[config]` table's keys and types are checked here, in the document, so that an
    /// error points at its line and column.
    pub fn from_toml(text: &str) -> Result<Self, ScenarioError> {
        let file: Self = toml::from_str(text)?;
        toml::from_str::<ConfigTable>(text).map_err(ConfigError::from)?;
        Ok(file)
    }

    /// The file as TOML.
    pub fn to_toml(&self) -> String {
        // Plain tables of numbers and strings always serialise.
        toml::to_string(self).unwrap_or_default()
    }

    /// The scenario on `base` (the built-in drive, or a `--config` file): `[config]`
    /// overrides `base` key by key; `strategy` names a built-in strategy or one of
    /// `plugins`. Every value is checked, so a scenario returned here runs.
    pub fn scenario(
        &self,
        base: &DriveConfig,
        plugins: &[PluginLibrary],
    ) -> Result<Scenario, ScenarioError> {
        let mut config = with_overrides(base, &self.config)?;
        let mut plugin = None;
        if let Some(name) = &self.strategy {
            if let Some(p) = plugins.iter().find(|p| p.name() == name) {
                plugin = Some(p.clone());
            } else {
                config.strategy.name =
                    name.parse::<StrategyName>()
                        .map_err(|_| ScenarioError::Strategy {
                            name: name.clone(),
                            known: StrategyName::ALL
                                .iter()
                                .map(|n| n.to_string())
                                .chain(plugins.iter().map(|p| p.name().to_string()))
                                .collect::<Vec<_>>()
                                .join(", "),
                        })?;
            }
        }
        if let Some(seed) = self.seed {
            config.sensing.seed = seed;
        }
        let mut sc = Scenario::hold(config, self.speed_rpm.value_at(0.0), self.duration_s);
        sc.plugin = plugin;
        sc.description = self.description.clone();
        sc.speed_rpm = self.speed_rpm.clone();
        sc.load = self.load.clone();
        sc.supply_v = self.supply_v.clone();
        if let Some(t) = self.steady_from_s {
            sc.steady_from_s = t;
        }
        if let Some(s) = self.profile_update_s {
            sc.profile_update_s = s;
        }
        if let Some(f) = self.torque_lowpass_hz {
            sc.torque_lowpass_hz = f;
        }
        sc.validate()?;
        Ok(sc)
    }

    /// The file that describes `sc` completely: every config key written out, the
    /// strategy by name. Running it again gives the same run.
    pub fn of(sc: &Scenario) -> Self {
        let config = toml::Table::try_from(&sc.config).unwrap_or_default();
        ScenarioFile {
            description: sc.description.clone(),
            strategy: Some(match &sc.plugin {
                Some(p) => p.name().to_string(),
                None => sc.config.strategy.name.to_string(),
            }),
            duration_s: sc.duration_s,
            steady_from_s: Some(sc.steady_from_s),
            seed: Some(sc.config.sensing.seed),
            speed_rpm: sc.speed_rpm.clone(),
            supply_v: sc.supply_v.clone(),
            profile_update_s: Some(sc.profile_update_s),
            torque_lowpass_hz: Some(sc.torque_lowpass_hz),
            load: sc.load.clone(),
            config,
        }
    }
}

/// The `[config]` table of a scenario document read as a config (every key optional), the
/// rest ignored: its keys and types checked where the user wrote them.
#[derive(Deserialize)]
struct ConfigTable {
    #[serde(default)]
    #[allow(dead_code)] // read for its errors only
    config: DriveConfig,
}

/// `base` with the keys of `overrides` replaced, table by table, then checked.
pub(crate) fn with_overrides(
    base: &DriveConfig,
    overrides: &toml::Table,
) -> Result<DriveConfig, ConfigError> {
    if overrides.is_empty() {
        base.validate()?;
        return Ok(base.clone());
    }
    let mut merged = toml::Table::try_from(base).unwrap_or_default();
    merge(&mut merged, overrides);
    DriveConfig::from_table(merged)
}

fn merge(into: &mut toml::Table, from: &toml::Table) {
    for (k, v) in from {
        match (into.get_mut(k), v) {
            (Some(toml::Value::Table(a)), toml::Value::Table(b)) => merge(a, b),
            _ => {
                into.insert(k.clone(), v.clone());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = r#"
description = "step under a fan"
strategy = "six-step-120"
duration_s = 4.0
seed = 9
speed_rpm = [[0, 3000], [2, 3000], [2, 5000]]
supply_v = 11.5
[load]
fan_nms2 = 2e-10
coulomb_nm = [[0, 0], [3, 0], [3, 1e-3]]
[config.motor]
resistance_ohm = 2.4
[config.control]
max_restarts = 2
"#;

    #[test]
    fn a_file_builds_its_scenario_over_the_base_config() {
        let f = ScenarioFile::from_toml(FILE).unwrap();
        let sc = f.scenario(&DriveConfig::default(), &[]).unwrap();
        assert_eq!(sc.config.strategy.name, StrategyName::SixStep120);
        assert_eq!(sc.config.motor.resistance_ohm, 2.4);
        assert_eq!(sc.config.control.max_restarts, 2);
        // Keys not overridden keep the base's values.
        let d = DriveConfig::default();
        assert_eq!(sc.config.motor.inertia_kgm2, d.motor.inertia_kgm2);
        assert_eq!(sc.config.sensing.seed, 9);
        assert_eq!(sc.speed_rpm.value_at(2.5), 5000.0);
        assert_eq!(sc.load.at(3.5).coulomb_nm, 1e-3);
        assert_eq!(sc.supply_v.as_ref().unwrap().value_at(1.0), 11.5);
        // The last third by default.
        assert!((sc.steady_from_s - 4.0 * 2.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn the_complete_file_of_a_scenario_rebuilds_it() {
        let sc = ScenarioFile::from_toml(FILE)
            .unwrap()
            .scenario(&DriveConfig::default(), &[])
            .unwrap();
        let again = ScenarioFile::from_toml(&ScenarioFile::of(&sc).to_toml())
            .unwrap()
            .scenario(&DriveConfig::default(), &[])
            .unwrap();
        assert_eq!(again.config, sc.config);
        assert_eq!(again.speed_rpm, sc.speed_rpm);
        assert_eq!(again.load, sc.load);
        assert_eq!(again.supply_v, sc.supply_v);
        assert_eq!(again.steady_from_s, sc.steady_from_s);
    }

    #[test]
    fn config_errors_point_into_the_users_own_file() {
        // Line 4 of a four-line file (the merged document has some fifty lines).
        for (line, at) in [
            ("resistanse_ohm = 2", "line 4, column 1"),
            ("resistance_ohm = \"x\"", "line 4, column 18"),
        ] {
            let text = format!("duration_s = 1\nspeed_rpm = 3000\n[config.motor]\n{line}\n");
            let e = ScenarioFile::from_toml(&text).unwrap_err().to_string();
            assert!(e.contains(at) && e.contains(line), "{e}");
        }
        // A table has no lines: the key's path, and no position.
        let table: toml::Table = toml::from_str("[motor]\nresistanse_ohm = 2\n").unwrap();
        let e = with_overrides(&DriveConfig::default(), &table)
            .unwrap_err()
            .to_string();
        assert!(e.contains("resistanse_ohm") && e.contains("`motor`"), "{e}");
        assert!(!e.contains("line"), "{e}");
    }

    #[test]
    fn errors_name_the_key_and_the_rule() {
        let cases = [
            ("duration_s = 2\n", "speed_rpm"),
            ("duration_s = 2\nspeed_rpm = 3000\nspeeed = 1\n", "speeed"),
            ("duration_s = 2\nspeed_rpm = 20000\n", "speed_rpm[0]"),
            (
                "duration_s = 2\nspeed_rpm = [[0, 1000], [3, 2000]]\n",
                "speed_rpm[1] time",
            ),
            (
                "duration_s = 2\nspeed_rpm = 1000\n[load]\ncoulomb_nm = -1\n",
                "load.coulomb_nm",
            ),
            (
                "duration_s = 2\nspeed_rpm = 1000\nsupply_v = 0\n",
                "supply_v[0]",
            ),
            (
                "duration_s = 2\nspeed_rpm = 1000\nstrategy = \"x\"\n",
                "unknown strategy `x`",
            ),
            (
                "duration_s = 2\nspeed_rpm = 1000\n[config.motor]\nresistance_ohm = -1\n",
                "motor.resistance_ohm",
            ),
            (
                "duration_s = 2\nspeed_rpm = 1000\n[config.motr]\nx = 1\n",
                "motr",
            ),
            ("duration_s = -2\nspeed_rpm = 1000\n", "duration_s"),
        ];
        for (text, key) in cases {
            let e = ScenarioFile::from_toml(text)
                .and_then(|f| f.scenario(&DriveConfig::default(), &[]).map(|_| ()))
                .unwrap_err()
                .to_string();
            assert!(e.contains(key), "{text:?}: {e}");
        }
    }
}
