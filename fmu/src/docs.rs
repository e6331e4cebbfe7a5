//! docs/fmu-variables.md: the variables table written from the same table as
//! `modelDescription.xml`, so the two cannot disagree. `cargo xtask fmu-docs` rewrites the
//! file; a test fails when the committed file differs.

use crate::variables::{EnumType, Kind, Variable, table};
use crate::xml::causality;
use std::fmt::Write;

/// The markdown text of docs/fmu-variables.md.
pub fn variables_markdown() -> String {
    let mut x = String::from(
        "# FMU variables\n\n\
         <!-- Generated from src/variables/table.rs by `cargo xtask fmu-docs`; do not edit. -->\n\n\
         Every variable of `BldcDrive.fmu`, in value-reference order, as `modelDescription.xml`\n\
         declares it. Bounds are inclusive (FMI); a rule `> 0` is declared with the smallest\n\
         positive double, `< 180` with the largest double below 180. Values outside the bounds\n\
         are refused when set, with a logger message naming the variable and the rule. Units:\n\
         see [fmu.md](fmu.md#units).\n\n\
         | vr | name | causality | variability | type | unit | start | min | max | description |\n\
         |---:|---|---|---|---|---|---:|---:|---:|---|\n",
    );
    for (vr, v) in table().iter().enumerate() {
        let (causality, variability, _) = causality(v);
        let _ = writeln!(
            x,
            "| {vr} | `{}` | {causality} | {variability} | {} | {} | {} | {} | {} | {} |",
            v.name,
            type_name(v.kind),
            v.unit,
            start(v),
            v.min.map_or(String::new(), |b| number(v.kind, b)),
            v.max.map_or(String::new(), |b| number(v.kind, b)),
            v.description.replace('|', "\\|"),
        );
    }
    x.push_str("\n## Enumerations\n\nItems count from 1 (`fmi2GetInteger`/`fmi2SetInteger`).\n");
    for t in EnumType::ALL {
        let _ = write!(x, "\n`{}`:", t.type_name());
        for (i, item) in t.items().iter().enumerate() {
            let _ = write!(
                x,
                " {} `{item}`{}",
                i + 1,
                if i + 1 < t.items().len() { "," } else { "" }
            );
        }
        x.push('\n');
    }
    x
}

fn type_name(kind: Kind) -> String {
    match kind {
        Kind::Real => "Real".into(),
        Kind::Integer => "Integer".into(),
        Kind::Boolean => "Boolean".into(),
        Kind::String => "String".into(),
        Kind::Enumeration(t) => t.type_name().into(),
    }
}

fn start(v: &Variable) -> String {
    if let Some(t) = v.start_text() {
        return format!("`\"{t}\"`");
    }
    match (v.kind, v.start()) {
        (_, None) => String::new(),
        (Kind::Boolean, Some(s)) => (s != 0.0).to_string(),
        (Kind::Enumeration(t), Some(s)) => {
            let items = t.items();
            format!("{} `{}`", s as i64, items[s as usize - 1])
        }
        (k, Some(s)) => number(k, s),
    }
}

/// As the model description writes it.
fn number(kind: Kind, x: f64) -> String {
    match kind {
        Kind::Real => format!("{x:?}"),
        _ => format!("{}", x as i64),
    }
}
