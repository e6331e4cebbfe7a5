//! The strategy benchmark: every built-in strategy on the same motor, compared on the
//! same scenarios. The `drive-bench` binary is a thin front end over this module.

pub mod pool;
pub mod range;
pub mod report;
pub mod startup;
pub mod svg;

use crate::config::DriveConfig;
use crate::metrics::{Disturbance, StepResponse, disturbance, held_above, step_response};
use crate::scenario::{RunError, Scenario, Summary, TraceRow, TraceSpec, run};
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
    /// Speed step out of saturation (what anti-windup is for).
    pub step: StepPlan,
    /// Load step: speed \[rpm\], torque [N·m], at \[s\], run length \[s\].
    pub load: (f64, f64, f64, f64),
    /// Whether to search each strategy's speed range.
    pub ranges: bool,
}

impl Default for Plan {
    fn default() -> Self {
        Plan {
            grid_rpm: vec![1000.0, 2000.0, 3000.0, 4500.0, 6000.0, 9000.0],
            grid_duration_s: 3.0,
            trace_rpm: 3000.0,
            step: StepPlan {
                start_rpm: 3000.0,
                beyond_rpm: 16000.0,
                beyond_at_s: 1.5,
                to_rpm: 8000.0,
                at_s: 3.5,
                duration_s: 4.5,
            },
            load: (3000.0, 4e-4, 2.5, 4.0),
            ranges: true,
        }
    }
}

/// A speed step that starts from a saturated current loop: the drive runs at
/// `start_rpm`, is commanded `beyond_rpm` (beyond its reach, so the voltage command sits
/// at full scale and an unprotected integrator winds up) at `beyond_at_s`, and at `at_s`
/// the command steps down to `to_rpm`. The response is measured from that step.
#[derive(Copy, Clone, Debug, Serialize)]
pub struct StepPlan {
    /// Command from t = 0 \[rpm\].
    pub start_rpm: f64,
    /// Command beyond reach \[rpm\].
    pub beyond_rpm: f64,
    /// When it is given \[s\].
    pub beyond_at_s: f64,
    /// Command of the measured step \[rpm\].
    pub to_rpm: f64,
    /// When \[s\].
    pub at_s: f64,
    /// Run length \[s\].
    pub duration_s: f64,
}

/// A steady-state grid point.
#[derive(Clone, Debug, Serialize)]
pub struct GridPoint {
    /// Variant label.
    pub variant: String,
    /// The run's summary.
    pub summary: Summary,
}

/// A speed-step response.
#[derive(Clone, Debug, Serialize)]
pub struct StepRun {
    /// Variant label.
    pub variant: String,
    /// Anti-windup on the current PI.
    pub anti_windup: bool,
    /// True speed when the step was given \[rpm\].
    pub from_rpm: f64,
    /// How long after the step the duty still reached 95 % \[s\] (the wound-up current
    /// loop holding full voltage after the command dropped).
    pub full_duty_after_s: f64,
    /// Response metrics.
    pub response: StepResponse,
    /// Restarts during the run.
    pub restarts: u32,
    /// True speed record (t \[s\], rpm).
    #[serde(skip)]
    pub speed: Vec<(f64, f64)>,
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
    /// True speed record (t \[s\], rpm).
    #[serde(skip)]
    pub speed: Vec<(f64, f64)>,
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
    /// Speed steps, with and without anti-windup.
    pub steps: Vec<StepRun>,
    /// Load steps.
    pub loads: Vec<LoadRun>,
    /// Crossing traces (not in the JSON; plotted).
    #[serde(skip)]
    pub crossings: Vec<CrossingTrace>,
    /// Wall-clock time of the whole comparison \[s\].
    pub wall_s: f64,
    /// Threads used.
    pub threads: usize,
}

enum Job {
    Grid(usize, f64),
    Range(usize),
    Step(usize, bool),
    Load(usize),
}

enum Done {
    Grid(GridPoint, Option<CrossingTrace>),
    Range(Range),
    Step(StepRun),
    Load(LoadRun),
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
    let mut jobs = Vec::new();
    for v in 0..variants.len() {
        if plan.ranges {
            jobs.push(Job::Range(v)); // longest first, so the pool ends together
        }
        for &rpm in &plan.grid_rpm {
            jobs.push(Job::Grid(v, rpm));
        }
        jobs.push(Job::Step(v, true));
        jobs.push(Job::Step(v, false));
        jobs.push(Job::Load(v));
    }
    let config_of = |v: usize| {
        let mut c = base.clone();
        c.strategy = variants[v].strategy.clone();
        c
    };
    let label = |v: usize| variants[v].label.clone();
    let results = pool::map(&jobs, threads, progress.then_some("drive-bench"), |job| {
        Ok::<Done, RunError>(match *job {
            Job::Grid(v, rpm) => {
                let mut sc = Scenario::hold(config_of(v), rpm, plan.grid_duration_s);
                sc.plugin = variants[v].plugin.clone();
                let traced = rpm == plan.trace_rpm;
                if traced {
                    // One electrical turn at this speed plus margin, at 0.5 µs.
                    let turn = 60.0 / rpm / f64::from(base.motor.poles / 2);
                    let from = sc.steady_from_s;
                    sc.trace = Some(TraceSpec {
                        every_s: 0.5e-6,
                        from_s: from,
                        to_s: from + 1.1 * turn,
                    });
                }
                let mut rows = Vec::new();
                let out = run(&sc, |r| rows.push(*r))?;
                let point = GridPoint {
                    variant: label(v),
                    summary: out.summary,
                };
                let trace = traced.then(|| CrossingTrace {
                    variant: label(v),
                    rows,
                });
                Done::Grid(point, trace)
            }
            Job::Range(v) => Done::Range(range::search(
                &config_of(v),
                variants[v].plugin.as_ref(),
                &label(v),
            )?),
            Job::Step(v, aw) => {
                let p = plan.step;
                let mut c = config_of(v);
                c.control.anti_windup = aw;
                let mut sc = Scenario::hold(c, p.start_rpm, p.duration_s);
                sc.plugin = variants[v].plugin.clone();
                sc.speed_steps.push((p.beyond_at_s, p.beyond_rpm));
                sc.speed_steps.push((p.at_s, p.to_rpm));
                sc.speed_record_s = 0.5e-3;
                let out = run(&sc, |_| {})?;
                // The step starts from wherever the speed is when it is given.
                let from = out
                    .speed
                    .iter()
                    .take_while(|q| q.0 <= p.at_s)
                    .last()
                    .map_or(p.start_rpm, |q| q.1);
                Done::Step(StepRun {
                    variant: label(v),
                    anti_windup: aw,
                    from_rpm: from,
                    full_duty_after_s: held_above(&out.duty, p.at_s, 0.95),
                    response: step_response(&out.speed, p.at_s, from, p.to_rpm),
                    restarts: out.summary.restarts,
                    speed: out.speed,
                })
            }
            Job::Load(v) => {
                let (rpm, nm, at, dur) = plan.load;
                let mut sc = Scenario::hold(config_of(v), rpm, dur);
                sc.plugin = variants[v].plugin.clone();
                sc.load_steps.push((at, nm));
                sc.speed_record_s = 0.5e-3;
                let out = run(&sc, |_| {})?;
                Done::Load(LoadRun {
                    variant: label(v),
                    response: disturbance(&out.speed, at, rpm),
                    restarts: out.summary.restarts,
                    speed: out.speed,
                })
            }
        })
    });
    let mut cmp = Comparison {
        variants,
        plan,
        grid: Vec::new(),
        ranges: Vec::new(),
        steps: Vec::new(),
        loads: Vec::new(),
        crossings: Vec::new(),
        wall_s: 0.0,
        threads,
    };
    for r in results {
        match r? {
            Done::Grid(p, t) => {
                cmp.grid.push(p);
                cmp.crossings.extend(t);
            }
            Done::Range(r) => cmp.ranges.push(r),
            Done::Step(s) => cmp.steps.push(s),
            Done::Load(l) => cmp.loads.push(l),
        }
    }
    cmp.wall_s = wall.elapsed().as_secs_f64();
    Ok(cmp)
}
