//! The config as TOML with each key's unit, bounds and meaning as a comment, written from
//! the variable table (the FMU's parameters are the config's keys), so that what
//! `drive-bench config` prints and what the FMU declares cannot disagree.

use super::{EnumType, Kind, Variable, table};
use crate::DriveConfig;
use crate::strategies::StrategyName;

/// The keys the FMU does not expose, with their unit and rule (`carrier_top` changes the
/// PI gains' meaning mid-model; the back-EMF shape is a tagged table, not a number; the
/// FMU's strategy item names the guard with the strategy).
const NOT_IN_FMU: [(&str, &str, &str); 6] = [
    (
        "control.carrier_top",
        "counts",
        "500..=4095: peak count of the PWM carrier; PWM frequency = 25 MHz / this",
    ),
    (
        "motor.back_emf.kind",
        "–",
        "sinusoidal, trapezoidal (with flat_top_deg) or harmonic (with third and fifth): shape of the back-EMF",
    ),
    (
        "motor.back_emf.flat_top_deg",
        "electrical degrees",
        "0..180: width of the trapezoid's flat top",
    ),
    (
        "motor.back_emf.third",
        "p.u. of the fundamental",
        "-1..=1: third-harmonic amplitude",
    ),
    (
        "motor.back_emf.fifth",
        "p.u. of the fundamental",
        "-1..=1: fifth-harmonic amplitude",
    ),
    (
        "strategy.guard",
        "–",
        "df, raw, nd or lm, with six-step-120 only: its zero-crossing guard",
    ),
];

/// `config` as TOML, every key followed by a comment: `# [unit] rule: description`.
pub fn to_toml_documented(config: &DriveConfig) -> String {
    let mut out = String::new();
    let mut section = String::new();
    for line in config.to_toml().lines() {
        let t = line.trim();
        if let Some(s) = t.strip_prefix('[').and_then(|s| s.strip_suffix(']')) {
            section = s.to_string();
        }
        let key = t.split_once(" = ").map(|(k, _)| k.trim());
        match key.filter(|_| !t.starts_with('[')) {
            Some(k) => {
                let path = if section.is_empty() {
                    k.to_string()
                } else {
                    format!("{section}.{k}")
                };
                out.push_str(line);
                out.push_str("  # ");
                out.push_str(&comment(&path));
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// The comment for the key at dotted `path`; "[?]" for a key no table describes (a test
/// keeps every key described).
fn comment(path: &str) -> String {
    if let Some((_, unit, rule)) = NOT_IN_FMU.iter().find(|k| k.0 == path) {
        return format!("[{unit}] {rule}");
    }
    let Some(v) = variable(path) else {
        return "[?] undocumented".into();
    };
    // An array's elements have a row each, alike but for their meaning.
    let meaning = if v.name.ends_with("[0]") {
        let prefix = v.name.trim_end_matches("[0]");
        table()
            .iter()
            .filter(|e| {
                e.name
                    .strip_prefix(prefix)
                    .is_some_and(|i| i.starts_with('['))
            })
            .map(|e| e.description)
            .collect::<Vec<_>>()
            .join("; ")
    } else {
        v.description.to_string()
    };
    format!("[{}] {}: {meaning}", unit(v), rule(v))
}

/// The table's row for a config path: the same name, but for the speed command (an FMU
/// input), the seed (named `seed`) and arrays (one row per element).
fn variable(path: &str) -> Option<&'static Variable> {
    let name = match path {
        "control.speed_ref_rpm" => "speed_ref_rpm".to_string(),
        "sensing.seed" => "seed".to_string(),
        p => p.to_string(),
    };
    let first = format!("{name}[0]");
    table().iter().find(|v| v.name == name || v.name == first)
}

/// The unit: the row's, else the one its description ends with in brackets (integers
/// carry theirs there), else "1" for a dimensionless number and "–" for the rest.
fn unit(v: &Variable) -> String {
    if !v.unit.is_empty() {
        return v.unit.to_string();
    }
    let bracket = v
        .description
        .rfind('[')
        .zip(v.description.rfind(']'))
        .filter(|(a, b)| a < b)
        .map(|(a, b)| v.description[a + 1..b].to_string());
    match (bracket, v.kind) {
        (Some(u), _) => u,
        (None, Kind::Integer) => "1".into(),
        (None, _) => "–".into(),
    }
}

/// The bounds as a rule: `a..=b`, with `> 0` and `< 180` for the bounds FMI can only
/// approach (the table declares them as the nearest doubles); the items of an
/// enumeration; "true or false".
fn rule(v: &Variable) -> String {
    let lo = v.min.map(|m| match m {
        f64::MIN_POSITIVE => "> 0".to_string(),
        m => format!(">= {m}"),
    });
    let hi = v.max.map(|m| {
        if m.to_bits() == 180f64.to_bits() - 1 {
            "< 180".to_string()
        } else {
            format!("<= {m}")
        }
    });
    match (v.kind, lo, hi) {
        (Kind::Boolean, ..) => "true or false".into(),
        (Kind::Enumeration(EnumType::Strategy), ..) => StrategyName::ALL
            .iter()
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        (Kind::Enumeration(t), ..) => t.items().join(", ").replace('_', "-"),
        (_, Some(l), Some(h)) => match (l.strip_prefix(">= "), h.strip_prefix("<= ")) {
            (Some(a), Some(b)) => format!("{a}..={b}"),
            _ => format!("{l}, {h}"),
        },
        (_, Some(b), None) | (_, None, Some(b)) => b,
        (_, None, None) => "any".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plants::BackEmfShape;
    use crate::strategies::GuardKind;

    /// Every key, the optional ones set too, has a comment with a unit, and the text
    /// still reads back as the same config.
    #[test]
    fn every_key_is_documented_and_the_text_parses_back() {
        let mut six = DriveConfig::default();
        six.strategy.name = StrategyName::SixStep120;
        six.strategy.guard = Some(GuardKind::Lm);
        six.motor.back_emf = BackEmfShape::Harmonic {
            third: 0.1,
            fifth: 0.0,
        };
        let mut twelve = DriveConfig::default();
        twelve.strategy.conduction_angle_deg = Some(165.0);
        twelve.motor.back_emf = BackEmfShape::Trapezoidal {
            flat_top_deg: 120.0,
        };
        for c in [DriveConfig::default(), six, twelve] {
            let text = to_toml_documented(&c);
            let keys: Vec<&str> = text.lines().filter(|l| l.contains(" = ")).collect();
            assert!(keys.len() >= 80, "{}", keys.len());
            for l in keys {
                let (_, comment) = l.split_once("  # [").unwrap_or_else(|| panic!("{l}"));
                let unit = &comment[..comment.find(']').unwrap()];
                assert!(!unit.is_empty() && unit != "?", "{l}");
            }
            assert_eq!(DriveConfig::from_toml(&text).unwrap(), c);
        }
    }

    #[test]
    fn bounds_read_as_rules() {
        let by = |n: &str| table().iter().find(|v| v.name == n).unwrap();
        assert_eq!(rule(by("motor.resistance_ohm")), "0.0001..=1000");
        assert_eq!(unit(by("motor.resistance_ohm")), "Ohm");
        // An integer's unit is in its description.
        assert_eq!(unit(by("strategy.lm_speed_min_rpm")), "rpm");
        assert_eq!(rule(by("strategy.conduction_angle_deg")), ">= 120, < 180");
        assert_eq!(rule(by("control.current_limit_a")), "> 0, <= 10");
        assert!(rule(by("strategy.name")).contains("twelve-step-df"));
    }
}
