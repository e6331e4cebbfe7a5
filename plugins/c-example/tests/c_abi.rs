//! The C example plugin called through its vtable directly, as a host would and as a
//! careless host might: pointers that are not its instances, a bad config, state bytes
//! it did not write and a small error buffer are each refused with an error naming the
//! rule, never a crash; save and restore round-trip.

#![allow(unsafe_code)] // calls into the C plugin through raw function pointers

use c_example_plugin::built;
use std::ffi::CString;
use strategy_abi as abi;

struct Loaded {
    _lib: libloading::Library,
    header: &'static abi::Header,
}

fn load(stem: &str) -> Loaded {
    let path = built(stem);
    // SAFETY: the plugin is this crate's, built against this ABI; the header is static
    // for the library's lifetime, which `Loaded` keeps.
    unsafe {
        let lib = libloading::Library::new(&path).unwrap();
        let entry = *lib.get::<abi::EntryFn>(abi::ENTRY_SYMBOL).unwrap();
        let header = &*entry();
        Loaded { _lib: lib, header }
    }
}

struct Err {
    bytes: [u8; 512],
    raw: abi::ErrorBuf,
}

impl Err {
    fn new(cap: usize) -> Box<Self> {
        let mut e = Box::new(Err {
            bytes: [0; 512],
            raw: abi::ErrorBuf {
                ptr: std::ptr::null_mut(),
                cap,
                len: 0,
            },
        });
        e.raw.ptr = e.bytes.as_mut_ptr();
        e
    }
    fn text(&self) -> String {
        String::from_utf8_lossy(&self.bytes[..self.raw.len]).into_owned()
    }
}

const INFO: abi::DriveInfo = abi::DriveInfo {
    pole_pairs: 6,
    amps_per_code: 10.0 / 4096.0 / 80.0 / 0.25,
    carrier_top: 2000,
};

/// The keys the plugin reads, at the drive's defaults, among others it ignores.
fn config() -> String {
    include_str!("default_keys.toml").to_string()
}

fn create(p: &Loaded, cfg: &str, err: &mut Err) -> abi::Instance {
    let c = CString::new(cfg).unwrap();
    // SAFETY: valid pointers for the call.
    unsafe { (p.header.vtable.create)(c.as_ptr(), &INFO, &mut err.raw) }
}

#[test]
fn null_and_foreign_instance_pointers_are_refused_by_the_c_plugin() {
    let p = load("c_six_step");
    let v = p.header.vtable;
    let mut clock = 0u64;
    let mut err = Err::new(512);
    // SAFETY: the calls below pass pointers the plugin must check, not dereference blindly.
    unsafe {
        assert_eq!(
            (v.clock)(std::ptr::null_mut(), &mut clock, &mut err.raw),
            abi::ERROR
        );
        assert_eq!(
            err.text(),
            "clock: null instance (rule: pass an instance create or clone returned)"
        );
        // A host buffer that is not an instance, and another plugin's instance.
        let mut junk = [0u64; 64];
        assert_eq!(
            (v.clock)(junk.as_mut_ptr().cast(), &mut clock, &mut err.raw),
            abi::ERROR
        );
        assert!(
            err.text().contains("not an instance of c-six-step (rule:"),
            "{}",
            err.text()
        );
        let other = load("c_misbehaving");
        let foreign = create(&other, "", &mut err);
        assert!(!foreign.is_null());
        let (s, c, mut cmd, mut st) = (
            abi::CSensed::default(),
            0u64,
            abi::CCommand::default(),
            abi::CStatus::default(),
        );
        assert_eq!(
            (v.step)(foreign, c, &s, &mut cmd, &mut st, &mut err.raw),
            abi::ERROR
        );
        assert!(
            err.text()
                .starts_with("step: not an instance of c-six-step"),
            "{}",
            err.text()
        );
        (other.header.vtable.destroy)(foreign);
        // Its own instance works (a destroyed one is freed memory: undefined in C).
        let inst = create(&p, &config(), &mut err);
        assert!(!inst.is_null(), "{}", err.text());
        assert_eq!((v.clock)(inst, &mut clock, &mut err.raw), abi::OK);
        assert_eq!(clock, 32);
        (v.destroy)(inst);
    }
}

#[test]
fn a_bad_config_is_refused_naming_the_key_the_value_and_the_rule() {
    let p = load("c_six_step");
    let good = config();
    let mut err = Err::new(512);
    let cfg = good.replace("resistance_ohm = 2.2", "resistance_ohm = -1.5");
    assert_ne!(cfg, good);
    assert!(create(&p, &cfg, &mut err).is_null());
    assert_eq!(
        err.text(),
        "create: `motor.resistance_ohm` = -1.5 (rule: finite and > 0)"
    );
    let cfg = good.replace("supply_v = 12.0", "");
    assert!(create(&p, &cfg, &mut err).is_null());
    assert_eq!(
        err.text(),
        "create: `power_stage.supply_v` missing or not a number (rule: the drive's config gives it)"
    );
    // A small buffer: the message cut at its capacity, never past it.
    let mut small = Err::new(12);
    assert!(create(&p, &cfg, &mut small).is_null());
    assert_eq!(small.raw.len, 12);
    assert_eq!(small.text(), "create: `pow");
    assert!(
        small.bytes[12..].iter().all(|&b| b == 0),
        "nothing written past cap"
    );
}

#[test]
fn save_and_restore_round_trip_and_refuse_what_save_did_not_write() {
    let p = load("c_six_step");
    let v = p.header.vtable;
    let (save, restore, plan) = (
        v.save.unwrap(),
        v.restore.unwrap(),
        v.planned_change.unwrap(),
    );
    let mut err = Err::new(512);
    let cfg = config();
    let a = create(&p, &cfg, &mut err);
    let b = create(&p, &cfg, &mut err);
    // SAFETY: live instances, valid buffers.
    unsafe {
        let inputs = abi::Inputs {
            now: 0,
            start: 1,
            reset: 0,
            speed_ref_rpm: 3000.0,
        };
        assert_eq!((v.set_inputs)(a, &inputs, &mut err.raw), abi::OK);
        let (s, mut cmd, mut st) = (
            abi::CSensed::default(),
            abi::CCommand::default(),
            abi::CStatus::default(),
        );
        assert_eq!((v.step)(a, 0, &s, &mut cmd, &mut st, &mut err.raw), abi::OK);
        assert_eq!(st.mode, 1, "aligning");
        assert_eq!(
            cmd.legs,
            [0, abi::LEG_LOW, abi::LEG_HIGH],
            "state 1's vector"
        );
        assert!(cmd.wake_at > 0 && cmd.wake_at != u64::MAX);
        let mut len = 0usize;
        assert_eq!(
            save(a, std::ptr::null_mut(), 0, &mut len, &mut err.raw),
            abi::OK
        );
        let mut bytes = vec![0u8; len];
        assert_eq!(
            save(a, bytes.as_mut_ptr(), 3, &mut len, &mut err.raw),
            abi::ERROR
        );
        assert!(
            err.text().contains("rule: ask for the length first"),
            "{}",
            err.text()
        );
        assert_eq!(
            save(a, bytes.as_mut_ptr(), len, &mut len, &mut err.raw),
            abi::OK
        );
        assert_eq!(restore(b, bytes.as_ptr(), len, &mut err.raw), abi::OK);
        let mut again = vec![0u8; len];
        assert_eq!(
            save(b, again.as_mut_ptr(), len, &mut len, &mut err.raw),
            abi::OK
        );
        assert_eq!(again, bytes);
        let (mut at, mut legs) = (0u64, [9u8; 3]);
        assert_eq!(plan(b, &mut at, &mut legs, &mut err.raw), abi::OK);
        assert_eq!(
            (at, legs),
            (u64::MAX, [0; 3]),
            "nothing timed while aligning"
        );
        // Refused: another magic, a short state, a field out of range, another drive.
        let mut bad = bytes.clone();
        bad[0] = b'X';
        assert_eq!(restore(b, bad.as_ptr(), len, &mut err.raw), abi::ERROR);
        assert!(
            err.text().contains("no c-six-step state magic"),
            "{}",
            err.text()
        );
        assert_eq!(
            restore(b, bytes.as_ptr(), len - 1, &mut err.raw),
            abi::ERROR
        );
        assert!(
            err.text().contains("rule: exactly what save wrote"),
            "{}",
            err.text()
        );
        let mode_at = 8 + 14 * 8 + 3 * 8; // magic, 14 params, start, reset, speed_ref
        let mut bad = bytes.clone();
        bad[mode_at] = 9;
        assert_eq!(restore(b, bad.as_ptr(), len, &mut err.raw), abi::ERROR);
        assert!(err.text().contains("rule: mode 0..4"), "{}", err.text());
        let other = create(
            &p,
            &cfg.replace("supply_v = 12.0", "supply_v = 24.0"),
            &mut err,
        );
        assert!(!other.is_null());
        assert_eq!(
            restore(other, bytes.as_ptr(), len, &mut err.raw),
            abi::ERROR
        );
        assert!(
            err.text()
                .contains("rule: restore into an instance created from the same config")
        );
        for i in [a, b, other] {
            (v.destroy)(i);
        }
    }
}
