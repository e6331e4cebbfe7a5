//! Project tasks. `cargo xtask fmu` builds the FMU library (release profile, or the one
//! `FMU_PROFILE` names) and packages
//! `target/fmu/BldcDrive.fmu`: `modelDescription.xml` (written by the fmu crate from its
//! variable table) and `binaries/linux64/bldc_drive.so`; `--plugin PATH` adds a strategy
//! plugin as `resources/<file name>`. `cargo xtask fmu-docs` writes docs/fmu-variables.md.
//! Tests call [`package_fmu`] and [`package_fmu_with`] too.

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

/// The cargo profile the FMU is built with: `FMU_PROFILE` if set, else `release` (what
/// ships: fat LTO, one codegen unit). scripts/test.sh sets `dev` (optimised, and shared
/// with the test profile and the test command's Python wheel), so CI compiles the
/// workspace once for all three without minutes of LTO; the drive's figures are the same,
/// bit for bit (no fast-math).
pub fn fmu_profile() -> Result<String, String> {
    let p = std::env::var("FMU_PROFILE").unwrap_or_else(|_| "release".into());
    let ok = !p.is_empty()
        && p.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    if ok {
        Ok(p)
    } else {
        Err(format!(
            "FMU_PROFILE = `{p}` (rule: a cargo profile name: letters, digits, - and _)"
        ))
    }
}

/// Where cargo puts a profile's build.
fn profile_dir(profile: &str) -> PathBuf {
    target_dir().join(match profile {
        "dev" | "test" => "debug",
        "release" | "bench" => "release",
        p => p,
    })
}

/// Builds the library and the model-description tool, writes the FMU, returns its path.
pub fn package_fmu() -> Result<PathBuf, String> {
    package_fmu_with(None, &fmu_path())
}

/// Where `cargo xtask fmu` writes the FMU unless told otherwise.
pub fn fmu_path() -> PathBuf {
    target_dir().join("fmu").join("BldcDrive.fmu")
}

/// As [`package_fmu`], to `out`, with the strategy plugin `plugin` packed as
/// `resources/<its file name>` when given. The plugin is checked (a file the FMU's loader
/// accepts) before anything is written.
pub fn package_fmu_with(plugin: Option<&Path>, out: &Path) -> Result<PathBuf, String> {
    // A missing file is reported before the build, an invalid one before packing.
    let name = plugin.map(plugin_name).transpose()?;
    let profile = fmu_profile()?;
    build_fmu_crate(&profile)?;
    let built = profile_dir(&profile);
    let tool = built.join("model-description");
    let mut entries: Vec<(String, Vec<u8>)> = Vec::new();
    if let (Some(p), Some(name)) = (plugin, name) {
        entries.push(plugin_entry(&tool, p, name)?);
    }
    let xml = run(&mut Command::new(&tool))?;
    let so = shared_object(&built.join("libfmu.so"))?;
    entries.insert(0, ("modelDescription.xml".into(), xml));
    entries.insert(1, ("binaries/linux64/bldc_drive.so".into(), so));
    let refs: Vec<(&str, &[u8])> = entries
        .iter()
        .map(|(n, b)| (n.as_str(), b.as_slice()))
        .collect();
    let zip = zip::archive(&refs)?;
    let dir = out.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    // Written beside and renamed, so a reader never sees half an archive.
    let name = out
        .file_name()
        .map_or_else(|| "fmu".into(), |n| n.to_string_lossy());
    let tmp = dir.join(format!(".{name}.{}", std::process::id()));
    std::fs::write(&tmp, zip).map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, out).map_err(|e| format!("{}: {e}", out.display()))?;
    Ok(out.to_path_buf())
}

/// Writes docs/fmu-variables.md from the variable table; returns its path.
pub fn write_fmu_docs() -> Result<PathBuf, String> {
    let profile = fmu_profile()?;
    build_fmu_crate(&profile)?;
    let tool = profile_dir(&profile).join("model-description");
    let text = run(Command::new(tool).arg("--variables-md"))?;
    let out = root().join("docs").join("fmu-variables.md");
    std::fs::write(&out, text).map_err(|e| format!("{}: {e}", out.display()))?;
    Ok(out)
}

fn build_fmu_crate(profile: &str) -> Result<(), String> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(&cargo)
        .current_dir(root())
        .args([
            "build",
            "--profile",
            profile,
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
    Ok(())
}

/// Runs a tool, returns its stdout; its stderr (the error) on failure.
fn run(cmd: &mut Command) -> Result<Vec<u8>, String> {
    let out = cmd
        .output()
        .map_err(|e| format!("cannot run {:?}: {e}", cmd.get_program()))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(err.trim().trim_start_matches("error: ").to_string());
    }
    Ok(out.stdout)
}

/// The file name a plugin is packed under, once the file is known to exist.
fn plugin_name(plugin: &Path) -> Result<&str, String> {
    let name = plugin
        .file_name()
        .and_then(|n| n.to_str())
        .filter(|n| !n.is_empty() && n.is_ascii())
        .ok_or_else(|| {
            format!(
                "--plugin {}: no ASCII file name (rule: a plugin library such as libexample_plugin.so)",
                plugin.display()
            )
        })?;
    if !plugin.is_file() {
        return Err(format!(
            "--plugin {}: no such file (rule: an existing strategy plugin library)",
            plugin.display()
        ));
    }
    Ok(name)
}

/// The archive entry of a plugin: `resources/<name>` and its bytes, once the FMU's own
/// loader has accepted the file (`model-description --check-plugin`).
fn plugin_entry(tool: &Path, plugin: &Path, name: &str) -> Result<(String, Vec<u8>), String> {
    run(Command::new(tool).arg("--check-plugin").arg(plugin))?;
    let bytes = std::fs::read(plugin).map_err(|e| format!("--plugin {}: {e}", plugin.display()))?;
    Ok((format!("resources/{name}"), bytes))
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
