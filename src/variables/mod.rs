//! The variable table: every variable of the drive's FMU, its value reference (its index
//! here), type, unit, description, range, and where it lives in
//! [`DriveConfig`](crate::DriveConfig) or the running drive.
//!
//! It is the one source of truth: the FMU's exported functions look values up here, its
//! `modelDescription.xml` and GUID are generated from it (the `fmu` crate), and
//! `drive-bench config` writes each key's unit and rule from it
//! ([`DriveConfig::to_toml_documented`](crate::DriveConfig::to_toml_documented)). It lives
//! in the library, not in the `fmu` crate, so that both can read it. Start values of
//! parameters are read from `DriveConfig::default()`, never written twice.
//!
//! One direction: `variable` says what a variable is, `table` writes the rows with it, and
//! this module serves the rows; neither of the two imports from here.

pub mod documented;
mod table;
mod variable;

pub use variable::{
    EnumType, Getter, Input, Kind, Output, Role, Setter, Text, Variable, strategy_choices,
};

use std::sync::OnceLock;

/// The variable table; the value reference of a variable is its index.
pub fn table() -> &'static [Variable] {
    static TABLE: OnceLock<Vec<Variable>> = OnceLock::new();
    TABLE.get_or_init(table::build_table)
}

/// The variable with value reference `vr`.
pub fn by_vr(vr: u32) -> Option<&'static Variable> {
    table().get(vr as usize)
}

/// The value reference of `name`.
pub fn vr_of(name: &str) -> Option<u32> {
    table()
        .iter()
        .position(|v| v.name == name)
        .map(|i| i as u32)
}

#[cfg(test)]
mod tests {
    use super::table::{get_strategy, set_strategy};
    use super::*;
    use crate::DriveConfig;

    #[test]
    fn names_are_unique_and_inputs_outputs_are_the_issues_names() {
        let t = table();
        let mut names: Vec<_> = t.iter().map(|v| v.name).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), t.len());
        let of = |pick: fn(&Role) -> bool| -> Vec<&str> {
            t.iter().filter(|v| pick(&v.role)).map(|v| v.name).collect()
        };
        assert_eq!(
            of(|r| matches!(r, Role::Input(_))),
            ["speed_ref_rpm", "load_torque_nm", "enable"]
        );
        assert_eq!(
            of(|r| matches!(r, Role::Output(_))),
            [
                "speed_rpm",
                "speed_est_rpm",
                "theta_e_deg",
                "i_u",
                "i_v",
                "i_w",
                "torque_nm",
                "duty",
                "state",
                "restarts",
                "in_sync",
                "verdict",
            ]
        );
    }

    #[test]
    fn every_real_has_a_unit_and_every_variable_a_description() {
        for v in table() {
            assert!(!v.description.is_empty(), "{}", v.name);
            assert_eq!(v.kind == Kind::Real, !v.unit.is_empty(), "{}", v.name);
        }
    }

    #[test]
    fn parameters_round_trip_their_defaults_and_defaults_lie_in_range() {
        let d = DriveConfig::default();
        let mut c = DriveConfig::default();
        for v in table() {
            if let Role::Parameter { get, set } = v.role {
                let x = get(&d);
                set(&mut c, x).unwrap();
                assert!(v.min.is_none_or(|m| x >= m), "{} = {x}", v.name);
                assert!(v.max.is_none_or(|m| x <= m), "{} = {x}", v.name);
            }
        }
        // The conduction angle becomes explicit; everything else is unchanged.
        c.strategy.conduction_angle_deg = None;
        assert_eq!(c, d);
    }

    /// The phrase of a description whose declared bound holds only with other keys
    /// changed: "with the other defaults at least X" (`at least`/`above` for the min,
    /// `at most`/`below` for the max), then the rule with every key it combines.
    const TIED: &str = "with the other defaults";

    /// `key` as a whole key in `text` (not the start or end of a longer one).
    fn names_key(text: &str, key: &str) -> bool {
        text.match_indices(key).any(|(i, _)| {
            let before = text[..i].chars().next_back();
            let after = text[i + key.len()..].chars().next();
            !before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '.')
                && !after.is_some_and(|c| c.is_alphanumeric() || c == '_')
        })
    }

    /// The first of `phrases` after [`TIED`] in `description`, and the number after it.
    fn tied_limit<'a>(description: &str, phrases: [&'a str; 2]) -> Option<(&'a str, f64)> {
        let rest = &description[description.find(TIED)? + TIED.len()..];
        let (at, phrase) = phrases
            .iter()
            .filter_map(|p| rest.find(&format!(" {p} ")).map(|i| (i, *p)))
            .min()?;
        let number: String = rest[at + phrase.len() + 2..]
            .chars()
            .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | '-' | '+'))
            .collect();
        Some((phrase, number.trim_end_matches('.').parse().ok()?))
    }

    #[test]
    fn the_declared_ranges_are_the_config_rules() {
        // Guards the table against drifting from the rules (the rules are the authority):
        // one step outside a declared bound must fail DriveConfig::validate, and the bound
        // itself must pass (FMI bounds are inclusive: a `> 0` rule is declared with the
        // smallest positive f64, `< 180` with the largest f64 below 180). A step is a
        // millionth for a Real, one for an Integer (two for the poles, which come in pairs).
        //
        // A bound that a rule combining several keys refuses with the other keys at their
        // defaults (the coupling, the speed's step, the current sense's full scale, an
        // ordering) stays declared (other values make it valid), but its description must
        // say so: "with the other defaults at least X" (or at most, above, below), X the
        // limit the rules set with the defaults (checked here), and every other key the
        // refusal names.
        for v in table() {
            let Role::Parameter { set, .. } = v.role else {
                continue;
            };
            for (bound, outward, which) in [(v.min, -1.0, "min"), (v.max, 1.0, "max")] {
                let Some(b) = bound else { continue };
                if v.name == "seed" {
                    continue; // the seed's bounds are the FMI Integer's, not a rule
                }
                let step = if v.kind == Kind::Real {
                    1e-6 * b.abs().max(1.0)
                } else if v.name == "motor.poles" {
                    2.0 // poles come in pairs
                } else {
                    1.0
                };
                let refusal = |x: f64| {
                    let mut c = DriveConfig::default();
                    set(&mut c, x).and_then(|()| c.validate()).err()
                };
                let ok = |x: f64| refusal(x).is_none();
                let outside = b + outward * step;
                assert!(!ok(outside), "{} = {outside} was accepted", v.name);
                let Some(e) = refusal(b) else { continue };
                let (inclusive, strict) = if which == "min" {
                    ("at least", "above")
                } else {
                    ("at most", "below")
                };
                let d = v.description;
                let Some((phrase, x)) = tied_limit(d, [inclusive, strict]) else {
                    panic!(
                        "{} = {b}, its declared {which}, is refused with the other defaults \
                         ({e}), and its description does not say \"{TIED} {inclusive} …\" \
                         or \"{TIED} {strict} …\": {d}",
                        v.name
                    );
                };
                // X, rounded inward if at all, and a step beyond it are on the two sides.
                let beyond = if v.kind == Kind::Real {
                    0.01 * x.abs()
                } else {
                    1.0
                };
                let (accepted, refused) = if phrase == inclusive {
                    (x, x + outward * beyond)
                } else {
                    (x - outward * beyond, x)
                };
                assert!(
                    ok(accepted) && !ok(refused),
                    "{}: \"{TIED} {phrase} {x}\" is not what the rules say ({accepted} \
                     must be accepted, {refused} refused)",
                    v.name
                );
                let msg = e.to_string();
                for other in table() {
                    if other.name != v.name && names_key(&msg, other.name) {
                        assert!(
                            names_key(d, other.name),
                            "{} = {b} is refused by a rule naming {} ({msg}); the \
                             description must name it too: {d}",
                            v.name,
                            other.name
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn every_parameter_has_finite_declared_bounds() {
        // A parameter without a max accepted values up to 1e300 that drove the model
        // non-finite; every rule now has a physical upper bound.
        for v in table() {
            // Booleans and enumerations are bounded by their type.
            let bounded_by_type = matches!(v.kind, Kind::Boolean | Kind::Enumeration(_));
            if matches!(v.role, Role::Parameter { .. }) && !bounded_by_type {
                let finite = |b: Option<f64>| b.is_some_and(f64::is_finite);
                assert!(
                    finite(v.min) && finite(v.max),
                    "{} has no finite bounds",
                    v.name
                );
            }
        }
    }

    #[test]
    fn enumeration_items_are_modelica_identifiers() {
        // Modelica IDENT: a letter or `_`, then letters, digits and `_`.
        for t in EnumType::ALL {
            let items = t.items();
            for item in &items {
                let mut chars = item.chars();
                let first = chars.next().unwrap();
                assert!(first.is_ascii_alphabetic() || first == '_', "{item}");
                assert!(
                    chars.all(|c| c.is_ascii_alphanumeric() || c == '_'),
                    "{item}"
                );
            }
            let mut unique = items.clone();
            unique.sort();
            unique.dedup();
            assert_eq!(unique.len(), items.len(), "{t:?}");
        }
        assert_eq!(
            EnumType::PwmScheme.items(),
            [
                "high_side_chop",
                "low_side_chop",
                "complementary",
                "lone_switch_chop"
            ]
        );
    }

    #[test]
    fn every_strategy_and_guard_is_an_item() {
        let items = EnumType::Strategy.items();
        assert_eq!(items.len(), 8);
        assert_eq!(items[0], "six_step_120_df");
        assert_eq!(items[7], "twelve_step_df");
        for (i, _) in items.iter().enumerate() {
            let mut c = DriveConfig::default();
            set_strategy(&mut c, (i + 1) as f64).unwrap();
            c.validate().unwrap();
            assert_eq!(get_strategy(&c), (i + 1) as f64);
        }
        let mut c = DriveConfig::default();
        assert!(set_strategy(&mut c, 0.0).is_err());
        assert!(set_strategy(&mut c, 9.0).is_err());
    }
}
