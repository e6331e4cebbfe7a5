//! `cargo xtask <task>`: `fmu` packages target/fmu/BldcDrive.fmu.

fn main() {
    let task = std::env::args().nth(1).unwrap_or_default();
    let result = match task.as_str() {
        "fmu" => xtask::package_fmu().map(|p| println!("{}", p.display())),
        _ => Err(format!("unknown task `{task}` (tasks: fmu)")),
    };
    if let Err(e) = result {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
