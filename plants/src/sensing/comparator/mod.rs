//! Phase-vs-neutral comparators with an explicit analog front end.
//!
//! Comparator x sees `s_x(t) = y_x(t) − y_n(t) − offset_x + ring(t) + noise_x(t)` where
//! `y_x`, `y_n` are the terminal and neutral voltages through first-order RC filters with
//! different time constants. A PWM edge moves terminal and neutral together by ≈ V_DD/2;
//! the filter mismatch turns that common-mode step into a differential spike, and the
//! switching node's ringing adds a damped sinusoid. Near a back-EMF crossing these flip the
//! comparator: the glitches the zero-crossing guards exist to reject.
//!
//! Over a plant step the inputs are interpolated from the step's ends (see [`Knot`]), and
//! the filters' responses to them are exact.
//!
//! The output has hysteresis (rises above +h/2, falls below −h/2), is decided on the 20 ns
//! master-tick grid, and reaches the controller after a propagation delay. Toggles are found
//! by scanning ticks only where bounds on the signal allow one, which keeps the comparators
//! cheap while the input is far from its thresholds; a channel nobody watches is scanned
//! only as far as it is read, and not at all where its reading is certain anyway. A
//! channel nobody reads (see [`drive_core::Command::reads`]) is left undecided: its steps
//! are recorded, and decided only if it is read again, from the last one whose end is
//! certain.

mod records;
mod state;

pub(crate) use state::Limits;

use super::foh::Foh;
use super::noise;
use super::rc::{CubicRc, ExpTable, hermite, horner};
use super::tick_powers::{RealPairPowers, TickPowers};
use crate::params::ComparatorParams;
use drive_core::{Abc, Phase, TICK_S, Ticks};
use records::{Bend, Record, Records};

/// The terminal and neutral voltages at one end of a plant step. Between two ends each
/// voltage is interpolated along its chord, except that a terminal following the neutral
/// (v_x = v_n + e_x: a floating leg) whose back-EMF rates are given takes its back-EMF's
/// cubic Hermite interpolant on top of the neutral's chord (the plant gives them on steps
/// long enough for the chord's error to matter). The back-EMF's curvature is what moves a
/// floating phase's zero crossing. The neutral curves too (it carries the conducting legs'
/// back-EMFs), but both paths of a comparator see its chord alike, so its error cancels
/// but for the filters' mismatch (τp vs τn); the driven terminals curve only with the
/// currents (τe = L/R ≫ a step).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Knot {
    /// Terminal voltages \[V\].
    pub v: Abc<f64>,
    /// Neutral voltage \[V\].
    pub vn: f64,
    /// de_x/dt \[V/s\] of each terminal following the neutral; `None` for a driven one.
    pub emf_rate: Abc<Option<f64>>,
}

impl Knot {
    /// Driven terminals at `v`, the neutral at `vn`.
    pub fn driven(v: Abc<f64>, vn: f64) -> Self {
        Knot {
            v,
            vn,
            emf_rate: Abc::splat(None),
        }
    }
}

/// Toggles kept without reallocating; more are kept too (the buffer grows), since every
/// toggle that may still be read must stay.
const HISTORY: usize = 64;

/// Recent toggles of one comparator, oldest first, to apply the propagation delay.
/// Toggles are dropped only once no query can reach them (see [`History::forget_before`]).
#[derive(Clone, Debug)]
struct History {
    toggles: std::collections::VecDeque<(u64, bool)>,
    /// State before the oldest retained toggle.
    base: bool,
}

impl History {
    fn new(state: bool) -> Self {
        History {
            toggles: std::collections::VecDeque::with_capacity(HISTORY),
            base: state,
        }
    }

    fn push(&mut self, tick: u64, state: bool) {
        debug_assert!(
            self.newest().is_none_or(|(t, s)| t < tick && s != state),
            "toggle to {state} at tick {tick} after {:?}",
            self.newest()
        );
        self.toggles.push_back((tick, state));
    }

    fn newest(&self) -> Option<(u64, bool)> {
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
    fn truncate_after(&mut self, tick: u64) -> u64 {
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

/// One channel's noise-free input over the step being processed, in closed form:
/// s(τ) = P(τ) + A·e^{−τ/τp} − B·e^{−τ/τn} with P cubic (ringing and noise come on top).
#[derive(Clone, Debug)]
struct Channel {
    x: Phase,
    /// Start of the step \[s\].
    t0: f64,
    /// The step's first tick and e^{−τ/τp}, e^{−τ/τn} there: the decays at a later tick
    /// follow by table (see [`Front::decay`]).
    k_s: u64,
    base: (f64, f64),
    /// P's coefficients \[V, V/s, …\]: the paths' particular solutions less the offset,
    /// linear but for a floating leg's back-EMF curvature; A and B \[V\] are the filter
    /// transients at τ = 0.
    poly: [f64; 4],
    /// Bounds use P's chord over the step, P(0) + β·τ with β \[V/s\], and how far P strays
    /// from it, within [dev.0, dev.1] \[V\]: as cheap as a linear input, and valid throughout.
    beta: f64,
    dev: (f64, f64),
    a: f64,
    b: f64,
    /// A/τp and B/τn [V/s]: the transients' rates at τ = 0 (their derivative's weights).
    ap: f64,
    bn: f64,
    /// The value of A·e^{−τ/τp} − B·e^{−τ/τn} at its stationary point, once computed: it
    /// depends only on the step, not on the interval being bounded.
    stationary: std::cell::Cell<Option<f64>>,
}

impl Channel {
    /// The channel over a step from `t0` (its first tick and the decays there are set when
    /// a scan needs them): the phase path's response `fx` to its chord, plus `bend` to its
    /// back-EMF's curvature (a floating leg), less the neutral path's `fn_`.
    /// `taus` holds τp and τn, the filters' time constants \[s\], `inv_tau` their
    /// inverses; the step is `h`.
    fn new(
        x: Phase,
        t0: f64,
        (fx, bend, fn_): (&Foh, Option<&Bend>, &Foh),
        (taus, inv_tau): ((f64, f64), (f64, f64)),
        offset: f64,
        h: f64,
    ) -> Self {
        let p0 = fx.a - fn_.a - fx.b * taus.0 + fn_.b * taus.1 - offset;
        let p1 = fx.b - fn_.b;
        let (poly, a, beta, dev) = match bend {
            // Most steps: P is linear, its own chord. The values are those the general case
            // gives with a zero bend, to the bit (adding +0.0 turns −0.0 into +0.0 alike),
            // without the deviation's arithmetic on zeros (≈ 20 instructions a channel).
            None => {
                let p1 = p1 + 0.0;
                ([p0 + 0.0, p1, 0.0, 0.0], fx.c + 0.0, p1, (-0.0, 0.0))
            }
            Some(bend) => {
                let q = bend.p;
                let poly = [p0 + q[0], p1 + q[1], q[2], q[3]];
                // P − chord = τ·(τ − h)·(p2 + p3·(τ + h)): the first factor lies in
                // [−h²/4, 0], the second is linear in τ, so its values at τ = 0 and h
                // bound it (and fix the sign of the deviation where they agree).
                let (fa, fb) = (poly[2] + poly[3] * h, poly[2] + 2.0 * poly[3] * h);
                let m = 0.25 * h * h * fa.abs().max(fb.abs());
                let dev = if fa > 0.0 && fb > 0.0 {
                    (-m, 0.0)
                } else if fa < 0.0 && fb < 0.0 {
                    (0.0, m)
                } else {
                    (-m, m)
                };
                let beta = poly[1] + h * (poly[2] + h * poly[3]);
                (poly, fx.c + bend.transient, beta, dev)
            }
        };
        Channel {
            k_s: 0,
            base: (1.0, 1.0),
            ap: a * inv_tau.0,
            bn: fn_.c * inv_tau.1,
            x,
            t0,
            poly,
            beta,
            dev,
            a,
            b: fn_.c,
            stationary: std::cell::Cell::new(None),
        }
    }
}

/// One channel's scan of one step, resumable: the next tick to decide. A channel nobody
/// watches is scanned only as far as someone reads it.
#[derive(Clone, Debug)]
struct Cursor {
    c: Channel,
    k: u64,
    k_end: u64,
}

/// The switching node's ringing, Im(z·e^{(−1/τr + jω)(t − t_k)}) from the excitation
/// on, referred to the tick k at instant t_k.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
struct Ring {
    /// The phasor (re, im) \[V\].
    z: (f64, f64),
    /// t_k \[s\].
    t: f64,
    k: u64,
    /// |z| \[V\]: the envelope at t_k.
    mag: f64,
}

impl Ring {
    /// |z| by a square root (one instruction; `hypot`, a libm call, guards against
    /// overflow far beyond volts), raised by 4 ulps so that it still bounds |z| whatever
    /// the rounding of its three operations.
    #[inline(always)]
    fn magnitude(z: (f64, f64)) -> f64 {
        (z.0 * z.0 + z.1 * z.1).sqrt() * (1.0 + 4.0 * f64::EPSILON)
    }
}

/// The three comparators, their filters, the coupled ringing and the noise.
#[derive(Clone, Debug)]
pub struct ComparatorBank {
    front: Front,
    /// Scans of the present step not yet walked, for channels nobody watches.
    pending: [Option<Cursor>; 3],
    /// The latest steps, newest last: the last update, and those a channel nobody reads
    /// has not been decided over.
    records: Records,
    /// For each channel nobody reads, the first recorded step it is undecided over.
    dormant: [Option<u64>; 3],
    /// From which instant each channel is read or watched (see
    /// [`ComparatorBank::declare`]).
    read_from: Abc<Ticks>,
}

/// The scans' work counters (for profiling).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct ScanWork {
    /// Scans started.
    pub scans: u64,
    /// Ticks evaluated one by one.
    pub ticks_scanned: u64,
    /// Noise segments bounded one by one.
    pub segments: u64,
    /// Blocks of several noise segments bounded at once.
    pub blocks: u64,
}

/// The front end and the outputs: everything but the scans left pending, which are kept
/// apart so that a scan can run on its cursor in place.
#[derive(Clone, Debug)]
struct Front {
    tau_p: f64,
    tau_n: f64,
    /// 1/τp, 1/τn [1/s].
    inv_tau: (f64, f64),
    offset: Abc<f64>,
    half_h: f64,
    delay: u64,
    noise_a: f64,
    noise_n: u64,
    seed: u64,
    ring_gain: f64,
    ring_w: f64,
    ring_decay: f64,
    /// Per-tick decay factors e^{−T/τp}, e^{−T/τn} and ring rotation e^{(−1/τr + jω)T}.
    q_p: f64,
    q_n: f64,
    q_ring: (f64, f64),
    /// Last step length and its decay factors e^{−h/τp}, e^{−h/τn}.
    decay_cache: (f64, f64, f64),
    /// Powers of the per-tick filter decays and ringing rotation.
    pow_p: TickPowers,
    pow_n: TickPowers,
    /// Both of them side by side, for the decays at a tick (see [`Front::decay`]).
    pow_pn: RealPairPowers,
    pow_ring: TickPowers,
    /// Powers of the per-tick decay of the ringing's envelope.
    pow_env: TickPowers,
    /// e^{−t/τp}, e^{−t/τn} and e^{−t/τr} at any t ≥ 0 (off the tick grid) without libm.
    exp_pn: ExpTable<2>,
    exp_env: ExpTable<1>,
    y: Abc<f64>,
    y_n: f64,
    out: Abc<bool>,
    hist: [History; 3],
    ring: Ring,
    toggles: u64,
    work: ScanWork,
}

impl ComparatorBank {
    /// Comparators settled on the given terminal and neutral voltages.
    pub fn new(p: &ComparatorParams, seed: u64, v_term: &Abc<f64>, v_n: f64) -> Self {
        let offset = p.offset_v;
        let out = Abc::from_fn(|x| v_term.get(x) - v_n - offset.get(x) > 0.0);
        let pow_p = TickPowers::new(-1.0 / p.phase_filter_tau_s, 0.0);
        let pow_n = TickPowers::new(-1.0 / p.neutral_filter_tau_s, 0.0);
        let front = Front {
            tau_p: p.phase_filter_tau_s,
            tau_n: p.neutral_filter_tau_s,
            inv_tau: (1.0 / p.phase_filter_tau_s, 1.0 / p.neutral_filter_tau_s),
            offset,
            half_h: p.hysteresis_v / 2.0,
            delay: p.delay().0,
            noise_a: p.noise_v,
            noise_n: p.noise_interval().0,
            seed,
            ring_gain: p.ring_gain,
            ring_w: std::f64::consts::TAU * p.ring_frequency_hz,
            ring_decay: p.ring_decay_s,
            q_p: (-TICK_S / p.phase_filter_tau_s).exp(),
            q_n: (-TICK_S / p.neutral_filter_tau_s).exp(),
            q_ring: {
                let d = (-TICK_S / p.ring_decay_s).exp();
                let (sn, cs) = (std::f64::consts::TAU * p.ring_frequency_hz * TICK_S).sin_cos();
                (d * cs, d * sn)
            },
            decay_cache: (f64::NAN, 0.0, 0.0),
            pow_p,
            pow_n,
            pow_pn: RealPairPowers::new(&pow_p, &pow_n),
            pow_ring: TickPowers::new(
                -1.0 / p.ring_decay_s,
                std::f64::consts::TAU * p.ring_frequency_hz,
            ),
            pow_env: TickPowers::new(-1.0 / p.ring_decay_s, 0.0),
            exp_pn: ExpTable::new([-1.0 / p.phase_filter_tau_s, -1.0 / p.neutral_filter_tau_s]),
            exp_env: ExpTable::new([-1.0 / p.ring_decay_s]),
            y: *v_term,
            y_n: v_n,
            out,
            hist: [
                History::new(out.u),
                History::new(out.v),
                History::new(out.w),
            ],
            ring: Ring::default(),
            toggles: 0,
            work: ScanWork::default(),
        };
        ComparatorBank {
            records: Records::new(&front.y, front.y_n),
            front,
            pending: [None, None, None],
            dormant: [None; 3],
            read_from: Abc::splat(Ticks::ZERO),
        }
    }

    /// Adds ringing excited by a switching-node step of `dv` volts at time `t`.
    pub fn excite(&mut self, t: f64, dv: f64) {
        if self.front.ring_gain == 0.0 || dv == 0.0 {
            return;
        }
        // Every tick up to this edge is decided with the ringing as it was: a scan left
        // pending would otherwise see this excitation extrapolated backwards, growing as
        // e^{+t/τr} before the edge that causes it.
        self.finish_pending(u64::MAX);
        let f = &mut self.front;
        // Referred to the tick at or after t (the engine's instants are ticks already).
        let k = Ticks::at_or_after(t).0.0;
        let lead = Ticks(k).seconds() - t;
        let (re, im) = f.ring_at(k);
        let (dr, di) = if lead > 0.0 {
            let d = (-lead / f.ring_decay).exp();
            let (sn, cs) = (f.ring_w * lead).sin_cos();
            (d * cs, d * sn)
        } else {
            (1.0, 0.0)
        };
        let g = f.ring_gain * dv;
        f.ring.z = (re + g * dr, im + g * di);
        f.ring.mag = Ring::magnitude(f.ring.z);
        f.ring.k = k;
        f.ring.t = Ticks(k).seconds();
    }

    /// Advances the filters over [t0, t1] with terminal and neutral voltages interpolated
    /// between `k0` and `k1` (see [`Knot`]), recording every output toggle on the tick grid:
    /// now for the `watched` channels, as far as they are read for the others (see
    /// [`ComparatorBank::catch_up`]), and not at all for a channel nobody reads over this
    /// step (see [`ComparatorBank::declare`]): its steps are kept, to be decided if it is
    /// read again.
    pub fn update(&mut self, t0: f64, t1: f64, k0: &Knot, k1: &Knot, watched: Abc<bool>) {
        if t1 - t0 <= 0.0 {
            return;
        }
        let k_end = Ticks::at_or_before(t1).0;
        // A channel is decided over the step if a read can reach into it (reads see the
        // output a delay back).
        let live = Abc::from_fn(|x| watched.get(x) || self.read_within(x, k_end));
        for x in Phase::ALL {
            if live.get(x) {
                self.wake(x, u64::MAX);
            }
        }
        // The last update's scans (a woken channel's too) are ended before the next.
        self.finish_pending(u64::MAX);
        let seq = self.push_record(t0, t1, k0, k1);
        let rec = self.records.get(seq);
        let f = &mut self.front;
        for x in Phase::ALL {
            let j = x.index();
            let slot = &mut self.pending[j];
            if !live.get(x) {
                self.dormant[j].get_or_insert(seq);
            } else if f.open(rec, x, slot) && watched.get(x) {
                if let Some(cur) = slot {
                    f.scan_to(cur, rec.k_end);
                }
                *slot = None;
            }
        }
        (f.y, f.y_n) = rec.filters_at(rec.h, rec.eh, (f.tau_p, f.tau_n));
    }

    /// Declares from which instant each channel is read (`read_from`, see
    /// [`drive_core::Command::reads`]) besides the `watched` ones, at tick `now`: reads
    /// come at `now` or later, and the last update is cut short, if at all, there or
    /// later. A channel read from within the last update on, or watched, that was left
    /// undecided is decided again: its earlier steps now, the last update as far as it is
    /// read (see [`ComparatorBank::catch_up`]).
    pub fn declare(&mut self, now: Ticks, watched: Abc<bool>, read_from: Abc<Ticks>) {
        self.read_from = Abc::from_fn(|x| {
            if watched.get(x) {
                Ticks::ZERO
            } else {
                read_from.get(x)
            }
        });
        let k_end = self.records.newest().k_end;
        for x in Phase::ALL {
            if self.dormant[x.index()].is_some() && self.read_within(x, k_end) {
                self.wake(x, now.0);
            }
        }
    }

    /// Whether a read of channel `x` can reach tick `k` or earlier (a read sees the
    /// output a delay back).
    fn read_within(&self, x: Phase, k: u64) -> bool {
        self.read_from.get(x).0.saturating_sub(self.front.delay) <= k
    }

    /// The channels decided for a read at instant `at`: watched, or read from `at` or
    /// earlier (see [`ComparatorBank::declare`]).
    pub fn decided_at(&self, at: Ticks) -> Abc<bool> {
        Abc::from_fn(|x| self.read_from.get(x) <= at)
    }

    /// Records the step [t0, t1] (the filters' responses over it, from their present
    /// state) as the newest, making room first; returns its sequence number.
    fn push_record(&mut self, t0: f64, t1: f64, k0: &Knot, k1: &Knot) -> u64 {
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
    fn wake(&mut self, x: Phase, now: u64) {
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

    /// Cuts the last update short at `t` (a tick instant inside it): toggles after `t` are
    /// forgotten and the filters take their values at `t`.
    pub fn truncate_at(&mut self, t: Ticks) {
        self.finish_pending(t.0);
        let rec = self.records.newest_mut();
        rec.k_end = rec.k_end.min(t.0);
        let rec = self.records.newest();
        let f = &mut self.front;
        let tau = t.seconds() - rec.t0;
        let [dp, dn] = f.exp_pn.at(tau);
        (f.y, f.y_n) = rec.filters_at(tau, (dp, dn), (f.tau_p, f.tau_n));
        for x in Phase::ALL {
            let h = &mut f.hist[x.index()];
            f.toggles -= h.truncate_after(t.0);
            *f.out.get_mut(x) = h.newest().map_or(h.base, |t| t.1);
        }
    }

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
    fn finish_pending(&mut self, k_stop: u64) {
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

    /// Forgets toggles no query can reach any more: queries come at `now` or later, so
    /// nothing before `now` − delay is read, except a change not yet reported to the
    /// controller (visible at `unreported`), which must still be found.
    pub fn forget_history(&mut self, now: Ticks, unreported: Option<Ticks>) {
        self.front.forget_history(now, unreported)
    }

    /// Outputs as seen after the propagation delay at instant `at`.
    pub fn outputs_at(&self, at: Ticks) -> Abc<bool> {
        self.front.outputs_at(at)
    }

    /// Earliest instant after `after` at which a watched output changes (delay included).
    #[inline]
    pub fn next_visible_change(&self, after: Ticks, watch: Abc<bool>) -> Option<Ticks> {
        self.front.next_visible_change(after, watch)
    }

    /// Toggles found so far (all channels). Toggles of an unwatched channel that no read
    /// needed walked (see [`ComparatorBank::catch_up`]), and of a channel nobody reads,
    /// are not counted.
    pub fn toggle_count(&self) -> u64 {
        self.front.toggles
    }

    /// Filter outputs (phase paths, neutral path) \[V\], for traces.
    pub fn filtered(&self) -> (Abc<f64>, f64) {
        (self.front.y, self.front.y_n)
    }

    /// The scans' work so far.
    pub fn work(&self) -> ScanWork {
        self.front.work
    }
}

impl Front {
    /// The ringing phasor at tick `k`, not before the last excitation (see
    /// [`ComparatorBank::excite`]): by table.
    fn ring_at(&self, k: u64) -> (f64, f64) {
        if self.ring.z == (0.0, 0.0) {
            return (0.0, 0.0);
        }
        debug_assert!(
            k >= self.ring.k,
            "ringing asked at tick {k}, before its excitation"
        );
        let (wr, wi) = self.pow_ring.at(k.saturating_sub(self.ring.k));
        let z = (
            self.ring.z.0 * wr - self.ring.z.1 * wi,
            self.ring.z.0 * wi + self.ring.z.1 * wr,
        );
        if z.0.abs() + z.1.abs() < 1e-9 {
            return (0.0, 0.0);
        }
        z
    }

    /// e^{−τ/τp}, e^{−τ/τn} at tick `k` (not before the step's first) of `c`'s step.
    #[inline(always)]
    fn decay(&self, c: &Channel, k: u64) -> (f64, f64) {
        debug_assert!(k >= c.k_s, "tick {k} before the step's first, {}", c.k_s);
        let (p, q) = self.pow_pn.at(k - c.k_s);
        (c.base.0 * p, c.base.1 * q)
    }

    /// The ringing's envelope at instant `t` (not before the excitation): by table where
    /// `t` is a tick, as the engine's instants mostly are.
    fn ring_envelope(&self, t: f64) -> f64 {
        match Ticks::at_or_after(t) {
            (k, true) if k.0 >= self.ring.k => self.ring_envelope_at(k.0),
            _ if self.ring.mag == 0.0 => 0.0,
            _ => self.ring.mag * self.exp_env.at(t - self.ring.t)[0],
        }
    }

    /// The ringing's envelope at tick `k` (not before the excitation), by table.
    #[inline(always)]
    fn ring_envelope_at(&self, k: u64) -> f64 {
        self.envelope_of(&self.ring, k)
    }

    /// The envelope of `ring` at tick `k` (not before its excitation), by table.
    #[inline(always)]
    fn envelope_of(&self, ring: &Ring, k: u64) -> f64 {
        if ring.mag == 0.0 {
            return 0.0;
        }
        ring.mag * self.pow_env.real(k.saturating_sub(ring.k))
    }

    /// e^{−h/τp}, e^{−h/τn} over a step of `h` \[s\]: by table for a length of whole
    /// ticks (most are), else by the exponential's table.
    #[inline(always)]
    fn decays_of(&self, h: f64) -> (f64, f64) {
        match Ticks::at_or_after(h) {
            (n, true) => (self.pow_p.real(n.0), self.pow_n.real(n.0)),
            _ => {
                let [dp, dn] = self.exp_pn.at(h);
                (dp, dn)
            }
        }
    }

    /// e^{−τ/τp}, e^{−τ/τn} at a step's first tick `k_start`, τ after its start `t0`.
    #[inline(always)]
    fn first_decays(&self, t0: f64, k_start: u64) -> (f64, f64) {
        let ta = tick_instant(k_start) - t0;
        if (ta - TICK_S).abs() < 1e-6 * TICK_S {
            (self.q_p, self.q_n)
        } else {
            let [dp, dn] = self.exp_pn.at(ta);
            (dp, dn)
        }
    }

    /// Forgets toggles no query can reach any more: queries come at `now` or later, so
    /// nothing before `now` − delay is read, except a change not yet reported to the
    /// controller (visible at `unreported`), which must still be found.
    fn forget_history(&mut self, now: Ticks, unreported: Option<Ticks>) {
        let mut horizon = now.0.saturating_sub(self.delay);
        if let Some(v) = unreported {
            horizon = horizon.min(v.0.saturating_sub(self.delay + 1));
        }
        for hist in &mut self.hist {
            hist.forget_before(horizon);
        }
    }

    /// Walks the ticks of `cur`'s step up to `k_stop` (at most its last) where a toggle is
    /// possible, and leaves `cur` at the next tick.
    ///
    /// Blocks of noise segments are ruled out whole where the bounds allow (with the noise
    /// anywhere in its range), the block doubling after each one ruled out and halving
    /// after each one that is not; a single segment is bounded with its own noise sample
    /// and walked tick by tick if that fails. So the segments where a toggle is possible
    /// are found with a number of bounds logarithmic in the step's length. A block may
    /// reach past `k_stop`: ticks ruled out there need no walk when the scan resumes.
    fn scan_to(&mut self, cur: &mut Cursor, k_stop: u64) {
        let c = &cur.c;
        let x = c.x;
        let ch = x.index();
        let key = noise::channel_key(self.seed, ch as u64);
        self.work.scans += 1;
        let (k_end, stop) = (cur.k_end, k_stop.min(cur.k_end));
        let (a, n) = (self.noise_a, self.noise_n);
        let mut k = cur.k;
        // A scan resumed mid-step tries the rest of the step first: usually ruled out at
        // once. A fresh one was opened because the whole step was not (see
        // `Front::open`), mostly for the filters' transient right after its start: it
        // starts with a block of 4 segments and doubles from there (or with those 4
        // one by one, below).
        let m_end = k_end / n; // the step's last noise segment
        // k's noise sample index, one per segment: divided once, then counted (a block
        // or segment ends at a segment's end, or past `stop`).
        let mut m = k / n;
        let rest = m_end - m + 1;
        // The output changes only in a walk: read once, not at every bound.
        let mut out = self.out.get(x);
        let mut walked = false;
        // The end of the last small block that may toggle: its segments are bounded one
        // by one up to there, unless a walk comes first.
        let mut singles_to = 0;
        let mut span = rest;
        if k == c.k_s {
            span = rest.min(4);
            // Where the first tick alone may toggle (a cheap bound: 45 % of the first
            // blocks that fail, measured), so would the first block: its segments are
            // bounded one by one at once.
            if self.may_toggle_at_start(c, out) {
                span = 1;
                singles_to = ((m + 4) * n - 1).min(k_end);
            }
        }
        while k <= stop {
            debug_assert_eq!(m, k / n);
            if span > 1 {
                self.work.blocks += 1;
                // The block as far as the step goes: halving a span beyond the step's end
                // would bound the same block again.
                let span_in = span.min(m_end - m + 1);
                let e = ((m + span_in) * n - 1).min(k_end);
                if self.may_toggle_over(c, out, k, e, -a, a) {
                    // A small block that may toggle is usually busy at its start (a filter
                    // transient or ringing dying away): its first segment is tried with its
                    // own noise at once, rather than halves of the block first.
                    span = if span_in <= 8 { 1 } else { span_in / 2 };
                    singles_to = e;
                } else {
                    k = e + 1;
                    m += span_in;
                    span = 2 * span_in;
                }
                continue;
            }
            let seg_end = ((m + 1) * n - 1).min(stop);
            let noise = noise::uniform_keyed(key, m, a);
            self.work.segments += 1;
            if self.may_toggle_over(c, out, k, seg_end, noise, noise) {
                out = self.walk(c, k, seg_end, noise);
                span = 1; // the next segment is likely busy too
                walked = true;
                singles_to = 0;
            } else {
                // Quiet here: the rest of the step likely is too. Restarting at 8 segments
                // rather than 2 costs fewer bounds (measured); the ticks walked are the same.
                // But inside a small block that may toggle, a block from here fails again
                // (98 times in 100 at the default drive: the signal nears a threshold over
                // it), so its other segments are bounded alone first.
                span = if seg_end < singles_to { 1 } else { 8 };
                // Quiet right after a walk: what was walked (mostly a PWM edge's ringing
                // and filter spike) has died away, and the rest of the step is usually
                // ruled out at once (3 times in 4 at the default drive), where doubling from
                // 8 segments takes 3–5 bounds. Where it is not, the doubling goes on.
                if walked && seg_end < k_end {
                    walked = false;
                    self.work.blocks += 1;
                    if !self.may_toggle_over(c, out, seg_end + 1, k_end, -a, a) {
                        k = k_end + 1;
                        break;
                    }
                }
            }
            k = seg_end + 1;
            m += 1;
        }
        cur.k = k;
    }

    /// Decides ticks `k..=last` of `c`'s step one by one, with per-tick factors instead of
    /// an exp and a sincos at every tick, recording each toggle; returns the output after.
    fn walk(&mut self, c: &Channel, k: u64, last: u64, noise: f64) -> bool {
        let x = c.x;
        self.work.ticks_scanned += last - k + 1;
        let (dp, dn) = self.decay(c, k);
        let e = (c.a * dp, c.b * dn);
        let zk = self.ring_at(k);
        let poly = [c.poly[0] + noise, c.poly[1], c.poly[2], c.poly[3]];
        let tau = tick_instant(k) - c.t0;
        let from = (k, tau, e, zk);
        // Without ringing the phasor stays 0 and adds nothing to the signal (but the sign
        // of a zero, which no threshold test sees): a loop without it. Likewise P is
        // linear but for a floating leg's bend on a long step, and its cubic terms then
        // add only zeros.
        let linear = poly[2] == 0.0 && poly[3] == 0.0;
        let out = match (zk == (0.0, 0.0), linear) {
            (true, true) => self.walk_ticks::<false, true>(x, from, last, &poly),
            (true, false) => self.walk_ticks::<false, false>(x, from, last, &poly),
            (false, true) => self.walk_ticks::<true, true>(x, from, last, &poly),
            (false, false) => self.walk_ticks::<true, false>(x, from, last, &poly),
        };
        *self.out.get_mut(x) = out;
        out
    }

    /// [`Front::walk`]'s loop over channel `x`'s ticks `k..=last` from τ, the transients
    /// (A·e^{−τ/τp}, B·e^{−τ/τn}) and the ringing phasor there (`from`), with P's
    /// coefficients `poly` (noise included), `RING` if the phasor is not 0, `LINEAR` if
    /// P's τ² and τ³ coefficients are zero; returns the output after the last tick.
    #[inline(always)]
    fn walk_ticks<const RING: bool, const LINEAR: bool>(
        &mut self,
        x: Phase,
        (k, tau, (ep, en), zk): (u64, f64, (f64, f64), (f64, f64)),
        last: u64,
        poly: &[f64; 4],
    ) -> bool {
        let (half_h, qp, qn, qr) = (self.half_h, self.q_p, self.q_n, self.q_ring);
        let (ch, mut out) = (x.index(), self.out.get(x));
        // c0 + τ·c1 is what Horner's scheme gives with zero c2 and c3, bit for bit (τ > 0:
        // the zeros it adds are exact; at most a zero's sign differs, which no threshold
        // test sees).
        let p = |tau: f64| {
            if LINEAR {
                poly[0] + tau * poly[1]
            } else {
                horner(poly, tau)
            }
        };
        // The output toggles where sign·s passes h/2: above +h/2 when low, below −h/2
        // when high (a negation is exact, so the test is the same).
        let mut sign = if out { -1.0 } else { 1.0 };
        // Two ticks at a time, as two lanes each stepped by two ticks' factors (the
        // compiler pairs the lanes' operations): the signal at a tick then differs from a
        // tick-by-tick recurrence's by a few ulps, far below anything a threshold test
        // resolves. Toggles are rare: the pair's lanes are tested together, then in turn.
        let (qp2, qn2) = (qp * qp, qn * qn);
        let qr2 = (qr.0 * qr.0 - qr.1 * qr.1, 2.0 * qr.0 * qr.1);
        let mut t2 = [tau, tau + TICK_S];
        let mut ep2 = [ep, ep * qp];
        let mut en2 = [en, en * qn];
        let (mut zr, mut zi) = if RING {
            (
                [zk.0, zk.0 * qr.0 - zk.1 * qr.1],
                [zk.1, zk.0 * qr.1 + zk.1 * qr.0],
            )
        } else {
            ([0.0; 2], [0.0; 2])
        };
        let mut kk = k;
        while kk < last {
            let mut s2 = [p(t2[0]) + ep2[0] - en2[0], p(t2[1]) + ep2[1] - en2[1]];
            if RING {
                s2 = [s2[0] + zi[0], s2[1] + zi[1]];
            }
            if (sign * s2[0] > half_h) | (sign * s2[1] > half_h) {
                for (j, s) in s2.into_iter().enumerate() {
                    if sign * s > half_h {
                        out = !out;
                        sign = -sign;
                        self.hist[ch].push(kk + j as u64, out);
                        self.toggles += 1;
                    }
                }
            }
            ep2 = [ep2[0] * qp2, ep2[1] * qp2];
            en2 = [en2[0] * qn2, en2[1] * qn2];
            if RING {
                (zr, zi) = (
                    [zr[0] * qr2.0 - zi[0] * qr2.1, zr[1] * qr2.0 - zi[1] * qr2.1],
                    [zr[0] * qr2.1 + zi[0] * qr2.0, zr[1] * qr2.1 + zi[1] * qr2.0],
                );
            }
            t2 = [t2[0] + 2.0 * TICK_S, t2[1] + 2.0 * TICK_S];
            kk += 2;
        }
        // An odd tick left: the first lane's.
        if kk == last {
            let mut s = p(t2[0]) + ep2[0] - en2[0];
            if RING {
                s += zi[0];
            }
            if sign * s > half_h {
                out = !out;
                self.hist[ch].push(kk, out);
                self.toggles += 1;
            }
        }
        out
    }

    /// Whether `c`'s output, now `out`, may toggle at a tick in `a..=b` of its step, with
    /// noise in [n_lo, n_hi]: the filter decays at both ends, the ringing's envelope at `a`.
    /// Inlined, as the bounds it calls: a scan's loop runs it 8 times on average, and out
    /// of line its arguments and results go through memory.
    #[inline(always)]
    fn may_toggle_over(
        &self,
        c: &Channel,
        out: bool,
        a: u64,
        b: u64,
        n_lo: f64,
        n_hi: f64,
    ) -> bool {
        let (ta, tb, w, env) = self.over(c, a, b);
        self.may_toggle(c, out, ta, tb, w, env, n_lo, n_hi)
    }

    /// Whether `c`'s output, now `out`, may toggle at its step's first tick, with the noise
    /// anywhere in its range (the filter transients and the ringing from their values
    /// there alone: the cheapest bound).
    #[inline(always)]
    fn may_toggle_at_start(&self, c: &Channel, out: bool) -> bool {
        let ta = tick_instant(c.k_s) - c.t0;
        let w = [c.base.0, c.base.1, c.base.0, c.base.1];
        let env = self.ring_envelope_at(c.k_s);
        let (lo, hi) = Self::range_ends(c, ta, ta, w, env);
        self.can_toggle(out, lo, hi, -self.noise_a, self.noise_a)
    }

    /// Ticks `a..=b` of `c`'s step as the bounds take them: τ at both ends, the filter
    /// decays there, and the ringing's envelope at `a` (it only decays after).
    #[inline(always)]
    fn over(&self, c: &Channel, a: u64, b: u64) -> (f64, f64, [f64; 4], f64) {
        let (ta, tb) = (tick_instant(a) - c.t0, tick_instant(b) - c.t0);
        let (pa, na) = self.decay(c, a);
        let (pb, nb) = if a == b { (pa, na) } else { self.decay(c, b) };
        (ta, tb, [pa, na, pb, nb], self.ring_envelope_at(a))
    }

    /// The output over ticks `a..=b` of `c`'s step if the comparator input is beyond a
    /// threshold there whatever the noise and ringing: then it does not depend on the
    /// ticks before.
    fn certain_over(&self, c: &Channel, a: u64, b: u64) -> Option<bool> {
        let (ta, tb, w, env) = self.over(c, a, b);
        let (lo, hi) = self.range(c, ta, tb, w, env);
        if lo - self.noise_a > self.half_h {
            Some(true)
        } else if hi + self.noise_a < -self.half_h {
            Some(false)
        } else {
            None
        }
    }

    /// Sets channel `cur`'s output to `level` from tick `k` on (a toggle there if it
    /// differs) and moves the cursor past `k`.
    fn settle_at(&mut self, cur: &mut Cursor, k: u64, level: bool) {
        self.set_output(cur.c.x, k, level);
        cur.k = k + 1;
    }

    /// Sets channel `x`'s output to `level` from tick `k` on (a toggle there if it
    /// differs).
    fn set_output(&mut self, x: Phase, k: u64, level: bool) {
        if self.out.get(x) != level {
            *self.out.get_mut(x) = level;
            self.hist[x.index()].push(k, level);
            self.toggles += 1;
        }
    }

    /// Writes into `rec` the step [t0, t1] with terminal and neutral voltages interpolated
    /// between `k0` and `k1`, from the filters' present state (see [`Record`]). A ringing
    /// decayed below a nanovolt is dropped first, so that bounds skip the envelope.
    fn record(&mut self, t0: f64, t1: f64, k0: &Knot, k1: &Knot, rec: &mut Record) {
        let h = t1 - t0;
        let k_start = Ticks::at_or_before(t0).0 + 1;
        // The envelope at the first tick, at most a tick after t0, is below the one at t0
        // (it decays by 2e-5 a tick or more, τr ≤ 1 ms, far beyond rounding): where it is a
        // nanovolt or more, so is the one at t0, which is then not computed.
        let mut env_first = self.ring_envelope_at(k_start);
        if self.ring.mag != 0.0 && env_first < 1e-9 && self.ring_envelope(t0) < 1e-9 {
            self.ring.z = (0.0, 0.0);
            self.ring.mag = 0.0;
            env_first = 0.0;
        }
        // One division per step: the four filter inputs' slopes share 1/h.
        let inv_h = 1.0 / h;
        let dvn = (k1.vn - k0.vn) * inv_h;
        let fn_ = Foh::ramp(self.y_n, k0.vn, dvn, self.tau_n);
        // Steps repeat their lengths (PWM half-periods, the solver's longest step): cache;
        // a length of whole ticks (most are) by table.
        if self.decay_cache.0 != h {
            let (dp, dn) = self.decays_of(h);
            self.decay_cache = (h, dp, dn);
        }
        let first = self.first_decays(t0, k_start);
        let (v0, v1) = (k0.v.to_array(), k1.v.to_array());
        let (r0, r1) = (k0.emf_rate.to_array(), k1.emf_rate.to_array());
        let y = self.y.to_array();
        let chord: [f64; 3] = std::array::from_fn(|j| (v1[j] - v0[j]) * inv_h);
        // Field by field: a whole `Record` assigned is built apart and copied in.
        rec.t0 = t0;
        rec.h = h;
        rec.k_start = k_start;
        rec.k_end = Ticks::at_or_before(t1).0;
        for j in 0..3 {
            rec.fx[j] = Foh::ramp(y[j], v0[j], chord[j], self.tau_p);
        }
        // A floating leg's input is the neutral's chord plus its back-EMF's Hermite
        // cubic: its chord plus a cubic vanishing at both ends, filtered from rest.
        rec.bend = std::array::from_fn(|j| match (r0[j], r1[j]) {
            (Some(d0), Some(d1)) => {
                let (a, b) = (dvn + d0 - chord[j], dvn + d1 - chord[j]);
                let q = hermite(inv_h, (0.0, a), (0.0, b));
                Some(Bend::new(&CubicRc::new(0.0, 0.0, q, self.tau_p)))
            }
            _ => None,
        });
        rec.fn_ = fn_;
        rec.eh = (self.decay_cache.1, self.decay_cache.2);
        rec.first = first;
        rec.env_first = env_first;
        rec.ring = self.ring;
        // Every field above, or the slot keeps an older step's value: this pattern names
        // them all, so a field added to `Record` fails to compile until written here.
        let Record {
            t0: _,
            h: _,
            k_start: _,
            k_end: _,
            fx: _,
            bend: _,
            fn_: _,
            eh: _,
            first: _,
            ring: _,
            env_first: _,
        } = rec;
    }

    /// Channel `x` over recorded step `rec`, its first tick and the decays there set.
    fn channel(&self, rec: &Record, x: Phase) -> Channel {
        let j = x.index();
        let paths = (&rec.fx[j], rec.bend[j].as_ref(), &rec.fn_);
        let off = self.offset.get(x);
        let taus = ((self.tau_p, self.tau_n), self.inv_tau);
        let mut c = Channel::new(x, rec.t0, paths, taus, off, rec.h);
        c.k_s = rec.k_start;
        c.base = rec.first;
        c
    }

    /// Puts in `slot` a scan of channel `x` over recorded step `rec`, unless nothing can
    /// happen in it (then `slot` is left empty); returns whether it did. The scan is built
    /// in its slot and bounded there: a scan is large, and most steps are ruled out whole.
    fn open(&self, rec: &Record, x: Phase, slot: &mut Option<Cursor>) -> bool {
        if rec.k_start > rec.k_end {
            *slot = None;
            return false;
        }
        let cur = slot.insert(Cursor {
            c: self.channel(rec, x),
            k: rec.k_start,
            k_end: rec.k_end,
        });
        // From the first tick on, as the scan's bounds: the step's start instant is the
        // last one's, and a PWM edge's ringing has decayed by a tick there (10 % at 0.2 µs).
        let ta = tick_instant(rec.k_start) - rec.t0;
        let w = [rec.first.0, rec.first.1, rec.eh.0, rec.eh.1];
        let (a, env) = (self.noise_a, rec.env_first);
        let open = self.may_toggle(&cur.c, self.out.get(x), ta, rec.h, w, env, -a, a);
        if !open {
            *slot = None;
        }
        open
    }

    /// Runs `op` with `ring` in place of the present ringing (to walk a recorded step).
    fn with_ring<R>(&mut self, ring: Ring, op: impl FnOnce(&mut Front) -> R) -> R {
        let now = std::mem::replace(&mut self.ring, ring);
        let r = op(self);
        self.ring = now;
        r
    }

    /// Whether the output, now `out`, may toggle somewhere in τ ∈ [ta, tb], given noise in
    /// [n_lo, n_hi].
    /// `w` holds the decay factors (e^{−ta/τp}, e^{−ta/τn}, e^{−tb/τp}, e^{−tb/τn}); `env`
    /// bounds the ringing from ta on.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn may_toggle(
        &self,
        c: &Channel,
        out: bool,
        ta: f64,
        tb: f64,
        w: [f64; 4],
        env: f64,
        n_lo: f64,
        n_hi: f64,
    ) -> bool {
        // The ends first: the stationary point can only widen the range.
        let (lo, hi) = Self::range_ends(c, ta, tb, w, env);
        if self.can_toggle(out, lo, hi, n_lo, n_hi) {
            return true;
        }
        match self.stationary_within(c, w) {
            Some(g) => self.can_toggle(out, lo.min(lo + g), hi.max(hi + g), n_lo, n_hi),
            None => false,
        }
    }

    /// Whether a noise-free signal range [lo, hi] plus noise in [n_lo, n_hi] can cross the
    /// threshold the output, now `out`, is waiting for.
    #[inline(always)]
    fn can_toggle(&self, out: bool, lo: f64, hi: f64, n_lo: f64, n_hi: f64) -> bool {
        if out {
            lo + n_lo < -self.half_h
        } else {
            hi + n_hi > self.half_h
        }
    }

    /// Range of the noise-free signal (offset and ringing envelope included) over
    /// τ ∈ [ta, tb]; `w` and `env` as in [`Front::may_toggle`].
    fn range(&self, c: &Channel, ta: f64, tb: f64, w: [f64; 4], env: f64) -> (f64, f64) {
        let (lo, hi) = Self::range_ends(c, ta, tb, w, env);
        match self.stationary_within(c, w) {
            Some(g) => (lo.min(lo + g), hi.max(hi + g)),
            None => (lo, hi),
        }
    }

    /// [`Front::range`] from the interval's ends only: exact for P's chord, widened
    /// by P's deviation from it, and for the transients unless their stationary point lies
    /// inside.
    #[inline(always)]
    fn range_ends(c: &Channel, ta: f64, tb: f64, w: [f64; 4], env: f64) -> (f64, f64) {
        let (l1, l2) = (c.poly[0] + c.beta * ta, c.poly[0] + c.beta * tb);
        let (ga, gb) = (c.a * w[0] - c.b * w[1], c.a * w[2] - c.b * w[3]);
        let (l_lo, l_hi) = min_max(l1, l2);
        let (g_lo, g_hi) = min_max(ga, gb);
        (l_lo + c.dev.0 + g_lo - env, l_hi + c.dev.1 + g_hi + env)
    }

    /// How far g(τ) = A·e^{−τ/τp} − B·e^{−τ/τn} reaches beyond its values at the ends of
    /// the interval whose decay factors are `w` (signed), if its one stationary point is
    /// inside: that is where g′ changes sign, so no logarithm is needed to rule it out.
    #[inline(always)]
    fn stationary_within(&self, c: &Channel, w: [f64; 4]) -> Option<f64> {
        let (ap, bn) = (c.ap, c.bn);
        let (da, db) = (bn * w[1] - ap * w[0], bn * w[3] - ap * w[2]);
        if da * db >= 0.0 {
            return None;
        }
        let gts = c
            .stationary
            .get()
            .unwrap_or_else(|| self.stationary_value(c));
        let (ga, gb) = (c.a * w[0] - c.b * w[1], c.a * w[2] - c.b * w[3]);
        Some(if gts > ga.max(gb) {
            gts - ga.max(gb)
        } else if gts < ga.min(gb) {
            gts - ga.min(gb)
        } else {
            0.0
        })
    }

    /// g at its stationary point (see [`Front::stationary_within`]), computed once per
    /// channel and step: out of line, so that the bounds inlined in the scans stay short.
    #[cold]
    #[inline(never)]
    fn stationary_value(&self, c: &Channel) -> f64 {
        // g′(ts) = 0: e^{(1/τp − 1/τn)·ts} = (A·τn)/(B·τp), and there
        // B·e^{−ts/τn} = (τn/τp)·A·e^{−ts/τp}: one exp for both terms.
        let (inv_p, inv_n) = self.inv_tau;
        let ts = (c.ap / c.bn).ln() / (inv_p - inv_n);
        let g = c.a * (-ts * inv_p).exp() * (1.0 - self.tau_n * inv_p);
        c.stationary.set(Some(g));
        g
    }

    /// Outputs as seen after the propagation delay at instant `at`.
    fn outputs_at(&self, at: Ticks) -> Abc<bool> {
        let t = at.0.saturating_sub(self.delay);
        Abc::from_fn(|x| self.hist[x.index()].state_at(t))
    }

    /// Earliest instant after `after` at which a watched output changes (delay included).
    /// Inlined as a check of each watched channel's newest toggle: the engine asks at
    /// every stop, and there usually is none.
    #[inline(always)]
    fn next_visible_change(&self, after: Ticks, watch: Abc<bool>) -> Option<Ticks> {
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

/// The instant of tick `k` \[s\], `k as f64 * TICK_S`: through i64, one conversion
/// where u64's takes a dozen instructions on baseline x86-64, with the same value (every
/// tick index is below 2⁶³). [`Ticks::seconds`] gives the same value but keeps a branch
/// for counts beyond i64, which costs 0.7 M instructions a simulated second in the scans
/// (measured); the scans' hot paths take this one.
#[inline(always)]
fn tick_instant(k: u64) -> f64 {
    debug_assert!(k < 1 << 63);
    (k as i64) as f64 * TICK_S
}

/// (min, max) of two finite values, as plain selects: `f64::min` and `max` also order
/// NaNs, which costs a handful of instructions a call in the bounds.
#[inline(always)]
fn min_max(a: f64, b: f64) -> (f64, f64) {
    if a < b { (a, b) } else { (b, a) }
}

#[cfg(test)]
mod tests;
