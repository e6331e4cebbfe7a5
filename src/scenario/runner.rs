//! A run as a value: started, advanced to an instant of its schedule, finished. Stopped at
//! an instant it can be copied and continued under another schedule ([`Run::fork`], in
//! `fork.rs`); [`super::run_observed`] is [`Run::start`] then [`Run::finish`], so a plain
//! run and a forked one go through the same loop.

use super::measure::Metrics;
use super::{Outcome, RunError, Scenario, TraceRow, TraceSpec};
use crate::config::DriveConfig;
use crate::drive::{DriveEngine, build, build_plugin};
use crate::profile::Profile;
use drive_core::error::ParamError;
use drive_core::{Plant, StopReason, Ticks};
use std::time::Instant;

/// A scenario's run so far: the drive, the metrics and trace gathered, and where it
/// stands in its schedule.
pub struct Run {
    pub(super) sc: Scenario,
    /// The config the engine was built from (the profiles' values at t = 0 in it).
    pub(super) config: DriveConfig,
    pub(super) eng: DriveEngine,
    pub(super) load: plants::Load,
    pub(super) events: Vec<(f64, Event)>,
    /// The first event not applied yet.
    pub(super) next: usize,
    /// Whether the engine stands at `events[next]`'s instant: run to it, the event not
    /// applied (a fork's continuation must not run that segment again).
    pub(super) at_event: bool,
    pub(super) trace: Option<Rows>,
    pub(super) metrics: Metrics,
    /// When `on_time` is called next \[s\].
    pub(super) next_time: f64,
    pub(super) trace_on: bool,
    pub(super) steady_on: bool,
    /// Wall-clock time spent advancing, a fork's included \[s\].
    pub(super) wall_s: f64,
}

impl Run {
    /// `sc` at t = 0, checked, its engine built with the profiles' first values.
    pub fn start(sc: &Scenario) -> Result<Run, RunError> {
        sc.validate()?;
        let (config, eng, load) = set_up(sc)?;
        let metrics = Metrics::new(sc, &eng);
        Ok(Run {
            sc: sc.clone(),
            config,
            eng,
            load,
            events: events(sc),
            next: 0,
            at_event: false,
            trace: sc.trace.map(Rows::new),
            metrics,
            next_time: 0.0,
            trace_on: false,
            steady_on: false,
            wall_s: 0.0,
        })
    }

    /// The scenario it runs.
    pub fn scenario(&self) -> &Scenario {
        &self.sc
    }

    /// Where the drive stands \[s\] (whole ticks).
    pub fn time_s(&self) -> f64 {
        self.eng.now().seconds()
    }

    /// Runs to `t_s`, an instant of the schedule not before where the run stands: a
    /// change of a profile, the trace window's ends, the steady-state window's start or
    /// the end. Every event before it is applied, those at it are not yet: the run
    /// continues from here exactly as if it had not stopped, and can be forked here.
    pub fn advance_to(
        &mut self,
        t_s: f64,
        mut on_row: impl FnMut(&TraceRow),
        mut on_time: impl FnMut(f64),
    ) -> Result<(), RunError> {
        let at = Ticks::from_seconds(t_s);
        let Some(k) =
            (self.next..self.events.len()).find(|&k| Some(tick_of(self.events[k].0)) == at)
        else {
            return Err(ParamError::new(
                "advance_to t_s",
                t_s,
                "must be an instant of the run's schedule (a profile's change, the trace's or steady-state window's start, the end) not before where it stands",
            )
            .into());
        };
        self.go(k, false, &mut on_row, &mut on_time)
    }

    /// Runs the rest of the schedule and returns the outcome.
    pub fn finish(
        mut self,
        mut on_row: impl FnMut(&TraceRow),
        mut on_time: impl FnMut(f64),
    ) -> Result<Outcome, RunError> {
        let last = self.events.len() - 1;
        self.go(last, true, &mut on_row, &mut on_time)?;
        let Run {
            sc,
            config,
            eng,
            metrics,
            wall_s,
            ..
        } = self;
        Ok(metrics.outcome(&sc, &config, &eng, wall_s))
    }

    /// Runs the events up to `events[last]`, applying it too when `apply_last`.
    fn go(
        &mut self,
        last: usize,
        apply_last: bool,
        on_row: &mut impl FnMut(&TraceRow),
        on_time: &mut impl FnMut(f64),
    ) -> Result<(), RunError> {
        let wall = Instant::now();
        while self.next <= last {
            if !self.at_event {
                self.segment(on_row, on_time)?;
                self.at_event = true;
            }
            if self.next == last && !apply_last {
                break;
            }
            self.apply(self.events[self.next].1)?;
            self.next += 1;
            self.at_event = false;
        }
        self.wall_s += wall.elapsed().as_secs_f64();
        Ok(())
    }

    /// Runs the engine to the next event's instant, measuring and tracing at its stops.
    fn segment(
        &mut self,
        on_row: &mut impl FnMut(&TraceRow),
        on_time: &mut impl FnMut(f64),
    ) -> Result<(), RunError> {
        let (t_event, event) = self.events[self.next];
        let end = tick_of(t_event);
        let trace_event = event.is_trace();
        let every = self.sc.duration_s / 200.0;
        let steady_on = self.steady_on;
        let Run {
            eng,
            metrics,
            trace,
            next_time,
            ..
        } = self;
        let block = metrics.block;
        eng.run_until(end, |e, reason| {
            if matches!(reason, StopReason::Diode | StopReason::Sensing) {
                return; // between ticks: the next whole-tick stop follows at once
            }
            if e.plant.time_s() >= *next_time {
                on_time(e.plant.time_s());
                *next_time = e.plant.time_s() + every;
            }
            // Stops made for the trace alone (its rows, its window's ends) are not seen by
            // the metrics, which sample at the stops: a trace observes without changing the
            // summary. An untraced run stops at samples only at the torque block boundaries.
            let trace_only = match reason {
                StopReason::Sample => !(steady_on && e.now().0 % block.0 == 0),
                StopReason::End => trace_event,
                _ => false,
            };
            // Observed once per stop, for the metrics and the trace alike.
            let mut obs = None;
            if !trace_only {
                metrics.stop(e, &mut obs);
            }
            if let Some(rows) = trace {
                rows.stop(e, obs, on_row);
            }
        })?;
        Ok(())
    }

    /// Applies `event`, then sets the stops the trace and the torque blocks need.
    fn apply(&mut self, event: Event) -> Result<(), RunError> {
        let eng = &mut self.eng;
        match event {
            Event::Speed(rpm) => eng.controller.set_speed_ref(rpm),
            Event::Load(k, x) => {
                self.load.set_term(k, x);
                eng.plant.set_load(self.load);
            }
            Event::Supply(v) => eng.plant.set_supply_v(v)?,
            Event::TraceOn => self.trace_on = true,
            Event::TraceOff => self.trace_on = false,
            Event::SteadyOn => self.steady_on = true,
            Event::End => {}
        }
        // Stops at trace rows and torque block boundaries: every multiple of both.
        let rows = self
            .trace
            .as_ref()
            .filter(|_| self.trace_on)
            .map(|t| t.every);
        let blocks = self.steady_on.then_some(self.metrics.block);
        eng.set_sample_period(match (rows, blocks) {
            (Some(a), Some(b)) => Ticks(gcd(a.0, b.0)),
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => Ticks::NEVER,
        });
        Ok(())
    }
}

/// The engine of `sc` at t = 0, with the profiles' first values, the config it was built
/// from and the load it carries.
fn set_up(sc: &Scenario) -> Result<(DriveConfig, DriveEngine, plants::Load), RunError> {
    let mut config = sc.config.clone();
    config.control.speed_ref_rpm = sc.speed_rpm.value_at(0.0);
    if let Some(p) = &sc.supply_v {
        config.power_stage.supply_v = p.value_at(0.0);
    }
    let mut eng = match &sc.plugin {
        Some(p) => build_plugin(&config, p)?,
        None => build(&config)?,
    };
    let load = sc.load.at(0.0);
    eng.plant.set_load(load);
    Ok((config, eng, load))
}

/// The trace's rows: every `every` from `from` to `to`.
#[derive(Clone)]
pub(super) struct Rows {
    every: Ticks,
    from: Ticks,
    to: Ticks,
    last: Option<Ticks>,
}

impl Rows {
    fn new(t: TraceSpec) -> Self {
        Rows {
            every: Ticks(((t.every_s / Ticks(1).seconds()).round() as u64).max(1)),
            from: tick_of(t.from_s),
            to: tick_of(t.to_s),
            last: None,
        }
    }

    /// Gives `on_row` the row of a whole-tick stop of `e` on a row's instant, once; `obs`:
    /// the plant, if observed at this stop already.
    fn stop(
        &mut self,
        e: &DriveEngine,
        obs: Option<plants::Observation>,
        on_row: &mut impl FnMut(&TraceRow),
    ) {
        let now = e.now();
        if now >= self.from
            && now <= self.to
            && now.0 % self.every.0 == 0
            && self.last.is_none_or(|r| now > r)
        {
            self.last = Some(now);
            let o = obs.unwrap_or_else(|| e.plant.observe());
            on_row(&TraceRow::observed(e, &o));
        }
    }
}

/// The run's schedule, in time order: every change of a profile after t = 0 (the engine
/// was built with their first values), the trace's window and the steady-state window's
/// start, then the end. Every schedule change is a segment end; the engine runs exactly to
/// it. It stops at the trace's sampling instants only inside the trace's window: elsewhere
/// those stops would cost most of the run (and change nothing but the instants seen).
pub(super) fn events(sc: &Scenario) -> Vec<(f64, Event)> {
    let traced = sc
        .trace
        .iter()
        .flat_map(|t| [(t.from_s, Event::TraceOn), (t.to_s, Event::TraceOff)])
        .chain([(sc.steady_from_s, Event::SteadyOn)]);
    let (end, stair) = (sc.duration_s, sc.profile_update_s);
    let later = |p: &Profile| p.settings(end, stair).into_iter().skip(1);
    let loads = sc
        .load
        .terms()
        .into_iter()
        .enumerate()
        .flat_map(|(k, (_, p))| later(p).map(move |(t, x)| (t, Event::Load(k, x))));
    let supply = sc
        .supply_v
        .iter()
        .flat_map(|p| later(p).map(|(t, x)| (t, Event::Supply(x))));
    let mut events: Vec<(f64, Event)> = later(&sc.speed_rpm)
        .map(|(t, x)| (t, Event::Speed(x)))
        .chain(loads)
        .chain(supply)
        .chain(traced)
        .filter(|e| e.0 < sc.duration_s)
        .collect();
    // Stable: settings at one instant keep their order.
    events.sort_by(|a, b| a.0.total_cmp(&b.0));
    events.push((sc.duration_s, Event::End));
    events
}

/// A change the schedule makes at its instant.
#[derive(Copy, Clone, Debug)]
pub(super) enum Event {
    Speed(f64),
    /// A torque term of the load (see [`plants::Load::set_term`]).
    Load(usize, f64),
    Supply(f64),
    TraceOn,
    TraceOff,
    SteadyOn,
    End,
}

impl Event {
    /// A trace window's end: the engine's stop there is the trace's alone.
    pub(super) fn is_trace(self) -> bool {
        matches!(self, Event::TraceOn | Event::TraceOff)
    }

    /// The same change, values compared bit for bit.
    pub(super) fn same(self, other: Event) -> bool {
        use Event::*;
        match (self, other) {
            (Speed(a), Speed(b)) | (Supply(a), Supply(b)) => a.to_bits() == b.to_bits(),
            (Load(k, a), Load(j, b)) => k == j && a.to_bits() == b.to_bits(),
            (TraceOn, TraceOn) | (TraceOff, TraceOff) | (SteadyOn, SteadyOn) | (End, End) => true,
            _ => false,
        }
    }
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 { a } else { gcd(b, a % b) }
}

pub(super) fn tick_of(t_s: f64) -> Ticks {
    Ticks::from_seconds(t_s).unwrap_or(Ticks::NEVER)
}
