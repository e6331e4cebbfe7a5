//! Project tasks. `cargo xtask fmu` builds the FMU library in release mode and packages
//! `target/fmu/BldcDrive.fmu`: `modelDescription.xml` (written by the fmu crate from its
//! variable table) and `binaries/linux64/bldc_drive.so`. Tests call [`package_fmu`] too.

pub mod zip;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from(".."), Path::to_path_buf)
}

/// The target directory cargo uses.
pub fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root().join("target"), PathBuf::from)
}

/// Builds the release library and the model-description tool, writes the FMU, returns its
/// path.
pub fn package_fmu() -> Result<PathBuf, String> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(&cargo)
        .current_dir(root())
        .args([
            "build",
            "--release",
            "--package",
            "fmu",
            "--lib",
            "--bins",
            "--examples",
        ])
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("cargo build of the fmu crate failed ({status})"));
    }
    let release = target_dir().join("release");
    let xml = Command::new(release.join("model-description"))
        .output()
        .map_err(|e| format!("cannot run model-description: {e}"))?;
    if !xml.status.success() {
        return Err("model-description failed".into());
    }
    let so = shared_object(&release.join("libfmu.so"))?;
    let zip = zip::archive(&[
        ("modelDescription.xml", &xml.stdout),
        ("binaries/linux64/bldc_drive.so", &so),
    ])?;
    let dir = target_dir().join("fmu");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let out = dir.join("BldcDrive.fmu");
    // Written beside and renamed, so a reader never sees half an archive.
    let tmp = dir.join(format!(".BldcDrive.fmu.{}", std::process::id()));
    std::fs::write(&tmp, zip).map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, &out).map_err(|e| format!("{}: {e}", out.display()))?;
    Ok(out)
}

/// The library without its debug info (the release profile keeps it for profiling; it
/// would make the FMU ten times larger). Unstripped, with a note, when `strip` is missing.
fn shared_object(path: &Path) -> Result<Vec<u8>, String> {
    let stripped = path.with_extension("stripped.so");
    let ok = Command::new("strip")
        .arg("--strip-debug")
        .arg("-o")
        .arg(&stripped)
        .arg(path)
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        eprintln!("note: `strip` (binutils) unavailable, the FMU keeps its debug info");
    }
    let src = if ok { &stripped } else { path };
    std::fs::read(src).map_err(|e| format!("{}: {e}", src.display()))
}
