//! The current-sense chain's dynamic state by value (see [`drive_core::state`]): the
//! filter, the conversions in the pipeline, the next sample and the last update's
//! pieces. Gains, time constant and converter are parameters, never read back.

use super::{CurrentSense, Pieces};
use drive_core::state::check;
use drive_core::{Ticks, persist_fields};

persist_fields!(Pieces { seg, n, y_end });

// The filter, pipeline, next sample and last update; the rest are parameters.
persist_fields!(CurrentSense {
    y,
    results,
    next_sample,
    last
} then CurrentSense::check_pieces);

impl CurrentSense {
    fn check_pieces(&self) -> Result<(), String> {
        let n = self.last.0.n;
        check((1..=self.last.0.seg.len()).contains(&n), || {
            format!("last.n = {n} (rule: 1..={} pieces)", self.last.0.seg.len())
        })
    }

    /// Checks a restored chain against the plant's time `t` \[s\]: the next sample lies
    /// within the longest step (`longest` ticks) and a conversion of it, so no update
    /// takes more samples than a step would; the pipeline holds no more than it can.
    pub(crate) fn check_against(&self, t: f64, longest: u64) -> Result<(), String> {
        let now = Ticks::at_or_before(t).0;
        let reach = longest.saturating_add(self.conv);
        let ns = self.next_sample;
        check(ns.abs_diff(now) <= reach, || {
            format!("cur.next_sample = {ns} (rule: within {reach} ticks of the plant's tick {now})")
        })?;
        check(self.results.len() <= self.results.capacity().max(1), || {
            format!(
                "cur.results holds {} conversions (rule: its pipeline's size)",
                self.results.len()
            )
        })?;
        Ok(())
    }
}
