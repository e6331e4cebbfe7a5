//! The plugin crates of the workspace, built on demand for the tests that load them.

use std::path::PathBuf;
use std::process::Command;
use std::sync::{Mutex, OnceLock};

/// Builds the plugin crates with the test profile (sharing the test build's artifacts)
/// and returns the folder holding the libraries. `c-example-plugin`'s build script
/// compiles the C plugins with the system C compiler and puts them there too.
pub fn plugin_dir() -> PathBuf {
    static BUILT: OnceLock<PathBuf> = OnceLock::new();
    BUILT
        .get_or_init(|| {
            let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
            let st = Command::new(cargo)
                .args([
                    "build",
                    "--profile",
                    "test",
                    "-p",
                    "example-plugin",
                    "-p",
                    "misbehaving-plugin",
                    "-p",
                    "c-example-plugin",
                ])
                .current_dir(env!("CARGO_MANIFEST_DIR"))
                .status()
                .expect("cargo runs");
            assert!(st.success(), "building the plugin crates failed");
            // Test binaries live in <target>/debug/deps; the libraries in <target>/debug.
            let exe = std::env::current_exe().unwrap();
            exe.parent().unwrap().parent().unwrap().to_path_buf()
        })
        .clone()
}

/// The example plugin (`example-twelve-step-df`).
pub fn example() -> PathBuf {
    plugin_dir().join("libexample_plugin.so")
}

/// The misbehaving test fixture.
pub fn misbehaving() -> PathBuf {
    plugin_dir().join("libmisbehaving_plugin.so")
}

/// The C SDK's example plugin (`c-six-step`), compiled by the system C compiler.
pub fn c_example() -> PathBuf {
    plugin_dir().join("libc_six_step.so")
}

/// The C misbehaving test fixture (`c-misbehaving`).
pub fn c_misbehaving() -> PathBuf {
    plugin_dir().join("libc_misbehaving.so")
}

/// Serialises the tests that steer the misbehaving fixtures through the environment.
static ENV: Mutex<()> = Mutex::new(());

/// Runs `f` with the misbehaving fixtures set to `mode` (`BLDC_TEST_MISBEHAVE`), one test
/// at a time: the fixtures read the variable from their own code, outside std's lock of
/// the environment. Kept out of the integration binary's tests, which set no variable.
#[allow(unsafe_code)] // setting the environment; crates that include this file deny unsafe
pub fn with_mode<R>(mode: &str, f: impl FnOnce() -> R) -> R {
    let _g = ENV.lock().unwrap_or_else(|e| e.into_inner());
    // SAFETY: every reader of this variable runs under the same lock.
    unsafe { std::env::set_var("BLDC_TEST_MISBEHAVE", mode) };
    let r = f();
    unsafe { std::env::remove_var("BLDC_TEST_MISBEHAVE") };
    r
}
