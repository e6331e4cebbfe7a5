//! Random FMI call sequences against the exported functions: out-of-order calls, extreme
//! and non-finite values, unknown value references, damaged serialized states, forged ones
//! (a value from the edges or a wrong code written over any field, the checksum resealed),
//! states taken after short steps at loads from the edges (sub-normal ones too), stale
//! state pointers. Fixed seed, so a failure repeats; `FMU_FUZZ_CASES` runs more sequences
//! (default 10 000, about ten seconds) and `FMU_FUZZ_SEED` another seed.
//!
//! Checked after every call: no panic was caught inside the FMU (each would be a bug the
//! importer only sees as fmi2Error), a step that returned OK left every output finite, a
//! damaged state was refused, a forged one accepted reads back every variable finite and
//! within its declared bounds, a state the FMU serialized restores, and at the end every
//! state was freed with its instance.
// Calls the exported C functions as an importer does; every unsafe block says why it holds.
#![allow(unsafe_code)]

use fmu::exports::states::{
    fmi2DeSerializeFMUstate, fmi2FreeFMUstate, fmi2GetFMUstate, fmi2SerializeFMUstate,
    fmi2SerializedFMUstateSize, fmi2SetFMUstate,
};
use fmu::exports::steps::fmi2DoStep;
use fmu::exports::values::{fmi2GetReal, fmi2SetBoolean, fmi2SetInteger, fmi2SetReal};
use fmu::exports::{
    fmi2EnterInitializationMode, fmi2ExitInitializationMode, fmi2FreeInstance, fmi2Reset,
    fmi2SetupExperiment, fmi2Terminate,
};
use fmu::ffi::{ERROR, OK, WARNING, caught_panics, live_states};
use fmu::variables::{Kind, Role, table};
use std::ffi::c_void;
use std::ptr;

mod instance;
use instance::{HEADER, instantiate, read_back, reseal};

/// xorshift64*: small, and the same sequence on every platform.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// A value from the edges: non-finite, huge, tiny, negative, or ordinary.
    fn value(&mut self, min: Option<f64>, max: Option<f64>) -> f64 {
        match self.below(12) {
            0 => f64::NAN,
            1 => f64::INFINITY,
            2 => f64::NEG_INFINITY,
            3 => 1e300,
            4 => -1e300,
            5 => f64::MIN_POSITIVE,
            6 => -1.0,
            7 => 0.0,
            8 => min.unwrap_or(0.0),
            9 => max.unwrap_or(1e6),
            _ => {
                let (lo, hi) = (min.unwrap_or(-10.0), max.unwrap_or(10.0));
                lo + (hi - lo) * self.unit()
            }
        }
    }
}

fn outputs() -> Vec<u32> {
    table()
        .iter()
        .enumerate()
        .filter(|(_, v)| matches!(v.role, Role::Output(_)) && v.kind == Kind::Real)
        .map(|(i, _)| i as u32)
        .collect()
}

/// A state's bytes forged on purpose and resealed: a value from the edges (NaN, ±inf,
/// huge, finite far beyond any rule, an out-of-bound load, a random bit pattern) over 8
/// bytes, or a wrong code over one, at a random offset of the payload.
fn forge(rng: &mut Rng, b: &mut [u8]) {
    if b.len() < HEADER + 8 {
        return;
    }
    let at = HEADER + rng.below(b.len() - HEADER - 7);
    if rng.below(4) == 0 {
        b[at] = [2, 9, 255, 0x80][rng.below(4)];
    } else {
        let x = [
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1e300,
            -1e300,
            1e30,
            5.0,
            -2.0,
            0.5,
        ][rng.below(9)];
        let bits = if rng.below(8) == 0 {
            rng.next()
        } else {
            x.to_bits()
        };
        b[at..at + 8].copy_from_slice(&bits.to_le_bytes());
    }
    reseal(b);
}

/// One sequence's instance and what it keeps between calls: the time the next step starts
/// at, the states taken and live, and those freed (offered again as stale pointers).
struct Fuzz {
    c: *mut c_void,
    t: f64,
    states: Vec<*mut c_void>,
    freed: Vec<*mut c_void>,
    outs: Vec<u32>,
}

// SAFETY (every unsafe block below): every pointer passed is valid for the call: C
// strings, arrays of the stated length, writable out-parameters; `c` is the live instance
// of `sequence`; state pointers come from the FMU or are deliberately stale, which it must
// refuse without dereferencing.
impl Fuzz {
    /// A step, mostly well-formed, sometimes not; one that returned OK left every output
    /// finite.
    fn step(&mut self, rng: &mut Rng, call: usize) {
        let (c, outs) = (self.c, &self.outs);
        // Long but legal steps only cost time, so sizes stay below 20 ms.
        let h = match rng.below(8) {
            0 => [f64::NAN, f64::INFINITY, -1e-3, 0.0, 1e300][rng.below(5)],
            1 => 7e-9,
            _ => 1e-3 * (1 + rng.below(20)) as f64,
        };
        let tc = if rng.below(10) == 0 {
            rng.value(None, None)
        } else {
            self.t
        };
        // SAFETY: see `impl Fuzz`.
        unsafe {
            let st = fmi2DoStep(c, tc, h, 1);
            if st == OK {
                self.t = tc + h;
                let mut o = vec![0.0; outs.len()];
                assert_eq!(
                    fmi2GetReal(c, outs.as_ptr(), outs.len(), o.as_mut_ptr()),
                    OK
                );
                assert!(
                    o.iter().all(|x| x.is_finite()),
                    "call {call}: a step returned OK with outputs {o:?}"
                );
            }
        }
    }

    /// One to three variables of one kind set, values from the edges.
    fn set_values(&mut self, rng: &mut Rng, call: usize) {
        let (c, vars) = (self.c, table());
        let n = 1 + rng.below(3);
        let kind = [Kind::Real, Kind::Integer, Kind::Boolean][rng.below(3)];
        let mut vrs = Vec::new();
        let mut xs = Vec::new();
        for _ in 0..n {
            let vr = if rng.below(20) == 0 {
                99_999
            } else {
                rng.below(vars.len()) as u32
            };
            let v = &vars[(vr as usize).min(vars.len() - 1)];
            vrs.push(vr);
            xs.push(rng.value(v.min, v.max));
        }
        // SAFETY: see `impl Fuzz`.
        let st = unsafe {
            match kind {
                Kind::Real => fmi2SetReal(c, vrs.as_ptr(), n, xs.as_ptr()),
                Kind::Integer => {
                    let is: Vec<i32> = xs.iter().map(|&x| x as i32).collect();
                    fmi2SetInteger(c, vrs.as_ptr(), n, is.as_ptr())
                }
                _ => {
                    let bs: Vec<i32> = xs.iter().map(|&x| i32::from(x != 0.0)).collect();
                    fmi2SetBoolean(c, vrs.as_ptr(), n, bs.as_ptr())
                }
            }
        };
        assert!(
            [OK, WARNING, ERROR].contains(&st),
            "call {call}: status {st}"
        );
    }

    /// The state taken, kept live.
    fn get_state(&mut self) {
        let mut s = ptr::null_mut();
        // SAFETY: see `impl Fuzz`.
        if unsafe { fmi2GetFMUstate(self.c, &mut s) } == OK {
            // The allocator may hand out a freed address again.
            self.freed.retain(|&f| f != s);
            self.states.push(s);
        }
    }

    /// A live state set, or one already freed (which must be refused).
    fn set_state(&mut self, rng: &mut Rng, call: usize) {
        let pool = if self.freed.is_empty() || rng.below(3) > 0 {
            &self.states
        } else {
            &self.freed
        };
        if let Some(&s) = pool.get(rng.below(pool.len().max(1))) {
            // SAFETY: see `impl Fuzz`.
            let st = unsafe { fmi2SetFMUstate(self.c, s) };
            if self.freed.contains(&s) {
                assert_eq!(st, ERROR, "call {call}: a freed state was accepted");
            } else {
                self.t = f64::NAN; // unknown: the next step's point is refused or re-learnt
            }
        }
    }

    /// A live state freed, its pointer kept as a stale one.
    fn free_state(&mut self, rng: &mut Rng) {
        if !self.states.is_empty() {
            let mut s = self.states.swap_remove(rng.below(self.states.len()));
            let p = s;
            // SAFETY: see `impl Fuzz`.
            assert_eq!(unsafe { fmi2FreeFMUstate(self.c, &mut s) }, OK);
            self.freed.push(p);
        }
    }

    /// A live state serialized, maybe damaged, deserialized. Returns false when there was
    /// no live state (no call made, and the checks after a call skipped).
    fn round_trip(&mut self, rng: &mut Rng, call: usize) -> bool {
        let c = self.c;
        let Some(&s) = self.states.get(rng.below(self.states.len().max(1))) else {
            return false;
        };
        // SAFETY: see `impl Fuzz`.
        unsafe {
            let mut n = 0;
            assert_eq!(fmi2SerializedFMUstateSize(c, s, &mut n), OK);
            let mut b = vec![0u8; n];
            assert_eq!(fmi2SerializeFMUstate(c, s, b.as_mut_ptr().cast(), n), OK);
            let damage = rng.below(6);
            match damage {
                0 => {}
                1 => {
                    let i = rng.below(n);
                    b[i] ^= 1 << rng.below(8);
                }
                2 => b.truncate(rng.below(n)),
                3 => {
                    let i = rng.below(n);
                    b[i] = b[i].wrapping_add(1 + rng.below(255) as u8);
                }
                _ => forge(rng, &mut b),
            }
            let mut copy = ptr::null_mut();
            let st = fmi2DeSerializeFMUstate(c, b.as_ptr().cast(), b.len(), &mut copy);
            if damage >= 4 {
                // Forged and resealed: refused, or within every rule once set.
                if st == OK {
                    self.freed.retain(|&f| f != copy);
                    self.states.push(copy);
                    assert_eq!(fmi2SetFMUstate(c, copy), OK);
                    if let Err(e) = read_back(c) {
                        panic!("call {call}: a forged state was accepted: {e}");
                    }
                    self.t = f64::NAN;
                } else {
                    assert_eq!(st, ERROR, "call {call}");
                }
            } else if damage == 0 {
                assert_eq!(
                    st,
                    OK,
                    "call {call}: an intact state was refused: {:?}",
                    fmu::state::deserialize(&b, None).err()
                );
                self.freed.retain(|&f| f != copy);
                self.states.push(copy);
            } else {
                assert_eq!(st, ERROR, "call {call}: a damaged state was accepted");
            }
        }
        true
    }

    /// A load from the edges, sub-normal ones included, a short step, and the state then:
    /// the FMU restores what it serialized itself. Returns false when the state could not
    /// be serialized after a failed step (the checks after a call skipped).
    fn edge_load(&mut self, rng: &mut Rng, call: usize) -> bool {
        let c = self.c;
        let load = [
            5e-324,
            -5e-324,
            f64::MIN_POSITIVE,
            1e-300,
            1e-12,
            -1e-12,
            0.0,
        ][rng.below(7)];
        let load = if rng.below(3) == 0 {
            load * rng.unit()
        } else {
            load
        };
        let vr = fmu::variables::vr_of("load_torque_nm").unwrap();
        // SAFETY: see `impl Fuzz`.
        unsafe {
            fmi2SetReal(c, &vr, 1, &load);
            let h = [1e-6, 7e-9, 1e-4][rng.below(3)];
            let stepped = fmi2DoStep(c, self.t, h, 1);
            if stepped == OK {
                self.t += h;
            }
            let mut s = ptr::null_mut();
            if fmi2GetFMUstate(c, &mut s) == OK {
                let mut n = 0;
                // A drive left non-finite by a failed step cannot be serialized;
                // one that just stepped must be.
                let sized = fmi2SerializedFMUstateSize(c, s, &mut n);
                assert!(
                    sized == OK || stepped != OK,
                    "call {call}: load {load}: a state after a good step is not serialized"
                );
                if sized != OK {
                    assert_eq!(fmi2FreeFMUstate(c, &mut s), OK);
                    return false;
                }
                let mut b = vec![0u8; n];
                assert_eq!(fmi2SerializeFMUstate(c, s, b.as_mut_ptr().cast(), n), OK);
                if let Err(e) = fmu::state::deserialize(&b, None) {
                    panic!("call {call}: load {load}: its own state refused: {e}");
                }
                assert_eq!(fmi2FreeFMUstate(c, &mut s), OK);
            }
        }
        true
    }

    /// One random call of kind `what` (0..18). Returns false when the checks after a call
    /// are to be skipped.
    fn call(&mut self, rng: &mut Rng, call: usize, what: usize) -> bool {
        let c = self.c;
        // SAFETY: see `impl Fuzz`.
        unsafe {
            match what {
                0 => {
                    fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
                }
                1 => {
                    fmi2EnterInitializationMode(c);
                }
                2 => {
                    fmi2ExitInitializationMode(c);
                }
                3..=5 => self.step(rng, call),
                6..=8 => self.set_values(rng, call),
                9 => self.get_state(),
                10 => self.set_state(rng, call),
                11 => self.free_state(rng),
                12 | 13 => return self.round_trip(rng, call),
                16 | 17 => return self.edge_load(rng, call),
                14 => {
                    if rng.below(4) == 0 {
                        fmi2Reset(c);
                        self.t = 0.0;
                    } else {
                        fmi2Terminate(c);
                    }
                }
                _ => {
                    let mut o = vec![0.0; self.outs.len()];
                    fmi2GetReal(c, self.outs.as_ptr(), self.outs.len(), o.as_mut_ptr());
                }
            }
        }
        true
    }
}

/// One sequence on a fresh instance; returns how many calls it made.
fn sequence(rng: &mut Rng, calls: usize) -> usize {
    let outs = outputs();
    let mut f = Fuzz {
        c: instantiate("fuzz"),
        t: 0.0,
        states: Vec::new(),
        freed: Vec::new(),
        outs,
    };
    for call in 0..calls {
        let panics = caught_panics();
        let what = rng.below(18);
        if !f.call(rng, call, what) {
            continue;
        }
        if f.t.is_nan() {
            let mut now = 0.0;
            // SAFETY: see `impl Fuzz`.
            unsafe { fmu::exports::steps::fmi2GetRealStatus(f.c, 2, &mut now) };
            f.t = now;
        }
        assert_eq!(
            caught_panics(),
            panics,
            "call {call} (kind {what}) panicked inside the FMU"
        );
    }
    fmi2FreeInstance(f.c);
    calls
}

#[test]
fn random_call_sequences_never_panic_leak_or_return_ok_with_nan() {
    let cases: usize = std::env::var("FMU_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000);
    let seed: u64 = std::env::var("FMU_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x5eed_f00d);
    let mut rng = Rng(seed.max(1));
    let mut calls = 0;
    for case in 0..cases {
        let before = live_states();
        calls += sequence(&mut rng, 60);
        assert_eq!(live_states(), before, "case {case}: states leaked");
    }
    assert_eq!(caught_panics(), 0);
    assert!(calls >= cases * 60);
}
