//! The comparison's experiments: the list of runs a plan asks for ([`jobs`]), and each
//! kind of run as a function of its own ([`Bench::run`] picks one). Kept apart from
//! [`super::compare`], which only schedules them and gathers what they give.

use super::{
    AntiWindup, CrossingTrace, GridPoint, LoadRun, Plan, SpectrumRun, StartupResult, StepRun,
    Variant, drift, range, sensitivity, spectrum, startup,
};
use crate::config::DriveConfig;
use crate::metrics::{disturbance, held_above, step_response};
use crate::profile::{LoadProfile, Profile};
use crate::scenario::{RunError, Scenario, TraceSpec, run, settled};
use drive_core::pwm::PwmSchemeKind;
use plants::params::PowerStageParams;
use range::Range;
use strategies::StrategyName;

/// One run of the comparison (variants by their index).
pub(super) enum Job {
    Grid(usize, f64),
    Range(usize, range::Meter),
    Step(usize, usize, AntiWindup),
    Load(usize),
    Startup(usize),
    Spectrum(usize, f64, bool),
    Drift(usize, bool),
    Sensitivity(usize),
}

/// What a [`Job`] gave.
pub(super) enum Done {
    Grid(GridPoint, Option<CrossingTrace>),
    Range(Range),
    Step(StepRun),
    Load(LoadRun),
    Startup(StartupResult),
    Spectrum(SpectrumRun),
    Drift(drift::DriftRun),
    Sensitivity(sensitivity::Point),
}

/// Every run `plan` asks of `variants`, in the order their results are reported: first the
/// `study` (sensitivity) runs, then per variant its range searches (longest first, so the
/// pool ends together), grid, drifts, spectra, anti-windup steps, load step and start-ups.
pub(super) fn jobs(variants: &[Variant], plan: &Plan, study: usize) -> Vec<Job> {
    let mut jobs: Vec<Job> = (0..study).map(Job::Sensitivity).collect();
    for (v, variant) in variants.iter().enumerate() {
        if plan.ranges {
            for &m in &plan.range_meters {
                jobs.push(Job::Range(v, m)); // longest first, so the pool ends together
            }
        }
        for &rpm in &plan.grid_rpm {
            jobs.push(Job::Grid(v, rpm));
        }
        // A plugin's table is not known here, so its commutations cannot be judged.
        if plan.drift && variant.plugin.is_none() {
            jobs.push(Job::Drift(v, false));
            if plan.drift_matched.as_ref() == Some(&variant.label) {
                jobs.push(Job::Drift(v, true));
            }
        }
        let contrast = plan.spectrum_chopping.as_ref() == Some(&variant.label);
        for &rpm in &plan.spectrum_rpm {
            jobs.push(Job::Spectrum(v, rpm, false));
            if contrast {
                jobs.push(Job::Spectrum(v, rpm, true));
            }
        }
        if plan.step.variants.contains(&variant.label) {
            for c in 0..plan.step.cases.len() {
                for aw in AntiWindup::ALL {
                    jobs.push(Job::Step(v, c, aw));
                }
            }
        }
        jobs.push(Job::Load(v));
        if plan.startup.0 > 0 && variant.plugin.is_none() {
            jobs.push(Job::Startup(v));
        }
    }
    jobs
}

/// What every experiment reads: the user's config, the variants and the plan.
pub(super) struct Bench<'a> {
    pub base: &'a DriveConfig,
    pub variants: &'a [Variant],
    pub plan: &'a Plan,
    /// The sensitivity study's runs ([`Job::Sensitivity`] indexes them).
    pub study: &'a [sensitivity::Job],
}

impl Bench<'_> {
    /// Runs one job.
    pub fn run(&self, job: &Job) -> Result<Done, RunError> {
        Ok(match *job {
            Job::Grid(v, rpm) => {
                let (point, trace) = self.grid(v, rpm)?;
                Done::Grid(point, trace)
            }
            Job::Spectrum(v, rpm, contrast) => Done::Spectrum(self.spectrum(v, rpm, contrast)?),
            Job::Drift(v, matched) => Done::Drift(self.drift(v, matched)?),
            Job::Sensitivity(k) => Done::Sensitivity(sensitivity::run_job(&self.study[k])?),
            Job::Range(v, m) => Done::Range(range::search(
                &m.apply(&self.config_of(v)),
                self.variants[v].plugin.as_ref(),
                &self.label(v),
                m.label,
            )?),
            Job::Step(v, case, aw) => Done::Step(self.step(v, case, aw)?),
            Job::Startup(v) => Done::Startup(self.startup(v)?),
            Job::Load(v) => Done::Load(self.load(v)?),
        })
    }

    /// The user's config with variant `v`'s strategy, read by the plan's meter.
    fn config_of(&self, v: usize) -> DriveConfig {
        let mut c = self.plan.meter.apply(self.base);
        c.strategy = self.variants[v].strategy.clone();
        c
    }

    fn label(&self, v: usize) -> String {
        self.variants[v].label.clone()
    }

    /// A point of the steady-state grid; at the trace speed, with its crossing trace.
    fn grid(&self, v: usize, rpm: f64) -> Result<(GridPoint, Option<CrossingTrace>), RunError> {
        let plan = self.plan;
        let mut sc = Scenario::hold(self.config_of(v), rpm, plan.grid_duration_s);
        sc.plugin = self.variants[v].plugin.clone();
        let traced = rpm == plan.trace_rpm;
        let mut rows = Vec::new();
        // Lengthened while its window falls in the start-up.
        let (_, out) = settled(&sc, |sc| {
            let mut sc = sc.clone();
            if traced {
                // One electrical turn at this speed plus margin, at 0.5 µs.
                let turn = 60.0 / rpm / f64::from(self.base.motor.poles / 2);
                let from = sc.steady_from_s;
                sc.trace = Some(TraceSpec {
                    every_s: 0.5e-6,
                    from_s: from,
                    to_s: from + 1.1 * turn,
                });
            }
            rows.clear();
            run(&sc, |r| rows.push(*r))
        })?;
        let point = GridPoint {
            variant: self.label(v),
            summary: out.summary,
        };
        let trace = traced.then(|| CrossingTrace {
            variant: self.label(v),
            rows,
        });
        Ok((point, trace))
    }

    /// A torque spectrum at `rpm`; `contrast`: with the other chopping, for the experiment.
    fn spectrum(&self, v: usize, rpm: f64, contrast: bool) -> Result<SpectrumRun, RunError> {
        let plan = self.plan;
        let variant = &self.variants[v];
        let mut c = self.config_of(v);
        if contrast {
            c.power_stage = contrast_chopping(&c.power_stage);
        }
        let mut sc = range::turned(&c, plan.trace_rpm, rpm, range::TURN_DOWN_S);
        sc.plugin = variant.plugin.clone();
        let mut samples = Vec::new();
        // Over the window, lengthened while that still falls in the settling.
        let (_, out) = settled(&sc, |sc| {
            let mut sc = sc.clone();
            sc.trace = Some(TraceSpec {
                every_s: spectrum::TRACE_EVERY_S,
                from_s: sc.steady_from_s,
                to_s: sc.duration_s,
            });
            samples.clear();
            run(&sc, |r| samples.push(spectrum::sample(r)))
        })?;
        // A plugin's steps are not known here: its lines are named on twelve
        // (a six-step plugin's commutation then reads "every 2 steps").
        let steps = match variant.plugin {
            Some(_) => 12,
            None => variant.strategy.table().states_per_turn(),
        };
        let spectrum = out
            .summary
            .verdict
            .is_running()
            .then(|| spectrum::torque_spectrum(&samples, steps))
            .flatten();
        Ok(SpectrumRun {
            variant: self.label(v),
            rpm,
            pwm_scheme: c.power_stage.pwm_scheme.name().to_string(),
            contrast,
            summary: out.summary,
            spectrum,
        })
    }

    /// A ramp down through the floor; `matched`: with the comparator's RC filters matched.
    fn drift(&self, v: usize, matched: bool) -> Result<drift::DriftRun, RunError> {
        let mut c = range::Meter::WIDE.apply(&self.config_of(v));
        let cmp = &mut c.sensing.comparator;
        if matched {
            cmp.neutral_filter_tau_s = cmp.phase_filter_tau_s;
        }
        let change = if matched {
            format!(
                "neutral filter τ = phase filter τ = {:.2} µs",
                cmp.phase_filter_tau_s * 1e6
            )
        } else {
            String::new()
        };
        let table = self.variants[v].strategy.table();
        drift::run_drift(&c, table, &self.label(v), &change)
    }

    /// A case of the anti-windup comparison, with anti-windup acting where `aw` says.
    fn step(&self, v: usize, case: usize, aw: AntiWindup) -> Result<StepRun, RunError> {
        let p = &self.plan.step.cases[case];
        let mut c = self.config_of(v);
        c.control.anti_windup = aw != AntiWindup::Off;
        c.control.speed_anti_windup = aw == AntiWindup::Both;
        let mut sc = Scenario::hold(c, p.speed_rpm.value_at(0.0), p.duration_s);
        sc.plugin = self.variants[v].plugin.clone();
        sc.speed_rpm = p.speed_rpm.clone();
        sc.load.coulomb_nm = p.load_nm.clone();
        sc.speed_record_s = Some(0.5e-3);
        // The verdict only says whether the drive holds its final command: judged
        // over the last 0.5 s, after the response (measured from the record),
        // and lengthened while that still falls in its settling.
        sc.steady_from_s = p.duration_s - 0.5;
        let (_, out) = settled(&sc, |sc| run(sc, |_| {}))?;
        // The response starts from wherever the speed is at the event.
        let from = out
            .speed
            .iter()
            .take_while(|q| q.0 <= p.at_s)
            .last()
            .map_or(p.speed_rpm.value_at(0.0), |q| q.1);
        let dip_rpm = p.load_nm.points().iter().find(|l| l.1 != 0.0).map(|l| {
            let during: Vec<_> = out
                .speed
                .iter()
                .copied()
                .filter(|q| q.0 <= p.at_s)
                .collect();
            disturbance(&during, l.0, p.to_rpm).dip
        });
        let sign = if p.to_rpm >= from { 1.0 } else { -1.0 };
        let peak_beyond_rpm = out
            .speed
            .iter()
            .filter(|q| q.0 >= p.at_s)
            .map(|q| sign * (q.1 - p.to_rpm))
            .fold(0.0, f64::max);
        Ok(StepRun {
            variant: self.label(v),
            case,
            peak_beyond_rpm,
            anti_windup: aw,
            from_rpm: from,
            dip_rpm,
            full_duty_after_s: held_above(&out.duty, p.at_s, 0.95),
            response: step_response(&out.speed, p.at_s, from, p.to_rpm),
            restarts: out.summary.restarts,
            verdict: out.summary.verdict,
            speed: out.speed,
            duty: out.duty,
            current_ref: out.current_ref,
        })
    }

    /// The start-up Monte-Carlo of a built-in strategy.
    fn startup(&self, v: usize) -> Result<StartupResult, RunError> {
        let (samples, seed) = self.plan.startup;
        let mut c = self.config_of(v);
        // ND's full-voltage window alone drives the motor above ≈ 4700 rpm.
        c.control.speed_ref_rpm = if c.strategy.name == StrategyName::TwelveStepNd {
            6000.0
        } else {
            3000.0
        };
        Ok(StartupResult {
            variant: self.label(v),
            command_rpm: c.control.speed_ref_rpm,
            command_note: (c.strategy.name == StrategyName::TwelveStepNd)
                .then_some("ND's full-voltage window alone drives the motor above ≈ 4700 rpm"),
            spread: startup::Spread::default(),
            stats: startup::monte_carlo(
                &c,
                &self.variants[v].strategy,
                samples,
                seed,
                startup::Spread::default(),
                1,
            )?,
        })
    }

    /// The load step's response.
    fn load(&self, v: usize) -> Result<LoadRun, RunError> {
        let (rpm, nm, at, dur) = self.plan.load;
        let mut sc = Scenario::hold(self.config_of(v), rpm, dur);
        sc.plugin = self.variants[v].plugin.clone();
        sc.load = LoadProfile {
            coulomb_nm: Profile::constant(0.0).step_to(at, nm),
            ..LoadProfile::default()
        };
        sc.speed_record_s = Some(0.5e-3);
        // Lengthened while its window falls in the recovery.
        let (_, out) = settled(&sc, |sc| run(sc, |_| {}))?;
        Ok(LoadRun {
            variant: self.label(v),
            response: disturbance(&out.speed, at, rpm),
            restarts: out.summary.restarts,
            verdict: out.summary.verdict,
            speed: out.speed,
        })
    }
}

/// The chopping experiment's scheme: the published chip's high-side chop, or against it
/// lone-switch chopping (the shipped default), the other settings as configured.
fn contrast_chopping(ps: &PowerStageParams) -> PowerStageParams {
    let mut other = ps.clone();
    other.pwm_scheme = match ps.pwm_scheme {
        PwmSchemeKind::HighSideChop => PwmSchemeKind::LoneSwitchChop,
        _ => PwmSchemeKind::HighSideChop,
    };
    other
}
