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
