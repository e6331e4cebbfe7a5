//! The current-sense chain's dynamic state by value (see [`drive_core::state`]): the
//! filter, the conversions in the pipeline, the next sample and the last update's
//! pieces. Gains, time constant and converter are parameters, never read back.

use super::{CurrentSense, Pieces, UPDATES};
use crate::sensing::rc::CubicRc;
use drive_core::Ticks;
use drive_core::state::{Persist, Reader, Writer, check, restore_default};
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
            if (k as u64) < n {
                let mut x = <(u64, u16)>::default();
                r.field(&format!("results[{k}]"), &mut x)?;
                results.push_back(x);
            } else {
                restore_default::<(u64, u16)>(r)
                    .map_err(|e| format!("results[{k}] = padding{e}"))?;
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

    /// The filter and the last update's pieces, as the amplifier's swing bounds them: the
    /// filter's input is the amplifier's output clipped to 0..=max_v, so its output, the
    /// pieces' inputs and outputs at their starts and the update's end lie there too
    /// (within the rounding of the terms they are computed from); the pieces in use are
    /// the filter's (its time constant), start at the update's start and follow one
    /// another, and the others are zeros, as saved.
    fn check_pieces(&self) -> Result<(), String> {
        let last = &self.updates[self.newest % UPDATES].pieces;
        let n = last.n;
        check((1..=last.seg.len()).contains(&n), || {
            format!("last.n = {n} (rule: 1..={} pieces)", last.seg.len())
        })?;
        let hi = self.max_v;
        let swing = |x: f64, terms: f64| {
            let slack = 1e-9 * (hi + terms);
            (-slack..=hi + slack).contains(&x)
        };
        let rule = format!("rule: within the amplifier's swing 0..={hi} V");
        check(swing(self.y, 0.0), || format!("y = {} ({rule})", self.y))?;
        check(swing(last.y_end, 0.0), || {
            format!("last.y_end = {} ({rule})", last.y_end)
        })?;
        let tau = self.tau_terms.tau();
        let mut from = 0.0;
        for (k, seg) in last.seg.iter().enumerate() {
            let name = format!("last.seg[{k}]");
            if k >= n {
                let zero =
                    seg.p == [0.0; 4] && (seg.from, seg.transient, seg.tau) == (0.0, 0.0, 0.0);
                check(zero, || {
                    format!("{name} = {seg:?} (rule: a piece not in use, zeros as saved)")
                })?;
                continue;
            }
            // The chain at rest before its first update holds a piece of zeros through a
            // filter of 1 s (see `CurrentSense::new`).
            let rest = CubicRc::new(0.0, 0.0, [0.0; 4], 1.0);
            check(seg.tau == tau || (n == 1 && *seg == rest), || {
                format!(
                    "{name}.tau = {} (rule: the filter's time constant {tau} s)",
                    seg.tau
                )
            })?;
            let first = k == 0;
            check(
                if first {
                    seg.from == 0.0
                } else {
                    seg.from > from
                },
                || {
                    format!(
                        "{name}.from = {} (rule: the first at the update's start, 0 s, each after the one before, {from} s)",
                        seg.from
                    )
                },
            )?;
            from = seg.from;
            // The input p + T·p′ (p is the particular solution of T·y′ + y = u) and the
            // output p + transient at its start.
            let t = seg.from;
            let p = seg.p;
            let d = [
                p[0] + t * (p[1] + t * (p[2] + t * p[3])),
                p[1] + t * (2.0 * p[2] + 3.0 * t * p[3]),
            ];
            let terms = tau * d[1].abs()
                + p.iter()
                    .enumerate()
                    .map(|(j, c)| (c * t.powi(j as i32)).abs())
                    .sum::<f64>();
            let input = d[0] + tau * d[1];
            check(swing(input, terms), || {
                format!("{name}: input {input} V at its start ({rule})")
            })?;
            let output = d[0] + seg.transient;
            check(swing(output, terms + seg.transient.abs()), || {
                format!("{name}: output {output} V at its start ({rule})")
            })?;
        }
        Ok(())
    }

    /// The last update against the plant's time `t` and the end of its last step `end`
    /// \[s\] (the step integrated ahead's, or `t`): the update spans that step, so the
    /// filter is at the update's end, its output there `y_end`, or, cut short at `t`, at
    /// its output at `t`; and each piece's input at its end (the next one's start, or the
    /// update's end or cut) lies within the swing.
    fn check_last(&self, t: f64, end: f64) -> Result<(), String> {
        let u = &self.updates[self.newest % UPDATES];
        let last = &u.pieces;
        let (hi, tau) = (self.max_v, self.tau_terms.tau());
        let h = if self.y == last.y_end {
            let h = end - u.t0;
            let y_end = last.at(h, &self.decay);
            check(last.y_end == y_end, || {
                format!(
                    "last.y_end = {} (rule: the pieces' output at the update's end, {h} s in, {y_end} V)",
                    last.y_end
                )
            })?;
            h
        } else {
            let h = t - u.t0;
            let cut = last.at(h, &self.decay);
            check(self.y == cut, || {
                format!(
                    "y = {} (rule: the filter at the last update's end, {} V, or cut short at the plant's time, {cut} V)",
                    self.y, last.y_end
                )
            })?;
            h
        };
        for k in 0..last.n {
            let seg = &last.seg[k];
            if seg.from > h {
                break;
            }
            let to = if k + 1 < last.n {
                last.seg[k + 1].from.min(h)
            } else {
                h
            };
            let p = seg.p;
            let (v, dv) = (
                p[0] + to * (p[1] + to * (p[2] + to * p[3])),
                p[1] + to * (2.0 * p[2] + 3.0 * to * p[3]),
            );
            let input = v + tau * dv;
            let terms = tau * dv.abs()
                + p.iter()
                    .enumerate()
                    .map(|(j, c)| (c * to.powi(j as i32)).abs())
                    .sum::<f64>();
            let slack = 1e-9 * (hi + terms);
            check(
                seg.tau != tau || (-slack..=hi + slack).contains(&input),
                || {
                    format!(
                        "last.seg[{k}]: input {input} V at its end, {to} s in (rule: within the amplifier's swing 0..={hi} V)"
                    )
                },
            )?;
        }
        Ok(())
    }

    /// Checks a restored chain against the plant's time `t` \[s\]: the next sample lies
    /// within the longest step (`longest` ticks) and a conversion of it, so no update
    /// takes more samples than a step would. (The pipeline's size and order are checked
    /// as it is restored.)
    pub(crate) fn check_against(&self, t: f64, end: f64, longest: u64) -> Result<(), String> {
        let now = Ticks::at_or_before(t).0;
        let reach = longest.saturating_add(self.conv);
        let ns = self.next_n * self.conv;
        check(ns.abs_diff(now) <= reach, || {
            format!("cur.next_sample = {ns} (rule: within {reach} ticks of the plant's tick {now})")
        })?;
        // The last update began within the longest step before the plant's time (it may
        // reach past it: a step integrated ahead).
        let t0 = self.updates[self.newest % UPDATES].t0;
        let earliest = t - (longest as f64 + 1.0) * drive_core::TICK_S;
        check((earliest..=t).contains(&t0), || {
            format!(
                "cur.last.1 = {t0} (rule: the last update's start, from {earliest} s to the plant's time {t} s)"
            )
        })?;
        self.check_last(t, end).map_err(|e| format!("cur.{e}"))
    }
}
