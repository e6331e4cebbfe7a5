//! Shared helpers of the importer tests: the packaged FMU and its value references.
#![allow(dead_code)]

use fmi::fmi2::import::Fmi2Import;
use fmi::traits::FmiImport;
use std::path::PathBuf;
use std::sync::OnceLock;

/// The workspace's plugin crates, built on demand (the root tests' helper, not a copy).
#[path = "../../../tests/common/plugins.rs"]
pub mod plugins;

/// Packages the FMU once per test process (tests run in parallel) and imports it.
pub fn import() -> Fmi2Import {
    static FMU: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    let path = FMU.get_or_init(xtask::package_fmu);
    let path = path
        .as_ref()
        .unwrap_or_else(|e| panic!("packaging the FMU failed: {e}"));
    fmi::import::from_path(path).expect("the fmi crate imports the FMU")
}

/// The value reference of `name`, as modelDescription.xml gives it.
pub fn vr(import: &Fmi2Import, name: &str) -> u32 {
    let md = import.model_description();
    md.model_variables
        .variables
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("`{name}` is in modelDescription.xml"))
        .value_reference
}
