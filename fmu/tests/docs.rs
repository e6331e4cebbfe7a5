//! docs/fmu-variables.md is the table the code writes (one source of truth).

#[test]
fn the_committed_variables_table_is_the_generated_one() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/fmu-variables.md");
    let committed = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (write it with `cargo xtask fmu-docs`)",
            path.display()
        )
    });
    let generated = fmu::docs::variables_markdown();
    assert!(
        committed == generated,
        "{} differs from the variable table; update it with `cargo xtask fmu-docs`",
        path.display()
    );
    // The table is the description's: every variable and item appears.
    for v in fmu::variables::table() {
        assert!(
            committed.contains(&format!("| `{}` |", v.name)),
            "{}",
            v.name
        );
    }
    assert!(committed.contains("`twelve_step_df`"));
}

#[test]
fn the_generation_date_comes_from_source_date_epoch() {
    let tool = env!("CARGO_BIN_EXE_model-description");
    let run = |epoch: &str| {
        std::process::Command::new(tool)
            .env("SOURCE_DATE_EPOCH", epoch)
            .output()
            .unwrap()
    };
    let out = run("1700000000");
    assert!(out.status.success());
    let xml = String::from_utf8(out.stdout).unwrap();
    // `date -u -d @1700000000`: 2023-11-14 22:13:20 UTC.
    assert!(xml.contains("generationDateAndTime=\"2023-11-14T22:13:20Z\""));
    assert_eq!(
        run("1700000000").stdout,
        xml.as_bytes(),
        "the same bytes again"
    );
    let bad = run("yesterday");
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("SOURCE_DATE_EPOCH = \"yesterday\"") && err.contains("rule"),
        "{err}"
    );
}
