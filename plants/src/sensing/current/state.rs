//! The current-sense chain's dynamic state by value (see [`drive_core::state`]): the
//! filter, the conversions in the pipeline, the next sample and the last update's
//! pieces. Gains, time constant and converter are parameters, never read back.

use super::{CurrentSense, Pieces};
use drive_core::state::{Persist, Reader, Writer, check};
use drive_core::{TICK_S, Ticks, persist_fields};

persist_fields!(Pieces { seg, n, y_end });

impl Persist for CurrentSense {
    fn save(&self, w: &mut Writer) {
        self.y.save(w);
        self.results.save(w);
        self.next_sample.save(w);
        self.last.save(w);
    }

    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        r.field("y", &mut self.y)?;
        r.field("results", &mut self.results)?;
        r.field("next_sample", &mut self.next_sample)?;
        r.field("last", &mut self.last)?;
        let n = self.last.0.n;
        check((1..=self.last.0.seg.len()).contains(&n), || {
            format!(
                "cur.last.n = {n} (rule: 1..={} pieces)",
                self.last.0.seg.len()
            )
        })
    }
}

impl CurrentSense {
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
        let _ = TICK_S;
        Ok(())
    }
}
