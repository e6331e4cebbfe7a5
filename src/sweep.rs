//! Sweeps: a list of [`Case`]s, each run on its own, the results one row per case in the
//! order of the list. `drive-bench sweep FILE` runs them on local threads and the Python
//! `bldc_drive.sweep` on a Dask cluster; both use this module, so a case gives the same
//! row on either.
//!
//! A sweep file is a JSON list of case objects with the keys of [`crate::case`]:
//!
//! ```json
//! [
//!   {"strategy": "twelve-step-df", "speed_rpm": 3000, "duration_s": 1.5},
//!   {"strategy": "six-step-120", "speed_rpm": 3000, "load_nm": 1e-3, "seed": 7,
//!    "config": {"motor": {"resistance_ohm": 2.4}}}
//! ]
//! ```
//!
//! **Paths.** A `config` or `scenario` path in a sweep file is taken relative to the file's
//! folder (see [`resolve_paths`]), so a sweep runs the same from any working directory.
//!
//! **Seeds.** A sweep always sets the comparator-noise seed: case `k` (counted from 0)
//! runs with its own `seed` when it gives one, else with seed `k`. So a case's result
//! does not depend on the order in which the cases happen to run, and a row can be run
//! again alone with the seed it reports.
//!
//! A sweep keeps no traces (`trace_every_us` is refused). Every case is checked before any
//! runs; an error names the case's index, the key, the value and the rule.

use crate::case::{Case, CaseError};
use crate::scenario::{RunError, Scenario, Summary, run, settled};
use serde::ser::{Serialize, SerializeMap, Serializer};
use serde_json::Value;
use std::path::Path;
use strategies::PluginLibrary;

/// The seed case `index` runs with (see the module doc).
pub fn seed_of(index: usize, case: &Case) -> u64 {
    case.seed.unwrap_or(index as u64)
}

/// Reads a sweep file: a JSON list of case objects.
pub fn parse(text: &str) -> Result<Vec<Case>, CaseError> {
    let v: Value = serde_json::from_str(text)
        .map_err(|e| CaseError(format!("sweep file: {e} (rule: JSON)")))?;
    let Value::Array(items) = v else {
        return Err(CaseError(
            "sweep file: not a list (rule: a JSON list of case objects)".into(),
        ));
    };
    if items.is_empty() {
        return Err(CaseError(
            "sweep file: an empty list (rule: at least one case)".into(),
        ));
    }
    items
        .into_iter()
        .enumerate()
        .map(|(k, x)| Case::from_value(x).map_err(|e| CaseError(format!("case {k}: {e}"))))
        .collect()
}

/// Makes the relative `config` and `scenario` paths of `cases` relative to `dir`, the
/// folder of the sweep file that names them; absolute paths and tables are kept.
pub fn resolve_paths(cases: &mut [Case], dir: &Path) {
    for c in cases {
        for v in [&mut c.config, &mut c.scenario].into_iter().flatten() {
            if let Value::String(p) = v
                && Path::new(p.as_str()).is_relative()
            {
                *p = dir.join(p.as_str()).to_string_lossy().into_owned();
            }
        }
    }
}

/// The scenario of case `index`, seeded as a sweep seeds it, with every value checked.
pub fn scenario_of(
    index: usize,
    case: &Case,
    plugins: &[PluginLibrary],
) -> Result<Scenario, CaseError> {
    let named = |e: String| CaseError(format!("case {index}: {e}"));
    if let Some(x) = case.trace_every_us {
        return Err(named(format!(
            "`trace_every_us` = {x} (rule: a sweep keeps no traces; simulate the case alone for one)"
        )));
    }
    let mut seeded = case.clone();
    seeded.seed = Some(seed_of(index, case));
    seeded.scenario(plugins).map_err(|e| named(e.0))
}

/// Every case's scenario, or the first case's error: all are checked before any runs.
pub fn scenarios(cases: &[Case], plugins: &[PluginLibrary]) -> Result<Vec<Scenario>, CaseError> {
    cases
        .iter()
        .enumerate()
        .map(|(k, c)| scenario_of(k, c, plugins))
        .collect()
}

/// One case's result: its index, seed, inputs and summary.
#[derive(Clone, Debug)]
pub struct Row {
    /// Index of the case in the list.
    pub case: usize,
    /// The seed it ran with.
    pub seed: u64,
    /// The case as given.
    pub inputs: Case,
    /// What the run gave.
    pub summary: Summary,
}

/// Runs case `index` (whose scenario is `sc`, from [`scenario_of`]). A case that gives
/// neither a duration nor a scenario is a hold lengthened until its window judges the
/// drive after its start-up ([`crate::scenario::settled`]): its `sim_s` says how long.
pub fn run_row(index: usize, case: &Case, sc: &Scenario) -> Result<Row, RunError> {
    let out = if case.duration_s.is_none() && case.scenario.is_none() {
        settled(sc, |s| run(s, |_| {}))?.1
    } else {
        run(sc, |_| {})?
    };
    Ok(Row {
        case: index,
        seed: sc.config.sensing.seed,
        inputs: case.clone(),
        summary: out.summary,
    })
}

impl Row {
    /// The row as named columns: `case`, `seed`, the inputs (tables flattened to dotted
    /// names such as `config.motor.resistance_ohm`; `strategy` and `seed` are the
    /// summary's and the row's own), then the summary's keys in its order.
    pub fn columns(&self) -> Vec<(String, Value)> {
        let mut cols = vec![
            ("case".to_string(), Value::from(self.case)),
            ("seed".to_string(), Value::from(self.seed)),
        ];
        let mut inputs = self.inputs.clone();
        inputs.strategy = None;
        inputs.seed = None;
        flatten("", ordered(&inputs), &mut cols);
        flatten("", ordered(&self.summary), &mut cols);
        cols
    }
}

impl Serialize for Row {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let cols = self.columns();
        let mut m = s.serialize_map(Some(cols.len()))?;
        for (k, v) in &cols {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

/// The rows as CSV: one column for every name any row has, in order of first appearance;
/// numbers as the shortest decimals that read back to the same value, lists and tables
/// as JSON, absent values empty.
pub fn to_csv(rows: &[Row]) -> String {
    let rows: Vec<Vec<(String, Value)>> = rows.iter().map(Row::columns).collect();
    let mut names: Vec<&str> = Vec::new();
    for r in &rows {
        for (k, _) in r {
            if !names.contains(&k.as_str()) {
                names.push(k);
            }
        }
    }
    let mut w = csv::Writer::from_writer(Vec::new());
    // Writing to memory cannot fail; every record has the header's length.
    let _ = w.write_record(&names);
    for r in &rows {
        let cell = |name: &str| match r.iter().find(|(k, _)| k == name).map(|(_, v)| v) {
            None | Some(Value::Null) => String::new(),
            Some(Value::String(s)) => s.clone(),
            Some(v) => v.to_string(),
        };
        let _ = w.write_record(names.iter().map(|n| cell(n)));
    }
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// The keys and values of a serialised struct, in field order (a `serde_json::Map` would
/// sort them). The values come from `to_value`, exact: reading floats back from JSON text
/// could change their last bit.
fn ordered<T: Serialize>(v: &T) -> Vec<(String, Value)> {
    let Ok(Value::Object(mut values)) = serde_json::to_value(v) else {
        return Vec::new();
    };
    let text = serde_json::to_string(v).unwrap_or_default();
    let keys = serde_json::from_str::<Keys>(&text).map_or_else(|_| Vec::new(), |k| k.0);
    keys.into_iter()
        .filter_map(|k| values.remove(&k).map(|x| (k, x)))
        .collect()
}

/// The keys of a JSON object, in order.
struct Keys(Vec<String>);

impl<'de> serde::Deserialize<'de> for Keys {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visit;
        impl<'de> serde::de::Visitor<'de> for Visit {
            type Value = Keys;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("an object")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, mut a: A) -> Result<Keys, A::Error> {
                let mut keys = Vec::new();
                while let Some((k, _)) = a.next_entry::<String, serde::de::IgnoredAny>()? {
                    keys.push(k);
                }
                Ok(Keys(keys))
            }
        }
        d.deserialize_map(Visit)
    }
}

/// Appends `fields` to `out`, tables flattened to `prefix.key` names.
fn flatten(prefix: &str, fields: Vec<(String, Value)>, out: &mut Vec<(String, Value)>) {
    for (k, v) in fields {
        let name = if prefix.is_empty() {
            k
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            Value::Object(m) => flatten(&name, m.into_iter().collect(), out),
            v => out.push((name, v)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_are_the_case_s_own_or_its_index() {
        let cases = parse(
            r#"[{"strategy": "six-step-120", "speed_rpm": 1000},
            {"strategy": "six-step-120", "speed_rpm": 1000, "seed": 42},
            {"strategy": "six-step-120", "speed_rpm": 1000}]"#,
        )
        .unwrap();
        let seeds: Vec<u64> = scenarios(&cases, &[])
            .unwrap()
            .iter()
            .map(|s| s.config.sensing.seed)
            .collect();
        assert_eq!(seeds, [0, 42, 2]);
    }

    #[test]
    fn errors_name_the_case() {
        let e = parse(
            r#"[{"strategy": "six-step-120", "speed_rpm": 1000},
            {"strategy": "six-step-120", "speed_rpm": -5}]"#,
        )
        .and_then(|c| scenarios(&c, &[]).map(|_| ()))
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("case 1: ") && e.contains("`speed_rpm[0]` = -5"),
            "{e}"
        );
        let e = parse(r#"[{"strategy": "six-step-120", "speed_rpm": 1000, "trace_every_us": 10}]"#)
            .and_then(|c| scenarios(&c, &[]).map(|_| ()))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("case 0: `trace_every_us` = 10"), "{e}");
        assert!(parse("{}").unwrap_err().to_string().contains("not a list"));
        assert!(
            parse("[1]")
                .unwrap_err()
                .to_string()
                .starts_with("case 0: ")
        );
    }

    #[test]
    fn columns_flatten_the_inputs_and_keep_the_summary_order() {
        let cases = parse(
            r#"[{"strategy": "six-step-120", "speed_rpm": 800,
            "duration_s": 0.02, "config": {"motor": {"resistance_ohm": 2.4}}}]"#,
        )
        .unwrap();
        let sc = scenarios(&cases, &[]).unwrap();
        let row = run_row(0, &cases[0], &sc[0]).unwrap();
        let names: Vec<String> = row.columns().into_iter().map(|c| c.0).collect();
        assert_eq!(
            names[..7],
            [
                "case",
                "seed",
                "speed_rpm",
                "duration_s",
                "config.motor.resistance_ohm",
                "strategy",
                "speed_ref_rpm"
            ]
        );
        let csv = to_csv(&[row]);
        let mut lines = csv.lines();
        assert!(
            lines
                .next()
                .unwrap()
                .starts_with("case,seed,speed_rpm,duration_s,")
        );
        assert!(
            lines
                .next()
                .unwrap()
                .starts_with("0,0,800.0,0.02,2.4,six-step-120,800.0,")
        );
    }

    #[test]
    fn a_text_with_commas_quotes_and_line_breaks_reads_back_from_the_csv() {
        let cases = parse(r#"[{"speed_rpm": 800, "duration_s": 0.02}]"#).unwrap();
        let sc = scenarios(&cases, &[]).unwrap();
        let mut row = run_row(0, &cases[0], &sc[0]).unwrap();
        let nasty = "lost sync, then \"restarted\"\nat 1 s";
        row.summary.verdict_reason = nasty.into();
        let text = to_csv(&[row]);
        let mut r = csv::Reader::from_reader(text.as_bytes());
        let at = r
            .headers()
            .unwrap()
            .iter()
            .position(|h| h == "verdict_reason")
            .unwrap();
        let rec = r.records().next().unwrap().unwrap();
        assert_eq!(&rec[at], nasty);
        assert!(r.records().next().is_none());
    }
}
