//! The step integrated ahead of the reported time: instants inside it are served from it,
//! and it is settled at the present time before the dynamics change.

use super::{BldcPlant, State, THETA, wrap_angle};
use crate::circuit::Solution;
use drive_core::{Phase, PlantStop, Ticks, Watch};
use std::f64::consts::TAU;

/// A step integrated beyond the reported time, up to the next known gate change. Instants
/// inside it (controller ticks, watched comparator changes, trace samples: they usually
/// change nothing in the drive) are served by a step from the step's start, so the trajectory
/// does not depend on how often anyone looks; when something changes the dynamics, the
/// plant settles at the present time.
#[derive(Clone, Debug)]
pub(super) struct Lookahead {
    /// The state the step starts from, and the derivative there.
    pub(super) x0: State,
    pub(super) f0: State,
    /// The step's starting angle with its sine and cosine.
    pub(super) base: (f64, f64, f64),
    pub(super) t0: f64,
    pub(super) t1: f64,
    pub(super) x1: State,
    pub(super) s1: Solution,
    /// sin θ, cos θ at the end (see `BldcPlant::end_angle`); with `s1` they make the
    /// derivative there when it is needed (see `BldcPlant::fsal`).
    pub(super) sc1: (f64, f64),
    pub(super) event: Option<Phase>,
}

impl BldcPlant {
    /// When the first watched change not yet reported becomes visible.
    pub(super) fn unreported(&self, watch: Watch) -> Option<Ticks> {
        self.cmp.next_visible_change(self.reported, watch.channels)
    }

    /// The clock edge (not before `now`) that samples a change visible at `tv`.
    pub(super) fn sample_edge(tv: Ticks, watch: Watch, now: Ticks) -> Ticks {
        tv.next_edge(watch.clock).max(now.next_edge(watch.clock))
    }

    /// Moves the reported time to tick `k` inside the lookahead step. The sensing chains
    /// have been advanced over the whole step already; the state there is computed only
    /// when asked for (see [`BldcPlant::state`]).
    pub(super) fn serve_at(&mut self, k: Ticks) {
        self.t = k.seconds();
        self.tick = (k, true);
    }

    /// The state at the present time: inside a lookahead step, a step of its own from the
    /// lookahead's start (not an interpolant), so what is observed is the solution to
    /// integrator accuracy and the energy integrals stay consistent with the currents.
    pub(super) fn state(&self) -> State {
        match &self.lookahead {
            Some(la) => {
                let mut x = self.integrate_from(&la.x0, self.t - la.t0, la.base, &la.f0);
                if !(0.0..TAU).contains(&x[THETA]) {
                    x[THETA] = wrap_angle(x[THETA]);
                }
                x
            }
            None => self.x,
        }
    }

    /// Serves a stop from the step already integrated ahead, or finishes that step; then
    /// `known` gets the first watched change not yet reported (see `BldcPlant::step_to`).
    pub(super) fn serve_lookahead(
        &mut self,
        until: Ticks,
        watch: Watch,
        known: &mut Option<Option<Ticks>>,
    ) -> Option<PlantStop> {
        let t1 = self.lookahead.as_ref()?.t1;
        let t_end = until.seconds();
        let unreported = self.unreported(watch);
        if let Some(p) = unreported.map(|tv| Self::sample_edge(tv, watch, self.tick.0)) {
            let ps = p.seconds();
            if ps < t1 - 1e-15 && ps <= t_end + 1e-15 {
                self.serve_at(p);
                self.reported = p;
                return Some(PlantStop::Sensing(p));
            }
        }
        if t_end < t1 - 1e-15 {
            if t_end <= self.t {
                return Some(PlantStop::Reached);
            }
            self.serve_at(until);
            return Some(PlantStop::Reached);
        }
        let la = self.lookahead.take()?;
        let stop = self.finish_step(la.x1, la.sc1, la.t0, la.t1, la.s1, la.event);
        *known = Some(unreported);
        stop
    }

    /// Where the plant stops inside the step just integrated, ending at `t1`, from tick
    /// `now`: at the clock edge that samples a watched change inside it (`after`: the first
    /// not yet reported), or at `until` if the step runs past it. `None`: the step is
    /// committed whole.
    pub(super) fn stop_inside(
        &mut self,
        t1: f64,
        until: Ticks,
        watch: Watch,
        (now, after): (Ticks, Option<Ticks>),
    ) -> Option<PlantStop> {
        let t_end = until.seconds();
        let sample = after
            .map(|tv| Self::sample_edge(tv, watch, now))
            .filter(|e| e.seconds() < t1 - 1e-15);
        if sample.is_some() || t_end < t1 - 1e-15 {
            if let Some(e) = sample.filter(|e| e.seconds() <= t_end + 1e-15) {
                self.serve_at(e);
                self.reported = e;
                return Some(PlantStop::Sensing(e));
            }
            self.serve_at(until);
            return Some(PlantStop::Reached);
        }
        None
    }

    /// Ends any lookahead at the present time, before the dynamics change. The check is
    /// inlined at every gate change; the work (one change in ten) is not.
    #[inline]
    pub(super) fn settle(&mut self) {
        if self.lookahead.is_some() {
            self.settle_lookahead();
        }
    }

    /// [`BldcPlant::settle`]'s work, with a lookahead present.
    #[inline(never)]
    fn settle_lookahead(&mut self) {
        self.cmp.truncate_at(self.tick.0);
        self.cur.truncate_at(self.t);
        self.x = self.state();
        self.fsal = false;
        let la = self.lookahead.take().expect("checked by settle");
        self.start = self.solve_near(&self.x, la.base);
        self.same_instant_events = 0;
        self.stats.retries += 1;
    }
}
