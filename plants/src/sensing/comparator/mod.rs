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
//!
//! A module a concept: the front end's closed forms over a step (`front`), the bounds that
//! rule ticks out (`bounds`), the scan for toggles (`scan`), the toggle histories
//! (`history`), the channels decided later (`deferred`, with the steps kept in `records`),
//! and the state by value (`state`).

mod bounds;
mod deferred;
mod front;
mod history;
mod records;
mod scan;
mod state;

pub(crate) use state::Limits;

use super::rc::ExpTable;
use super::tick_powers::{RealPairPowers, TickPowers};
use crate::params::ComparatorParams;
use drive_core::{Abc, Phase, TICK_S, Ticks};
use front::{Channel, Front, Ring};
use history::History;
use records::Records;
use scan::Cursor;

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

    /// The channels decided for a read at instant `at`: watched, or read from `at` or
    /// earlier (see [`ComparatorBank::declare`]).
    pub fn decided_at(&self, at: Ticks) -> Abc<bool> {
        Abc::from_fn(|x| self.read_from.get(x) <= at)
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

#[cfg(test)]
mod tests;
