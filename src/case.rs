//! One run named by its inputs: the options of `drive-bench run`, the keyword arguments of
//! the Python `bldc_drive.simulate`, and the objects of a sweep file (see
//! [`crate::sweep`]) are all a [`Case`], built into a [`Scenario`] here and nowhere else.
//!
//! Keys, all optional: `strategy` (a name), `speed_rpm` \[rpm\], `duration_s` \[s\]
//! (default 3), `load_nm` (a Coulomb load \[N·m\], default 0), `config` (a path to a
//! TOML config, or a table of overrides of the built-in config as in a scenario file's
//! `[config]`), `scenario` (a path to a scenario file, or a table of its keys; it then
//! gives the command, duration and load), `seed` (the comparator-noise seed) and
//! `trace_every_us` (a trace of the whole run at this period \[µs\]). Without them,
//! `strategy` and `speed_rpm` are the config's `strategy.name` and `control.speed_ref_rpm`.

use crate::config::DriveConfig;
use crate::profile::LoadProfile;
use crate::scenario::{Scenario, TraceSpec};
use crate::scenario_file::{ScenarioFile, with_overrides};
use drive_core::error::{ParamError, check_finite};
use serde::Serialize;
use std::path::Path;
use strategies::{PluginLibrary, StrategyName};

/// The inputs of one run (see the module doc for each key).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Case {
    /// Strategy name: built in (`drive-bench list`) or a loaded plugin's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub strategy: Option<String>,
    /// Constant speed command \[rpm\].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_rpm: Option<f64>,
    /// Simulated time \[s\]; default 3.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub duration_s: Option<f64>,
    /// A passive (Coulomb) load from t = 0 \[N·m\]; default 0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub load_nm: Option<f64>,
    /// A path to a TOML config (a string) or a table of overrides.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub config: Option<serde_json::Value>,
    /// A path to a scenario file (a string) or a table of its keys.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scenario: Option<serde_json::Value>,
    /// Comparator-noise seed (overrides `sensing.seed` and the scenario's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Trace sampling period over the whole run \[µs\]; none without it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trace_every_us: Option<f64>,
}

/// A case that cannot be run. Every message names the key, the value and the rule.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct CaseError(pub String);

impl From<ParamError> for CaseError {
    fn from(e: ParamError) -> Self {
        CaseError(e.to_string())
    }
}

/// Every key of a case, in the order of `bldc_drive.simulate`'s arguments.
pub const KEYS: [&str; 8] = [
    "strategy",
    "speed_rpm",
    "duration_s",
    "load_nm",
    "config",
    "scenario",
    "seed",
    "trace_every_us",
];

/// The most rows a trace kept in memory may have (18 columns of 8 bytes: 1.4 GB).
pub const MAX_TRACE_ROWS: u64 = 10_000_000;

impl Case {
    /// Reads a case from JSON data (the keys of the module doc). An unknown key, or a
    /// value of the wrong type, is an error naming the key, the value and the rule.
    pub fn from_value(v: serde_json::Value) -> Result<Self, CaseError> {
        let serde_json::Value::Object(map) = v else {
            let rule = format!("an object of the keys {}", KEYS.join(", "));
            return Err(ParamError::new("case", v, rule).into());
        };
        let mut c = Case::default();
        for (key, x) in map {
            if x.is_null() {
                continue; // as if not given, like Python's None
            }
            let number = || match x.as_f64() {
                Some(n) => check_finite(&key, n).map(|()| n),
                None => Err(ParamError::new(&key, &x, "a number")),
            };
            match key.as_str() {
                "strategy" => match &x {
                    serde_json::Value::String(s) => c.strategy = Some(s.clone()),
                    _ => {
                        return Err(
                            ParamError::new("strategy", x, "a strategy name, a string").into()
                        );
                    }
                },
                "speed_rpm" => c.speed_rpm = Some(number()?),
                "duration_s" => c.duration_s = Some(number()?),
                "load_nm" => c.load_nm = Some(number()?),
                "trace_every_us" => c.trace_every_us = Some(number()?),
                "seed" => {
                    c.seed =
                        Some(x.as_u64().ok_or_else(|| {
                            ParamError::new("seed", &x, "a whole number 0..=2^64-1")
                        })?)
                }
                "config" => c.config = Some(x),
                "scenario" => c.scenario = Some(x),
                _ => {
                    return Err(CaseError(format!(
                        "unknown key `{key}` (rule: one of {})",
                        KEYS.join(", ")
                    )));
                }
            }
        }
        Ok(c)
    }

    /// The scenario this case runs, with every value checked: a scenario returned here
    /// runs. `plugins` are the strategies loaded besides the built-in ones.
    pub fn scenario(&self, plugins: &[PluginLibrary]) -> Result<Scenario, CaseError> {
        let cfg = self.base_config()?;
        let mut sc = match &self.scenario {
            Some(source) => {
                for (key, given) in [
                    ("speed_rpm", self.speed_rpm),
                    ("duration_s", self.duration_s),
                    ("load_nm", self.load_nm),
                ] {
                    if let Some(x) = given {
                        let rule =
                            "not with `scenario`, which gives the command, duration and load";
                        return Err(ParamError::new(key, x, rule).into());
                    }
                }
                scenario_file(source)?
                    .and_then(|f| f.scenario(&cfg, plugins).map_err(|e| e.to_string()))
                    .map_err(|e| CaseError(label(source, e)))?
            }
            None => {
                // A number that is no number is refused before any other rule reads it.
                for (key, given) in [
                    ("speed_rpm", self.speed_rpm),
                    ("duration_s", self.duration_s),
                    ("load_nm", self.load_nm),
                ] {
                    check_finite(key, given.unwrap_or(0.0))?;
                }
                // Without them: the config's own strategy and speed command.
                let rpm = self.speed_rpm.unwrap_or(cfg.control.speed_ref_rpm);
                let mut sc = Scenario::hold(cfg, rpm, self.duration_s.unwrap_or(3.0));
                sc.load = LoadProfile::coulomb(self.load_nm.unwrap_or(0.0));
                sc
            }
        };
        if let Some(name) = &self.strategy {
            let mut cfg = sc.config.clone();
            sc.plugin = apply(choose(name, plugins)?, &mut cfg);
            sc.config = cfg;
        }
        if let Some(seed) = self.seed {
            sc.config.sensing.seed = seed;
        }
        if let Some(us) = self.trace_every_us {
            let spec = TraceSpec {
                every_s: us * 1e-6,
                from_s: 0.0,
                to_s: sc.duration_s,
            };
            sc.trace = Some(spec);
            sc.validate()?;
            if spec.rows() > MAX_TRACE_ROWS {
                let rule = format!(
                    "at most {MAX_TRACE_ROWS} rows, here {}: a longer period or a shorter run",
                    spec.rows()
                );
                return Err(ParamError::new("trace_every_us", us, rule).into());
            }
        }
        sc.validate()?;
        Ok(sc)
    }

    /// The config the case starts from: the built-in one, a file's, or the built-in one
    /// with overrides.
    fn base_config(&self) -> Result<DriveConfig, CaseError> {
        match &self.config {
            None => Ok(DriveConfig::default()),
            Some(serde_json::Value::String(p)) => {
                DriveConfig::from_file(std::path::Path::new(p)).map_err(CaseError)
            }
            Some(v @ serde_json::Value::Object(_)) => {
                let table: toml::Table = serde_json::from_value(v.clone())
                    .map_err(|e| CaseError(format!("`config`: {e}")))?;
                with_overrides(&DriveConfig::default(), &table)
                    .map_err(|e| CaseError(e.to_string()))
            }
            Some(v) => Err(ParamError::new(
                "config",
                v,
                "a path to a TOML config or a table of overrides",
            )
            .into()),
        }
    }
}

/// The scenario file `source` names or holds.
fn scenario_file(source: &serde_json::Value) -> Result<Result<ScenarioFile, String>, CaseError> {
    match source {
        serde_json::Value::String(p) => {
            let text = std::fs::read_to_string(p).map_err(|e| CaseError(format!("{p}: {e}")))?;
            Ok(ScenarioFile::from_toml(&text).map_err(|e| e.to_string()))
        }
        v @ serde_json::Value::Object(_) => Ok(serde_json::from_value::<toml::Table>(v.clone())
            .map_err(|e| e.to_string())
            .and_then(|t| {
                toml::Value::Table(t)
                    .try_into::<ScenarioFile>()
                    .map_err(|e| format!("scenario: {e}"))
            })),
        v => Err(ParamError::new(
            "scenario",
            v,
            "a path to a scenario file or a table of its keys",
        )
        .into()),
    }
}

/// An error about a scenario, prefixed by its file when it came from one.
fn label(source: &serde_json::Value, e: String) -> String {
    match source {
        serde_json::Value::String(p) => format!("{}: {e}", Path::new(p).display()),
        _ => e,
    }
}

/// A strategy chosen by name: built in, or from a loaded plugin.
pub enum Chosen {
    /// One of [`StrategyName::ALL`].
    Builtin(StrategyName),
    /// A loaded plugin's.
    Plugin(PluginLibrary),
}

/// The strategy called `name`: a loaded plugin's first, then a built-in one.
pub fn choose(name: &str, plugins: &[PluginLibrary]) -> Result<Chosen, CaseError> {
    if let Some(p) = plugins.iter().find(|p| p.name() == name) {
        return Ok(Chosen::Plugin(p.clone()));
    }
    name.parse().map(Chosen::Builtin).map_err(|_| {
        let mut known: Vec<String> = StrategyName::ALL.iter().map(|n| n.to_string()).collect();
        known.extend(plugins.iter().map(|p| p.name().to_string()));
        CaseError(format!(
            "unknown strategy `{name}` (rule: one of {})",
            known.join(", ")
        ))
    })
}

/// Applies the choice to `cfg`, returning the plugin if there is one.
pub fn apply(chosen: Chosen, cfg: &mut DriveConfig) -> Option<PluginLibrary> {
    match chosen {
        Chosen::Builtin(n) => {
            cfg.strategy.name = n;
            None
        }
        Chosen::Plugin(p) => Some(p),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn err(v: serde_json::Value) -> String {
        Case::from_value(v)
            .and_then(|c| c.scenario(&[]).map(|_| ()))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn a_plain_case_is_a_hold_with_a_coulomb_load() {
        let c = Case::from_value(json!({"strategy": "six-step-120", "speed_rpm": 2000.0,
            "duration_s": 1.5, "load_nm": 1e-4, "seed": 4}))
        .unwrap();
        let sc = c.scenario(&[]).unwrap();
        assert_eq!(sc.config.strategy.name, StrategyName::SixStep120);
        assert_eq!(sc.speed_rpm.value_at(1.0), 2000.0);
        assert_eq!(sc.duration_s, 1.5);
        assert_eq!(sc.load.at(0.5).coulomb_nm, 1e-4);
        assert_eq!(sc.config.sensing.seed, 4);
        assert!(sc.trace.is_none());
    }

    #[test]
    fn config_overrides_apply_key_by_key() {
        let c = Case::from_value(json!({"strategy": "twelve-step-df", "speed_rpm": 3000,
            "config": {"motor": {"resistance_ohm": 2.5}}}))
        .unwrap();
        let sc = c.scenario(&[]).unwrap();
        assert_eq!(sc.config.motor.resistance_ohm, 2.5);
        let d = DriveConfig::default();
        assert_eq!(sc.config.motor.inertia_kgm2, d.motor.inertia_kgm2);
        assert_eq!(sc.duration_s, 3.0);
    }

    #[test]
    fn errors_name_the_key_the_value_and_the_rule() {
        let cases = [
            (
                json!({"strategy": "x", "speed_rpm": 1000}),
                "unknown strategy `x`",
            ),
            (
                json!({"strategy": "six-step-120", "speed_rpm": 99999}),
                "`speed_rpm[0]` = 99999",
            ),
            (
                json!({"strategy": "six-step-120", "speed_rpm": 1000, "config": {"motor": {"resistance_ohm": -1}}}),
                "`motor.resistance_ohm` = -1",
            ),
            (
                json!({"strategy": "six-step-120", "speed_rpm": 1000, "config": 3}),
                "`config` = 3",
            ),
            (
                json!({"strategy": "six-step-120", "speed_rpm": 1000, "speeed": 1}),
                "unknown key `speeed`",
            ),
            (
                json!({"scenario": {"duration_s": 1, "speed_rpm": 1000}, "load_nm": 0.1}),
                "`load_nm` = 0.1 (rule: not with `scenario`",
            ),
            (
                json!({"strategy": "six-step-120", "speed_rpm": 1000, "duration_s": 100, "trace_every_us": 1}),
                "`trace_every_us` = 1 (rule: at most",
            ),
            (json!([1]), "`case` = [1] (rule: an object"),
            (
                json!({"strategy": "six-step-120", "speed_rpm": "fast"}),
                "`speed_rpm` = \"fast\" (rule: a number)",
            ),
            (
                json!({"strategy": "six-step-120", "speed_rpm": 1000, "seed": -1}),
                "`seed` = -1 (rule: a whole number",
            ),
        ];
        for (v, want) in cases {
            let e = err(v.clone());
            assert!(e.contains(want), "{v}: {e}");
        }
    }

    #[test]
    fn a_scenario_table_is_a_scenario_file() {
        let c = Case::from_value(json!({"scenario": {"duration_s": 1.0,
            "speed_rpm": [[0, 1000], [0.5, 1000], [0.5, 2000]], "load": {"fan_nms2": 2e-10}},
            "strategy": "twelve-step-nd", "seed": 3}))
        .unwrap();
        let sc = c.scenario(&[]).unwrap();
        assert_eq!(sc.speed_rpm.value_at(0.7), 2000.0);
        assert_eq!(sc.config.strategy.name, StrategyName::TwelveStepNd);
        assert_eq!(sc.config.sensing.seed, 3);
        assert_eq!(sc.load.at(0.0).fan_nms2, 2e-10);
    }
}
