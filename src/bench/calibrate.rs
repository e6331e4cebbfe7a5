//! Calibration of the LM guard's speeds ωm and ωM for a given drive, by simulation.
//!
//! LM shrinks the linear region with the measured speed: 1° at and below ωm, the full
//! window θmax (`strategy.linear_region_deg`) from ωM on. Both are properties of the motor
//! and drive, found here with ND runs (a fixed window θ) judged by the verdict from the
//! true rotor:
//!
//! - **ωm**, the lowest speed reachable with a 1° window: the floor of ND at θ = 1°, i.e.
//!   the lowest command the drive holds (verdict `running`, no restart after the turn)
//!   after being turned down from a running speed. A window of θ applies full voltage θ/60
//!   of the time, so it bounds the average voltage, hence the speed, from below; 1° is the
//!   narrowest window the chip's whole degrees allow, so its floor is the lowest any LM
//!   setting can reach.
//! - **ωM**, the speed from which θmax is needed: the highest command at which the next
//!   narrower window, θmax − 1, still keeps the commutation in synchronism (verdict
//!   `running` or `off-speed`, no restart after the turn) when turned up to it from a
//!   running speed. Synchronism, not the speed, is the criterion: a window only protects
//!   the crossings, and a command the voltage cannot reach is off-speed whatever the
//!   window. If θmax − 1 keeps synchronism up to the search's ceiling
//!   ([`range::SEARCH_MAX_RPM`]), no narrower window is ever needed below the top speed
//!   the voltage allows: the result says so and ωM is that top speed (the true mean speed
//!   of the ceiling run), so that LM reaches θmax only where no speed is left to control.
//!
//! Both bounds are judged on a drive already running (turned from a seed speed at
//! [`TURN_S`]), so that start-up, which the window also affects, does not decide them;
//! restarts before the turn are start-up's and are not counted. The runs use the 24-bit
//! speed meter ([`Meter::WIDE`]): the published 15-bit one cannot read below 1192 rpm and
//! would set ωm itself.

use super::pool;
use super::range::{self, FLOOR_RESOLUTION_RPM, Limit, Meter, RESOLUTION, SEARCH_MAX_RPM, SEEDS};
use crate::config::DriveConfig;
use crate::scenario::{RunError, Scenario, Summary, run, settled};
use crate::verdict::Verdict;
use drive_core::error::ParamError;
use serde::Serialize;
use std::time::Instant;
use strategies::StrategyName;
use strategies::params::SPEED_CMD_MAX_RPM;

/// When the calibration runs are turned from their seed speed \[s\]: the seed is judged
/// over 2–3 s from standstill, so the drive is known to run in synchronism there.
pub const TURN_S: f64 = 3.0;

/// The criterion, stated in every result.
pub const CRITERION: &str = "ND runs with a fixed window, 24-bit speed meter, started at a seed speed and ramped at 1000 rpm/s from 3 s, settled 2 s, window 20 electrical turns (1–5 s); ωm: lowest command held at 1° (verdict `running`, no restart after the turn), bisected to 3 % / 5 rpm; ωM: highest command kept in synchronism at θmax − 1 (verdict `running` or `off-speed`, no restart after the turn), bisected to 3 %";

/// What a bound is judged by.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Criterion {
    /// Verdict `running`: in synchronism and within tolerance of the command.
    Held,
    /// Verdict `running` or `off-speed`: the commutation in synchronism, whatever the speed.
    InSync,
}

impl Criterion {
    fn passes(self, v: Verdict) -> bool {
        match self {
            Criterion::Held => v == Verdict::Running,
            Criterion::InSync => matches!(v, Verdict::Running | Verdict::OffSpeed),
        }
    }
}

/// One simulation of the calibration.
#[derive(Clone, Debug, Serialize)]
pub struct CalRun {
    /// `"min"` (ωm search) or `"max"` (ωM search).
    pub search: &'static str,
    /// ND window [whole electrical degrees].
    pub window_deg: u32,
    /// Seed speed the run was turned from \[rpm\] (None: a seed run from standstill).
    pub from_rpm: Option<f64>,
    /// Command judged \[rpm\].
    pub rpm: f64,
    /// Its verdict.
    pub verdict: Verdict,
    /// Restarts after the turn (for a seed run: over the whole run).
    pub restarts: u32,
    /// True mean speed over the window \[rpm\].
    pub speed_mean_rpm: f64,
    /// Whether it passed the search's criterion.
    pub passed: bool,
}

/// The calibrated LM speeds of one drive.
#[derive(Clone, Debug, Serialize)]
pub struct LmCalibration {
    /// ωm: lowest speed held with a 1° window \[rpm\] (the value of
    /// `strategy.lm_speed_min_rpm`).
    pub min_rpm: u32,
    /// What stops ωm going lower: the failed run just below it (None when the search
    /// reached its 5 rpm resolution above 0 rpm without a failure on record).
    pub min_limit: Option<Limit>,
    /// ωM: the speed from which θmax is needed \[rpm\] (the value of
    /// `strategy.lm_speed_max_rpm`).
    pub max_rpm: u32,
    /// What stops θmax − 1 above ωM: the failed run just above it (None when it kept
    /// synchronism up to the ceiling).
    pub max_limit: Option<Limit>,
    /// Whether θmax − 1 lost synchronism below the top speed the voltage allows; false:
    /// ωM is that top speed.
    pub full_window_needed: bool,
    /// Whether θmax itself kept synchronism at the command where θmax − 1 failed (None when
    /// nothing failed); false: the failure is not the window's width.
    pub full_window_holds_at_limit: Option<bool>,
    /// θmax [whole electrical degrees].
    pub theta_max_deg: u32,
    /// The window ωM is judged with, θmax − 1 [whole electrical degrees].
    pub narrower_deg: u32,
    /// The speed meter of the runs.
    pub meter: &'static str,
    /// The criterion.
    pub criterion: &'static str,
    /// Every run, in the order made.
    pub runs: Vec<CalRun>,
    /// Wall-clock time of the calibration \[s\].
    pub wall_s: f64,
}

impl LmCalibration {
    /// The `[strategy]` lines that set the calibrated values.
    pub fn toml_lines(&self) -> String {
        format!(
            "[strategy]\nlm_speed_min_rpm = {}\nlm_speed_max_rpm = {}\n",
            self.min_rpm, self.max_rpm
        )
    }

    /// `config` with the calibrated values, checked by the strategy's rules (ωM > ωm).
    pub fn apply(&self, config: &DriveConfig) -> Result<DriveConfig, ParamError> {
        let mut c = config.clone();
        c.strategy.lm_speed_min_rpm = self.min_rpm;
        c.strategy.lm_speed_max_rpm = self.max_rpm;
        c.strategy.validate()?;
        Ok(c)
    }
}

/// Why a calibration could not be made.
#[derive(Debug, thiserror::Error)]
pub enum CalibrationError {
    /// The config, or a calibration option, breaks a rule.
    #[error("{0}")]
    Param(#[from] ParamError),
    /// A run could not be made.
    #[error("{0}")]
    Run(#[from] RunError),
    /// No seed speed ran (the drive does not run with this window at any of them).
    #[error(
        "no seed speed ({seeds:?} rpm) ran with a {window_deg}° window ({criterion:?}); last: {last}"
    )]
    NoSeed {
        /// The window.
        window_deg: u32,
        /// The seeds tried \[rpm\].
        seeds: [f64; 5],
        /// What a seed had to pass.
        criterion: Criterion,
        /// The last seed's verdict and reason.
        last: String,
    },
}

/// Finds ωm and ωM for `config`'s motor and drive (its `[strategy]` name is replaced by
/// `twelve-step-nd`; `linear_region_deg` is θmax), on up to `threads` threads (the two
/// searches are independent; more than 2 do not help).
pub fn calibrate_lm(
    config: &DriveConfig,
    threads: usize,
) -> Result<LmCalibration, CalibrationError> {
    config.validate()?;
    let theta_max = config.strategy.linear_region_deg;
    if theta_max < 2 {
        return Err(ParamError::new(
            "strategy.linear_region_deg",
            theta_max,
            "must be >= 2 to calibrate LM (ωM is judged with the window 1° narrower)",
        )
        .into());
    }
    let nd = |deg: u32| -> Result<DriveConfig, ParamError> {
        let mut c = Meter::WIDE.apply(config);
        c.strategy.name = StrategyName::TwelveStepNd;
        c.strategy.guard = None; // the name fixes it
        c.strategy.linear_region_deg = deg;
        c.validate()?;
        Ok(c)
    };
    let (low, high) = (nd(1)?, nd(theta_max - 1)?);
    let full = nd(theta_max)?;
    let wall = Instant::now();
    let jobs = [Search::Min, Search::Max];
    let found = pool::map(&jobs, threads.clamp(1, 2), None, |job| match job {
        Search::Min => min_search(&low).map(Found::Min),
        Search::Max => max_search(&high, &full).map(Found::Max),
    });
    let (mut min, mut max) = (None, None);
    for f in found {
        match f? {
            Found::Min(m) => min = Some(m),
            Found::Max(m) => max = Some(m),
        }
    }
    let (Some(min), Some(max)) = (min, max) else {
        unreachable!("pool::map returns one result per job")
    };
    let mut runs = min.runs;
    runs.extend(max.runs);
    Ok(LmCalibration {
        min_rpm: min.rpm,
        min_limit: min.limit,
        max_rpm: max.rpm,
        max_limit: max.limit,
        full_window_needed: max.needed,
        full_window_holds_at_limit: max.full_holds,
        theta_max_deg: theta_max,
        narrower_deg: theta_max - 1,
        meter: Meter::WIDE.label,
        criterion: CRITERION,
        runs,
        wall_s: wall.elapsed().as_secs_f64(),
    })
}

enum Search {
    Min,
    Max,
}

enum Found {
    Min(Bound),
    Max(Bound),
}

/// One bound with what limits it and the runs that found it.
struct Bound {
    rpm: u32,
    limit: Option<Limit>,
    needed: bool,
    full_holds: Option<bool>,
    runs: Vec<CalRun>,
}

/// A drive started from standstill at its seed speed, known to run there.
struct Seed {
    rpm: f64,
    /// Restarts before [`TURN_S`] (start-up's; identical in every run turned from it,
    /// which is the same simulation up to the turn).
    restarts: u32,
}

/// The runs of one search.
struct Log {
    search: &'static str,
    window_deg: u32,
    runs: Vec<CalRun>,
}

impl Log {
    fn push(&mut self, from: Option<f64>, rpm: f64, s: &Summary, restarts: u32, passed: bool) {
        self.runs.push(CalRun {
            search: self.search,
            window_deg: self.window_deg,
            from_rpm: from,
            rpm: rpm.round(),
            verdict: s.verdict,
            restarts,
            speed_mean_rpm: s.speed_mean_rpm,
            passed,
        });
    }
}

/// The first seed of [`SEEDS`] at which the drive, started from standstill, passes `crit`
/// over 2–3 s.
fn seed(config: &DriveConfig, crit: Criterion, log: &mut Log) -> Result<Seed, CalibrationError> {
    let mut last = String::new();
    for rpm in SEEDS {
        let sc = Scenario::hold(config.clone(), rpm, TURN_S);
        let s = settled(&sc, |s| run(s, |_| {}))?.1.summary;
        let ok = crit.passes(s.verdict);
        log.push(None, rpm, &s, s.restarts, ok);
        if ok {
            return Ok(Seed {
                rpm,
                restarts: s.restarts,
            });
        }
        last = format!("{rpm} rpm: {}: {}", s.verdict, s.verdict_reason);
    }
    Err(CalibrationError::NoSeed {
        window_deg: config.strategy.linear_region_deg,
        seeds: SEEDS,
        criterion: crit,
        last,
    })
}

/// The drive running at `seed`, its command ramped to `rpm` from [`TURN_S`] and judged as
/// [`range::turned`] does: whether it passes `crit` with no restart after the turn, the
/// limit it sets if not, and its summary.
fn turned(
    config: &DriveConfig,
    seed: &Seed,
    rpm: f64,
    crit: Criterion,
    log: &mut Log,
) -> Result<(bool, Limit, Summary), CalibrationError> {
    let sc = range::turned(config, seed.rpm, rpm, TURN_S);
    let s = settled(&sc, |s| run(s, |_| {}))?.1.summary;
    let restarts = s.restarts.saturating_sub(seed.restarts);
    let ok = crit.passes(s.verdict) && restarts == 0;
    log.push(Some(seed.rpm), rpm, &s, restarts, ok);
    let reason = if restarts > 0 && crit.passes(s.verdict) {
        format!("{restarts} restart(s) after the turn before the window")
    } else {
        s.verdict_reason.clone()
    };
    let limit = Limit {
        rpm: rpm.round(),
        verdict: s.verdict,
        reason,
    };
    Ok((ok, limit, s))
}

/// ωm: the floor of the 1° window, bisected from the seed down to 0 rpm.
fn min_search(config: &DriveConfig) -> Result<Bound, CalibrationError> {
    let mut log = Log {
        search: "min",
        window_deg: 1,
        runs: Vec::new(),
    };
    let crit = Criterion::Held;
    let seed = seed(config, crit, &mut log)?;
    let (mut good, mut bad, mut limit) = (seed.rpm, 0.0, None);
    while good - bad > (RESOLUTION * good).max(FLOOR_RESOLUTION_RPM) {
        let mid = 0.5 * (good + bad);
        let (ok, l, _) = turned(config, &seed, mid, crit, &mut log)?;
        if ok {
            good = mid;
        } else {
            bad = mid;
            limit = Some(l);
        }
    }
    Ok(Bound {
        rpm: good.round() as u32,
        limit,
        needed: true,
        full_holds: None,
        runs: log.runs,
    })
}

/// ωM: the highest command θmax − 1 keeps in synchronism, bisected from the seed up to the
/// ceiling; `full` (θmax) is tried once where θmax − 1 first failed.
fn max_search(narrower: &DriveConfig, full: &DriveConfig) -> Result<Bound, CalibrationError> {
    let mut log = Log {
        search: "max",
        window_deg: narrower.strategy.linear_region_deg,
        runs: Vec::new(),
    };
    let crit = Criterion::InSync;
    let seed = seed(narrower, crit, &mut log)?;
    let (ok, l, s) = turned(narrower, &seed, SEARCH_MAX_RPM, crit, &mut log)?;
    if ok {
        // Never lost below the top the voltage allows: ωM is that top speed.
        return Ok(Bound {
            rpm: s.speed_mean_rpm.min(SPEED_CMD_MAX_RPM).round() as u32,
            limit: None,
            needed: false,
            full_holds: None,
            runs: log.runs,
        });
    }
    let (mut good, mut bad, mut limit) = (seed.rpm, SEARCH_MAX_RPM, l);
    while bad - good > RESOLUTION * good {
        let mid = 0.5 * (good + bad);
        let (ok, l, _) = turned(narrower, &seed, mid, crit, &mut log)?;
        if ok {
            good = mid;
        } else {
            bad = mid;
            limit = l;
        }
    }
    // Is it the width? The full window at the same command, from its own seed.
    let mut full_log = Log {
        search: "max",
        window_deg: full.strategy.linear_region_deg,
        runs: Vec::new(),
    };
    let full_holds = match seed_at(full, crit, &mut full_log)? {
        Some(fs) => Some(turned(full, &fs, bad, crit, &mut full_log)?.0),
        None => Some(false),
    };
    log.runs.extend(full_log.runs);
    Ok(Bound {
        rpm: good.round() as u32,
        limit: Some(limit),
        needed: true,
        full_holds,
        runs: log.runs,
    })
}

/// [`seed`], with no seed as `None` rather than an error.
fn seed_at(
    config: &DriveConfig,
    crit: Criterion,
    log: &mut Log,
) -> Result<Option<Seed>, CalibrationError> {
    match seed(config, crit, log) {
        Ok(s) => Ok(Some(s)),
        Err(CalibrationError::NoSeed { .. }) => Ok(None),
        Err(e) => Err(e),
    }
}
