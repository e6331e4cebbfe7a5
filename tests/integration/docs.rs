//! The documentation stays true to the code: the metric and column reference in
//! `docs/outputs.md` is the report's own (regenerated with `UPDATE_DOCS=1 cargo test --test
//! docs`), every summary key and trace column is documented, and the README, ARCHITECTURE.md
//! and `docs/` stand alone: their relative links resolve inside the project, and the files
//! ARCHITECTURE.md names exist.

use bldc_drive::DriveConfig;
use bldc_drive::bench::Plan;
use bldc_drive::bench::report::metrics_reference;
use bldc_drive::scenario::{Scenario, TraceRow, run};
use std::path::{Path, PathBuf};

const BEGIN: &str = "<!-- generated from src/bench/report.rs (metrics_reference); `UPDATE_DOCS=1 cargo test --test integration docs::` rewrites it -->\n";
const END: &str = "<!-- end of generated part -->";

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

#[test]
fn metric_reference_is_current() {
    let path = root().join("docs/outputs.md");
    let doc = read("docs/outputs.md");
    let (head, rest) = doc
        .split_once(BEGIN)
        .expect("the generated part's start marker");
    let (_, tail) = rest
        .split_once(END)
        .expect("the generated part's end marker");
    let want = format!(
        "{head}{BEGIN}{}\n{END}{tail}",
        metrics_reference(Plan::default().grid_duration_s)
    );
    if want != doc {
        if std::env::var_os("UPDATE_DOCS").is_some() {
            std::fs::write(&path, want).unwrap();
        } else {
            panic!(
                "docs/outputs.md's metric reference is stale: run `UPDATE_DOCS=1 cargo test --test integration docs::`"
            );
        }
    }
}

#[test]
fn every_summary_key_and_trace_column_is_documented() {
    let doc = read("docs/outputs.md");
    let sc = Scenario::hold(DriveConfig::default(), 3000.0, 0.05);
    let summary = serde_json::to_value(run(&sc, |_| {}).unwrap().summary).unwrap();
    let keys = summary.as_object().unwrap().keys().cloned();
    let columns = TraceRow::HEADER.split(',').map(String::from);
    let missing: Vec<String> = keys
        .chain(columns)
        .filter(|k| !doc.contains(&format!("`{k}`")))
        .collect();
    assert!(missing.is_empty(), "docs/outputs.md lacks {missing:?}");
}

/// Every Markdown file the project ships for readers.
fn reader_docs() -> Vec<PathBuf> {
    let mut files = ["README.md", "CHANGELOG.md", "ARCHITECTURE.md"]
        .map(|f| root().join(f))
        .to_vec();
    for e in std::fs::read_dir(root().join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            files.push(p);
        }
    }
    files
}

#[test]
fn docs_stand_alone() {
    let mut broken = Vec::new();
    for file in reader_docs() {
        let text = std::fs::read_to_string(&file).unwrap();
        let name = file.strip_prefix(root()).unwrap().display().to_string();
        assert!(
            !text.contains("../shared") && !text.contains("SPEC"),
            "{name} points outside the project"
        );
        // Relative links `](path)` or `](path#anchor)` must name a file of the project.
        for link in text.split("](").skip(1) {
            let target = link.split(')').next().unwrap_or("");
            let path = target.split('#').next().unwrap_or("");
            if path.is_empty() || path.contains("://") || path.starts_with("mailto:") {
                continue;
            }
            if !file.parent().unwrap().join(path).exists() {
                broken.push(format!("{name}: {target}"));
            }
        }
    }
    assert!(broken.is_empty(), "broken links: {broken:?}");
}

/// The READMEs show the examples the test command runs, as they are (without their `//!`
/// header), so its code cannot rot.
#[test]
fn readme_examples_are_the_files() {
    let readme = read("README.md");
    let rust: String = read("examples/library.rs")
        .lines()
        .filter(|l| !l.starts_with("//!"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(
        readme.contains(&format!("```rust\n{rust}```")),
        "README.md must show examples/library.rs as it is"
    );
    let python = read("examples/fmu/quickstart.py");
    assert!(
        readme.contains(&format!("```python\n{python}```")),
        "README.md must show examples/fmu/quickstart.py as it is"
    );
    let cases = read("examples/sweep.json");
    assert!(
        read("python/README.md").contains(&format!("```json\n{cases}```")),
        "python/README.md must show examples/sweep.json as it is"
    );
}

/// The files ARCHITECTURE.md names in code spans (`tests/integration/summary.rs`, `scripts/test.sh`)
/// exist: the map names code by module and type, and the tests and scripts by path.
#[test]
fn the_files_architecture_md_names_exist() {
    let text = read("ARCHITECTURE.md");
    let mut missing = Vec::new();
    let mut named = 0;
    for span in text.split('`').skip(1).step_by(2) {
        let path = span.split_whitespace().next().unwrap_or("");
        let is_file = [".rs", ".md", ".sh", ".json"]
            .iter()
            .any(|x| path.ends_with(x));
        if is_file && path.contains('/') {
            named += 1;
            if !root().join(path).exists() {
                missing.push(path.to_string());
            }
        }
    }
    assert!(named > 10, "only {named} paths found: the parse broke");
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md names missing files: {missing:?}"
    );
}
