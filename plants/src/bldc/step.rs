//! The step loop behind [`Plant::advance`](drive_core::Plant::advance): steps from the
//! committed state towards the horizon, each ended at its first diode event, handed to the
//! sensing chains, and committed or kept as the lookahead.

use super::lookahead::Lookahead;
use super::{BldcPlant, State, THETA, wrap_angle};
use crate::circuit::Solution;
use crate::emf;
use drive_core::{Phase, PlantStop, Ticks, Watch};
use std::f64::consts::TAU;

/// The most steps sin θ and cos θ are carried from step to step by rotations before a
/// fresh `sin_cos` re-anchors them (see `BldcPlant::start_angle`; committed steps are
/// counted by `PlantStats::steps`, which a state saves, so a restored run re-anchors
/// where the uninterrupted one does).
///
/// The bound: a step carries the pair by at most three rotations, two by Ω·h/2 (sin and
/// cos by [`emf::rotation`]'s series, whose truncation for |d| <= 0.5 is below d¹³/13! <
/// 2e-14; a larger d takes a fresh `sin_cos`) and one by the end's small δ
/// ([`emf::sin_cos_close`], off by δ⁴/4 < 3e-17 in s² + c², or from the step's base).
/// Each rotation is a 2×2 product whose roundings move s² + c² and the angle by a few ε
/// (ε = 2^-53 ≈ 1.1e-16, say 8ε < 1e-15), so a step moves them by less than
/// 3·(2e-14 + 1e-15) < 7e-14, and `ANCHOR` steps by less than 128 × 7e-14 < 9e-12: more
/// than a hundred times inside the 1e-9 a restored state is held to (`bldc/state.rs`),
/// for any run however long. (Observed at a crawl: under 6e-14 in 128 steps.)
/// A power of two, so the test is a mask; a re-anchor costs one `sin_cos` in 128 steps.
pub(super) const ANCHOR: u64 = 128;

impl BldcPlant {
    /// [`Plant::advance`](drive_core::Plant::advance) without the comparator bookkeeping
    /// around it.
    pub(super) fn step_to(&mut self, until: Ticks, watch: Watch) -> PlantStop {
        let t_end = until.seconds();
        // The first watched change not yet reported, as found at the end of the last step
        // (nothing since has moved the comparators or the report): asked once a step.
        let mut known = None;
        loop {
            if let Some(stop) = self.serve_lookahead(until, watch, &mut known) {
                return stop;
            }
            let t0 = self.t;
            let (now, on_tick) = self.tick;
            let unreported = known.take().unwrap_or_else(|| self.unreported(watch));
            let pending = unreported.map(|tv| Self::sample_edge(tv, watch, now));
            if on_tick && pending == Some(now) {
                self.reported = now;
                return PlantStop::Sensing(now);
            }
            if t0 >= t_end - 1e-15 {
                if t_end > self.t {
                    self.serve_at(until);
                }
                return PlantStop::Reached;
            }
            let mut t1 = self.step_end(t0, watch.horizon.max(until), pending);
            let x0 = self.x;
            let (b0, angle) = self.start_angles(&x0);
            let f0 = self.end_derivative(&x0, &self.start, angle);
            // A diode event predicted inside the step: the step ends there when its
            // current is within 1e-9 A of zero (as the search after a step accepts). The
            // step runs on the response Newton searched, so this only catches a search
            // stopped short, with 1000× the room of its 1e-12 A stop.
            let h = t1 - t0;
            let cand = self.diode_candidate(&x0, &f0, h);
            let built = cand.and_then(|_| self.step_response(&x0, &f0, h, b0));
            let zero = match (cand, &built) {
                (Some(p), Some(b)) => Self::diode_zero(b, x0[p.index()], p, h).map(|t| (t, p)),
                _ => None,
            };
            let (mut x1, mut end) = match &built {
                Some(b) => self.flow_built(&x0, zero.map_or(h, |z| z.0), &f0, b),
                None => self.integrate_end(&x0, h, b0, &f0),
            };
            let predicted = zero.filter(|&(_, p)| x1[p.index()].abs() < 1e-9);
            match (zero, predicted, &built) {
                (_, Some((hz, _)), _) => t1 = t0 + hz,
                (Some(_), None, Some(b)) => (x1, end) = self.flow_built(&x0, h, &f0, b),
                _ => {} // no zero predicted (a predicted zero implies a built response)
            }
            let (mut s1, mut sc1) = self.solution_at(&x1, emf::sin_cos_close(x1[THETA], end, b0));
            let mut event = predicted.map(|(_, p)| p);
            let found = self.event_after((&x0, &f0), (&x1, &s1), t1 - t0, b0, event);
            if let Some((h_ev, p, at)) = found {
                // The step to the event is integrated (not interpolated), so the energy
                // integrals stay consistent with the currents.
                x1 = at.unwrap_or_else(|| self.integrate_from(&x0, h_ev, b0, &f0));
                (s1, sc1) = self.solution_at(&x1, emf::sin_cos_near(x1[THETA], b0));
                t1 = t0 + h_ev;
                event = Some(p);
            }
            let (start, end) = ((&x0, &f0), (&x1, &s1, sc1));
            self.sense_step(start, end, (t0, t1), b0, unreported, watch.channels);
            let after = self.unreported(watch);
            if let Some(stop) = self.stop_inside(t1, until, watch, (now, after)) {
                // The rest of the step is kept for later.
                self.lookahead = Some(Lookahead {
                    x0,
                    f0,
                    base: b0,
                    t0,
                    t1,
                    x1,
                    s1,
                    sc1,
                    event,
                });
                return stop;
            }
            if let Some(stop) = self.finish_step(x1, sc1, t0, t1, s1, event) {
                return stop;
            }
            known = Some(after);
        }
    }

    /// Where the step from `t0` ends: a longest step on, or at the instant `to` (a tick)
    /// if that comes first, or at `pending`, the clock edge that samples a watched change
    /// already found.
    fn step_end(&self, t0: f64, to: Ticks, pending: Option<Ticks>) -> f64 {
        // Integrate up to the horizon, not just to `until`: instants before it are
        // served from this step (see `Lookahead`) unless the dynamics change first.
        // The horizon's instant is a tick's own time already (as `Ticks::at_or_after`
        // finds it); a step of the longest length that lands on a tick takes that
        // tick's own time, so it ends where a step cut there by the engine would (bit
        // for bit).
        let horizon = to.seconds();
        let mut t1 = if horizon > t0 + self.h_max {
            match Ticks::at_or_after(t0 + self.h_max) {
                (k, true) => k.seconds(),
                _ => t0 + self.h_max,
            }
        } else {
            horizon
        };
        if let Some(e) = pending {
            t1 = t1.min(e.seconds());
        }
        t1
    }

    /// The angle base of the step from the committed state `x0` (see
    /// [`BldcPlant::start_angle`]), and the angle with its sine and cosine at which the
    /// derivative there is taken from the network's solution there, `start`.
    fn start_angles(&mut self, x0: &State) -> ((f64, f64, f64), (f64, f64, f64)) {
        let b0 = self.start_angle(x0);
        self.base_hint = b0;
        // First same as last: the previous step's end derivative when nothing has changed
        // the dynamics since (taken at that step's end angle, before θ's wrap); else the
        // network was just solved here (a gate change, an event, a settled lookahead).
        let angle = match (std::mem::take(&mut self.fsal), self.end_angle) {
            (true, Some(e)) => e,
            _ => {
                if std::mem::take(&mut self.verify_start) && !self.start_solves(x0, b0) {
                    self.start = self.solve_near(x0, b0);
                }
                // A state gone non-finite has no solution to compare (NaN ≠ NaN); the
                // run goes on and its summary reports it.
                debug_assert!(
                    self.start_solves(x0, b0),
                    "the network solution at the step's start is stale"
                );
                (x0[THETA], b0.1, b0.2)
            }
        };
        (b0, angle)
    }

    /// The angle, sine and cosine the step from the committed state `x0` starts from: the
    /// last step's end angle, unless the state moved since (a wrap of θ, a settled
    /// lookahead, a set rotor) or the chain has run `ANCHOR` steps: a fresh sin_cos then
    /// re-anchors the chain of rotations, at least once a turn and once every `ANCHOR`
    /// steps however slowly the rotor turns.
    pub(super) fn start_angle(&self, x0: &State) -> (f64, f64, f64) {
        match self.end_angle {
            Some(e) if e.0 == x0[THETA] && self.stats.steps % ANCHOR != 0 => e,
            _ => Self::base(x0),
        }
    }

    /// The angle, sine and cosine a step starts from: every evaluation inside the step
    /// reaches its own angle from them by angle addition (see [`emf::sin_cos_near`]).
    pub(super) fn base(x: &State) -> (f64, f64, f64) {
        let (s, c) = x[THETA].sin_cos();
        (x[THETA], s, c)
    }

    /// Commits a step ending at `t1` with sin θ, cos θ `sc1` there (handling its diode
    /// event, if any).
    #[inline(always)]
    pub(super) fn finish_step(
        &mut self,
        x1: State,
        sc1: (f64, f64),
        t0: f64,
        t1: f64,
        s1: Solution,
        event: Option<Phase>,
    ) -> Option<PlantStop> {
        self.end_angle = Some((x1[THETA], sc1.0, sc1.1));
        // The back-EMF at the committed state (a re-resolve after a gate change or an
        // event, an observation) then takes this sine and cosine as they are, not by angle
        // addition from the step's start again: the same values, since they were made so.
        self.base_hint = (x1[THETA], sc1.0, sc1.1);
        self.commit(x1, t1);
        if let Some(p) = event {
            return Some(self.apply_event(p, t1 - t0 < 1e-12));
        }
        self.same_instant_events = 0;
        if t1 - t0 >= 1e-12 {
            self.muted = [false; 3];
        }
        self.start = s1;
        self.fsal = true;
        None
    }

    fn commit(&mut self, x: State, t: f64) {
        self.x = x;
        self.t = t;
        self.tick = Ticks::at_or_after(t);
        if !(0.0..TAU).contains(&self.x[THETA]) {
            self.x[THETA] = wrap_angle(self.x[THETA]);
        }
        self.stats.steps += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bldc::testing::{crawl, restored};
    use crate::params::PlantParams;

    /// At a crawl θ never wraps, so only the anchor every `ANCHOR` steps bounds the
    /// rounding carried by the chain of rotations: s² + c² and the angle stay within the
    /// bound derived at `ANCHOR`, and the plant's own state restores. (Unanchored, s² + c²
    /// drifted by about 2e-16 a step: 4e-11 here, 1.1e-9 after 5.5 M steps, refused.)
    #[test]
    fn a_long_crawl_keeps_sin_and_cos_within_the_anchor_s_bound_and_restores() {
        let bound = ANCHOR as f64 * 7e-14;
        let mut worst = (0.0f64, 0.0f64);
        let pl = crawl(PlantParams::default(), 0.01, 200_000, |pl| {
            let (th, s, c) = pl.end_angle.expect("a step's end angle");
            let (ws, wc) = th.sin_cos();
            worst.0 = worst.0.max((s * s + c * c - 1.0).abs());
            worst.1 = worst.1.max((s - ws).abs().max((c - wc).abs()));
        });
        assert!(pl.x[THETA] < TAU - 0.3, "θ never wrapped");
        assert!(
            worst.0 < bound && worst.1 < bound,
            "s² + c² − 1 up to {:e}, sin and cos off by up to {:e} (bound {bound:e})",
            worst.0,
            worst.1
        );
        restored(&pl).unwrap();
    }
}
