//! `bldc_drive._native`: the library's cases, runs and sweeps for the Python package
//! `bldc_drive` (python/bldc_drive/), which wraps these functions in its public API.
//!
//! Data crosses as JSON text, which both sides read exactly (every float written as the
//! shortest decimal that reads back to the same value), and traces as little-endian
//! column bytes for NumPy. Bad input is a `ValueError`, a failed run a `RuntimeError`;
//! a panic is caught and becomes a `RuntimeError` too.

use bldc_drive::DriveConfig;
use bldc_drive::case::{Case, CaseError};
use bldc_drive::drive_core::error::{NOT_FINITE, ParamError};
use bldc_drive::scenario::{self, TraceRow};
use bldc_drive::scenario_file::RunRecord;
use bldc_drive::strategies::{PluginLibrary, StrategyName};
use bldc_drive::sweep;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::panic::{AssertUnwindSafe, catch_unwind};

/// The built-in config as JSON: every key, with its value (`drive-bench config`).
#[pyfunction]
fn default_config() -> String {
    DriveConfig::default().to_json()
}

/// The refusal of `key` = `value` (NaN or infinite), worded as every door words it.
#[pyfunction]
fn not_finite(key: &str, value: f64) -> String {
    ParamError::new(key, value, NOT_FINITE).to_string()
}

/// The refusal of `key` = `value` (the value as written) for breaking `rule`.
#[pyfunction]
fn refusal(key: &str, value: &str, rule: String) -> String {
    ParamError::new(key, value, rule).to_string()
}

/// The built-in strategies' names, then those of the plugins at `plugins` (paths).
#[pyfunction]
#[pyo3(signature = (plugins=Vec::new()))]
fn strategies(plugins: Vec<String>) -> PyResult<Vec<String>> {
    let libs = load(&plugins)?;
    Ok(StrategyName::ALL
        .iter()
        .map(|n| n.to_string())
        .chain(libs.iter().map(|l| l.name().to_string()))
        .collect())
}

/// The plugin libraries at `paths`, each checked as `drive-bench --plugin` checks it.
fn load(paths: &[String]) -> PyResult<Vec<PluginLibrary>> {
    paths
        .iter()
        .map(|p| {
            PluginLibrary::load(std::path::Path::new(p))
                .map_err(|e| PyValueError::new_err(format!("plugins: {e}")))
        })
        .collect()
}

/// A trace's columns: (name, NumPy dtype, little-endian bytes), in the CSV's order.
type Columns = Vec<(String, &'static str, Vec<u8>)>;

/// [`Columns`] with the bytes as Python `bytes`.
type PyColumns<'py> = Vec<(String, &'static str, Bound<'py, PyBytes>)>;

/// Runs the case given as a JSON object; returns the run's record as JSON (what
/// `drive-bench run --json` writes) and the trace's columns when `trace_every_us` is set.
/// `plugins` are paths of plugin libraries whose strategies the case may name.
#[pyfunction]
#[pyo3(signature = (case_json, plugins=Vec::new()))]
fn simulate<'py>(
    py: Python<'py>,
    case_json: &str,
    plugins: Vec<String>,
) -> PyResult<(String, Option<PyColumns<'py>>)> {
    let case = parse_case(case_json)?;
    let sc = case.scenario(&load(&plugins)?).map_err(value_error)?;
    // The GIL is released while simulating: other Python threads run meanwhile.
    let out = py.detach(|| {
        guarded(|| {
            let mut trace = sc.trace.map(|t| Trace::with_capacity(t.rows() as usize));
            let out = scenario::run(&sc, |row| {
                if let Some(t) = trace.as_mut() {
                    t.push(row);
                }
            })
            .map_err(|e| e.to_string())?;
            let record = RunRecord::of(&sc, out.summary);
            let json = serde_json::to_string(&record).map_err(|e| e.to_string())?;
            Ok((json, trace.map(Trace::columns)))
        })
    });
    let (json, columns) = out.map_err(PyRuntimeError::new_err)?;
    let columns = columns.map(|cols| {
        cols.into_iter()
            .map(|(name, dtype, bytes)| (name, dtype, PyBytes::new(py, &bytes)))
            .collect()
    });
    Ok((json, columns))
}

/// Checks every case of a sweep (a JSON list) before any runs; returns each case's seed.
#[pyfunction]
#[pyo3(signature = (cases_json, plugins=Vec::new()))]
fn sweep_seeds(cases_json: &str, plugins: Vec<String>) -> PyResult<Vec<u64>> {
    let cases = sweep::parse(cases_json).map_err(value_error)?;
    sweep::scenarios(&cases, &load(&plugins)?).map_err(value_error)?;
    Ok(cases
        .iter()
        .enumerate()
        .map(|(k, c)| sweep::seed_of(k, c))
        .collect())
}

/// Runs case `index` of a sweep (a JSON object) and returns its row as a JSON object.
#[pyfunction]
#[pyo3(signature = (index, case_json, plugins=Vec::new()))]
fn sweep_row(
    py: Python<'_>,
    index: usize,
    case_json: &str,
    plugins: Vec<String>,
) -> PyResult<String> {
    let case = parse_case(case_json)?;
    let sc = sweep::scenario_of(index, &case, &load(&plugins)?).map_err(value_error)?;
    py.detach(|| {
        guarded(|| {
            let row =
                sweep::run_row(index, &case, &sc).map_err(|e| format!("case {index}: {e}"))?;
            serde_json::to_string(&row).map_err(|e| e.to_string())
        })
    })
    .map_err(PyRuntimeError::new_err)
}

fn parse_case(json: &str) -> PyResult<Case> {
    let v: serde_json::Value = serde_json::from_str(json)
        .map_err(|e| PyValueError::new_err(format!("case: {e} (rule: JSON)")))?;
    Case::from_value(v).map_err(value_error)
}

fn value_error(e: CaseError) -> PyErr {
    PyValueError::new_err(e.0)
}

/// Runs `f`, turning a panic into an error: none crosses into Python.
fn guarded<T>(f: impl FnOnce() -> Result<T, String>) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| {
        let what = p
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        Err(format!("internal error (a bug, please report it): {what}"))
    })
}

/// A trace held as columns.
#[derive(Default)]
struct Trace {
    floats: [Vec<f64>; 18],
    flags: [Vec<u8>; 4],
    restarts: Vec<u32>,
}

impl Trace {
    fn with_capacity(n: usize) -> Self {
        let mut t = Trace::default();
        t.floats.iter_mut().for_each(|c| c.reserve(n));
        t.flags.iter_mut().for_each(|c| c.reserve(n));
        t.restarts.reserve(n);
        t
    }

    /// Adds a row with the values `drive-bench run --trace` writes for it.
    fn push(&mut self, r: &TraceRow) {
        let floats = [
            r.time_ns() as f64 / 1e9,
            r.speed_rpm,
            r.speed_est_rpm,
            r.theta_e_deg_wrapped(),
            r.i_u,
            r.i_v,
            r.i_w,
            r.v_u,
            r.v_v,
            r.v_w,
            r.v_n,
            r.torque_nm,
            r.duty,
            r.speed_ref_rpm,
            r.current_ref_a,
            r.load_nm,
            r.supply_v,
            r.i_shunt_a,
        ];
        for (c, x) in self.floats.iter_mut().zip(floats) {
            c.push(x);
        }
        for (c, x) in self.flags.iter_mut().zip([r.state, r.zd, r.zdf, r.linear]) {
            c.push(x);
        }
        self.restarts.push(r.restarts);
    }

    /// The columns named as in [`TraceRow::HEADER`], in its order.
    fn columns(self) -> Columns {
        let bytes = |c: Vec<f64>| c.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let mut floats = self.floats.into_iter().map(|c| ("<f8", bytes(c)));
        let mut flags = self.flags.into_iter().map(|c| ("|u1", c));
        let restarts = self.restarts.iter().flat_map(|x| x.to_le_bytes()).collect();
        let mut restarts = Some(("<u4", restarts));
        TraceRow::HEADER
            .split(',')
            .filter_map(|name| {
                let col = match name {
                    "state" | "zd" | "zdf" | "linear" => flags.next(),
                    "restarts" => restarts.take(),
                    _ => floats.next(),
                }?;
                Some((name.to_string(), col.0, col.1))
            })
            .collect()
    }
}

/// The native part of `bldc_drive`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(default_config, m)?)?;
    m.add_function(wrap_pyfunction!(not_finite, m)?)?;
    m.add_function(wrap_pyfunction!(refusal, m)?)?;
    m.add_function(wrap_pyfunction!(strategies, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_seeds, m)?)?;
    m.add_function(wrap_pyfunction!(sweep_row, m)?)?;
    m.add("VERSION", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
