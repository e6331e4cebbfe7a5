//! The outputs' toggle histories: what a read sees after the propagation delay, the
//! watched changes not yet reported, and what no query can reach any more.

use super::front::Front;
use drive_core::{Abc, Phase, Ticks};

/// Toggles kept without reallocating; more are kept too (the buffer grows), since every
/// toggle that may still be read must stay.
const HISTORY: usize = 64;

/// Recent toggles of one comparator, oldest first, to apply the propagation delay.
/// Toggles are dropped only once no query can reach them (see [`History::forget_before`]).
#[derive(Clone, Debug)]
pub(super) struct History {
    pub(super) toggles: std::collections::VecDeque<(u64, bool)>,
    /// State before the oldest retained toggle.
    pub(super) base: bool,
}

impl History {
    pub(super) fn new(state: bool) -> Self {
        History {
            toggles: std::collections::VecDeque::with_capacity(HISTORY),
            base: state,
        }
    }

    pub(super) fn push(&mut self, tick: u64, state: bool) {
        debug_assert!(
            self.newest().is_none_or(|(t, s)| t < tick && s != state),
            "toggle to {state} at tick {tick} after {:?}",
            self.newest()
        );
        self.toggles.push_back((tick, state));
    }

    pub(super) fn newest(&self) -> Option<(u64, bool)> {
        self.toggles.back().copied()
    }

    fn state_at(&self, tick: u64) -> bool {
        // Usually the newest toggle says so without a walk (or there is none).
        match self.toggles.back() {
            None => return self.base,
            Some(&(t, s)) if t <= tick => return s,
            Some(_) => {}
        }
        self.toggles
            .iter()
            .rev()
            .find(|t| t.0 <= tick)
            .map_or(self.base, |t| t.1)
    }

    /// Earliest toggle tick strictly after `tick`.
    fn first_after(&self, tick: u64) -> Option<u64> {
        // Usually there is none: the newest toggle says so without a walk.
        let newest = self.newest()?.0;
        if newest <= tick {
            return None;
        }
        // Else usually the newest alone (one toggle not yet seen): the one before says so.
        let n = self.toggles.len();
        if n < 2 || self.toggles[n - 2].0 <= tick {
            return Some(newest);
        }
        self.toggles
            .iter()
            .rev()
            .take_while(|t| t.0 > tick)
            .last()
            .map(|t| t.0)
    }

    /// Removes toggles after `tick` (when a step is cut short); returns how many.
    pub(super) fn truncate_after(&mut self, tick: u64) -> u64 {
        let mut removed = 0;
        while self.toggles.back().is_some_and(|t| t.0 > tick) {
            self.toggles.pop_back();
            removed += 1;
        }
        removed
    }

    /// Folds toggles at or before `tick` into the base state: no query reaches further back.
    fn forget_before(&mut self, tick: u64) {
        while let Some(&(t, s)) = self.toggles.front() {
            if t > tick {
                break;
            }
            self.base = s;
            self.toggles.pop_front();
        }
    }
}

impl Front {
    /// Sets channel `x`'s output to `level` from tick `k` on (a toggle there if it
    /// differs).
    pub(super) fn set_output(&mut self, x: Phase, k: u64, level: bool) {
        if self.out.get(x) != level {
            *self.out.get_mut(x) = level;
            self.hist[x.index()].push(k, level);
            self.toggles += 1;
        }
    }

    /// Forgets toggles no query can reach any more: queries come at `now` or later, so
    /// nothing before `now` − delay is read, except a change not yet reported to the
    /// controller (visible at `unreported`), which must still be found.
    pub(super) fn forget_history(&mut self, now: Ticks, unreported: Option<Ticks>) {
        let mut horizon = now.0.saturating_sub(self.delay);
        if let Some(v) = unreported {
            horizon = horizon.min(v.0.saturating_sub(self.delay + 1));
        }
        for hist in &mut self.hist {
            hist.forget_before(horizon);
        }
    }

    /// Outputs as seen after the propagation delay at instant `at`.
    pub(super) fn outputs_at(&self, at: Ticks) -> Abc<bool> {
        let t = at.0.saturating_sub(self.delay);
        Abc::from_fn(|x| self.hist[x.index()].state_at(t))
    }

    /// Earliest instant after `after` at which a watched output changes (delay included).
    /// Inlined as a check of each watched channel's newest toggle: the engine asks at
    /// every stop, and there usually is none.
    #[inline(always)]
    pub(super) fn next_visible_change(&self, after: Ticks, watch: Abc<bool>) -> Option<Ticks> {
        let t = after.0.saturating_sub(self.delay);
        let any = Phase::ALL
            .into_iter()
            .any(|x| watch.get(x) && self.hist[x.index()].newest().is_some_and(|(k, _)| k > t));
        if any {
            self.first_visible_after(t, watch)
        } else {
            None
        }
    }

    /// [`Front::next_visible_change`] once a watched channel has toggled after tick `t`.
    #[cold]
    #[inline(never)]
    fn first_visible_after(&self, t: u64, watch: Abc<bool>) -> Option<Ticks> {
        Phase::ALL
            .into_iter()
            .filter(|&x| watch.get(x))
            .filter_map(|x| self.hist[x.index()].first_after(t))
            .min()
            .map(|k| Ticks(k + self.delay))
    }
}
