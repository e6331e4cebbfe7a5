//! Lowest and highest controllable speed, by bisection.
//!
//! Criterion: a speed is controllable when, started from standstill with that command,
//! the drive is running closed loop at the end, never restarted, and its time-weighted
//! mean speed over the steady-state window is within 2 % of the command.

use crate::config::DriveConfig;
use crate::scenario::{RunError, Scenario, Summary, run};
use serde::Serialize;
use strategies::PluginLibrary;

/// The criterion, stated in every range result.
pub const CRITERION: &str = "started from standstill with the command, after 3 s of simulated time: running closed loop, no restart, mean true speed over the last 1 s within 2 % of the command";

/// Lowest speed searched \[rpm\].
pub const SEARCH_MIN_RPM: f64 = 100.0;
/// Highest speed searched \[rpm\] (the 14-bit speed command tops out at 16383).
pub const SEARCH_MAX_RPM: f64 = 16000.0;
/// Relative resolution of the bisection.
const RESOLUTION: f64 = 0.03;
/// Where the search starts; tried first, then a ladder if it fails.
const SEEDS: [f64; 5] = [3000.0, 2000.0, 4500.0, 1000.0, 6000.0];

/// The range of one strategy.
#[derive(Clone, Debug, Serialize)]
pub struct Range {
    /// Strategy label.
    pub strategy: String,
    /// Lowest controllable speed found \[rpm\] (None: none controllable).
    pub min_rpm: Option<f64>,
    /// Highest controllable speed found \[rpm\].
    pub max_rpm: Option<f64>,
    /// The criterion.
    pub criterion: &'static str,
    /// Resolution of the bisection: each reported bound was controllable and a speed
    /// this many percent further out was not (or is the end of the search) [%].
    pub resolution_pct: f64,
    /// Every speed tried and whether it passed.
    pub tried: Vec<(f64, bool)>,
    /// Speeds tried between the bounds that failed: bisection assumes the controllable
    /// speeds form one interval, and these show where that does not hold.
    pub gaps_rpm: Vec<f64>,
}

/// Whether `rpm` is controllable, with the run's summary.
pub fn controllable(
    config: &DriveConfig,
    plugin: Option<&PluginLibrary>,
    rpm: f64,
) -> Result<(bool, Summary), RunError> {
    let mut sc = Scenario::hold(config.clone(), rpm, 3.0);
    sc.plugin = plugin.cloned();
    let s = run(&sc, |_| {})?.summary;
    let ok = s.running && s.restarts == 0 && (s.speed_mean_rpm - rpm).abs() <= 0.02 * rpm;
    Ok((ok, s))
}

/// Searches the range of `config`'s strategy (or `plugin`'s), labelled `label`.
pub fn search(
    config: &DriveConfig,
    plugin: Option<&PluginLibrary>,
    label: &str,
) -> Result<Range, RunError> {
    let mut tried = Vec::new();
    let mut test = |rpm: f64| -> Result<bool, RunError> {
        let ok = controllable(config, plugin, rpm)?.0;
        tried.push((rpm, ok));
        Ok(ok)
    };
    let mut seed = None;
    for s in SEEDS {
        if test(s)? {
            seed = Some(s);
            break;
        }
    }
    let Some(seed) = seed else {
        return Ok(Range {
            strategy: label.to_string(),
            min_rpm: None,
            max_rpm: None,
            criterion: CRITERION,
            resolution_pct: RESOLUTION * 100.0,
            tried,
            gaps_rpm: Vec::new(),
        });
    };
    // Down: `good` passes, `bad` fails (or is below the search floor).
    let (mut good, mut bad) = (seed, SEARCH_MIN_RPM);
    if test(bad)? {
        good = bad;
    } else {
        while good - bad > RESOLUTION * good {
            let mid = (good * bad).sqrt(); // geometric: speeds span two decades
            if test(mid)? { good = mid } else { bad = mid }
        }
    }
    let min_rpm = good.round();
    let (mut good, mut bad) = (seed, SEARCH_MAX_RPM);
    if test(bad)? {
        good = bad;
    } else {
        while bad - good > RESOLUTION * good {
            let mid = 0.5 * (good + bad);
            if test(mid)? { good = mid } else { bad = mid }
        }
    }
    let max_rpm = good.round();
    let gaps_rpm = tried
        .iter()
        .filter(|&&(rpm, ok)| !ok && rpm > min_rpm && rpm < max_rpm)
        .map(|&(rpm, _)| rpm.round())
        .collect();
    Ok(Range {
        strategy: label.to_string(),
        min_rpm: Some(min_rpm),
        max_rpm: Some(max_rpm),
        gaps_rpm,
        criterion: CRITERION,
        resolution_pct: RESOLUTION * 100.0,
        tried,
    })
}
