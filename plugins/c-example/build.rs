//! Compiles the C plugins with the system C compiler (found by the `cc` crate: `$CC`, else
//! `cc`) into shared libraries of their own, exactly as a firmware engineer's build would,
//! and copies them beside the Rust plugins (`target/<profile>/`), where the tests, the
//! FMU's scripts and Python find them. Also compiles `src/layout.c` (the struct layouts as
//! C sees them) into this crate for the layout test, and checks that the header is valid
//! C++ as well.

use std::path::{Path, PathBuf};
use std::process::Command;

const INSTALL: &str = "install a C and C++ compiler (Debian/Ubuntu: `apt-get install gcc g++`; \
    Fedora: `dnf install gcc gcc-c++`; macOS: `xcode-select --install`) or name one in $CC / $CXX";

fn run(mut cmd: Command, what: &str) {
    let shown = format!("{cmd:?}");
    match cmd.status() {
        Ok(s) if s.success() => {}
        Ok(s) => panic!("{what} failed ({s}): {shown}"),
        Err(e) => panic!("{what}: cannot run the compiler ({e}): {shown}\n{INSTALL}"),
    }
}

/// `src/<stem>.c` as `lib<stem>.so`, with every warning an error.
fn shared_library(cc: &cc::Tool, include: &Path, out: &Path, stem: &str) -> PathBuf {
    let so = out.join(format!("lib{stem}.so"));
    let mut cmd = cc.to_command();
    cmd.args([
        "-std=c99",
        "-Wall",
        "-Wextra",
        "-pedantic",
        "-Werror",
        "-O2",
        "-g",
    ])
    .args(["-fPIC", "-shared", "-fvisibility=hidden"])
    .arg("-I")
    .arg(include)
    .arg("-o")
    .arg(&so)
    .arg(format!("src/{stem}.c"))
    .arg("-lm");
    run(cmd, &format!("compiling src/{stem}.c"));
    so
}

fn main() {
    let include = PathBuf::from("../../strategy-abi/include");
    for f in [
        "build.rs",
        "src/c_six_step.c",
        "src/c_misbehaving.c",
        "src/layout.c",
        "../../strategy-abi/include/bldc_strategy.h",
    ] {
        println!("cargo:rerun-if-changed={f}");
    }
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let cc = cc::Build::new().get_compiler();
    let mut probe = cc.to_command();
    probe.arg("--version").stdout(std::process::Stdio::null());
    if !probe.status().is_ok_and(|s| s.success()) {
        panic!(
            "no working C compiler at `{}` (the C SDK's tests build the C plugins with it): {INSTALL}",
            cc.path().display()
        );
    }
    // OUT_DIR is <target>/<profile>/build/<pkg>-<hash>/out: the plugins go to <profile>/.
    let profile_dir = out
        .ancestors()
        .nth(3)
        .expect("OUT_DIR has the layout cargo gives it");
    for stem in ["c_six_step", "c_misbehaving"] {
        let so = shared_library(&cc, &include, &out, stem);
        let dest = profile_dir.join(so.file_name().unwrap());
        std::fs::copy(&so, &dest)
            .unwrap_or_else(|e| panic!("copying {} to {}: {e}", so.display(), dest.display()));
    }
    // The header as C++ (C++11, warnings as errors): it must stay valid in both languages.
    let cxx = cc::Build::new().cpp(true).get_compiler();
    let mut cmd = cxx.to_command();
    cmd.args([
        "-x",
        "c++",
        "-std=c++11",
        "-Wall",
        "-Wextra",
        "-pedantic",
        "-Werror",
    ])
    .args(["-fsyntax-only"])
    .arg(include.join("bldc_strategy.h"));
    run(cmd, "compiling bldc_strategy.h as C++11");
    // The layout table, linked into this crate.
    cc::Build::new()
        .file("src/layout.c")
        .include(&include)
        .std("c99")
        .warnings_into_errors(true)
        .compile("bldc_layout");
}
