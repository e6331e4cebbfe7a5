//! The sensitivity study: what a chip designer controls (PWM frequency, the guards, the
//! speed meter, the loop gains) and what the hardware varies (the comparator's filters and
//! hysteresis, friction), each set to a low and a high level, and what that does to the
//! floor and to the low-band torque ripple of a few strategies. The report's tornado
//! charts are drawn from it ([`super::tornado`]).
//!
//! - **Floor**: [`range::floor`], the range's bisection, on the 24-bit meter
//!   ([`Meter::WIDE`]), seeded at [`SEED_RPM`] after the seed holds from standstill
//!   ([`range::controllable`]), to [`RESOLUTION`] (the range's 3 %).
//! - **Ripple**: the low-band ripple (`torque_ripple_lf_nm / torque_mean_nm`) at
//!   [`RIPPLE_RPM`], turned down from [`SEED_RPM`] as the vibration section's runs are.

use super::pool;
use super::range::{self, Limit, Meter};
use super::seeded::Seeded;
use crate::config::DriveConfig;
use crate::scenario::RunError;
use drive_core::error::ParamError;
use serde::Serialize;
use std::time::Instant;
use strategies::{GuardKind, StrategyName, StrategyParams};

/// The strategies studied: one per guard that holds low speeds at 150° (DF, the chip's
/// default, and LM), and 120° conduction with the DF (the lowest floor). raw has no guard
/// to vary, ND's floor (≈ 4700 rpm) is its window's full-voltage time, and the other
/// conduction angles share DF's guard.
pub const STRATEGIES: [StrategyName; 3] = [
    StrategyName::SixStep120,
    StrategyName::TwelveStepLm,
    StrategyName::TwelveStepDf,
];
/// Where every run starts and the floor's bisection is seeded \[rpm\] (the range's first
/// seed).
pub const SEED_RPM: f64 = range::SEEDS[0];
/// Speed of the ripple runs \[rpm\] (the vibration section's low speed).
pub const RIPPLE_RPM: f64 = 1000.0;
/// Relative resolution of the study's floor bisection: the range's 3 %, ±8 rpm at a
/// 500 rpm floor (6 % saved one run per floor before the runs forked from one start-up).
pub const RESOLUTION: f64 = range::RESOLUTION;

/// A factor of the study.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Factor {
    /// `control.carrier_top`, with the current PI's gains kept in duty per ampere.
    PwmFrequency,
    /// The neutral filter's time constant against the phase filter's.
    FilterMismatch,
    /// `sensing.comparator.hysteresis_v`.
    Hysteresis,
    /// `strategy.filter_samples` (DF guard only).
    DfSamples,
    /// `strategy.lm_speed_min_rpm`, ωm (LM guard only).
    LmWindow,
    /// `control.speed_periods`.
    MeterPeriods,
    /// `control.speed_counter_bits`.
    MeterWidth,
    /// `control.speed_kp` and `speed_ki` together.
    SpeedGains,
    /// `control.current_kp` and `current_ki` together.
    CurrentGains,
    /// `motor.coulomb_friction_nm`.
    Friction,
}

/// Which of a factor's two levels.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Side {
    /// The low level.
    Low,
    /// The high level.
    High,
}

impl Factor {
    /// Every factor, in table order.
    pub const ALL: [Factor; 10] = [
        Factor::PwmFrequency,
        Factor::FilterMismatch,
        Factor::Hysteresis,
        Factor::DfSamples,
        Factor::LmWindow,
        Factor::MeterPeriods,
        Factor::MeterWidth,
        Factor::SpeedGains,
        Factor::CurrentGains,
        Factor::Friction,
    ];

    /// How tables and charts name it.
    pub fn name(self) -> &'static str {
        match self {
            Factor::PwmFrequency => "PWM frequency",
            Factor::FilterMismatch => "comparator filter mismatch",
            Factor::Hysteresis => "comparator hysteresis",
            Factor::DfSamples => "DF samples",
            Factor::LmWindow => "LM ωm (1° window below it)",
            Factor::MeterPeriods => "meter periods",
            Factor::MeterWidth => "meter width",
            Factor::SpeedGains => "speed loop gains",
            Factor::CurrentGains => "current loop gains",
            Factor::Friction => "Coulomb friction",
        }
    }

    /// Why these levels.
    pub fn basis(self) -> &'static str {
        match self {
            Factor::PwmFrequency => {
                "½× and 2× the chip's 12.5 kHz (carrier top 4000 and 1000 counts, inside the 12-bit carrier's 500..=4095); the current PI's gains scaled by top/2000 so the loop's duty per ampere is unchanged"
            }
            Factor::FilterMismatch => {
                "the neutral RC's τ 0 % and 10 % above the phase RC's, around the default 5 % (matched parts, and 1 % resistors with 5 % capacitors at their worst): the drift's cause (docs/chip.md)"
            }
            Factor::Hysteresis => "½× and 2× the default",
            Factor::DfSamples => "one flip-flop fewer and one more than the chip's 3",
            Factor::LmWindow => "½× and 2× the calibrated ωm (`drive-bench calibrate-lm`)",
            Factor::MeterPeriods => {
                "½× and 2× the chip's 10 FG periods (the 20 ms window still ends a reading first at low speed)"
            }
            Factor::MeterWidth => {
                "one bit fewer than the published 15, and the 15 (the study's baseline has 24): with the 20 ms window a reading spans less than the window plus one FG period, so 14 bits (41.9 ms) read down to 238 rpm and 15 bits (83.9 ms) down to 119 rpm; 13 bits (21.0 ms) saturate below ≈ 2900 rpm (floors of 1450–2900 rpm when tried)"
            }
            Factor::SpeedGains => {
                "Kp and Ki ½× and 2× the tuned values (a 6 dB gain margin either way)"
            }
            Factor::CurrentGains => "Kp and Ki ½× and 2× the tuned values",
            Factor::Friction => {
                "½× and 2× the bearing drag (spread between spindles and with temperature); the turn-down's 1000 rpm/s outruns the coast-down at ½×"
            }
        }
    }

    /// Whether it applies to `s` (the guards' own parameters only to their guard).
    pub fn applies(self, s: &StrategyParams) -> bool {
        match self {
            Factor::DfSamples => s.guard_kind() == GuardKind::Df,
            Factor::LmWindow => s.guard_kind() == GuardKind::Lm,
            _ => true,
        }
    }

    /// `config` at this factor's `side` level, with the level's label; an error names the
    /// key, the factor and level, and the rule the level breaks.
    pub fn level(
        self,
        side: Side,
        config: &DriveConfig,
    ) -> Result<(DriveConfig, String), ParamError> {
        let mut c = config.clone();
        let low = side == Side::Low;
        // ½× at the low level, 2× at the high.
        let x = if low { 0.5 } else { 2.0 };
        let label = match self {
            Factor::PwmFrequency => {
                // The low frequency is the longer carrier.
                let top = if low {
                    c.control.carrier_top * 2
                } else {
                    c.control.carrier_top / 2
                };
                let k = f64::from(top) / f64::from(c.control.carrier_top);
                c.control.carrier_top = top;
                c.control.current_kp *= k;
                c.control.current_ki *= k;
                format!("{} kHz", (2.5e6 / f64::from(top)).round() / 100.0)
            }
            Factor::FilterMismatch => {
                let m = if low { 0.0 } else { 0.10 };
                let cmp = &mut c.sensing.comparator;
                cmp.neutral_filter_tau_s = cmp.phase_filter_tau_s * (1.0 + m);
                format!("{:.0} %", m * 100.0)
            }
            Factor::Hysteresis => {
                c.sensing.comparator.hysteresis_v *= x;
                format!("{:.0} mV", c.sensing.comparator.hysteresis_v * 1e3)
            }
            Factor::DfSamples => {
                let n = &mut c.strategy.filter_samples;
                *n = if low { n.saturating_sub(1) } else { *n + 1 };
                format!("{n}")
            }
            Factor::LmWindow => {
                let w = &mut c.strategy.lm_speed_min_rpm;
                *w = (f64::from(*w) * x).round() as u32;
                format!("{w} rpm")
            }
            Factor::MeterPeriods => {
                let k = &mut c.control.speed_periods;
                *k = if low { *k / 2 } else { *k * 2 };
                format!("{k}")
            }
            Factor::MeterWidth => {
                c.control.speed_counter_bits = if low { 14 } else { 15 };
                format!("{} bits", c.control.speed_counter_bits)
            }
            Factor::SpeedGains => {
                c.control.speed_kp *= x;
                c.control.speed_ki *= x;
                format!("{x}×")
            }
            Factor::CurrentGains => {
                c.control.current_kp *= x;
                c.control.current_ki *= x;
                format!("{x}×")
            }
            Factor::Friction => {
                c.motor.coulomb_friction_nm *= x;
                format!("{:.3} mN·m", c.motor.coulomb_friction_nm * 1e3)
            }
        };
        match c.validate() {
            Ok(()) => Ok((c, label)),
            Err(e) => Err(ParamError {
                field: format!(
                    "{} (the sensitivity study's {} at {label})",
                    e.field,
                    self.name()
                ),
                ..e
            }),
        }
    }
}

/// One run of the study: a strategy at the baseline or at one factor's level.
#[derive(Clone, Debug)]
pub struct Job {
    /// Strategy label.
    pub strategy: String,
    /// The factor and level (None: the baseline).
    pub level: Option<(Factor, Side)>,
    /// The level's label ("baseline" for none).
    pub label: String,
    /// The config it runs (checked).
    pub config: DriveConfig,
}

/// The jobs for `strategies` (label and `[strategy]` section) on `base` with the 24-bit
/// meter: the baseline and both levels of every factor that applies. Every config is
/// checked here, before any runs: an error names the first level that breaks a rule.
pub fn jobs(
    base: &DriveConfig,
    strategies: &[(String, StrategyParams)],
) -> Result<Vec<Job>, ParamError> {
    let mut out = Vec::new();
    for (label, s) in strategies {
        let mut c = Meter::WIDE.apply(base);
        c.strategy = s.clone();
        c.validate()?;
        out.push(Job {
            strategy: label.clone(),
            level: None,
            label: "baseline".into(),
            config: c.clone(),
        });
        for f in Factor::ALL.into_iter().filter(|f| f.applies(s)) {
            for side in [Side::Low, Side::High] {
                let (config, level) = f.level(side, &c)?;
                out.push(Job {
                    strategy: label.clone(),
                    level: Some((f, side)),
                    label: level,
                    config,
                });
            }
        }
    }
    Ok(out)
}

/// What one job found.
#[derive(Clone, Debug, Serialize)]
pub struct Point {
    /// Strategy label.
    pub strategy: String,
    /// The factor and level (None: the baseline).
    pub level: Option<(Factor, Side)>,
    /// The level's label ("baseline" for none).
    pub label: String,
    /// Floor \[rpm\] (None: the seed did not hold from standstill).
    pub floor_rpm: Option<f64>,
    /// The failed run below the floor, or the seed's when it did not hold.
    pub floor_limit: Option<Limit>,
    /// Low-band ripple at [`RIPPLE_RPM`], % of the mean torque (None: not `running`).
    pub ripple_pct: Option<f64>,
    /// The ripple run's verdict and reason.
    pub ripple_verdict: String,
    /// Runs made.
    pub runs: usize,
    /// Simulated time of the runs \[s\].
    pub sim_s: f64,
    /// Time the job took on its thread \[s\].
    pub wall_s: f64,
}

/// Runs `job`: the seed from standstill, the floor's bisection, the ripple run.
pub fn run_job(job: &Job) -> Result<Point, RunError> {
    let wall = Instant::now();
    let c = &job.config;
    let (held, seed) = range::controllable(c, None, SEED_RPM)?;
    let (mut runs, mut sim_s) = (1, seed.sim_s);
    // The floor's runs and the ripple run fork from one start-up at the seed.
    let mut seeded = Seeded::new(c, None, SEED_RPM);
    let (floor_rpm, floor_limit) = if held {
        let f = range::floor(&mut seeded, RESOLUTION)?;
        runs += f.tried.len();
        sim_s += f.sim_s;
        (Some(f.rpm), f.limit)
    } else {
        (None, Some(range::limit(SEED_RPM, &seed)))
    };
    // Lengthened while its window still falls in the settling, as the range search does.
    let s = seeded.settled(RIPPLE_RPM)?.summary;
    runs += 1;
    sim_s += s.sim_s;
    let ripple_pct = s
        .verdict
        .is_running()
        .then(|| 100.0 * s.torque_ripple_lf_nm / s.torque_mean_nm.abs().max(f64::MIN_POSITIVE));
    Ok(Point {
        strategy: job.strategy.clone(),
        level: job.level,
        label: job.label.clone(),
        floor_rpm,
        floor_limit,
        ripple_pct,
        ripple_verdict: format!("{}: {}", s.verdict, s.verdict_reason),
        runs,
        sim_s,
        wall_s: wall.elapsed().as_secs_f64(),
    })
}

/// The study's strategies as (label, section) on `base`'s `[strategy]` settings.
pub fn strategies(base: &StrategyParams, names: &[StrategyName]) -> Vec<(String, StrategyParams)> {
    names
        .iter()
        .map(|&n| {
            let v = super::Variant::builtin(base, n, None);
            (v.label, v.strategy)
        })
        .collect()
}

/// Runs the study for `strategies` on `threads` threads (every config checked first).
pub fn study(
    base: &DriveConfig,
    strategies: &[(String, StrategyParams)],
    threads: usize,
    progress: bool,
) -> Result<Vec<Point>, String> {
    let jobs = jobs(base, strategies).map_err(|e| e.to_string())?;
    pool::map(&jobs, threads, progress.then_some("sensitivity"), run_job)
        .into_iter()
        .map(|r| r.map_err(|e| e.to_string()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_strategy_gets_the_baseline_and_both_levels_of_the_factors_that_apply() {
        let base = DriveConfig::default();
        let studied = strategies(&base.strategy, &STRATEGIES);
        let jobs = jobs(&base, &studied).unwrap();
        // Eight common factors and one guard's own: 1 + 2 × 9 each.
        assert_eq!(jobs.len(), 3 * 19);
        let has = |st: &str, f: Factor| {
            jobs.iter()
                .any(|j| j.strategy == st && j.level.is_some_and(|l| l.0 == f))
        };
        // six-step-120 runs the DF guard by default.
        assert!(has("six-step-120", Factor::DfSamples) && !has("six-step-120", Factor::LmWindow));
        assert!(
            has("twelve-step-lm", Factor::LmWindow) && !has("twelve-step-lm", Factor::DfSamples)
        );
        assert!(
            has("twelve-step-df", Factor::DfSamples) && !has("twelve-step-df", Factor::LmWindow)
        );
        // Every run has the 24-bit meter unless the meter is the factor.
        assert!(
            jobs.iter()
                .all(|j| j.config.control.speed_counter_bits == 24
                    || j.level.is_some_and(|l| l.0 == Factor::MeterWidth))
        );
    }

    #[test]
    fn the_pwm_levels_halve_and_double_the_frequency_keeping_the_duty_per_ampere() {
        let base = DriveConfig::default();
        for (side, top, khz) in [(Side::Low, 4000, "6.25 kHz"), (Side::High, 1000, "25 kHz")] {
            let (c, label) = Factor::PwmFrequency.level(side, &base).unwrap();
            assert_eq!((c.control.carrier_top, label.as_str()), (top, khz));
            // Counts per ampere over counts per unit duty: the same as the chip's.
            let duty_gain =
                |c: &DriveConfig| c.control.current_ki / f64::from(c.control.carrier_top);
            assert!((duty_gain(&c) - duty_gain(&base)).abs() < 1e-12);
        }
        let (c, label) = Factor::FilterMismatch.level(Side::High, &base).unwrap();
        let cmp = &c.sensing.comparator;
        assert!((cmp.neutral_filter_tau_s / cmp.phase_filter_tau_s - 1.10).abs() < 1e-12);
        assert_eq!(label, "10 %");
    }

    #[test]
    fn a_level_that_breaks_a_rule_is_named_with_its_key_and_factor() {
        let mut base = DriveConfig::default();
        base.control.carrier_top = 4095;
        let studied = strategies(&base.strategy, &STRATEGIES);
        let Err(e) = jobs(&base, &studied) else {
            panic!("not refused")
        };
        assert_eq!(e.value, "8190");
        assert!(
            e.field.starts_with("control.carrier_top") && e.field.contains("PWM frequency"),
            "{e}"
        );
        base.control.carrier_top = 2000;
        base.strategy.filter_samples = 1;
        let studied = strategies(&base.strategy, &STRATEGIES);
        let Err(e) = jobs(&base, &studied) else {
            panic!("not refused")
        };
        assert!(
            e.field.starts_with("strategy.filter_samples") && e.field.contains("DF samples at 0"),
            "{e}"
        );
    }
}
