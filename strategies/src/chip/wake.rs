//! When the chip next needs a tick: the earliest of its pending internal events.

use super::{Chip, Mode, START_DEBOUNCE};
use crate::params::GuardKind;
use drive_core::{Ticks, clocks};

impl Chip {
    pub(super) fn wake_at(&self, now: Ticks) -> Ticks {
        match self.mode {
            Mode::Off => {
                if self.start && !self.reset && self.told_to_stop() {
                    // Stopped: the sequencer looks at the command on its own clock.
                    Ticks(now.0 + 1).next_edge(clocks::ALIGN)
                } else if self.start && !self.reset {
                    Ticks(self.start_since.0 + START_DEBOUNCE.0).max(Ticks(now.0 + 1))
                } else {
                    Ticks::NEVER
                }
            }
            Mode::GaveUp => Ticks::NEVER,
            Mode::Aligning { until, .. } => {
                let mut w = until.min(self.next_pi);
                if let Some(r) = self.next_read() {
                    w = w.min(r.max(Ticks(now.0 + 1)));
                }
                w
            }
            Mode::Running => {
                let mut w = self.next_pi.min(self.step_miss_deadline());
                if let Some(r) = self.next_read() {
                    w = w.min(r.max(Ticks(now.0 + 1)));
                }
                if let Some(e) = self.shifter.post_end() {
                    w = w.min(e);
                }
                if let Some((s, end)) = self.window() {
                    if s > now {
                        w = w.min(s);
                    }
                    if let Some(e) = end
                        && e > now
                    {
                        w = w.min(e);
                    }
                }
                if let Some(s) = self.shifter.demag_timeout()
                    && s > now
                {
                    w = w.min(s);
                }
                let s = self.shifter.earliest_crossing();
                if self.shifter.in_pre() && s > now {
                    w = w.min(s);
                }
                if let Some(s) = self.shifter.confirmation_due()
                    && s > now
                {
                    w = w.min(s);
                }
                if self.shifter.in_pre()
                    && let Some(s) = self.guard.filter.settles_at()
                    && self.guard.kind == GuardKind::Df
                {
                    w = w.min(s);
                }
                w
            }
        }
    }
}
