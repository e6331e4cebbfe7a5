//! The channels decided later: a channel nobody watches is scanned only as far as it is
//! read (its scan left pending), and a channel nobody reads not at all: its steps are
//! recorded, and decided only if it is read again.

use super::ComparatorBank;
use super::Knot;
use drive_core::{Abc, Phase, Ticks};

impl ComparatorBank {
    /// Brings the channels nobody watches up to what is read at instant `at` (the output at
    /// `at` − delay). Where the input is certainly beyond a threshold at that tick, the
    /// ticks before it need not be walked: what is read is the same.
    pub fn catch_up(&mut self, at: Ticks) {
        if !self.any_pending() {
            return;
        }
        let q = at.0.saturating_sub(self.front.delay);
        let f = &mut self.front;
        for slot in &mut self.pending {
            let Some(cur) = slot else { continue };
            if cur.k <= q.min(cur.k_end) {
                let q = q.min(cur.k_end);
                // Usually the input stays beyond the threshold for the rest of the step
                // (a driven leg between PWM edges): then the step is done with.
                if let Some(level) = f.certain_over(&cur.c, q, cur.k_end) {
                    f.settle_at(cur, q, level);
                    cur.k = cur.k_end + 1;
                } else {
                    // Else the tick read alone (when it is not the step's last: just tried).
                    match (q < cur.k_end)
                        .then(|| f.certain_over(&cur.c, q, q))
                        .flatten()
                    {
                        Some(level) => f.settle_at(cur, q, level),
                        None => f.scan_to(cur, q),
                    }
                }
            }
            if cur.k > cur.k_end {
                *slot = None;
            }
        }
    }

    /// Walks the rest of the present step for the `watched` channels: their changes are
    /// looked for tick by tick from now on.
    ///
    /// The engine calls this at every advance, and there is rarely a scan pending: that is
    /// asked first, and the slots are then checked in a plain loop (a filtered iterator
    /// over the phases cost ≈ 40 instructions a call).
    pub fn watch(&mut self, watched: Abc<bool>) {
        if !self.any_pending() {
            return;
        }
        for (slot, w) in self.pending.iter_mut().zip(watched.to_array()) {
            if let Some(cur) = slot
                && w
            {
                self.front.scan_to(cur, u64::MAX);
                *slot = None;
            }
        }
    }

    /// Ends the pending scans at tick `k_stop` (or their step's end): every tick a later
    /// read can reach (from the end − delay on) is decided exactly, or known.
    ///
    /// Inlined: at most updates and edges there are none.
    #[inline(always)]
    pub(super) fn finish_pending(&mut self, k_stop: u64) {
        if self.any_pending() {
            self.finish_pending_scans(k_stop);
        }
    }

    /// Whether a scan is pending: the three slots tested at once, without a loop (the
    /// engine's every advance and the plant's every step ask, and mostly none is).
    #[inline(always)]
    fn any_pending(&self) -> bool {
        let [u, v, w] = &self.pending;
        u.is_some() | v.is_some() | w.is_some()
    }

    /// [`ComparatorBank::finish_pending`] when a scan is pending.
    fn finish_pending_scans(&mut self, k_stop: u64) {
        let f = &mut self.front;
        for slot in &mut self.pending {
            let Some(cur) = slot else { continue };
            cur.k_end = cur.k_end.min(k_stop);
            if cur.k <= cur.k_end {
                let a = cur.k.max(cur.k_end.saturating_sub(f.delay));
                match f.certain_over(&cur.c, a, cur.k_end) {
                    Some(level) => f.settle_at(cur, a, level),
                    None => f.scan_to(cur, cur.k_end),
                }
            }
            *slot = None;
        }
    }

    /// Whether a read of channel `x` can reach tick `k` or earlier (a read sees the
    /// output a delay back).
    pub(super) fn read_within(&self, x: Phase, k: u64) -> bool {
        self.read_from.get(x).0.saturating_sub(self.front.delay) <= k
    }

    /// Records the step [t0, t1] (the filters' responses over it, from their present
    /// state) as the newest, making room first; returns its sequence number.
    pub(super) fn push_record(&mut self, t0: f64, t1: f64, k0: &Knot, k1: &Knot) -> u64 {
        if self.records.is_full() {
            // The oldest step goes: a channel still undecided over it is decided first.
            let oldest = self.records.first;
            for x in Phase::ALL {
                if self.dormant[x.index()] == Some(oldest) {
                    self.compact(x);
                }
            }
        }
        let (seq, slot) = self.records.push_slot();
        self.front.record(t0, t1, k0, k1, slot);
        seq
    }

    /// Decides what channel `x` left undecided (its recorded steps from `dormant[x]` on)
    /// and makes it decided again, where reads may come from tick `now` on (a read sees
    /// the output a delay back) and the newest step may be cut short from `now` on. Where
    /// the input is certain over the last `delay` ticks read of a step, the steps before
    /// do not matter: what any later read sees is the same.
    ///
    /// Inlined: at every update it finds nothing to do for each channel.
    #[inline(always)]
    pub(super) fn wake(&mut self, x: Phase, now: u64) {
        if let Some(from) = self.dormant[x.index()].take() {
            self.wake_from(x, from, now);
        }
    }

    /// [`ComparatorBank::wake`] for channel `x`, undecided from recorded step `from` on.
    fn wake_from(&mut self, x: Phase, from: u64, now: u64) {
        let newest = self.records.newest_seq();
        if from > newest || self.settle_end(x, newest, now) {
            return;
        }
        let mut start = from;
        for seq in (from..newest).rev() {
            if self.settle_end(x, seq, u64::MAX) {
                start = seq + 1;
                break;
            }
        }
        for seq in start..newest {
            self.scan_record(x, seq);
        }
        // The newest step is scanned as far as it is read, like any other, while the
        // ringing is still its own; after an edge has excited more, it is walked now.
        let rec = self.records.newest();
        if rec.ring == self.front.ring {
            self.front.open(rec, x, &mut self.pending[x.index()]);
        } else {
            self.scan_record(x, newest);
        }
    }

    /// Makes room in the records for channel `x`, undecided from the oldest step on: if it
    /// is certain at the end of the newest (committed) step, the steps up to it no longer
    /// matter; else the oldest is walked.
    fn compact(&mut self, x: Phase) {
        let j = x.index();
        let newest = self.records.newest_seq();
        if self.settle_end(x, newest, u64::MAX) {
            self.dormant[j] = Some(newest + 1);
        } else if let Some(from) = self.dormant[j] {
            self.scan_record(x, from);
            self.dormant[j] = Some(from + 1);
        }
    }

    /// Settles channel `x` over the end of recorded step `seq` if its input is beyond a
    /// threshold from `delay` ticks before the step's end or tick `upto`, whichever is
    /// sooner, to the end (and the step reaches that far back).
    fn settle_end(&mut self, x: Phase, seq: u64, upto: u64) -> bool {
        let rec = self.records.get(seq);
        let a = rec.k_end.min(upto).saturating_sub(self.front.delay);
        if a < rec.k_start || rec.k_start > rec.k_end {
            return false;
        }
        let f = &mut self.front;
        let level = f.with_ring(rec.ring, |f| {
            let c = f.channel(rec, x);
            f.certain_over(&c, a, rec.k_end)
        });
        match level {
            Some(level) => {
                f.set_output(x, a, level);
                true
            }
            None => false,
        }
    }

    /// Walks channel `x` over the whole of recorded step `seq`, with the ringing of then.
    fn scan_record(&mut self, x: Phase, seq: u64) {
        let rec = self.records.get(seq);
        self.front.with_ring(rec.ring, |f| {
            let mut slot = None;
            if f.open(rec, x, &mut slot)
                && let Some(cur) = &mut slot
            {
                f.scan_to(cur, rec.k_end);
            }
        });
    }
}
