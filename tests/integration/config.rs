//! The drive's TOML config: defaults, round trip, unknown keys, and every rule the chip's
//! config must enforce, each error naming the key.

use bldc_drive::DriveConfig;
use bldc_drive::strategies::{GuardKind, StrategyName};

fn refused(toml_text: &str, key: &str) {
    let err = DriveConfig::from_toml(toml_text)
        .expect_err(key)
        .to_string();
    assert!(err.contains(key), "error `{err}` must name `{key}`");
}

#[test]
fn default_config_round_trips_through_toml() {
    let c = DriveConfig::default();
    c.validate().unwrap();
    let text = c.to_toml();
    for section in [
        "[motor]",
        "[power_stage]",
        "[sensing]",
        "[control]",
        "[strategy]",
    ] {
        assert!(text.contains(section), "{section} missing from\n{text}");
    }
    assert!(text.contains("anti_windup = true"));
    assert_eq!(DriveConfig::from_toml(&text).unwrap(), c);
    assert_eq!(DriveConfig::from_toml("").unwrap(), c);
}

#[test]
fn strategy_names_and_keys_parse() {
    let c = DriveConfig::from_toml(
        "[strategy]\nname = \"twelve-step-lm\"\nlm_speed_max_rpm = 9000\nlm_speed_min_rpm = 500\nconduction_angle_deg = 165.0\n[control]\nanti_windup = false\n",
    )
    .unwrap();
    assert_eq!(c.strategy.name, StrategyName::TwelveStepLm);
    assert_eq!(c.strategy.guard_kind(), GuardKind::Lm);
    assert_eq!(c.strategy.conduction_deg(), 165.0);
    assert!(!c.control.anti_windup);
    let c =
        DriveConfig::from_toml("[strategy]\nname = \"six-step-120\"\nguard = \"nd\"\n").unwrap();
    assert_eq!(c.strategy.guard_kind(), GuardKind::Nd);
    assert_eq!(c.strategy.conduction_deg(), 120.0);
    for n in StrategyName::ALL {
        assert_eq!(n.as_str().parse::<StrategyName>().unwrap(), n);
    }
}

#[test]
fn bad_configs_are_refused_naming_the_key() {
    refused("[strategy]\nname = \"twelve-step-xx\"\n", "twelve-step-xx");
    refused("[control]\nspeed_kp_typo = 1.0\n", "speed_kp_typo");
    refused(
        "[strategy]\nlm_speed_max_rpm = 1000\nlm_speed_min_rpm = 1000\n",
        "strategy.lm_speed_max_rpm",
    );
    refused(
        "[strategy]\nlm_speed_max_rpm = 900\nlm_speed_min_rpm = 1000\n",
        "strategy.lm_speed_max_rpm",
    );
    refused(
        "[strategy]\nlinear_region_deg = 0\n",
        "strategy.linear_region_deg",
    );
    refused(
        "[strategy]\nlinear_region_deg = 61\n",
        "strategy.linear_region_deg",
    );
    refused(
        "[strategy]\nconduction_angle_deg = 119.0\n",
        "strategy.conduction_angle_deg",
    );
    refused(
        "[strategy]\nconduction_angle_deg = 180.0\n",
        "strategy.conduction_angle_deg",
    );
    refused(
        "[strategy]\nname = \"six-step-120\"\nconduction_angle_deg = 150.0\n",
        "strategy.conduction_angle_deg",
    );
    refused(
        "[strategy]\nname = \"twelve-step-df\"\nguard = \"nd\"\n",
        "strategy.guard",
    );
    refused(
        "[strategy]\nfilter_samples = 0\n",
        "strategy.filter_samples",
    );
    refused("[control]\nspeed_kp = -1.0\n", "control.speed_kp");
    refused("[control]\ncurrent_ki = -0.5\n", "control.current_ki");
    refused(
        "[control]\nspeed_ref_rpm = 20000.0\n",
        "control.speed_ref_rpm",
    );
    refused("[control]\nstartup_duty = 0.0\n", "control.startup_duty");
    // The descent's rate: 0 (off) or 1..=1e6 rpm/s.
    for bad in ["0.5", "-1.0", "nan", "2e6"] {
        refused(
            &format!("[control]\nstart_descent_rpm_s = {bad}\n"),
            "control.start_descent_rpm_s",
        );
    }
    refused(
        "[control]\nalign_current_a = 0.005\n",
        "control.align_current_a",
    );
    refused(
        "[control]\nstart_phase_current_a = -0.5\n",
        "control.start_phase_current_a",
    );
    refused(
        "[control]\nstartup_confirm_deg = 16\n",
        "control.startup_confirm_deg",
    );
    refused(
        "[control]\nstartup_conduction_deg = 180.0\n",
        "control.startup_conduction_deg",
    );
    refused(
        "[control]\nstartup_conduction_deg = 119.0\n",
        "control.startup_conduction_deg",
    );
    refused(
        "[control]\nalign_s = [0.7, 0.0, 0.015]\n",
        "control.align_s[1]",
    );
    refused("[motor]\nresistance_ohm = -2.2\n", "motor.resistance_ohm");
    refused(
        "[motor]\ncoulomb_friction_nm = -1e-4\n",
        "motor.coulomb_friction_nm",
    );
}

/// The current sense reads at most min(10 V, 10 V) / (80 · 0.25 Ω) = 0.5 A with the default
/// sensing; a limit at or above it reads as clipped and is never reached.
#[test]
fn current_limit_must_be_readable() {
    refused(
        "[control]\ncurrent_limit_a = 0.5\n",
        "control.current_limit_a",
    );
    DriveConfig::from_toml("[control]\ncurrent_limit_a = 0.499\n").unwrap();
    // A smaller shunt raises the full scale to 1 A: the same 0.5 A limit is then fine.
    DriveConfig::from_toml("[control]\ncurrent_limit_a = 0.5\n[power_stage]\nshunt_ohm = 0.125\n")
        .unwrap();
    // A lower amplifier swing lowers it: 5 V / 20 V/A = 0.25 A refuses the default 0.25 A.
    refused(
        "[sensing.current]\namplifier_max_v = 5.0\n",
        "control.current_limit_a",
    );
}

/// A documented bound refused with the other keys at their defaults is refused in words
/// that name every key of the rule, and the values that decide it.
#[test]
fn a_combined_rule_names_every_key() {
    // The shunt's documented maximum: the full scale falls to 10 V / (80 · 10 Ω) = 12.5 mA.
    let err = DriveConfig::from_toml("[power_stage]\nshunt_ohm = 10\n")
        .unwrap_err()
        .to_string();
    for key in [
        "control.current_limit_a",
        "power_stage.shunt_ohm",
        "sensing.current.amplifier_gain",
        "sensing.current.amplifier_max_v",
        "sensing.current.adc_full_scale_v",
        "here 0.0125 A",
    ] {
        assert!(err.contains(key), "error `{err}` must name `{key}`");
    }
    // ωm's documented maximum against the default ωM = 13430.
    let err = DriveConfig::from_toml("[strategy]\nlm_speed_min_rpm = 16382\n")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("`strategy.lm_speed_max_rpm` = 13430")
            && err.contains("strategy.lm_speed_min_rpm = 16382"),
        "{err}"
    );
    // The current limit's documented minimum against the default start current.
    let err = DriveConfig::from_toml("[control]\ncurrent_limit_a = 1e-3\n")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("`control.start_current_a` = 0.15")
            && err.contains("control.current_limit_a = 0.001"),
        "{err}"
    );
}
