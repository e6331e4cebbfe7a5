//! The steps kept for comparator channels nobody reads (see [`super::ComparatorBank`]):
//! each step's filter responses and ringing, enough to walk a channel over it later.

use super::Ring;
use crate::sensing::foh::Foh;
use crate::sensing::rc::{CubicRc, horner};
use drive_core::Abc;

/// Steps kept for channels nobody reads: enough to walk them later, with room for 16
/// (a channel still undecided over the oldest is decided before it goes).
pub(super) const RECORDS: usize = 16;

/// A floating leg's phase-path response to its back-EMF's bend (a [`CubicRc`] from rest at
/// τ = 0 through the phase filter): its particular cubic and transient alone, since the
/// start and time constant are the same for every bend.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub(super) struct Bend {
    /// The particular solution's coefficients \[V, V/s, V/s², V/s³\].
    pub(super) p: [f64; 4],
    /// Its transient's amplitude at τ = 0 \[V\].
    pub(super) transient: f64,
}

impl Bend {
    /// The bend of `rc`, a [`CubicRc`] from τ = 0 through the phase filter.
    pub(super) fn new(rc: &CubicRc) -> Self {
        debug_assert_eq!(rc.from, 0.0);
        Bend {
            p: rc.p,
            transient: rc.transient,
        }
    }

    /// Its value at τ given the transient's decay there (as [`CubicRc::at_decayed`]).
    pub(super) fn at_decayed(&self, t: f64, decay: f64) -> f64 {
        horner(&self.p, t) + self.transient * decay
    }
}

/// One step's inputs to the three channels: the filter responses over it and the ringing.
/// Kept small: every step's record is copied into the ring.
#[derive(Copy, Clone, Debug)]
pub(super) struct Record {
    /// Start \[s\] and length \[s\].
    pub(super) t0: f64,
    pub(super) h: f64,
    /// Its first and last tick (the last moves back if the step is cut short).
    pub(super) k_start: u64,
    pub(super) k_end: u64,
    /// Each phase path's response to its chord and to a floating leg's bend, the neutral
    /// path's response (see [`super::Channel::new`]), through the phase filter (τp) and
    /// the neutral's (τn).
    pub(super) fx: [Foh; 3],
    pub(super) bend: [Option<Bend>; 3],
    pub(super) fn_: Foh,
    /// e^{−h/τp}, e^{−h/τn}, and the decays at the first tick.
    pub(super) eh: (f64, f64),
    pub(super) first: (f64, f64),
    /// The ringing over the step, and its envelope at the first tick \[V\].
    pub(super) ring: Ring,
    pub(super) env_first: f64,
}

impl Record {
    /// The filters' outputs τ \[s\] into the step, phase paths and neutral path \[V\],
    /// given their decays there, e^{−τ/τp} and e^{−τ/τn}, and their time constants
    /// `tau_p`, `tau_n` \[s\].
    pub(super) fn filters_at(
        &self,
        tau: f64,
        (dp, dn): (f64, f64),
        (tau_p, tau_n): (f64, f64),
    ) -> (Abc<f64>, f64) {
        let y = Abc::from_fn(|x| {
            let j = x.index();
            self.fx[j].at_decayed(tau, dp, tau_p)
                + self.bend[j].map_or(0.0, |b| b.at_decayed(tau, dp))
        });
        (y, self.fn_.at_decayed(tau, dn, tau_n))
    }
}

/// A ring of the latest [`RECORDS`] steps by sequence number.
#[derive(Clone, Debug)]
pub(super) struct Records {
    pub(super) buf: [Record; RECORDS],
    /// Sequence number of the oldest.
    pub(super) first: u64,
    pub(super) len: usize,
}

impl Records {
    /// One empty step at t = 0, settled on `y`, `y_n`.
    pub(super) fn new(y: &Abc<f64>, y_n: f64) -> Self {
        let rest = |v: f64| Foh::new(v, v, v, 0.0, 1.0);
        let rec = Record {
            t0: 0.0,
            h: 0.0,
            k_start: 1,
            k_end: 0,
            fx: y.to_array().map(rest),
            bend: [None; 3],
            fn_: rest(y_n),
            eh: (1.0, 1.0),
            first: (1.0, 1.0),
            ring: Ring::default(),
            env_first: 0.0,
        };
        Records {
            buf: [rec; RECORDS],
            first: 0,
            len: 1,
        }
    }

    pub(super) fn is_full(&self) -> bool {
        self.len == RECORDS
    }

    /// Appends a step, dropping the oldest when full; returns its sequence number and its
    /// slot, still holding an old step, for the caller to write in place (a record built
    /// apart and moved in costs a copy of its ≈ 350 bytes at every step).
    pub(super) fn push_slot(&mut self) -> (u64, &mut Record) {
        if self.is_full() {
            self.first += 1;
            self.len -= 1;
        }
        let seq = self.first + self.len as u64;
        self.len += 1;
        (seq, &mut self.buf[(seq % RECORDS as u64) as usize])
    }

    pub(super) fn newest_seq(&self) -> u64 {
        self.first + self.len as u64 - 1
    }

    pub(super) fn get(&self, seq: u64) -> &Record {
        debug_assert!(
            (self.first..=self.newest_seq()).contains(&seq),
            "step {seq} is not recorded"
        );
        &self.buf[(seq % RECORDS as u64) as usize]
    }

    pub(super) fn newest(&self) -> &Record {
        self.get(self.newest_seq())
    }

    pub(super) fn newest_mut(&mut self) -> &mut Record {
        let seq = self.newest_seq();
        &mut self.buf[(seq % RECORDS as u64) as usize]
    }
}
