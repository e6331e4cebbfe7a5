//! The comparators' dynamic state by value (see [`drive_core::state`]): filters,
//! outputs, toggle histories, ringing, the steps kept for channels nobody reads and the
//! scans left pending. The front end's parameters and tables are never read back; the
//! noise is a function of the tick, so it has no state of its own.

use super::records::{Bend, RECORDS, Record, Records};
use super::{Channel, ComparatorBank, Cursor, Front, History, Ring, ScanWork};
use crate::sensing::foh::Foh;
use crate::sensing::rc::CubicRc;
use drive_core::state::{check, check_count};
use drive_core::{Phase, TICK_S, Ticks, persist_fields};

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

/// What the comparators' analog values are held to (from the plant's bounds, see
/// `BldcPlant::bounds`).
#[derive(Copy, Clone, Debug)]
pub(crate) struct Limits {
    /// The plant's time \[s\] and its tick.
    pub(crate) t: f64,
    pub(crate) now: u64,
    /// The longest step \[ticks\].
    pub(crate) longest: u64,
    /// |v| of the terminals and the neutral \[V\].
    pub(crate) volts: f64,
    /// |de/dt| of a back-EMF [V/s].
    pub(crate) emf_rate: f64,
}

impl Limits {
    /// |y| of a filter whose steps are at most `h` \[s\] long: its inputs' range, and a
    /// floating leg's bend on top, a cubic vanishing at a step's ends whose end slopes are
    /// the back-EMF's rate less the chord's (each at most 2·volts/h), so within
    /// h·(4·volts/h + 2·|de/dt|) of the chord.
    fn filter(&self, h: f64) -> f64 {
        5.0 * self.volts + 2.0 * h * self.emf_rate
    }
}

/// A value computed in the run against its rule's `bound`, with room for the rounding of
/// the `terms` it was computed from (1e-9 of their magnitudes).
fn within(x: f64, bound: f64, terms: f64) -> bool {
    x.abs() <= bound + 1e-9 * terms
}

impl Front {
    /// The filters' outputs (three phase paths, then the neutral's) τ into `rec`'s step,
    /// and the magnitude of the terms they are sums of.
    fn outputs_in(&self, rec: &Record, tau: f64) -> ([f64; 4], f64) {
        let (dp, dn) = ((-tau / self.tau_p).exp(), (-tau / self.tau_n).exp());
        let (y, y_n) = rec.filters_at(tau, (dp, dn), (self.tau_p, self.tau_n));
        let foh =
            |f: &Foh, d: f64, tau_f: f64| f.a.abs() + (f.b * (tau - tau_f)).abs() + (f.c * d).abs();
        let mut terms = foh(&rec.fn_, dn, self.tau_n);
        for j in 0..3 {
            terms += foh(&rec.fx[j], dp, self.tau_p);
            if let Some(b) = &rec.bend[j] {
                terms += b.transient.abs()
                    + b.p
                        .iter()
                        .enumerate()
                        .map(|(k, p)| (p * tau.powi(k as i32)).abs())
                        .sum::<f64>();
            }
        }
        ([y.u, y.v, y.w, y_n], terms)
    }

    /// A kept step, any of the ring's (the run wrote each, and an older one is overwritten
    /// whole before it is used again): its ticks and decays follow from its start and
    /// length as [`Front::record`] makes them, its ringing is one [`Front::check_ring`]
    /// allows, and the filters' outputs at its start, middle and end lie within `lim`.
    fn check_record(&self, k: usize, rec: &Record, lim: &Limits) -> Result<(), String> {
        let longest_s = lim.longest as f64 * TICK_S;
        check(
            (0.0..=lim.t).contains(&rec.t0) && (0.0..=longest_s).contains(&rec.h),
            || {
                format!(
                    "cmp.records.buf[{k}]: t0 = {} s, h = {} s (rule: a step begun by the plant's time {} s, at most the longest step {longest_s} s)",
                    rec.t0, rec.h, lim.t
                )
            },
        )?;
        let k_start = Ticks::at_or_before(rec.t0).0 + 1;
        check(rec.k_start == k_start, || {
            format!(
                "cmp.records.buf[{k}].k_start = {} (rule: the first tick after its start, {k_start})",
                rec.k_start
            )
        })?;
        self.check_ring(&format!("cmp.records.buf[{k}].ring"), &rec.ring, lim)?;
        let env = self.envelope_of(&rec.ring, rec.k_start);
        check(rec.env_first == env, || {
            format!(
                "cmp.records.buf[{k}].env_first = {} (rule: its ringing's envelope at its first tick, {env})",
                rec.env_first
            )
        })?;
        // The decays of a step walked (one with a tick in it; the ring's first, empty
        // step holds ones).
        if rec.k_start <= rec.k_end {
            let (eh, first) = (
                self.decays_of(rec.h),
                self.first_decays(rec.t0, rec.k_start),
            );
            check(rec.eh == eh && rec.first == first, || {
                format!(
                    "cmp.records.buf[{k}]: eh = {:?}, first = {:?} (rule: the filters' decays over its length and to its first tick, {eh:?} and {first:?})",
                    rec.eh, rec.first
                )
            })?;
        }
        for (j, b) in rec.bend.iter().enumerate() {
            if let Some(b) = b {
                check(b.transient == -b.p[0], || {
                    format!(
                        "cmp.records.buf[{k}].bend[{j}].transient = {} (rule: from rest at the step's start, −p[0] = {})",
                        b.transient, -b.p[0]
                    )
                })?;
            }
        }
        // A filter carries the bends of earlier steps too: the longest step's allowance.
        let bound = lim.filter(lim.longest as f64 * TICK_S);
        for tau in [0.0, 0.5 * rec.h, rec.h] {
            let (y, terms) = self.outputs_in(rec, tau);
            if let Some(j) = (0..4).find(|&j| !within(y[j], bound, terms)) {
                return Err(format!(
                    "cmp.records.buf[{k}]: filter {} = {} V {tau} s into the step (rule: |y| <= {bound} V, what the terminals and a back-EMF's bend drive)",
                    ["u", "v", "w", "n"][j],
                    y[j]
                ));
            }
        }
        Ok(())
    }

    /// The ringing: its instant is its tick's, its envelope |z| as [`Ring::magnitude`]
    /// makes it, and |z| no more than the largest switching-node step (twice `volts`)
    /// coupled in at every tick, twice, decaying between: 4·g·volts/(1 − e^{−T/τr}) ≤
    /// 4·g·volts·(1 + τr/T).
    fn check_ring(&self, name: &str, ring: &Ring, lim: &Limits) -> Result<(), String> {
        check(ring.t == Ticks(ring.k).seconds(), || {
            format!(
                "{name}.t = {} (rule: the instant of its tick {}, {} s)",
                ring.t,
                ring.k,
                Ticks(ring.k).seconds()
            )
        })?;
        let bound = 4.0 * self.ring_gain * lim.volts * (1.0 + self.ring_decay / TICK_S);
        let mag = Ring::magnitude(ring.z);
        check(ring.mag == mag && mag <= bound, || {
            format!(
                "{name} = {:?}, mag = {} (rule: mag = |z| raised by 4 ulps, {mag}, and |z| <= {bound} V)",
                ring.z, ring.mag
            )
        })
    }

    /// The scan of channel `j` left pending: of the newest step, as [`Front::channel`]
    /// makes it from that step, its stationary value (once computed) that step's.
    fn check_pending(&self, j: usize, cur: &Cursor, newest: &Record) -> Result<(), String> {
        let (c, want) = (&cur.c, self.channel(newest, cur.c.x));
        let fields = [
            ("t0", c.t0, want.t0),
            ("base.0", c.base.0, want.base.0),
            ("base.1", c.base.1, want.base.1),
            ("poly[0]", c.poly[0], want.poly[0]),
            ("poly[1]", c.poly[1], want.poly[1]),
            ("poly[2]", c.poly[2], want.poly[2]),
            ("poly[3]", c.poly[3], want.poly[3]),
            ("beta", c.beta, want.beta),
            ("dev.0", c.dev.0, want.dev.0),
            ("dev.1", c.dev.1, want.dev.1),
            ("a", c.a, want.a),
            ("b", c.b, want.b),
            ("ap", c.ap, want.ap),
            ("bn", c.bn, want.bn),
        ];
        if let Some((name, got, want)) = fields.into_iter().find(|f| f.1 != f.2) {
            return Err(format!(
                "cmp.pending[{j}].c.{name} = {got} (rule: the newest step's channel as its record makes it, {want})"
            ));
        }
        check(c.k_s == want.k_s, || {
            format!(
                "cmp.pending[{j}].c.k_s = {} (rule: the newest step's first tick, {})",
                c.k_s, want.k_s
            )
        })?;
        if let Some(g) = c.stationary.get() {
            let v = self.stationary_value(&want);
            check(g == v, || {
                format!(
                    "cmp.pending[{j}].c.stationary = {g} (rule: the channel's stationary value, {v})"
                )
            })?;
        }
        Ok(())
    }
}

impl ComparatorBank {
    /// Checks a restored bank against the plant's tick `now`: the kept steps, the scans
    /// and the ringing lie within the longest step (`longest` ticks) of it, and every
    /// index is in bounds, so no walk reaches further than a step would.
    pub(crate) fn check_against(&self, lim: &Limits) -> Result<(), String> {
        let (now, longest) = (lim.now, lim.longest);
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
        })?;
        self.check_values(lim)
    }

    /// The analog values and counts: the filters within what drives them, each output
    /// the state its toggle history ends in, the toggle count at least the toggles held,
    /// the kept steps and the ringing as [`Front::check_record`] and
    /// [`Front::check_ring`] hold them, and the scans left pending as the newest step
    /// makes them.
    fn check_values(&self, lim: &Limits) -> Result<(), String> {
        let f = &self.front;
        let bound = lim.filter(lim.longest as f64 * TICK_S);
        let y = [f.y.u, f.y.v, f.y.w, f.y_n];
        if let Some(j) = (0..4).find(|&j| !within(y[j], bound, 0.0)) {
            return Err(format!(
                "cmp.front.{} = {} (rule: |y| <= {bound} V, what the terminals and a back-EMF's bend drive)",
                ["y.u", "y.v", "y.w", "y_n"][j],
                y[j]
            ));
        }
        let mut held = 0;
        for x in Phase::ALL {
            let h = &f.hist[x.index()];
            let last = h.newest().map_or(h.base, |t| t.1);
            check(f.out.get(x) == last, || {
                format!(
                    "cmp.front.out.{x:?} = {} (rule: the state its toggle history ends in, {last})",
                    f.out.get(x)
                )
            })?;
            held += h.toggles.len() as u64;
        }
        check(f.toggles >= held, || {
            format!(
                "cmp.front.toggles = {} (rule: at least the {held} toggles held, which it counts)",
                f.toggles
            )
        })?;
        check_count("cmp.front.toggles", f.toggles)?;
        let w = &f.work;
        for (name, n) in [
            ("scans", w.scans),
            ("ticks_scanned", w.ticks_scanned),
            ("segments", w.segments),
            ("blocks", w.blocks),
        ] {
            check_count(&format!("cmp.front.work.{name}"), n)?;
        }
        f.check_ring("cmp.front.ring", &f.ring, lim)?;
        for (k, rec) in self.records.buf.iter().enumerate() {
            f.check_record(k, rec, lim)?;
        }
        let newest = self.records.newest();
        for (j, cur) in self.pending.iter().enumerate() {
            if let Some(cur) = cur {
                f.check_pending(j, cur, newest)?;
            }
        }
        Ok(())
    }
}
