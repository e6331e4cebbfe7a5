//! The packaged FMU, imported through the `fmi` crate, runs the example strategy plugin
//! packed into its resources (`cargo xtask fmu --plugin`) and named relatively by
//! `strategy.plugin`: it reproduces the built-in twelve-step-df it re-implements bit for
//! bit, a state taken while it runs continues bit-identically after serialization, and a
//! plugin that cannot be loaded is refused: by xtask before packing, with fmi2Error at
//! initialization.

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::{FmiImport, FmiInstance, FmiStatus};
use std::ffi::CString;
use std::path::PathBuf;
use std::sync::OnceLock;

mod common;

use common::{import, plugins, vr};

const H: f64 = 0.5e-3;
const SPEED_REF: f64 = 3500.0;
const LOAD_AT_STEP: u32 = 2000; // 1.0 s
const LOAD_NM: f64 = 1e-4;
const STEPS: u32 = 3000; // 1.5 s
// 0.9 s: past the alignment (0.75 s), running closed loop, before the load step.
const SAVE_AT_STEP: u32 = 1800;
const OUTPUTS: [&str; 5] = ["speed_rpm", "i_u", "duty", "state", "speed_est_rpm"];

/// The FMU with `plugin` packed as `resources/<its file name>`, written once to
/// `target/fmu/<file>` (its own file, so that the plain FMU other tests import is left
/// alone), imported.
fn import_packed(
    fmu: &'static OnceLock<Result<PathBuf, String>>,
    plugin: PathBuf,
    file: &str,
) -> Fmi2Import {
    let path = fmu.get_or_init(|| {
        let out = xtask::target_dir().join("fmu").join(file);
        xtask::package_fmu_with(Some(&plugin), &out)
    });
    let path = path
        .as_ref()
        .unwrap_or_else(|e| panic!("packaging the FMU with {} failed: {e}", plugin.display()));
    fmi::import::from_path(path).expect("the fmi crate imports the FMU")
}

/// The FMU with the example plugin packed as `resources/libexample_plugin.so`, imported.
fn import_with_plugin() -> Fmi2Import {
    static FMU: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    import_packed(&FMU, plugins::example(), "BldcDrive-example-plugin.fmu")
}

/// The name `strategy.plugin` gives the packed plugin: relative to the resources.
const PACKED: &str = "libexample_plugin.so";

fn text(s: &str) -> CString {
    CString::new(s).expect("no NUL in the path")
}

/// An initialized instance, with `strategy.plugin` = `plugin` if given.
fn start(import: &Fmi2Import, name: &str, plugin: Option<&str>) -> InstanceCS {
    let mut inst = import.instantiate_cs(name, false, true).unwrap();
    Common::set_real(&mut inst, &[vr(import, "speed_ref_rpm")], &[SPEED_REF]).unwrap();
    if let Some(p) = plugin {
        Common::set_string(&mut inst, &[vr(import, "strategy.plugin")], &[text(p)]).unwrap();
        // Item 1, six-step-120-df: ignored when a plugin is named, so a trace matching
        // twelve-step-df proves the plugin ran.
        Common::set_integer(&mut inst, &[vr(import, "strategy.name")], &[1]).unwrap();
    }
    FmiInstance::enter_initialization_mode(&mut inst, None, 0.0, None).unwrap();
    FmiInstance::exit_initialization_mode(&mut inst).unwrap();
    inst
}

/// `strategy.plugin` as fmi2GetString returns it.
fn plugin_of(import: &Fmi2Import, inst: &mut InstanceCS) -> String {
    let mut got = [CString::default()];
    Common::get_string(inst, &[vr(import, "strategy.plugin")], &mut got).unwrap();
    got[0].to_str().expect("UTF-8").to_owned()
}

/// Outputs now (speed, current, duty, commutation state, measured speed).
fn sample(import: &Fmi2Import, inst: &mut InstanceCS) -> [f64; 5] {
    let mut real = [0.0; 3];
    let reals = [OUTPUTS[0], OUTPUTS[1], OUTPUTS[2]].map(|n| vr(import, n));
    Common::get_real(inst, &reals, &mut real).unwrap();
    let mut int = [0; 1];
    Common::get_integer(inst, &[vr(import, "state")], &mut int).unwrap();
    let mut est = [0.0];
    Common::get_real(inst, &[vr(import, "speed_est_rpm")], &mut est).unwrap();
    [real[0], real[1], real[2], f64::from(int[0]), est[0]]
}

/// Steps `from..STEPS` (the load applied at its step) and samples every 10 ms.
fn run(import: &Fmi2Import, inst: &mut InstanceCS, from: u32) -> Vec<[f64; 5]> {
    let mut out = Vec::new();
    for k in from..STEPS {
        if k == LOAD_AT_STEP {
            Common::set_real(inst, &[vr(import, "load_torque_nm")], &[LOAD_NM]).unwrap();
        }
        inst.do_step(f64::from(k) * H, H, true).unwrap();
        if (k + 1) % 20 == 0 {
            out.push(sample(import, inst));
        }
    }
    out
}

#[test]
fn the_example_plugin_in_the_fmu_reproduces_the_builtin_strategy_bit_for_bit() {
    let import = import_with_plugin();
    let lib = PACKED;

    // The default strategy.name is twelve-step-df, the strategy the example wraps.
    let mut builtin = start(&import, "builtin", None);
    let reference = run(&import, &mut builtin, 0);

    let mut inst = start(&import, "plugin", Some(lib));
    assert_eq!(
        plugin_of(&import, &mut inst),
        lib,
        "fmi2GetString returns the path set"
    );

    let mut traced = run(&import, &mut inst, 0)[..(SAVE_AT_STEP / 20) as usize].to_vec();
    // Taken at 0.9 s by rerunning to it; serialized so the continuation starts from bytes.
    let mut again = start(&import, "again", Some(lib));
    for k in 0..SAVE_AT_STEP {
        again.do_step(f64::from(k) * H, H, true).unwrap();
    }
    let at_save = sample(&import, &mut again);
    assert!(
        at_save[3] != 0.0 && at_save[0] > 1000.0,
        "commutating closed loop at the save point: {at_save:?}"
    );
    let state = again.get_fmu_state().unwrap();
    let bytes = again.serialize_fmu_state(&state).unwrap();
    let unpacked = import
        .archive_path()
        .to_str()
        .expect("a UTF-8 path")
        .as_bytes();
    assert!(
        !bytes.windows(unpacked.len()).any(|w| w == unpacked),
        "no absolute path in the serialized state"
    );
    traced.extend(run(&import, &mut again, SAVE_AT_STEP));

    assert_eq!(traced.len(), reference.len());
    for (k, (a, b)) in traced.iter().zip(&reference).enumerate() {
        let bits = |x: &[f64; 5]| x.map(f64::to_bits);
        assert_eq!(
            bits(a),
            bits(b),
            "plugin vs built-in at t = {} s",
            (k + 1) as f64 * 0.01
        );
    }
    let peak = reference.iter().map(|r| r[0]).fold(0.0, f64::max);
    assert!(peak > 0.98 * SPEED_REF, "the drive reached {peak} rpm");
    assert!(
        reference.windows(2).filter(|w| w[0][3] != w[1][3]).count() > 50,
        "the commutation state moves"
    );
    assert!(
        reference.iter().any(|r| r[3] > 6.0),
        "twelve-step states (six-step has 1..6 only)"
    );

    // The serialized state, deserialized (the plugin loaded again) and restored in a
    // fresh instance, continues bit-identically to the end.
    let mut fresh = import.instantiate_cs("restored", false, true).unwrap();
    let s = fresh.deserialize_fmu_state(&bytes).unwrap();
    fresh.set_fmu_state(&s).ok().expect("state restored");
    let rest = run(&import, &mut fresh, SAVE_AT_STEP);
    assert_eq!(
        rest.last().map(|x| x.map(f64::to_bits)),
        reference.last().map(|x| x.map(f64::to_bits))
    );
    assert_eq!(
        plugin_of(&import, &mut fresh),
        lib,
        "the state carries the parameter"
    );
    for i in [&mut builtin, &mut inst, &mut again, &mut fresh] {
        FmiInstance::terminate(i).unwrap();
    }
}

#[test]
fn a_plugin_that_cannot_be_loaded_fails_initialization() {
    let import = import();
    let not_a_library =
        std::env::temp_dir().join(format!("fmu-not-a-plugin-{}.so", std::process::id()));
    std::fs::write(&not_a_library, "text, not a library").unwrap();
    for bad in ["/nonexistent/plugin.so", not_a_library.to_str().unwrap()] {
        let mut inst = import.instantiate_cs("bad", false, true).unwrap();
        Common::set_string(&mut inst, &[vr(&import, "strategy.plugin")], &[text(bad)]).unwrap();
        FmiInstance::enter_initialization_mode(&mut inst, None, 0.0, None).unwrap();
        assert!(
            FmiInstance::exit_initialization_mode(&mut inst).is_err(),
            "`{bad}` accepted as a plugin"
        );
        // Back to the built-in strategy, the same instance initializes and steps.
        Common::set_string(&mut inst, &[vr(&import, "strategy.plugin")], &[text("")]).unwrap();
        FmiInstance::exit_initialization_mode(&mut inst).unwrap();
        inst.do_step(0.0, H, true).unwrap();
    }
    std::fs::remove_file(&not_a_library).unwrap();
}

#[test]
fn xtask_refuses_a_missing_or_invalid_plugin_before_packing() {
    let dir = std::env::temp_dir().join(format!("fmu-xtask-plugin-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let not_a_library = dir.join("notes.so");
    std::fs::write(&not_a_library, "text, not a library").unwrap();
    let out = dir.join("Never.fmu");
    for (plugin, needle) in [
        (dir.join("missing.so"), "no such file"),
        (
            not_a_library,
            "rule: a strategy plugin built against strategy-abi",
        ),
    ] {
        let e = xtask::package_fmu_with(Some(&plugin), &out).unwrap_err();
        assert!(
            e.contains(&plugin.display().to_string()) && e.contains(needle),
            "{e}"
        );
        assert!(!out.exists(), "nothing written for {}", plugin.display());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The FMU with the C SDK's example plugin (`libc_six_step.so`, compiled by the system C
/// compiler) packed, imported.
fn import_with_c_plugin() -> Fmi2Import {
    static FMU: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    import_packed(&FMU, plugins::c_example(), "BldcDrive-c-plugin-test.fmu")
}

#[test]
fn the_c_plugin_in_the_fmu_starts_the_motor_and_a_restored_state_continues_bit_identically() {
    let import = import_with_c_plugin();
    let start_c = |name: &str| {
        let mut inst = import.instantiate_cs(name, false, true).unwrap();
        Common::set_real(&mut inst, &[vr(&import, "speed_ref_rpm")], &[3000.0]).unwrap();
        let plugin = text("libc_six_step.so");
        Common::set_string(&mut inst, &[vr(&import, "strategy.plugin")], &[plugin]).unwrap();
        FmiInstance::enter_initialization_mode(&mut inst, None, 0.0, None).unwrap();
        FmiInstance::exit_initialization_mode(&mut inst).unwrap();
        inst
    };
    let steps = |inst: &mut InstanceCS, from: u32, to: u32| {
        for k in from..to {
            inst.do_step(f64::from(k) * H, H, true).unwrap();
        }
    };
    // Saved at 0.9 s (the comparators took over at ~0.3 s), compared at 1.3 s.
    let (save_at, end) = (1800, 2600);
    let mut inst = start_c("c-plugin");
    steps(&mut inst, 0, save_at);
    let at_save = sample(&import, &mut inst);
    assert!(
        at_save[0] > 1000.0 && (1.0..=6.0).contains(&at_save[3]),
        "commutating on its crossings at the save point: {at_save:?}"
    );
    let state = inst.get_fmu_state().unwrap();
    let bytes = inst.serialize_fmu_state(&state).unwrap();
    steps(&mut inst, save_at, end);
    let uninterrupted = sample(&import, &mut inst);
    let mut fresh = import.instantiate_cs("restored", false, true).unwrap();
    let s = fresh.deserialize_fmu_state(&bytes).unwrap();
    fresh.set_fmu_state(&s).ok().expect("state restored");
    steps(&mut fresh, save_at, end);
    let restored = sample(&import, &mut fresh);
    assert_eq!(
        restored.map(f64::to_bits),
        uninterrupted.map(f64::to_bits),
        "{restored:?} vs {uninterrupted:?}"
    );
    assert!(uninterrupted[0] > 2500.0, "{uninterrupted:?}");
    for i in [&mut inst, &mut fresh] {
        FmiInstance::terminate(i).unwrap();
    }
}
