//! Lowest and highest controllable speed, by bisection, each judged by the run's verdict
//! ([`crate::verdict`]: from the true rotor), with what limits it.
//!
//! - **Top speed**: turned up as the floor is turned down: the drive starts at the search's
//!   seed speed and from [`TURN_DOWN_S`] its command ramps up at [`RAMP_RPM_PER_S`] to the
//!   higher speed, settles for [`SETTLE_S`] and is judged over at least 20 electrical
//!   turns; controllable when the verdict is `running` with no restart. (Judged 3 s from
//!   standstill, a top speed measured the start-up's overshoot and settling, not the drive:
//!   twelve-step-df's came out at 8 688 rpm while a 9 s run at 10 000 rpm holds it.)
//! - **Floor**: what a drive holds after being turned down from a running speed, as a user
//!   would: the drive starts at the search's seed speed and from [`TURN_DOWN_S`] its
//!   command ramps down at [`RAMP_RPM_PER_S`] (slower than the rotor coasts on its
//!   friction, so the speed loop keeps control; a step down would let the rotor coast past
//!   the target while the meter catches up) to the lower speed; after [`SETTLE_S`] it is
//!   judged over a window of at least 20 electrical turns at that speed (1–5 s); searched
//!   down to 0 rpm. Start-up is measured separately.
//!
//! The limit of each bound is the verdict and reason of the failed run just beyond it
//! (lost synchronism of the guard, a stall, off-speed from the meter or the PWM floor, …),
//! led by where the rotor first slipped out of synchronism, if it did.

use super::seeded::Seeded;
use crate::config::DriveConfig;
use crate::profile::Profile;
use crate::scenario::{RunError, Scenario, Summary, run, settled};
use crate::verdict::Verdict;
use serde::Serialize;
use strategies::PluginLibrary;

/// The criterion, stated in every range result.
pub const CRITERION: &str = "verdict `running` (commutation in synchronism with the true rotor, true mean speed within 2 % of the command over the steady-state window) and no restart; top speed turned up from the seed speed by a 1000 rpm/s ramp from 1.5 s, settled for 2 s, window at least 1 s; floor turned down from the seed speed by a 1000 rpm/s ramp from 1.5 s, settled for 2 s, window 20 electrical turns (1–5 s)";

/// Highest speed searched \[rpm\] (the 14-bit speed command tops out at 16383).
pub const SEARCH_MAX_RPM: f64 = 16000.0;
/// When the floor's runs are turned down from the seed speed \[s\].
pub const TURN_DOWN_S: f64 = 1.5;
/// Time the turned-down drive gets to settle before its window \[s\].
pub const SETTLE_S: f64 = 2.0;
/// Rate of the turn-down ramp \[rpm/s\]: below the built-in rotor's coast-down rate on
/// its Coulomb friction alone (0.25 mN·m / 1.7e-6 kg·m² ≈ 1400 rpm/s).
pub const RAMP_RPM_PER_S: f64 = 1000.0;
/// Command updates of the ramp \[s\].
const RAMP_STEP_S: f64 = 0.01;
/// Relative resolution of the bisection.
pub const RESOLUTION: f64 = 0.03;
/// Absolute resolution of the floor's bisection \[rpm\].
pub const FLOOR_RESOLUTION_RPM: f64 = 5.0;
/// Where the search starts; tried first, then a ladder if it fails.
pub const SEEDS: [f64; 5] = [3000.0, 2000.0, 4500.0, 1000.0, 6000.0];

/// The chip's FG speed meter (a counter over k FG periods).
#[derive(Copy, Clone, Debug, PartialEq, Serialize)]
pub struct Meter {
    /// How reports name it.
    pub label: &'static str,
    /// FG periods per measurement.
    pub periods: u32,
    /// Counter width \[bits\].
    pub bits: u32,
    /// The meter's window `control.speed_window_s` \[s\] (`None`: the config's).
    pub window_s: Option<f64>,
}

impl Meter {
    /// The published chip's: 15 bits over 10 FG periods, no window; it cannot read below
    /// 1192 rpm with 12 poles (39 062 500 / 32 767).
    pub const AS_PUBLISHED: Meter = Meter {
        label: "15-bit (as published)",
        periods: 10,
        bits: 15,
        window_s: Some(0.0),
    };
    /// The config's meter (its window) with a 24-bit counter, which reads down to 2.3 rpm:
    /// a meter that does not bind, so that the floors show the guards.
    pub const WIDE: Meter = Meter {
        label: "24-bit (does not bind)",
        periods: 10,
        bits: 24,
        window_s: None,
    };

    /// `config` with this meter.
    pub fn apply(&self, config: &DriveConfig) -> DriveConfig {
        let mut c = config.clone();
        c.control.speed_periods = self.periods;
        c.control.speed_counter_bits = self.bits;
        if let Some(w) = self.window_s {
            c.control.speed_window_s = w;
        }
        c
    }
}

/// What stops a bound from going further: the failed run just beyond it.
#[derive(Clone, Debug, Serialize)]
pub struct Limit {
    /// The command that failed \[rpm\].
    pub rpm: f64,
    /// Its verdict.
    pub verdict: Verdict,
    /// Its reason.
    pub reason: String,
}

/// The range of one strategy with one meter.
#[derive(Clone, Debug, Serialize)]
pub struct Range {
    /// Strategy label.
    pub strategy: String,
    /// Speed meter of the chip.
    pub meter: String,
    /// Lowest speed held after being turned down \[rpm\] (None: none controllable).
    pub min_rpm: Option<f64>,
    /// What stops it going lower.
    pub min_limit: Option<Limit>,
    /// Highest speed held after being turned up from the seed speed \[rpm\].
    pub max_rpm: Option<f64>,
    /// What stops it going higher (None when the search's ceiling passed).
    pub max_limit: Option<Limit>,
    /// The criterion.
    pub criterion: &'static str,
    /// Resolution of the bisection: each reported bound was controllable and a speed
    /// this many percent further out was not (or is the end of the search) [%]; the floor
    /// also stops at 5 rpm.
    pub resolution_pct: f64,
    /// Every speed tried and whether it passed (floor runs turned down from the seed).
    pub tried: Vec<(f64, bool)>,
    /// Top-speed runs between the seed and the top that failed: bisection assumes the
    /// controllable speeds form one interval, and these show where that does not hold.
    pub gaps_rpm: Vec<f64>,
}

/// Whether `rpm` is controllable started from standstill, with the run's summary.
pub fn controllable(
    config: &DriveConfig,
    plugin: Option<&PluginLibrary>,
    rpm: f64,
) -> Result<(bool, Summary), RunError> {
    let mut sc = Scenario::hold(config.clone(), rpm, 3.0);
    sc.plugin = plugin.cloned();
    judge(&sc)
}

/// Whether the drive, running at `seed_rpm`, holds `rpm` after being turned down (or up)
/// to it, run from standstill (the searches fork their runs: [`Seeded::held`]).
pub fn held_after_turn_down(
    config: &DriveConfig,
    plugin: Option<&PluginLibrary>,
    seed_rpm: f64,
    rpm: f64,
) -> Result<(bool, Summary), RunError> {
    let mut sc = turned(config, seed_rpm, rpm, TURN_DOWN_S);
    sc.plugin = plugin.cloned();
    judge(&sc)
}

/// A drive commanded `seed_rpm` from standstill whose command ramps at [`RAMP_RPM_PER_S`]
/// from `at_s` to `rpm` (down or up), given [`SETTLE_S`] and then judged over a window of
/// at least 20 electrical turns at `rpm` (1–5 s).
pub fn turned(config: &DriveConfig, seed_rpm: f64, rpm: f64, at_s: f64) -> Scenario {
    let pole_pairs = f64::from(config.motor.poles / 2);
    let window = (20.0 * 60.0 / (rpm * pole_pairs)).clamp(1.0, 5.0);
    let ramp_s = (seed_rpm - rpm).abs() / RAMP_RPM_PER_S;
    let duration = at_s + ramp_s + SETTLE_S + window;
    let mut sc = Scenario::hold(config.clone(), seed_rpm, duration);
    sc.speed_rpm = Profile::constant(seed_rpm).ramp_to(at_s, at_s + ramp_s, rpm);
    sc.profile_update_s = RAMP_STEP_S;
    sc.steady_from_s = duration - window;
    sc
}

/// Whether a run held its command: verdict `running` and no restart in the whole run.
pub fn holds(s: &Summary) -> bool {
    s.verdict.is_running() && s.restarts == 0
}

fn judge(sc: &Scenario) -> Result<(bool, Summary), RunError> {
    // Lengthened while the window falls in the start-up (or, turned, the speed's settling).
    let s = settled(sc, |s| run(s, |_| {}))?.1.summary;
    Ok((holds(&s), s))
}

/// The limit a failed run at `rpm` sets: its verdict and reason (restarts named when the
/// verdict alone would read `running`), led by where the rotor first slipped.
pub fn limit(rpm: f64, s: &Summary) -> Limit {
    let reason = if s.restarts > 0 && s.verdict == Verdict::Running {
        format!("{} restarts before holding the speed", s.restarts)
    } else {
        s.verdict_reason.clone()
    };
    Limit {
        rpm: rpm.round(),
        verdict: s.verdict,
        reason: match s.sync_lost_at {
            Some((t, at)) => {
                format!("first out of synchronism at {t:.2} s, {at:.0} rpm (true); then {reason}")
            }
            None => reason,
        },
    }
}

/// A floor found by bisection.
#[derive(Clone, Debug, Serialize)]
pub struct Floor {
    /// Lowest speed held after being turned down \[rpm\] (the seed when nothing below it
    /// held).
    pub rpm: f64,
    /// The failed run just below it.
    pub limit: Option<Limit>,
    /// Every speed tried and whether it held.
    pub tried: Vec<(f64, bool)>,
    /// Simulated time of the runs \[s\].
    pub sim_s: f64,
}

/// The floor of a drive running at the seed speed, by bisection between the seed (held)
/// and 0 rpm (never held), each run turned down from the seed (forked from `seeded`'s
/// start-up); it stops when the bracket is within `resolution` of the floor (relative)
/// or [`FLOOR_RESOLUTION_RPM`].
pub fn floor(seeded: &mut Seeded, resolution: f64) -> Result<Floor, RunError> {
    let seed_rpm = seeded.seed_rpm();
    let mut f = Floor {
        rpm: seed_rpm,
        limit: None,
        tried: Vec::new(),
        sim_s: 0.0,
    };
    // `good` holds after the turn-down, `bad` does not (0 rpm never does).
    let (mut good, mut bad) = (seed_rpm, 0.0);
    while good - bad > (resolution * good).max(FLOOR_RESOLUTION_RPM) {
        let mid = 0.5 * (good + bad);
        let (ok, sum) = seeded.held(mid)?;
        f.tried.push((mid, ok));
        f.sim_s += sum.sim_s;
        if ok {
            good = mid;
        } else {
            bad = mid;
            f.limit = Some(limit(mid, &sum));
        }
    }
    f.rpm = good.round();
    Ok(f)
}

/// Searches the range of `config`'s strategy (or `plugin`'s), labelled `label`, with the
/// meter `config` sets (named `meter` in the result).
pub fn search(
    config: &DriveConfig,
    plugin: Option<&PluginLibrary>,
    label: &str,
    meter: &str,
) -> Result<Range, RunError> {
    let mut tried = Vec::new();
    let mut range = Range {
        strategy: label.to_string(),
        meter: meter.to_string(),
        min_rpm: None,
        min_limit: None,
        max_rpm: None,
        max_limit: None,
        criterion: CRITERION,
        resolution_pct: RESOLUTION * 100.0,
        tried: Vec::new(),
        gaps_rpm: Vec::new(),
    };
    let mut seed = None;
    for s in SEEDS {
        let (ok, sum) = controllable(config, plugin, s)?;
        tried.push((s, ok));
        if ok {
            seed = Some(s);
            break;
        }
        range.max_limit = Some(limit(s, &sum));
    }
    let Some(seed) = seed else {
        range.tried = tried;
        return Ok(range);
    };
    range.max_limit = None;
    // The floor's and the top's runs all fork from one start-up at the seed.
    let mut seeded = Seeded::new(config, plugin, seed);
    let floor = floor(&mut seeded, RESOLUTION)?;
    tried.extend(floor.tried);
    range.min_rpm = Some(floor.rpm);
    range.min_limit = floor.limit;
    // Top: `good` holds after the turn-up, `bad` does not (or is the ceiling).
    let (mut good, mut bad) = (seed, SEARCH_MAX_RPM);
    let (ok, sum) = seeded.held(bad)?;
    tried.push((bad, ok));
    if ok {
        good = bad;
    } else {
        range.max_limit = Some(limit(bad, &sum));
        while bad - good > RESOLUTION * good {
            let mid = 0.5 * (good + bad);
            let (ok, sum) = seeded.held(mid)?;
            tried.push((mid, ok));
            if ok {
                good = mid;
            } else {
                bad = mid;
                range.max_limit = Some(limit(mid, &sum));
            }
        }
    }
    range.max_rpm = Some(good.round());
    range.gaps_rpm = tried
        .iter()
        .filter(|&&(rpm, ok)| !ok && rpm > seed && rpm < good)
        .map(|&(rpm, _)| rpm.round())
        .collect();
    range.tried = tried;
    Ok(range)
}
