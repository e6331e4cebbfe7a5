//! Forks of a run: a run stopped at an instant of its schedule, copied and continued as
//! another scenario that is the same up to there (a long study's points share their
//! start-up). A fork's outcome is the other scenario's own from standstill, bit for bit
//! (wall time aside), so every difference that could reach the instant is refused.

use super::runner::{Run, events, tick_of};
use super::{RunError, Scenario};
use crate::drive::try_clone;
use drive_core::Plant;

/// Why a run cannot be forked as another scenario.
#[derive(Debug, thiserror::Error)]
pub enum ForkError {
    /// The scenarios differ before the fork instant (or in what is fixed from the start).
    #[error("cannot fork the run at {at_s} s as this scenario: {what}")]
    Differs {
        /// The fork instant \[s\].
        at_s: f64,
        /// What differs.
        what: &'static str,
    },
    /// The strategy cannot copy itself (a plugin without `clone`).
    #[error("cannot fork the run: {0}")]
    Copy(String),
}

fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits()
}

impl Run {
    /// A copy of this run, continued as `sc` from where it stands: `sc` must be what this
    /// run's scenario is up to here (config, strategy, verdict rule, metrics and trace
    /// settings, the profiles' settings before this instant, and an event of its own at
    /// it). It may differ after: its profiles, its length and its steady-state window (if
    /// neither window started yet).
    pub fn fork(&self, sc: &Scenario) -> Result<Run, RunError> {
        sc.validate()?;
        let at_s = self.time_s();
        let differs = |what| Err(ForkError::Differs { at_s, what }.into());
        let base = &self.sc;
        if sc.config != base.config {
            return differs("its config differs");
        }
        let plugin = |s: &Scenario| s.plugin.as_ref().map(|p| p.path().to_path_buf());
        if plugin(sc) != plugin(base) {
            return differs("its plugin differs");
        }
        if sc.verdict_rule != base.verdict_rule {
            return differs("its verdict rule differs");
        }
        if !same(sc.torque_lowpass_hz, base.torque_lowpass_hz) {
            return differs("its torque_lowpass_hz differs");
        }
        let record = |s: &Scenario| s.speed_record_s.map(f64::to_bits);
        if record(sc) != record(base) {
            return differs("its speed_record_s differs");
        }
        let trace = |s: &Scenario| {
            s.trace
                .map(|t| [t.every_s, t.from_s, t.to_s].map(f64::to_bits))
        };
        if trace(sc) != trace(base) {
            return differs("its trace differs");
        }
        // What the engine was built with.
        if !same(sc.speed_rpm.value_at(0.0), base.speed_rpm.value_at(0.0)) {
            return differs("its speed_rpm differs at t = 0");
        }
        let supply = |s: &Scenario| {
            s.supply_v
                .as_ref()
                .map_or(s.config.power_stage.supply_v, |p| p.value_at(0.0))
        };
        if !same(supply(sc), supply(base)) {
            return differs("its supply_v differs at t = 0");
        }
        let (l, m) = (sc.load.at(0.0), base.load.at(0.0));
        let terms = |l: plants::Load| {
            [
                l.active_nm,
                l.coulomb_nm,
                l.viscous_nms,
                l.fan_nms2,
                l.inertia_kgm2,
            ]
            .map(f64::to_bits)
        };
        if terms(l) != terms(m) {
            return differs("its load differs at t = 0");
        }
        // Every setting before the instant, and the segment run to it.
        let ev = events(sc);
        let n = self.next;
        let prefix = ev.len() > n
            && ev[..n]
                .iter()
                .zip(&self.events[..n])
                .all(|(a, b)| same(a.0, b.0) && a.1.same(b.1));
        if !prefix {
            return differs(
                "its schedule (a profile's setting, the trace's or steady-state window) differs before that instant",
            );
        }
        if self.at_event {
            let (a, b) = (ev[n], self.events[n]);
            if tick_of(a.0) != tick_of(b.0) || a.1.is_trace() != b.1.is_trace() {
                return differs("its schedule has no setting at that instant");
            }
        }
        // The metrics judged every stop so far in or out of the window by its start.
        let t = self.eng.plant.time_s();
        let (a, b) = (sc.steady_from_s, base.steady_from_s);
        if !same(a, b) && a.min(b) <= t {
            return differs("its steady_from_s differs and a window starts by then");
        }
        let eng = try_clone(&self.eng).map_err(ForkError::Copy)?;
        let mut metrics = self.metrics.clone();
        metrics.steady_from = sc.steady_from_s;
        Ok(Run {
            sc: sc.clone(),
            config: self.config.clone(),
            eng,
            load: self.load,
            events: ev,
            next: n,
            at_event: self.at_event,
            trace: self.trace.clone(),
            metrics,
            next_time: self.next_time,
            trace_on: self.trace_on,
            steady_on: self.steady_on,
            wall_s: self.wall_s,
        })
    }
}
