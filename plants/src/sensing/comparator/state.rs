//! The comparators' dynamic state by value (see [`drive_core::state`]): filters,
//! outputs, toggle histories, ringing, the steps kept for channels nobody reads and the
//! scans left pending. The front end's parameters and tables are never read back; the
//! noise is a function of the tick, so it has no state of its own.

use super::records::{Bend, RECORDS, Record, Records};
use super::{Channel, ComparatorBank, Cursor, Front, History, Ring, ScanWork};
use crate::sensing::foh::Foh;
use crate::sensing::rc::CubicRc;
use drive_core::state::check;
use drive_core::{Phase, persist_fields};

persist_fields!(Foh { a, b, c });
persist_fields!(Bend { p, transient });
persist_fields!(CubicRc {
    p,
    from,
    transient,
    tau
});
persist_fields!(Ring { z, t, k, mag });
persist_fields!(Record {
    t0,
    h,
    k_start,
    k_end,
    fx,
    bend,
    fn_,
    eh,
    first,
    ring,
    env_first
});
persist_fields!(Records { buf, first, len });
persist_fields!(History { toggles, base });
persist_fields!(ScanWork {
    scans,
    ticks_scanned,
    segments,
    blocks
});
persist_fields!(Channel {
    x,
    t0,
    k_s,
    base,
    poly,
    beta,
    dev,
    a,
    b,
    ap,
    bn,
    stationary
});
persist_fields!(Cursor { c, k, k_end });

impl Default for Foh {
    fn default() -> Self {
        Foh::new(0.0, 0.0, 0.0, 0.0, 1.0)
    }
}

impl Default for CubicRc {
    fn default() -> Self {
        CubicRc::new(0.0, 0.0, [0.0; 4], 1.0)
    }
}

impl Default for Record {
    fn default() -> Self {
        Records::new(&drive_core::Abc::splat(0.0), 0.0).buf[0]
    }
}

impl Default for Channel {
    fn default() -> Self {
        let f = Foh::default();
        Channel::new(
            Phase::U,
            0.0,
            (&f, None, &f),
            ((1.0, 1.0), (1.0, 1.0)),
            0.0,
            0.0,
        )
    }
}

// Here rather than derived, so that the scans' file is left as it is.
#[allow(clippy::derivable_impls)]
impl Default for Cursor {
    fn default() -> Self {
        Cursor {
            c: Channel::default(),
            k: 0,
            k_end: 0,
        }
    }
}

// The front's outputs, filters, histories and ringing; its parameters are not saved.
persist_fields!(Front {
    y,
    y_n,
    out,
    hist,
    ring,
    toggles,
    work
});
persist_fields!(ComparatorBank {
    front,
    pending,
    records,
    dormant,
    read_from
});

impl ComparatorBank {
    /// Checks a restored bank against the plant's tick `now`: the kept steps, the scans
    /// and the ringing lie within the longest step (`longest` ticks) of it, and every
    /// index is in bounds, so no walk reaches further than a step would.
    pub(crate) fn check_against(&self, now: u64, longest: u64) -> Result<(), String> {
        let late = now.saturating_add(longest);
        let rs = &self.records;
        check((1..=RECORDS).contains(&rs.len), || {
            format!("cmp.records.len = {} (rule: 1..={RECORDS})", rs.len)
        })?;
        let newest = rs.newest_seq();
        for seq in rs.first..=newest {
            let rec = rs.get(seq);
            let ok = rec.k_end <= late
                && rec.k_start <= rec.k_end.saturating_add(1)
                && rec.k_end.saturating_sub(rec.k_start) <= longest
                && rec.h >= 0.0
                && rec.ring.k <= rec.k_start;
            check(ok, || {
                format!(
                    "cmp.records step {seq}: ticks {}..={} (rule: at most the longest step, ending by tick {late}, its ringing from before it)",
                    rec.k_start, rec.k_end
                )
            })?;
        }
        for (j, d) in self.dormant.iter().enumerate() {
            check(
                d.is_none_or(|s| (rs.first..=newest + 1).contains(&s)),
                || {
                    format!(
                        "cmp.dormant[{j}] = {d:?} (rule: a kept step, {}..={})",
                        rs.first,
                        newest + 1
                    )
                },
            )?;
        }
        for (j, cur) in self.pending.iter().enumerate() {
            let Some(cur) = cur else { continue };
            let ok = cur.c.x.index() == j
                && cur.k_end <= late
                && cur.c.k_s <= cur.k
                && cur.k_end.saturating_sub(cur.c.k_s) <= longest;
            check(ok, || {
                format!(
                    "cmp.pending[{j}]: phase {:?}, ticks {}..={} (rule: its own channel, within the longest step, ending by tick {late})",
                    cur.c.x, cur.k, cur.k_end
                )
            })?;
        }
        for (j, h) in self.front.hist.iter().enumerate() {
            // Toggles as the scans push them: one a tick at most, each to the other state
            // (the first from the base), none past the step integrated ahead.
            let mut last = (None::<u64>, h.base);
            for (k, &(tick, state)) in h.toggles.iter().enumerate() {
                let ok = last.0.is_none_or(|t| t < tick) && state != last.1 && tick <= late;
                check(ok, || {
                    format!(
                        "cmp.hist[{j}].toggles[{k}] = ({tick}, {state}) (rule: after the one before, to the other state, by tick {late})"
                    )
                })?;
                last = (Some(tick), state);
            }
        }
        let ring = &self.front.ring;
        check(ring.k <= late, || {
            format!("cmp.ring.k = {} (rule: excited by tick {late})", ring.k)
        })
    }
}
