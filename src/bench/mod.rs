//! The strategy benchmark: every built-in strategy on the same motor, compared on the
//! same scenarios. The `drive-bench` binary is a thin front end over this module.

pub mod calibrate;
pub mod decimate;
pub mod drift;
mod experiments;
pub mod floors;
pub mod html;
pub mod pool;
pub mod range;
pub mod report;
mod report_sections;
pub mod results;
pub mod seeded;
pub mod sensitivity;
pub mod sensitivity_report;
pub mod spectrum;
pub mod startup;
pub mod svg;
pub mod tornado;
pub mod vibration;

use crate::config::DriveConfig;
use crate::metrics::{Disturbance, StepResponse};
use crate::profile::Profile;
use crate::scenario::{RunError, Summary, TraceRow};
use experiments::{Bench, Done};
use range::Range;
use serde::Serialize;
use std::time::Instant;
use strategies::{PluginLibrary, StrategyName, StrategyParams};

/// One strategy setting under comparison.
#[derive(Clone, Debug, Serialize)]
pub struct Variant {
    /// Label in tables and plots (the strategy name, with `@angle` for a conduction
    /// angle other than 150°).
    pub label: String,
    /// The `[strategy]` section used.
    pub strategy: StrategyParams,
    /// The plugin that provides the strategy (None: the built-in chip).
    #[serde(skip)]
    pub plugin: Option<PluginLibrary>,
}

impl Variant {
    /// A built-in strategy keeping the user's `[strategy]` settings that apply to it; a
    /// `conduction_deg` overrides the user's angle (twelve-step only).
    pub fn builtin(base: &StrategyParams, name: StrategyName, conduction_deg: Option<f64>) -> Self {
        let mut strategy = base.clone();
        strategy.name = name;
        let six_step = name == StrategyName::SixStep120;
        if !six_step {
            strategy.guard = None; // the name fixes it
        }
        strategy.conduction_angle_deg = if six_step {
            None
        } else {
            conduction_deg.or(base.conduction_angle_deg)
        };
        let label = match conduction_deg {
            Some(a) => format!("{name}@{a}"),
            None => name.to_string(),
        };
        Variant {
            label,
            strategy,
            plugin: None,
        }
    }

    /// A plugin strategy; the config's `[strategy]` section is passed to it unchanged.
    pub fn plugin(base: &StrategyParams, plugin: PluginLibrary) -> Self {
        Variant {
            label: plugin.name().to_string(),
            strategy: base.clone(),
            plugin: Some(plugin),
        }
    }
}

/// The standard set: every built-in strategy, plus the digital-filter twelve-step at two
/// more conduction angles (the trade between torque and crossing visibility).
pub fn standard_variants(base: &StrategyParams) -> Vec<Variant> {
    let mut v: Vec<Variant> = StrategyName::ALL
        .iter()
        .map(|&n| Variant::builtin(base, n, None))
        .collect();
    for a in [135.0, 165.0] {
        v.push(Variant::builtin(base, StrategyName::TwelveStepDf, Some(a)));
    }
    v
}

/// The scenarios of the standard comparison.
#[derive(Clone, Debug, Serialize)]
pub struct Plan {
    /// Speeds of the steady-state grid \[rpm\].
    pub grid_rpm: Vec<f64>,
    /// Simulated time of each grid run \[s\]; steady state is the last third.
    pub grid_duration_s: f64,
    /// Grid speed whose run also records the crossing trace \[rpm\].
    pub trace_rpm: f64,
    /// Speeds of the torque spectra, low and medium \[rpm\]: each strategy started at
    /// `trace_rpm`, turned down (or held) there as the range's floors are
    /// ([`range::turned`]), its torque traced over the judged window.
    pub spectrum_rpm: Vec<f64>,
    /// Whether each strategy is ramped down through its floor ([`drift`]).
    pub drift: bool,
    /// The variant also ramped down with the comparator's two RC filters matched (the
    /// neutral's time constant set to the phase's): the experiment that names the early
    /// commutation at low speed.
    pub drift_matched: Option<String>,
    /// The variant whose spectra are also taken with the other chopping
    /// (the published high-side chop, or lone-switch chopping against a high-side config):
    /// the experiment that names the chopping's lines.
    pub spectrum_chopping: Option<String>,
    /// The anti-windup comparison: runs that drive a PI into saturation.
    pub step: StepPlan,
    /// Load step: speed \[rpm\], torque [N·m], at \[s\], run length \[s\].
    pub load: (f64, f64, f64, f64),
    /// Whether to search each strategy's speed range.
    pub ranges: bool,
    /// Starts of each strategy in the start-up Monte-Carlo (0: none), and its seed.
    pub startup: (usize, u64),
    /// The chip's speed meter in every run but the range searches.
    pub meter: range::Meter,
    /// The meters each strategy's range is searched with.
    pub range_meters: Vec<range::Meter>,
    /// The variants of the sensitivity study ([`sensitivity`]; empty: none).
    pub sensitivity: Vec<String>,
}

impl Default for Plan {
    fn default() -> Self {
        Plan {
            grid_rpm: vec![1000.0, 2000.0, 3000.0, 4500.0, 6000.0, 9000.0],
            grid_duration_s: 3.0,
            trace_rpm: 3000.0,
            spectrum_rpm: vec![1000.0, 3000.0],
            drift: true,
            drift_matched: Some("twelve-step-df".into()),
            spectrum_chopping: Some("twelve-step-df".into()),
            step: StepPlan::default(),
            load: (3000.0, 4e-4, 2.5, 4.0),
            ranges: true,
            startup: (10, 1),
            meter: range::Meter::WIDE,
            range_meters: vec![range::Meter::WIDE, range::Meter::AS_PUBLISHED],
            sensitivity: sensitivity::STRATEGIES
                .iter()
                .map(|n| n.to_string())
                .collect(),
        }
    }
}

/// The anti-windup comparison: each case on each listed variant, with anti-windup off,
/// on the current PI only (the chip's) and on both PIs.
///
/// Which PI saturates decides which anti-windup can act. With the 0.25 A current limit
/// the current PI has duty to spare below ≈ 9000 rpm, so only near top speed does the
/// voltage command sit at full scale; the speed PI saturates at the current limit when
/// Kp·e exceeds it (a step of more than ≈ 5000 rpm) or under a load the limit cannot hold.
/// A step such as 1000 → 2500 rpm saturates neither (Kp·1500 rpm = 0.075 A), and 1000 rpm
/// lies below what the 15-bit speed meter reads (≈ 1192 rpm), hence the low speed here is
/// 1500 rpm.
#[derive(Clone, Debug, Serialize)]
pub struct StepPlan {
    /// Labels of the variants to run (the guards that hold 1500 rpm: ND's floor is ≈ 4700
    /// rpm, raw mis-commutates at low speed).
    pub variants: Vec<String>,
    /// The cases.
    pub cases: Vec<AwCase>,
}

impl Default for StepPlan {
    fn default() -> Self {
        StepPlan {
            variants: vec!["twelve-step-lm".into(), "twelve-step-df".into()],
            cases: vec![
                AwCase {
                    name: "step 1500 → 6000 rpm".into(),
                    saturates: "speed PI at the current limit".into(),
                    speed_rpm: Profile::constant(3000.0)
                        .step_to(1.5, 1500.0)
                        .step_to(3.0, 6000.0),
                    load_nm: Profile::default(),
                    at_s: 3.0,
                    to_rpm: 6000.0,
                    duration_s: 5.5,
                },
                AwCase {
                    name: "step 16000 (beyond reach) → 8000 rpm".into(),
                    saturates: "current PI at full duty, speed PI at the current limit".into(),
                    speed_rpm: Profile::constant(3000.0)
                        .step_to(1.5, 16000.0)
                        .step_to(3.5, 8000.0),
                    load_nm: Profile::default(),
                    at_s: 3.5,
                    to_rpm: 8000.0,
                    duration_s: 5.5,
                },
                AwCase {
                    name: "load 2.5 mN·m at 6000 rpm, 2–3 s".into(),
                    saturates: "speed PI at the current limit".into(),
                    speed_rpm: Profile::constant(6000.0),
                    load_nm: Profile::constant(0.0)
                        .step_to(2.0, 2.5e-3)
                        .step_to(3.0, 0.0),
                    at_s: 3.0,
                    to_rpm: 6000.0,
                    duration_s: 5.0,
                },
                AwCase {
                    name: "step 6000 → 1500 rpm".into(),
                    saturates: "both PIs at their lower limits (no current, no duty): each integrator is clamped there, so neither winds up".into(),
                    speed_rpm: Profile::constant(3000.0)
                        .step_to(1.5, 6000.0)
                        .step_to(3.5, 1500.0),
                    load_nm: Profile::default(),
                    at_s: 3.5,
                    to_rpm: 1500.0,
                    duration_s: 8.0,
                },
            ],
        }
    }
}

/// One anti-windup case: a schedule, and the instant from which the response is measured
/// (a speed step, or the release of a load).
#[derive(Clone, Debug, Serialize)]
pub struct AwCase {
    /// Name in tables and plots.
    pub name: String,
    /// Which PI it saturates, and where.
    pub saturates: String,
    /// Speed command \[rpm\].
    pub speed_rpm: Profile,
    /// Coulomb (passive) load [N·m]; the first non-zero point is the load whose dip is
    /// shown.
    pub load_nm: Profile,
    /// Start of the measured response \[s\].
    pub at_s: f64,
    /// Command from then on \[rpm\].
    pub to_rpm: f64,
    /// Run length \[s\].
    pub duration_s: f64,
}

impl AwCase {
    /// Whether the measured event is a step of the command down (peak = undershoot).
    pub fn is_step_down(&self) -> bool {
        self.to_rpm < self.speed_before()
    }

    /// The peak beyond the command of `run` in percent: of the command's change for a
    /// speed step (the usual overshoot), of the command itself for the release of a load.
    /// A release starts from wherever the load held the speed, often a few rpm below the
    /// command, so a percentage of that small change would read as hundreds of percent.
    pub fn peak_pct(&self, run: &StepRun) -> f64 {
        if self.to_rpm != self.speed_before() {
            run.response.beyond_pct(self.is_step_down())
        } else {
            100.0 * run.peak_beyond_rpm / self.to_rpm.abs()
        }
    }

    /// What [`Self::peak_pct`] is a percentage of.
    pub fn peak_pct_of(&self) -> &'static str {
        if self.to_rpm != self.speed_before() {
            "of the step"
        } else {
            "of the command"
        }
    }

    /// The command just before the measured event \[rpm\].
    pub fn speed_before(&self) -> f64 {
        let p = self.speed_rpm.points();
        p.iter()
            .rfind(|q| q.0 < self.at_s)
            .or(p.first())
            .map_or(0.0, |q| q.1)
    }
}

/// Where anti-windup acts in a run of the comparison.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AntiWindup {
    /// Neither PI: clamped integrators only (the current PI's up to its 23-bit register).
    Off,
    /// The current PI (the chip's: `control.anti_windup`).
    Current,
    /// Both PIs (`control.anti_windup` and `control.speed_anti_windup`).
    Both,
}

impl AntiWindup {
    /// Every setting, in report order.
    pub const ALL: [AntiWindup; 3] = [AntiWindup::Off, AntiWindup::Current, AntiWindup::Both];

    /// Short name.
    pub fn as_str(self) -> &'static str {
        match self {
            AntiWindup::Off => "off",
            AntiWindup::Current => "current PI",
            AntiWindup::Both => "both PIs",
        }
    }
}

/// A steady-state grid point.
#[derive(Clone, Debug, Serialize)]
pub struct GridPoint {
    /// Variant label.
    pub variant: String,
    /// The run's summary.
    pub summary: Summary,
}

/// A run of the anti-windup comparison.
#[derive(Clone, Debug, Serialize)]
pub struct StepRun {
    /// Variant label.
    pub variant: String,
    /// Index of the case in the plan.
    pub case: usize,
    /// Where anti-windup acts.
    pub anti_windup: AntiWindup,
    /// True speed when the measured event came \[rpm\].
    pub from_rpm: f64,
    /// Largest excursion beyond the command after the event, in the direction of the
    /// change \[rpm\] (0 if none).
    pub peak_beyond_rpm: f64,
    /// Largest drop below the command after the case's first load step \[rpm\] (None
    /// without a load).
    pub dip_rpm: Option<f64>,
    /// How long after the step the duty still reached 95 % \[s\] (the wound-up current
    /// loop holding full voltage after the command dropped).
    pub full_duty_after_s: f64,
    /// Response metrics from the event: overshoot is the peak beyond the command in the
    /// direction of the change (an undershoot for a step down), in % of the change.
    pub response: StepResponse,
    /// Restarts during the run.
    pub restarts: u32,
    /// The run's verdict at its end (figures of a run that did not hold its command at
    /// the end are not shown as a measurement).
    pub verdict: crate::verdict::Verdict,
    /// True speed record (t \[s\], rpm).
    #[serde(skip)]
    pub speed: Vec<(f64, f64)>,
    /// The PIs' outputs at the same instants: the duty (current PI, 0..1) and the current
    /// command (speed PI) \[A\].
    #[serde(skip)]
    pub duty: Vec<(f64, f64)>,
    /// See `duty`.
    #[serde(skip)]
    pub current_ref: Vec<(f64, f64)>,
}

/// A start-up Monte-Carlo of one strategy (plugins are not sampled).
#[derive(Clone, Debug, Serialize)]
pub struct StartupResult {
    /// Variant label.
    pub variant: String,
    /// The speed command of every start \[rpm\]: 3000, or 6000 for ND, whose linear
    /// region alone drives the motor above ≈ 4700 rpm.
    pub command_rpm: f64,
    /// Why the command differs from the others', when it does.
    pub command_note: Option<&'static str>,
    /// The tolerances sampled.
    pub spread: startup::Spread,
    /// What came of it.
    pub stats: startup::StartupStats,
}

/// A load-step response.
#[derive(Clone, Debug, Serialize)]
pub struct LoadRun {
    /// Variant label.
    pub variant: String,
    /// Response metrics (dip in rpm).
    pub response: Disturbance,
    /// Restarts during the run.
    pub restarts: u32,
    /// The run's verdict at its end.
    pub verdict: crate::verdict::Verdict,
    /// True speed record (t \[s\], rpm).
    #[serde(skip)]
    pub speed: Vec<(f64, f64)>,
}

/// A steady run's torque spectrum, with the run's vibration figures.
#[derive(Clone, Debug, Serialize)]
pub struct SpectrumRun {
    /// Variant label.
    pub variant: String,
    /// Speed command \[rpm\].
    pub rpm: f64,
    /// The PWM scheme of the run.
    pub pwm_scheme: String,
    /// Whether the run is the chopping experiment's (the other scheme than the config's).
    pub contrast: bool,
    /// The run's summary (verdict, low-band ripple, commutation surge).
    pub summary: Summary,
    /// The spectrum (None: the run was not `running`, or too few turns).
    pub spectrum: Option<spectrum::Spectrum>,
}

/// A fine trace around zero crossings in steady state.
#[derive(Clone, Debug)]
pub struct CrossingTrace {
    /// Variant label.
    pub variant: String,
    /// Rows.
    pub rows: Vec<TraceRow>,
}

/// Everything the comparison produced.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// Variants, in order.
    pub variants: Vec<Variant>,
    /// The scenarios.
    pub plan: Plan,
    /// Steady-state grid.
    pub grid: Vec<GridPoint>,
    /// Speed ranges.
    pub ranges: Vec<Range>,
    /// The anti-windup comparison.
    pub steps: Vec<StepRun>,
    /// Load steps.
    pub loads: Vec<LoadRun>,
    /// Start-up Monte-Carlo per strategy.
    pub startups: Vec<StartupResult>,
    /// Torque spectra per strategy and speed.
    pub spectra: Vec<SpectrumRun>,
    /// Ramps down through the floors.
    pub drifts: Vec<drift::DriftRun>,
    /// The sensitivity study.
    pub sensitivity: Vec<sensitivity::Point>,
    /// Crossing traces (not in the JSON; plotted).
    #[serde(skip)]
    pub crossings: Vec<CrossingTrace>,
    /// The failed runs below the floors, traced where they lost the rotor.
    pub floor_zooms: Vec<floors::FloorZoom>,
    /// Wall-clock time of the whole comparison \[s\].
    pub wall_s: f64,
    /// Threads used.
    pub threads: usize,
}

impl Comparison {
    /// The palette index of a variant's label: its place in the comparison, so that a
    /// strategy has one colour in every chart.
    pub fn color_of(&self, label: &str) -> Option<usize> {
        self.variants.iter().position(|v| v.label == label)
    }
}

/// Runs `plan` for every variant on `base` (the motor, power stage, sensing and control
/// of the user's config), on `threads` threads.
pub fn compare(
    base: &DriveConfig,
    variants: Vec<Variant>,
    plan: Plan,
    threads: usize,
    progress: bool,
) -> Result<Comparison, RunError> {
    let wall = Instant::now();
    // Built-in strategies only: a plugin's guard parameters are not known here.
    let studied: Vec<_> = variants
        .iter()
        .filter(|v| v.plugin.is_none() && plan.sensitivity.contains(&v.label))
        .map(|v| (v.label.clone(), v.strategy.clone()))
        .collect();
    let study = sensitivity::jobs(base, &studied)?;
    let jobs = experiments::jobs(&variants, &plan, study.len());
    let bench = Bench {
        base,
        variants: &variants,
        plan: &plan,
        study: &study,
    };
    let results = pool::map(&jobs, threads, progress.then_some("drive-bench"), |job| {
        bench.run(job)
    });
    let mut cmp = Comparison {
        variants,
        plan,
        grid: Vec::new(),
        ranges: Vec::new(),
        steps: Vec::new(),
        loads: Vec::new(),
        startups: Vec::new(),
        spectra: Vec::new(),
        drifts: Vec::new(),
        sensitivity: Vec::new(),
        crossings: Vec::new(),
        floor_zooms: Vec::new(),
        wall_s: 0.0,
        threads,
    };
    for r in results {
        cmp.gather(r?);
    }
    cmp.floor_zooms = zoom_floors(base, &cmp, threads)?;
    cmp.wall_s = wall.elapsed().as_secs_f64();
    Ok(cmp)
}

impl Comparison {
    /// Files one run's result where the report reads it.
    fn gather(&mut self, done: Done) {
        match done {
            Done::Grid(p, t) => {
                self.grid.push(p);
                self.crossings.extend(t);
            }
            Done::Range(r) => self.ranges.push(r),
            Done::Step(s) => self.steps.push(s),
            Done::Load(l) => self.loads.push(l),
            Done::Startup(x) => self.startups.push(x),
            Done::Spectrum(x) => self.spectra.push(x),
            Done::Drift(x) => self.drifts.push(x),
            Done::Sensitivity(x) => self.sensitivity.push(x),
        }
    }
}

/// Below each floor (found by the range searches), the failed run again, traced where it
/// failed.
fn zoom_floors(
    base: &DriveConfig,
    cmp: &Comparison,
    threads: usize,
) -> Result<Vec<floors::FloorZoom>, RunError> {
    let zooms = pool::map(&cmp.ranges, threads, None, |r| {
        let Some(v) = cmp.variants.iter().find(|x| x.label == r.strategy) else {
            return Ok(None);
        };
        let mut c = cmp.plan.meter.apply(base);
        c.strategy = v.strategy.clone();
        floors::zoom(&c, v.plugin.as_ref(), r)
    });
    let mut found = Vec::new();
    for z in zooms {
        found.extend(z?);
    }
    Ok(found)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_with(peak_beyond_rpm: f64, response: crate::metrics::StepResponse) -> StepRun {
        StepRun {
            variant: "v".into(),
            case: 0,
            anti_windup: AntiWindup::Off,
            from_rpm: 0.0,
            peak_beyond_rpm,
            dip_rpm: None,
            full_duty_after_s: 0.0,
            response,
            restarts: 0,
            verdict: crate::verdict::Verdict::Running,
            speed: Vec::new(),
            duty: Vec::new(),
            current_ref: Vec::new(),
        }
    }

    /// A speed step's peak is a share of the step; a load release's, of the command (it
    /// starts a few rpm below the command, and 600 rpm beyond 6000 is 10 %, not 600 %).
    #[test]
    fn peak_percentages_have_a_meaningful_base() {
        let cases = StepPlan::default().cases;
        let step = &cases[0]; // 1500 → 6000 rpm
        let load = &cases[2]; // a load released at 6000 rpm
        assert_eq!(
            (step.peak_pct_of(), load.peak_pct_of()),
            ("of the step", "of the command")
        );
        // 900 rpm beyond 6000 after a 4500 rpm step: 20 % of the step.
        let samples = [(2.9, 1500.0), (3.2, 6900.0), (3.6, 6000.0)];
        let r = crate::metrics::step_response(&samples, 3.0, 1500.0, 6000.0);
        assert!((step.peak_pct(&run_with(900.0, r)) - 20.0).abs() < 1e-9);
        // Released from 5990 rpm, peaking at 6600 rpm: 10 % of the command.
        let samples = [(2.9, 5990.0), (3.2, 6600.0), (3.6, 6000.0)];
        let r = crate::metrics::step_response(&samples, 3.0, 5990.0, 6000.0);
        assert!((load.peak_pct(&run_with(600.0, r)) - 10.0).abs() < 1e-9);
    }
}
