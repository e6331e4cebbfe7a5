//! Strategy plugins loaded at run time: the example plugin reproduces the built-in
//! strategy it re-implements, and every way a plugin can be broken is refused cleanly.

use bldc_drive::DriveConfig;
use bldc_drive::drive::{build_plugin, run_to};
use bldc_drive::scenario::{Scenario, TraceRow, TraceSpec, run};
use bldc_drive::strategies::{PluginError, PluginLibrary, StrategyName};
use std::path::PathBuf;

mod common;

use common::plugins::{example, misbehaving, with_mode};

fn trace(plugin: Option<PluginLibrary>) -> Vec<TraceRow> {
    let mut cfg = DriveConfig::default();
    cfg.strategy.name = StrategyName::TwelveStepDf;
    let mut sc = Scenario::hold(cfg, 3000.0, 1.6);
    sc.plugin = plugin;
    sc.trace = Some(TraceSpec {
        every_s: 20e-6,
        from_s: 0.0,
        to_s: 1.6,
    });
    let mut rows = Vec::new();
    let out = run(&sc, |r| rows.push(*r)).expect("runs");
    assert!(
        out.summary.verdict.in_sync() && out.summary.commutations > 100,
        "{:?}",
        out.summary
    );
    rows
}

#[test]
fn the_example_plugin_reproduces_the_builtin_strategy() {
    let lib = PluginLibrary::load(&example()).expect("example plugin loads");
    assert_eq!(lib.name(), "example-twelve-step-df");
    let builtin = trace(None);
    let plugin = trace(Some(lib));
    assert_eq!(builtin.len(), plugin.len());
    // The same commutation sequence at the same instants, and the same speed trace.
    let states = |rows: &[TraceRow]| -> Vec<(u64, u8)> {
        let mut v = Vec::new();
        for w in rows.windows(2) {
            if w[1].state != w[0].state {
                v.push(((w[1].t_s / 20e-9).round() as u64, w[1].state));
            }
        }
        v
    };
    let (a, b) = (states(&builtin), states(&plugin));
    assert!(a.len() > 1000, "{} state changes", a.len());
    assert_eq!(a, b);
    for (x, y) in builtin.iter().zip(&plugin) {
        assert_eq!(
            x.speed_rpm.to_bits(),
            y.speed_rpm.to_bits(),
            "at {} s",
            x.t_s
        );
        assert_eq!(
            (x.zd, x.zdf, x.duty.to_bits()),
            (y.zd, y.zdf, y.duty.to_bits())
        );
    }
}

#[test]
fn the_library_outlives_the_handle_it_was_loaded_by() {
    let lib = PluginLibrary::load(&example()).unwrap();
    let mut eng = build_plugin(&DriveConfig::default(), &lib).unwrap();
    drop(lib);
    run_to(&mut eng, 0.05, |_, _| {}).expect("the instance keeps its library loaded");
    let copy = bldc_drive::drive::try_clone(&eng).expect("plugin instances can be copied");
    drop(eng);
    drop(copy);
}

#[test]
fn a_file_that_is_not_a_library_is_refused() {
    let p = std::env::temp_dir().join(format!("not-a-plugin-{}.so", std::process::id()));
    std::fs::write(&p, "this is text").unwrap();
    let e = PluginLibrary::load(&p).unwrap_err();
    assert!(matches!(e, PluginError::NotALibrary { .. }), "{e}");
    assert!(e.to_string().contains(p.to_str().unwrap()), "{e}");
    let missing = PluginLibrary::load(std::path::Path::new("/nonexistent/plugin.so")).unwrap_err();
    assert!(
        missing.to_string().contains("/nonexistent/plugin.so"),
        "{missing}"
    );
}

#[test]
fn a_library_without_the_entry_symbol_is_refused() {
    // Any shared library that is not a plugin: the C maths library of the system.
    let libm = [
        "/lib/x86_64-linux-gnu/libm.so.6",
        "/usr/lib/x86_64-linux-gnu/libm.so.6",
        "/lib64/libm.so.6",
        "/usr/lib64/libm.so.6",
    ]
    .into_iter()
    .map(PathBuf::from)
    .find(|p| p.exists())
    .expect("libm.so.6 not found in the usual places; install the C library (libc6)");
    let e = PluginLibrary::load(&libm).unwrap_err();
    let m = e.to_string();
    assert!(matches!(e, PluginError::NoEntry { .. }), "{m}");
    assert!(
        m.contains("bldc_strategy_entry") && m.contains("libm.so.6") && m.contains("host ABI 1.2"),
        "{m}"
    );
}

#[test]
fn a_wrong_magic_or_a_null_header_is_refused_before_anything_else_is_read() {
    let e = with_mode("magic", || PluginLibrary::load(&misbehaving())).unwrap_err();
    let m = e.to_string();
    assert!(
        m.contains("bad magic")
            && m.contains("bldc_strategy_entry")
            && m.contains("libmisbehaving_plugin.so"),
        "{m}"
    );
    let e = with_mode("null-header", || PluginLibrary::load(&misbehaving())).unwrap_err();
    assert!(e.to_string().contains("null header"), "{e}");
}

#[test]
fn a_vtable_size_ending_inside_a_function_pointer_is_refused() {
    let e = with_mode("vtable-mid-pointer", || PluginLibrary::load(&misbehaving())).unwrap_err();
    let ptr = std::mem::size_of::<usize>();
    let size = 8 * ptr + 4; // the eight functions of ABI 1.0, and half of `save`
    assert!(matches!(e, PluginError::BadHeader { .. }), "{e}");
    assert!(
        e.to_string().contains(&format!(
            "vtable of {size} bytes (rule: a whole number of {ptr}-byte function pointers)"
        )),
        "{e}"
    );
}

#[test]
fn a_newer_abi_major_is_refused_with_both_versions() {
    let e = with_mode("major", || PluginLibrary::load(&misbehaving())).unwrap_err();
    assert!(
        matches!(
            e,
            PluginError::Version {
                plugin_major: 2,
                host_major: 1,
                ..
            }
        ),
        "{e}"
    );
    assert!(
        e.to_string().contains("ABI 2.2 (plugin) vs 1.2 (host)"),
        "{e}"
    );
}

#[test]
fn a_plugin_whose_create_fails_names_the_call_and_its_message() {
    let e = with_mode("create-error", || {
        let lib = PluginLibrary::load(&misbehaving()).unwrap();
        build_plugin(&DriveConfig::default(), &lib).err().unwrap()
    });
    let m = e.to_string();
    assert!(
        m.contains("create") && m.contains("create-error requested"),
        "{m}"
    );
}

#[test]
fn a_panic_in_step_stops_the_run_with_an_error_not_a_crash() {
    let err = with_mode("panic", || {
        let lib = PluginLibrary::load(&misbehaving()).unwrap();
        let mut eng = build_plugin(&DriveConfig::default(), &lib).unwrap();
        run_to(&mut eng, 0.01, |_, _| {}).unwrap_err()
    });
    let m = err.to_string();
    assert!(
        m.contains("plugin panicked: deliberate panic") && m.contains("misbehaving"),
        "{m}"
    );
}

/// A deliberate panic is reported as the host's error and not printed: the plugin's std
/// (its own, in the cdylib) writes to stderr past the harness's capture, so the test above
/// runs in a child process whose stderr is read.
#[test]
fn a_deliberate_plugin_panic_prints_nothing() {
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "a_panic_in_step_stops_the_run_with_an_error_not_a_crash",
            "--nocapture",
        ])
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(
        out.status.success() && stdout.contains("1 passed"),
        "{stdout}\n{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn a_panic_in_planned_change_stops_the_run_with_an_error_naming_it() {
    let err = with_mode("plan-panic", || {
        let lib = PluginLibrary::load(&misbehaving()).unwrap();
        let mut eng = build_plugin(&DriveConfig::default(), &lib).unwrap();
        run_to(&mut eng, 0.01, |_, _| {}).unwrap_err()
    });
    let m = err.to_string();
    assert!(
        m.contains("planned_change") && m.contains("deliberate panic in planned_change"),
        "{m}"
    );
}

#[test]
fn a_plan_the_bridge_cannot_take_or_long_past_does_not_stop_the_run() {
    // Only a hint: legs no bridge takes are dropped by the host (no plan reaches the
    // engine), and a plan long past is the engine's to ignore (a unit test there holds its
    // horizons to those of no plan).
    use bldc_drive::drive_core::Controller;
    for (mode, passed_on) in [("plan-garbage", false), ("plan-past", true)] {
        let plan = with_mode(mode, || {
            let lib = PluginLibrary::load(&misbehaving()).unwrap();
            let mut eng = build_plugin(&DriveConfig::default(), &lib).unwrap();
            run_to(&mut eng, 0.01, |_, _| {}).unwrap_or_else(|e| panic!("{mode}: {e}"));
            eng.controller.planned_change()
        });
        assert_eq!(plan.is_some(), passed_on, "{mode}: {plan:?}");
    }
}

#[test]
fn a_shoot_through_command_is_refused_by_the_host() {
    let (err, gates) = with_mode("shoot-through", || {
        let lib = PluginLibrary::load(&misbehaving()).unwrap();
        let mut eng = build_plugin(&DriveConfig::default(), &lib).unwrap();
        let mut worst = false;
        let r = run_to(&mut eng, 0.01, |e, _| {
            let g = e.gates();
            worst |= (g.high.u && g.low.u) || (g.high.v && g.low.v) || (g.high.w && g.low.w);
        });
        (r.unwrap_err(), worst)
    });
    assert!(!gates, "the bridge never saw both switches of a leg on");
    let m = err.to_string();
    assert!(
        m.contains("shoot-through refused") && m.contains("leg u"),
        "{m}"
    );
    // 64 000 ticks = 1.28 ms: the first step that misbehaves.
    assert!(m.contains("t = 0.00128"), "{m}");
}

/// The engine's state by value (plant, engine and strategy).
fn saved(e: &bldc_drive::drive::DriveEngine) -> Result<Vec<u8>, String> {
    use bldc_drive::drive_core::Persist;
    e.to_bytes()
}

fn restored(lib: &PluginLibrary, bytes: &[u8]) -> Result<bldc_drive::drive::DriveEngine, String> {
    use bldc_drive::drive_core::Persist;
    let mut e = build_plugin(&DriveConfig::default(), lib).unwrap();
    e.restore_from(bytes)?;
    Ok(e)
}

#[test]
fn a_plugin_drive_saved_by_value_continues_bit_identically() {
    let lib = PluginLibrary::load(&example()).unwrap();
    let mut e = build_plugin(&DriveConfig::default(), &lib).unwrap();
    run_to(&mut e, 0.9, |_, _| {}).unwrap();
    let bytes = saved(&e).unwrap();
    let mut copy = restored(&lib, &bytes).unwrap();
    assert_eq!(saved(&copy).unwrap(), bytes);
    run_to(&mut e, 1.0, |_, _| {}).unwrap();
    run_to(&mut copy, 1.0, |_, _| {}).unwrap();
    assert_eq!(saved(&copy).unwrap(), saved(&e).unwrap());
    let o = (e.plant.observe(), copy.plant.observe());
    assert_eq!(o.0.speed_rpm.to_bits(), o.1.speed_rpm.to_bits());
    assert!(o.0.speed_rpm > 1000.0, "running: {} rpm", o.0.speed_rpm);
}

#[test]
fn a_plugin_that_cannot_save_or_misbehaves_in_save_or_restore_is_an_error_not_a_crash() {
    for (mode, says) in [
        ("minor-0", "strategy-abi 1.0, which has no save"),
        ("save-panic", "plugin panicked: deliberate panic in save"),
        ("save-huge", "rule: at most"),
    ] {
        let e = with_mode(mode, || {
            let lib = PluginLibrary::load(&misbehaving()).unwrap();
            let mut e = build_plugin(&DriveConfig::default(), &lib).unwrap();
            run_to(&mut e, 0.01, |_, _| {}).unwrap();
            saved(&e).unwrap_err()
        });
        assert!(
            e.contains("plugin `misbehaving`") && e.contains(says) && e.contains("rule"),
            "{mode}: {e}"
        );
    }
    let e = with_mode("restore-panic", || {
        let lib = PluginLibrary::load(&misbehaving()).unwrap();
        let e = build_plugin(&DriveConfig::default(), &lib).unwrap();
        let bytes = saved(&e).unwrap();
        restored(&lib, &bytes).err().unwrap()
    });
    assert!(e.contains("restore: plugin panicked"), "{e}");
    // Bytes the plugin does not accept: its own refusal, named.
    let e = with_mode("", || {
        let lib = PluginLibrary::load(&misbehaving()).unwrap();
        let e = build_plugin(&DriveConfig::default(), &lib).unwrap();
        let mut bytes = saved(&e).unwrap();
        let n = bytes.len();
        bytes[n - 1] = b'X';
        restored(&lib, &bytes).err().unwrap()
    });
    assert!(
        e.contains("plugin `misbehaving`") && e.contains("not a state"),
        "{e}"
    );
}
