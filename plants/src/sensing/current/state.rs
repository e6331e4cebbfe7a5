//! The current-sense chain's dynamic state by value (see [`drive_core::state`]): the
//! filter, the conversions in the pipeline, the next sample and the last update's
//! pieces. Gains, time constant and converter are parameters, never read back.

use super::{CurrentSense, Pieces, UPDATES};
use crate::sensing::rc::CubicRc;
use drive_core::Ticks;
use drive_core::state::{Persist, Reader, Writer, check};
use std::collections::VecDeque;

/// The pieces in use, the others written as zeros: a slot's pieces beyond `n` are left
/// from whichever update used it before, which a restored chain does not share.
impl Persist for Pieces {
    fn save(&self, w: &mut Writer) {
        let unused = CubicRc {
            p: [0.0; 4],
            from: 0.0,
            transient: 0.0,
            tau: 0.0,
        };
        let seg: [CubicRc; 7] =
            std::array::from_fn(|k| if k < self.n { self.seg[k] } else { unused });
        seg.save(w);
        self.n.save(w);
        self.y_end.save(w);
    }

    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        r.field("seg", &mut self.seg)?;
        r.field("n", &mut self.n)?;
        r.field("y_end", &mut self.y_end)
    }
}

/// The filter, pipeline, next sample and last update; the rest are parameters. The
/// pipeline is written as the conversions held, (readable from tick, code) oldest first,
/// as a deque of them is, and the last update as its pieces and start.
impl Persist for CurrentSense {
    fn save(&self, w: &mut Writer) {
        self.y.save(w);
        self.save_results(&self.conversions(), w);
        (self.next_n * self.conv).save(w);
        let u = &self.updates[self.newest % UPDATES];
        (u.pieces, u.t0).save(w);
    }

    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        // The sample last read is not the restored state's (even when this fails midway).
        self.read.set(super::NO_READ);
        r.field("y", &mut self.y)?;
        let results = self.restore_results(r)?;
        let mut next_sample = 0u64;
        r.field("next_sample", &mut next_sample)?;
        let u = &mut self.updates[self.newest % UPDATES];
        let mut last = (u.pieces, u.t0);
        r.field("last", &mut last)?;
        (u.pieces, u.t0) = last;
        self.check_pieces()?;
        self.set_conversions(&results, next_sample)
    }
}

impl CurrentSense {
    /// Writes the pipeline `results` at its size, `keep` slots (fixed by the parameters:
    /// a step's conversions and four), however many it holds: a state's size does not
    /// change with the steps taken.
    pub(super) fn save_results(&self, results: &VecDeque<(u64, u16)>, w: &mut Writer) {
        w.u64(results.len() as u64);
        results.iter().for_each(|x| x.save(w));
        for _ in results.len()..self.keep {
            <(u64, u16)>::default().save(w);
        }
    }

    /// The pipeline as [`CurrentSense::save_results`] writes it: a count up to `keep`, then
    /// `keep` slots, the first `count` of them held.
    fn restore_results(&self, r: &mut Reader) -> Result<VecDeque<(u64, u16)>, String> {
        let mut n = 0u64;
        r.field("results.len", &mut n)?;
        let keep = self.keep;
        check(n <= keep as u64, || {
            format!("results.len = {n} (rule: at most its pipeline's size, {keep})")
        })?;
        let mut results = VecDeque::with_capacity(keep);
        for k in 0..keep {
            let mut x = <(u64, u16)>::default();
            r.field(&format!("results[{k}]"), &mut x)?;
            if (k as u64) < n {
                results.push_back(x);
            }
        }
        Ok(results)
    }

    /// The conversions held, (readable from tick, code), oldest first.
    pub(super) fn conversions(&self) -> VecDeque<(u64, u16)> {
        (self.next_n - self.held as u64..self.next_n)
            .map(|n| ((n + 1) * self.conv, self.code_of(n)))
            .collect()
    }

    /// Takes `results` (as [`CurrentSense::conversions`] gives them) into the ring, with
    /// the next sample's tick `ns`: they must be back to back, the newest the one before
    /// it. All are coded then, no update holding any.
    fn set_conversions(&mut self, results: &VecDeque<(u64, u16)>, ns: u64) -> Result<(), String> {
        let conv = self.conv;
        check(ns % conv == 0 && ns > 0, || {
            format!("next_sample = {ns} (rule: a whole number of conversions, {conv} ticks each)")
        })?;
        let next_n = ns / conv;
        let n = results.len();
        check(n <= self.keep && (n as u64) < next_n, || {
            format!(
                "results holds {n} conversions (rule: its pipeline's size, {}, and no more than taken before sample {next_n})",
                self.keep
            )
        })?;
        let first = next_n - n as u64;
        let top = self.max_code;
        for (j, &(at, code)) in results.iter().enumerate() {
            let want = (first + j as u64 + 1) * conv;
            check(at == want, || {
                format!(
                    "results[{j}].0 = {at} (rule: conversions back to back up to next_sample, here {want})"
                )
            })?;
            check(code <= top, || {
                format!("results[{j}].1 = {code} (rule: a code of the converter, 0..={top})")
            })?;
        }
        let mask = self.codes_ring.len() - 1;
        for (j, &(_, code)) in results.iter().enumerate() {
            self.codes_ring[(first + j as u64) as usize & mask] = code;
        }
        self.held = n;
        self.next_n = next_n;
        self.coded_to = next_n;
        // The held samples are all in the ring: no update claims any.
        for u in self.updates.iter_mut() {
            (u.from, u.to) = (first, first);
        }
        Ok(())
    }

    fn check_pieces(&self) -> Result<(), String> {
        let last = &self.updates[self.newest % UPDATES].pieces;
        let n = last.n;
        check((1..=last.seg.len()).contains(&n), || {
            format!("last.n = {n} (rule: 1..={} pieces)", last.seg.len())
        })
    }

    /// Checks a restored chain against the plant's time `t` \[s\]: the next sample lies
    /// within the longest step (`longest` ticks) and a conversion of it, so no update
    /// takes more samples than a step would. (The pipeline's size and order are checked
    /// as it is restored.)
    pub(crate) fn check_against(&self, t: f64, longest: u64) -> Result<(), String> {
        let now = Ticks::at_or_before(t).0;
        let reach = longest.saturating_add(self.conv);
        let ns = self.next_n * self.conv;
        check(ns.abs_diff(now) <= reach, || {
            format!("cur.next_sample = {ns} (rule: within {reach} ticks of the plant's tick {now})")
        })
    }
}
