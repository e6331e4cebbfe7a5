//! `modelDescription.xml` and the GUID, both generated from the variable table.
//!
//! The GUID is a hash of the table's own text (units, types, variables with their start
//! values and ranges), so the binary and the XML always agree, and any change of a variable
//! or a default gives a new GUID.

use crate::variables::{EnumType, Kind, Output, Role, Variable, table};
use std::fmt::Write;
use std::sync::OnceLock;

/// `CoSimulation@modelIdentifier`: the base name of the binary in the FMU.
pub const MODEL_IDENTIFIER: &str = "bldc_drive";
/// `fmiModelDescription@modelName`.
pub const MODEL_NAME: &str = "BldcDrive";

/// Log categories (`<LogCategories>`); every logger call names one of them.
pub const LOG_CATEGORIES: [(&str, &str); 3] = [
    (
        "logStatusError",
        "Errors: a call refused, a bad value, a broken rule (on unless switched off)",
    ),
    (
        "logStatusWarning",
        "Warnings: a value clamped (on unless switched off)",
    ),
    (
        "logEvents",
        "Instance life cycle and state restores (on with loggingOn)",
    ),
];

/// The GUID of this model: `{…}` around 128 bits of FNV-1a over the table's text.
pub fn guid() -> &'static str {
    static GUID: OnceLock<String> = OnceLock::new();
    GUID.get_or_init(|| {
        let text = table_text();
        let a = fnv1a(text.as_bytes(), 0xcbf2_9ce4_8422_2325);
        let b = fnv1a(text.as_bytes(), a ^ 0x9e37_79b9_7f4a_7c15);
        format!(
            "{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}",
            a >> 32,
            (a >> 16) & 0xffff,
            a & 0xffff,
            b >> 48,
            b & 0xffff_ffff_ffff
        )
    })
}

/// FNV-1a, 64 bit, from `seed`.
fn fnv1a(bytes: &[u8], seed: u64) -> u64 {
    bytes.iter().fold(seed, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// The complete model description, generated at `generated` (seconds since 1970 UTC, see
/// [`generation_time`]).
pub fn model_description(generated: u64) -> String {
    let mut x = String::new();
    x.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        x,
        "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"{MODEL_NAME}\" guid=\"{}\"\n  \
         description=\"Sensorless BLDC drive: the published spindle motor on a six-switch bridge with diodes and sensing, driven by the twelve-step sensorless chip\"\n  \
         author=\"{}\" license=\"{}\" version=\"{}\"\n  \
         generationTool=\"bldc-drive xtask\" generationDateAndTime=\"{}\"\n  \
         variableNamingConvention=\"structured\" numberOfEventIndicators=\"0\">",
        guid(),
        esc(&env!("CARGO_PKG_AUTHORS").replace(':', ", ")),
        esc(env!("CARGO_PKG_LICENSE")),
        env!("CARGO_PKG_VERSION"),
        utc_date_time(generated),
    );
    let _ = writeln!(
        x,
        "  <CoSimulation modelIdentifier=\"{MODEL_IDENTIFIER}\" canHandleVariableCommunicationStepSize=\"true\" \
         canInterpolateInputs=\"false\" canBeInstantiatedOnlyOncePerProcess=\"false\" \
         canNotUseMemoryManagementFunctions=\"true\" canGetAndSetFMUstate=\"true\" canSerializeFMUstate=\"true\" \
         providesDirectionalDerivative=\"false\"/>"
    );
    x.push_str(&units_and_types());
    x.push_str("  <LogCategories>\n");
    for (name, desc) in LOG_CATEGORIES {
        let _ = writeln!(
            x,
            "    <Category name=\"{name}\" description=\"{}\"/>",
            esc(desc)
        );
    }
    x.push_str("  </LogCategories>\n");
    x.push_str("  <DefaultExperiment startTime=\"0\" stopTime=\"3\" stepSize=\"0.001\"/>\n");
    x.push_str(&variables_text());
    x.push_str(&structure_text());
    x.push_str("</fmiModelDescription>\n");
    x
}

/// When the description is generated: `SOURCE_DATE_EPOCH` (seconds since 1970 UTC) when
/// set, so that a reproducible build writes the same bytes; else now.
pub fn generation_time() -> Result<u64, String> {
    match std::env::var("SOURCE_DATE_EPOCH") {
        Ok(s) => s.trim().parse().map_err(|e| {
            format!(
                "SOURCE_DATE_EPOCH = {s:?} ({e}) (rule: whole seconds since 1970-01-01 UTC, >= 0)"
            )
        }),
        Err(std::env::VarError::NotPresent) => std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_secs())
            .map_err(|e| format!("the system clock is before 1970 ({e})")),
        Err(e) => Err(format!(
            "SOURCE_DATE_EPOCH: {e} (rule: whole seconds since 1970-01-01 UTC)"
        )),
    }
}

/// `secs` since 1970 as an xs:dateTime in UTC, e.g. `2023-11-14T22:13:20Z`.
fn utc_date_time(secs: u64) -> String {
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (the proleptic Gregorian calendar, in 400-year
    // eras of 146 097 days, with years starting in March so leap days come last).
    let z = days + 719_468;
    let era = z / 146_097;
    let doe = z % 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + u64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

/// Units, types and variables: the part of the description the GUID is taken from.
fn table_text() -> String {
    units_and_types() + &variables_text()
}

fn units_and_types() -> String {
    let mut x = String::new();
    x.push_str("  <UnitDefinitions>\n");
    let mut units: Vec<&str> = table()
        .iter()
        .filter(|v| v.kind == Kind::Real)
        .map(|v| v.unit)
        .collect();
    units.sort_unstable();
    units.dedup();
    for u in units {
        let _ = writeln!(x, "    <Unit name=\"{}\">{}</Unit>", esc(u), base_unit(u));
    }
    x.push_str("  </UnitDefinitions>\n  <TypeDefinitions>\n");
    for t in EnumType::ALL {
        let _ = writeln!(
            x,
            "    <SimpleType name=\"{}\">\n      <Enumeration>",
            t.type_name()
        );
        for (i, item) in t.items().iter().enumerate() {
            let _ = writeln!(
                x,
                "        <Item name=\"{}\" value=\"{}\"/>",
                esc(item),
                i + 1
            );
        }
        x.push_str("      </Enumeration>\n    </SimpleType>\n");
    }
    x.push_str("  </TypeDefinitions>\n");
    x
}

/// SI base-unit exponents and factor of every unit the table uses.
fn base_unit(unit: &str) -> &'static str {
    match unit {
        "rpm" => "<BaseUnit rad=\"1\" s=\"-1\" factor=\"0.10471975511965977\"/>",
        "rad/s" => "<BaseUnit rad=\"1\" s=\"-1\"/>",
        "rpm/s" => "<BaseUnit rad=\"1\" s=\"-2\" factor=\"0.10471975511965977\"/>",
        "deg" => "<BaseUnit rad=\"1\" factor=\"0.017453292519943295\"/>",
        "N.m" => "<BaseUnit kg=\"1\" m=\"2\" s=\"-2\"/>",
        "N.m.s/rad" => "<BaseUnit kg=\"1\" m=\"2\" s=\"-1\" rad=\"-1\"/>",
        "kg.m2" => "<BaseUnit kg=\"1\" m=\"2\"/>",
        "A" => "<BaseUnit A=\"1\"/>",
        "1/A" => "<BaseUnit A=\"-1\"/>",
        "A/rpm" => "<BaseUnit A=\"1\" s=\"1\" rad=\"-1\" factor=\"9.549296585513721\"/>",
        "V" => "<BaseUnit kg=\"1\" m=\"2\" s=\"-3\" A=\"-1\"/>",
        "Wb" => "<BaseUnit kg=\"1\" m=\"2\" s=\"-2\" A=\"-1\"/>",
        "H" => "<BaseUnit kg=\"1\" m=\"2\" s=\"-2\" A=\"-2\"/>",
        "Ohm" => "<BaseUnit kg=\"1\" m=\"2\" s=\"-3\" A=\"-2\"/>",
        "s" => "<BaseUnit s=\"1\"/>",
        "Hz" => "<BaseUnit s=\"-1\"/>",
        _ => "<BaseUnit/>",
    }
}

fn variables_text() -> String {
    let mut x = String::from("  <ModelVariables>\n");
    for (vr, v) in table().iter().enumerate() {
        let (causality, variability, initial) = causality(v);
        let _ = write!(
            x,
            "    <ScalarVariable name=\"{}\" valueReference=\"{vr}\" description=\"{}\" causality=\"{causality}\" variability=\"{variability}\"",
            esc(v.name),
            esc(v.description)
        );
        if let Some(i) = initial {
            let _ = write!(x, " initial=\"{i}\"");
        }
        let _ = writeln!(x, ">\n      {}\n    </ScalarVariable>", type_element(v));
    }
    x.push_str("  </ModelVariables>\n");
    x
}

/// `causality`, `variability` and `initial` of a variable.
pub(crate) fn causality(v: &Variable) -> (&'static str, &'static str, Option<&'static str>) {
    match v.role {
        Role::Parameter { .. } | Role::Text(_) => ("parameter", "fixed", Some("exact")),
        Role::Input(_) => ("input", discrete_unless_real(v), None),
        // The chip's measurement and duty change only at its updates: piecewise constant.
        Role::Output(Output::SpeedEstRpm | Output::Duty) => {
            ("output", "discrete", Some("calculated"))
        }
        Role::Output(_) => ("output", discrete_unless_real(v), Some("calculated")),
    }
}

fn discrete_unless_real(v: &Variable) -> &'static str {
    if v.kind == Kind::Real {
        "continuous"
    } else {
        "discrete"
    }
}

fn type_element(v: &Variable) -> String {
    if v.kind == Kind::String {
        let start = v.start_text().unwrap_or_default();
        return format!("<String start=\"{}\"/>", esc(start));
    }
    let mut attrs = String::new();
    if let Kind::Enumeration(t) = v.kind {
        let _ = write!(attrs, " declaredType=\"{}\"", t.type_name());
    }
    if v.kind == Kind::Real {
        let _ = write!(attrs, " unit=\"{}\"", esc(v.unit));
    }
    let num = |x: f64| match v.kind {
        Kind::Real => format!("{x:?}"),
        _ => format!("{}", x as i64),
    };
    if v.kind != Kind::Boolean {
        if let Some(m) = v.min {
            let _ = write!(attrs, " min=\"{}\"", num(m));
        }
        if let Some(m) = v.max {
            let _ = write!(attrs, " max=\"{}\"", num(m));
        }
    }
    if let Some(s) = v.start() {
        let s = match v.kind {
            Kind::Boolean => (if s != 0.0 { "true" } else { "false" }).to_string(),
            _ => num(s),
        };
        let _ = write!(attrs, " start=\"{s}\"");
    }
    let tag = match v.kind {
        Kind::Real => "Real",
        Kind::Integer => "Integer",
        Kind::Boolean => "Boolean",
        Kind::String => "String",
        Kind::Enumeration(_) => "Enumeration",
    };
    format!("<{tag}{attrs}/>")
}

/// Outputs have no direct feedthrough (inputs act during the next step), so
/// `dependencies=""`; at initialization they depend on the parameters and inputs.
fn structure_text() -> String {
    let outputs: Vec<usize> = table()
        .iter()
        .enumerate()
        .filter(|(_, v)| matches!(v.role, Role::Output(_)))
        .map(|(i, _)| i + 1)
        .collect();
    let mut x = String::from("  <ModelStructure>\n    <Outputs>\n");
    for i in &outputs {
        let _ = writeln!(x, "      <Unknown index=\"{i}\" dependencies=\"\"/>");
    }
    x.push_str("    </Outputs>\n    <InitialUnknowns>\n");
    for i in &outputs {
        let _ = writeln!(x, "      <Unknown index=\"{i}\"/>");
    }
    x.push_str("    </InitialUnknowns>\n  </ModelStructure>\n");
    x
}

/// Escapes text for an XML attribute.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guid_is_stable_braced_and_in_the_xml() {
        let g = guid();
        assert_eq!(g.len(), 38);
        assert!(g.starts_with('{') && g.ends_with('}'));
        assert!(model_description(0).contains(&format!("guid=\"{g}\"")));
        assert_ne!(fnv1a(b"a", 1), fnv1a(b"b", 1));
    }

    #[test]
    fn every_variable_appears_once_with_its_start_value() {
        let x = model_description(0);
        for (vr, v) in table().iter().enumerate() {
            let tag = format!("name=\"{}\" valueReference=\"{vr}\"", esc(v.name));
            assert_eq!(x.matches(&tag).count(), 1, "{}", v.name);
        }
        assert!(x.contains("name=\"motor.resistance_ohm\""));
        assert!(x.contains("<Real unit=\"Ohm\" min=\"0.0001\" max=\"1000.0\" start=\"2.2\"/>"));
        // Appended after the plugin, in this order, so that every older variable kept its
        // value reference.
        let appended = [
            "control.speed_anti_windup",
            "control.speed_anti_windup_gain",
            "in_sync",
            "control.supervisor",
            "control.supervisor_no_load_rpm",
            "control.supervisor_emf_fraction",
            "control.supervisor_current_a",
            "control.supervisor_updates",
            "control.supervisor_coast_rise",
            "control.supervisor_locked_rotor_a",
            "control.supervisor_locked_share",
            "control.startup_confirm_deg",
            "control.startup_conduction_deg",
            "control.supervisor_blind_sectors",
            "strategy.lm_window_capped",
            "verdict",
            "control.current_reads",
            "control.speed_window_s",
            "control.gain_schedule",
            "control.schedule_min_duty",
            "control.stop_at_zero",
            "control.align_current_a",
            "control.start_phase_current_a",
            "control.speed_resume",
            "control.start_descent_rpm_s",
        ];
        let n = table().len();
        let tail: Vec<&str> = table()[n - appended.len()..]
            .iter()
            .map(|v| v.name)
            .collect();
        assert_eq!(tail, appended);
        let plugin = n - appended.len() - 1;
        assert!(x.contains(&format!(
            "name=\"strategy.plugin\" valueReference=\"{plugin}\""
        )));
        assert!(x.contains("<String start=\"\"/>"));
        // Piecewise-constant outputs are discrete, the plant's continuous.
        for (name, variability) in [
            ("duty", "discrete"),
            ("speed_est_rpm", "discrete"),
            ("speed_rpm", "continuous"),
        ] {
            let v = &table()[crate::variables::vr_of(name).unwrap() as usize];
            assert_eq!(causality(v).1, variability, "{name}");
        }
    }

    #[test]
    fn generation_date_is_utc_and_deterministic() {
        // Dates checked against `date -u -d @N`.
        assert_eq!(utc_date_time(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc_date_time(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(utc_date_time(1_700_000_000), "2023-11-14T22:13:20Z");
        assert_eq!(utc_date_time(4_107_542_399), "2100-02-28T23:59:59Z");
        let x = model_description(1_700_000_000);
        assert!(x.contains("generationDateAndTime=\"2023-11-14T22:13:20Z\""));
        assert!(x.contains("license=\"MIT OR Apache-2.0\""));
        assert!(x.contains("author=\"bldc-drive developers\""));
        assert_eq!(x, model_description(1_700_000_000));
    }
}
