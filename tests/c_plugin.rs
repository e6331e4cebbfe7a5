//! The C SDK's plugins, compiled by the system C compiler (plugins/c-example's build
//! script): the example `c-six-step` starts the drive from standstill and holds the speed
//! command under `drive-bench`, several of its instances run side by side, a drive saved
//! while it runs continues bit-identically, and every way the C fixture breaks the ABI is
//! an error naming the plugin and the rule, not a crash.

use bldc_drive::DriveConfig;
use bldc_drive::drive::{DriveEngine, build_plugin, run_to};
use bldc_drive::drive_core::Persist;
use bldc_drive::strategies::{PluginError, PluginLibrary};
use std::process::Command;

mod common;

use common::plugins::{c_example, c_misbehaving, with_mode};

fn engine(lib: &PluginLibrary, rpm: f64) -> DriveEngine {
    let mut cfg = DriveConfig::default();
    cfg.control.speed_ref_rpm = rpm;
    build_plugin(&cfg, lib).expect("the C plugin accepts the default drive")
}

#[test]
fn drive_bench_runs_the_c_plugin_from_standstill_to_the_speed_command() {
    let plugin = c_example();
    let out = Command::new(env!("CARGO_BIN_EXE_drive-bench"))
        .arg("--plugin")
        .arg(&plugin)
        .args(["run", "--strategy", "c-six-step", "--speed-rpm", "3000"])
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert_eq!(out.status.code(), Some(0), "{stdout}\n{stderr}");
    assert!(
        stdout.starts_with("c-six-step at 3000 rpm: running: in synchronism"),
        "{stdout}"
    );
    assert!(stdout.contains("0 restarts"), "{stdout}");
}

#[test]
fn c_plugin_instances_share_nothing() {
    // One instance alone, and two of the same library stepped in turn with other speed
    // commands: the first ends in exactly the same state either way. Both reach their
    // commands by ~0.45 s, so their speed loops (the state most tempting to keep in a
    // static) work side by side until 0.8 s.
    let lib = PluginLibrary::load(&c_example()).unwrap();
    assert_eq!(lib.name(), "c-six-step");
    // (Both in the same 10 ms pieces: where a run stops ends a plant step.)
    let (mut alone, mut a, mut b) = (
        engine(&lib, 800.0),
        engine(&lib, 800.0),
        engine(&lib, 1000.0),
    );
    for k in 1..=80 {
        let t = f64::from(k) * 0.01;
        run_to(&mut alone, t, |_, _| {}).unwrap();
    }
    for k in 1..=80 {
        let t = f64::from(k) * 0.01;
        run_to(&mut a, t, |_, _| {}).unwrap();
        run_to(&mut b, t, |_, _| {}).unwrap();
    }
    assert!(
        a.to_bytes().unwrap() == alone.to_bytes().unwrap(),
        "the instance stepped beside another ended elsewhere"
    );
    let (sa, sb) = (a.plant.observe().speed_rpm, b.plant.observe().speed_rpm);
    assert!(
        (sa - 800.0).abs() < 40.0 && (sb - 1000.0).abs() < 50.0,
        "each at its command: {sa} and {sb} rpm"
    );
}

#[test]
fn a_c_plugin_drive_saved_while_running_continues_bit_identically() {
    let lib = PluginLibrary::load(&c_example()).unwrap();
    let mut e = engine(&lib, 3000.0);
    // 0.8 s: past the alignment and the ramp (the comparators took over at ~0.3 s).
    run_to(&mut e, 0.8, |_, _| {}).unwrap();
    let bytes = e.to_bytes().unwrap();
    let mut copy = engine(&lib, 3000.0);
    copy.restore_from(&bytes).unwrap();
    assert!(copy.to_bytes().unwrap() == bytes, "restored as saved");
    run_to(&mut e, 1.2, |_, _| {}).unwrap();
    run_to(&mut copy, 1.2, |_, _| {}).unwrap();
    assert!(
        copy.to_bytes().unwrap() == e.to_bytes().unwrap(),
        "the restored drive's state differs from the uninterrupted one's at 1.2 s"
    );
    let o = (e.plant.observe(), copy.plant.observe());
    assert_eq!(o.0.speed_rpm.to_bits(), o.1.speed_rpm.to_bits());
    assert_eq!(o.0.theta_e.to_bits(), o.1.theta_e.to_bits());
    assert!(o.0.speed_rpm > 2000.0, "running: {} rpm", o.0.speed_rpm);
}

fn load_err(mode: &str) -> String {
    with_mode(mode, || PluginLibrary::load(&c_misbehaving()))
        .map(|_| ())
        .unwrap_err()
        .to_string()
}

#[test]
fn a_c_header_that_breaks_the_rules_is_refused_naming_the_file_and_rule() {
    let file = "libc_misbehaving.so";
    let m = load_err("c-foreign-header");
    assert!(
        m.contains(file) && m.contains("bad magic") && m.contains("not a strategy plugin"),
        "{m}"
    );
    let m = load_err("c-null-name");
    assert!(
        m.contains(file) && m.contains("name is a null pointer"),
        "{m}"
    );
    let m = load_err("c-null-function");
    assert!(
        m.contains(file)
            && m.contains("vtable entry `step` is a null pointer")
            && m.contains("rule: the eight ABI 1.0 functions"),
        "{m}"
    );
    let ptr = size_of::<usize>();
    let m = load_err("c-vtable-mid-pointer");
    assert!(
        m.contains(file)
            && m.contains(&format!(
                "vtable of {} bytes (rule: a whole number of {ptr}-byte function pointers)",
                8 * ptr + ptr / 2
            )),
        "{m}"
    );
}

/// Runs the fixture in `mode` for 10 ms: the error that stopped it.
fn run_err(mode: &str) -> String {
    with_mode(mode, || {
        let lib = PluginLibrary::load(&c_misbehaving()).unwrap();
        let mut e = build_plugin(&DriveConfig::default(), &lib).unwrap();
        let mut worst = false;
        let r = run_to(&mut e, 0.01, |e, _| {
            let g = e.gates();
            worst |= (g.high.u && g.low.u) || (g.high.v && g.low.v) || (g.high.w && g.low.w);
        });
        assert!(
            !worst,
            "{mode}: the bridge never saw both switches of a leg on"
        );
        r.unwrap_err().to_string()
    })
}

#[test]
fn c_calls_that_break_the_rules_stop_the_run_with_an_error_naming_plugin_and_rule() {
    let named = |m: &str| m.contains("plugin `c-misbehaving`") && m.contains("libc_misbehaving.so");
    // create returns NULL without a word.
    let e = with_mode("c-null-instance", || {
        let lib = PluginLibrary::load(&c_misbehaving()).unwrap();
        build_plugin(&DriveConfig::default(), &lib).err().unwrap()
    });
    let m = e.to_string();
    assert!(
        named(&m)
            && m.contains(
                "create: (no message; rule: a failed call writes its reason into the error buffer)"
            ),
        "{m}"
    );
    // A message that fills the buffer without a NUL and claims more: cut at the buffer.
    let m = run_err("c-long-error");
    assert!(named(&m) && m.contains("step: xxxx"), "{m}");
    assert!(
        m.contains(
            "[message cut: the plugin set len = 612 for a buffer of 512 bytes (rule: len <= cap)]"
        ),
        "{m}"
    );
    // The plugin's own text, between the call's name and the host's remark (the path
    // before it may hold an 'x' of its own).
    let text = m
        .split_once("step: ")
        .and_then(|(_, rest)| rest.split_once(" [message cut"))
        .map(|(text, _)| text);
    assert_eq!(text, Some("x".repeat(512).as_str()), "{m}");
    let m = run_err("c-shoot-through");
    assert!(
        named(&m) && m.contains("both switches of leg u on: shoot-through refused (rule: at most one switch per leg)"),
        "{m}"
    );
    let m = run_err("c-wake-past");
    assert!(
        named(&m)
            && m.contains("wake_at = 63000 ticks at the step of tick 64000 (rule: a wake-up after the step's instant"),
        "{m}"
    );
    // The well-behaved mode runs (the faults above are the modes', not the fixture's).
    with_mode("", || {
        let lib = PluginLibrary::load(&c_misbehaving()).unwrap();
        let mut e = build_plugin(&DriveConfig::default(), &lib).unwrap();
        run_to(&mut e, 0.01, |_, _| {}).unwrap();
    });
    assert!(matches!(
        with_mode("c-null-name", || PluginLibrary::load(&c_misbehaving())),
        Err(PluginError::BadHeader { .. })
    ));
}
