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

/// docs/model.md's table of bounds a combined rule refuses with the other defaults is the
/// descriptions' (which `variables` checks against the rules): a row for each such
/// variable, with each of its limits, and no other row.
#[test]
fn the_model_docs_list_the_bounds_the_descriptions_tie() {
    const TIED: &str = "with the other defaults";
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/model.md");
    let model = std::fs::read_to_string(&path).unwrap();
    let section = &model[model
        .find("| key | documented range | with the other defaults |")
        .unwrap()..];
    let rows: Vec<&str> = section
        .lines()
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .collect();
    let mut tied = 0;
    for v in fmu::variables::table() {
        let Some(at) = v.description.find(TIED) else {
            continue;
        };
        tied += 1;
        let row = rows
            .iter()
            .find(|r| r.starts_with(&format!("| `{}` |", v.name)))
            .unwrap_or_else(|| panic!("{}: no row in docs/model.md", v.name));
        let rest = &v.description[at + TIED.len()..];
        for phrase in ["at least", "at most", "above", "below"] {
            for (i, _) in rest.match_indices(&format!(" {phrase} ")) {
                let number: String = rest[i + phrase.len() + 2..]
                    .chars()
                    .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | '-'))
                    .collect();
                let limit = format!("{phrase} {}", number.trim_end_matches('.'));
                assert!(row.contains(&limit), "{}: `{limit}` not in {row}", v.name);
            }
        }
    }
    assert_eq!(rows.len(), tied, "{rows:#?}");
}
