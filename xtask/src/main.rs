//! `cargo xtask <task>`: `fmu [--plugin PATH [--out FILE]]` packages
//! target/fmu/BldcDrive.fmu (with a strategy plugin in its resources; to FILE instead if
//! given); `fmu-docs` writes docs/fmu-variables.md.

use std::path::PathBuf;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["fmu"] => xtask::package_fmu().map(|p| println!("{}", p.display())),
        ["fmu", "--plugin", path] => fmu_with_plugin(path, xtask::fmu_path()),
        ["fmu", "--plugin", path, "--out", out] => fmu_with_plugin(path, PathBuf::from(out)),
        ["fmu-docs"] => xtask::write_fmu_docs().map(|p| println!("{}", p.display())),
        _ => Err(format!(
            "unknown arguments `{}` (tasks: fmu, fmu --plugin PATH [--out FILE], fmu-docs)",
            args.join(" ")
        )),
    };
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

/// `fmu --plugin PATH [--out FILE]`: the FMU with the plugin packed, and how to select it.
fn fmu_with_plugin(path: &str, out: PathBuf) -> Result<(), String> {
    let plugin = PathBuf::from(path);
    xtask::package_fmu_with(Some(&plugin), &out).map(|p| {
        println!("{}", p.display());
        let name = plugin.file_name().unwrap_or_default().to_string_lossy();
        eprintln!(
            "note: select it with strategy.plugin = \"{name}\" (relative to the FMU's resources)"
        );
    })
}
