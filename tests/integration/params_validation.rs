//! Bad parameters are refused with an error naming the field and the rule.

use bldc_drive::DriveConfig;
use bldc_drive::drive_core::pwm::PwmSchemeKind;
use bldc_drive::plants::{BackEmfShape, BldcPlant, PlantParams};

fn refused(edit: impl FnOnce(&mut PlantParams), field: &str, rule_word: &str) {
    let mut p = PlantParams::default();
    edit(&mut p);
    let err = p.validate().expect_err(field);
    assert_eq!(err.field, field);
    let msg = err.to_string();
    assert!(
        msg.contains(field) && msg.contains(rule_word),
        "message `{msg}` must name `{field}` and `{rule_word}`"
    );
    assert!(BldcPlant::new(p).is_err(), "the plant must refuse it too");
}

#[test]
fn defaults_are_valid_and_published() {
    let p = PlantParams::default();
    p.validate().unwrap();
    assert_eq!(p.motor.poles, 12);
    assert_eq!(p.motor.flux_linkage_wb, 7.62e-4);
    assert_eq!(p.motor.self_inductance_h, 0.63e-3);
    assert_eq!(p.motor.mutual_inductance_h, 0.37e-3);
    assert_eq!(p.motor.resistance_ohm, 2.2);
    assert_eq!(p.motor.inertia_kgm2, 17e-7);
    assert_eq!(p.power_stage.shunt_ohm, 0.25);
    // A designer's choice beside the chip's high-side chop (docs/chip.md, "The chopping").
    assert_eq!(p.power_stage.pwm_scheme, PwmSchemeKind::LoneSwitchChop);
    assert_eq!(p.power_stage.dead_time_s, 0.0);
    assert_eq!(p.sensing.current.amplifier_gain, 80.0);
    assert_eq!(p.sensing.current.adc_bits, 12);
}

#[test]
fn motor_rules() {
    refused(
        |p| p.motor.resistance_ohm = -2.2,
        "motor.resistance_ohm",
        "1e-4..=1e3",
    );
    refused(
        |p| p.motor.inertia_kgm2 = 0.0,
        "motor.inertia_kgm2",
        "1e-9..=10",
    );
    // Physical bounds: a resistance of 1e300 Ω overflowed the network into NaN.
    refused(
        |p| p.motor.resistance_ohm = 1e300,
        "motor.resistance_ohm",
        "1e-4..=1e3",
    );
    // Consistency: two coils cannot couple more than fully.
    refused(
        |p| p.motor.mutual_inductance_h = p.motor.self_inductance_h,
        "motor.mutual_inductance_h",
        "below motor.self_inductance_h",
    );
    // Consistency: a coupled electro-mechanical mode too fast for the step (1 Wb·turn on
    // the built-in rotor: h·ωn ≈ 14; it left the reals), while 10 times the built-in flux
    // linkage is still fine.
    refused(
        |p| p.motor.flux_linkage_wb = 1.0,
        "motor.flux_linkage_wb",
        "too strong a coupling",
    );
    let mut p = PlantParams::default();
    p.motor.flux_linkage_wb *= 10.0;
    p.validate().unwrap();
    // Consistency: a rotor too light for its friction's slope at the solver's step.
    refused(
        |p| p.motor.inertia_kgm2 = 1e-8,
        "motor.inertia_kgm2",
        "too stiff",
    );
    refused(
        |p| p.motor.flux_linkage_wb = f64::NAN,
        "motor.flux_linkage_wb",
        "must be finite",
    );
    // A combined rule names every key it combines: a resistance within its own range
    // (1e-4 Ω; with the defaults the coupling needs R >= h·k²/(4J) ≈ 7.4e-4 Ω) is refused
    // by the coupling, whose words name the resistance too.
    refused(
        |p| p.motor.resistance_ohm = 1e-4,
        "motor.flux_linkage_wb",
        "k²/(2·motor.resistance_ohm·motor.inertia_kgm2)",
    );
    // ... and says how far off the combination is (14.755 against 2 at 1e-4 Ω).
    refused(
        |p| p.motor.resistance_ohm = 1e-4,
        "motor.flux_linkage_wb",
        "must be <= 2, here 14.755",
    );
    // An ordering names the other key with its value: the self inductance's documented
    // minimum is refused (with the default M) in the words of M's rule.
    refused(
        |p| p.motor.self_inductance_h = 1e-7,
        "motor.mutual_inductance_h",
        "below motor.self_inductance_h = 0.0000001",
    );
    refused(
        |p| p.motor.self_inductance_h = f64::INFINITY,
        "motor.self_inductance_h",
        "must be finite",
    );
    refused(|p| p.motor.poles = 0, "motor.poles", "even");
    refused(|p| p.motor.poles = 7, "motor.poles", "even");
    refused(
        |p| p.motor.viscous_friction_nms = -1e-6,
        "motor.viscous_friction_nms",
        "0..=1",
    );
    refused(
        |p| p.motor.mutual_inductance_h = -1e-4,
        "motor.mutual_inductance_h",
        ">= 0",
    );
    refused(
        |p| {
            p.motor.back_emf = BackEmfShape::Trapezoidal {
                flat_top_deg: 200.0,
            }
        },
        "motor.back_emf.flat_top_deg",
        "179",
    );
}

#[test]
fn power_stage_and_sensing_rules() {
    refused(
        |p| p.power_stage.supply_v = 0.0,
        "power_stage.supply_v",
        "> 0",
    );
    refused(
        |p| p.power_stage.diode_forward_v = -0.7,
        "power_stage.diode_forward_v",
        "0..=10",
    );
    refused(
        |p| p.power_stage.dead_time_s = 1.0,
        "power_stage.dead_time_s",
        "10e-6",
    );
    refused(
        |p| p.power_stage.pwm_scheme = PwmSchemeKind::Complementary,
        "power_stage.dead_time_s",
        "complementary",
    );
    refused(
        |p| p.sensing.current.adc_bits = 0,
        "sensing.current.adc_bits",
        "1..=16",
    );
    refused(
        |p| p.sensing.current.filter_cutoff_hz = 0.0,
        "sensing.current.filter_cutoff_hz",
        "10 Hz",
    );
    refused(
        |p| p.sensing.comparator.hysteresis_v = -0.01,
        "sensing.comparator.hysteresis_v",
        "0 ..= 1 V",
    );
    refused(
        |p| p.sensing.comparator.offset_v.w = 5.0,
        "sensing.comparator.offset_v.w",
        "-1 ..= 1 V",
    );
    refused(
        |p| p.sensing.comparator.delay_s = f64::NAN,
        "sensing.comparator.delay_s",
        "must be finite",
    );
    refused(|p| p.solver.max_step_s = 1.0, "solver.max_step_s", "100e-6");
}

#[test]
fn toml_round_trip_and_unknown_keys() {
    let p = PlantParams::default();
    let text = toml::to_string(&p).unwrap();
    let back: PlantParams = toml::from_str(&text).unwrap();
    assert_eq!(back, p);
    let partial: PlantParams = toml::from_str("[motor]\nresistance_ohm = 3.0\n").unwrap();
    assert_eq!(partial.motor.resistance_ohm, 3.0);
    assert_eq!(
        partial.motor.poles, 12,
        "unspecified keys keep their defaults"
    );
    let err = toml::from_str::<PlantParams>("[motor]\nresistence_ohm = 3.0\n").unwrap_err();
    assert!(err.to_string().contains("resistence_ohm"), "{err}");
    let shape: PlantParams =
        toml::from_str("[motor.back_emf]\nkind = \"trapezoidal\"\nflat_top_deg = 120.0\n").unwrap();
    assert_eq!(
        shape.motor.back_emf,
        BackEmfShape::Trapezoidal {
            flat_top_deg: 120.0
        }
    );
}

/// Upper bounds of parameters that once had none (a switch resistance of 1e300 Ω was
/// accepted and drove the network non-finite): each limit is accepted, a value a millionth
/// above it is refused with an error naming the key, the value and the rule.
#[test]
fn formerly_unbounded_parameters_have_physical_upper_bounds() {
    type Field = fn(&mut DriveConfig) -> &mut f64;
    let cases: [(&str, Field, f64, &str); 11] = [
        (
            "power_stage.switch_on_resistance_ohm",
            |c| &mut c.power_stage.switch_on_resistance_ohm,
            10.0,
            "0..=10 Ω",
        ),
        (
            "power_stage.diode_forward_v",
            |c| &mut c.power_stage.diode_forward_v,
            10.0,
            "0..=10 V",
        ),
        (
            "power_stage.diode_resistance_ohm",
            |c| &mut c.power_stage.diode_resistance_ohm,
            10.0,
            "0..=10 Ω",
        ),
        (
            "power_stage.shunt_ohm",
            |c| &mut c.power_stage.shunt_ohm,
            10.0,
            "0..=10 Ω",
        ),
        (
            "sensing.current.amplifier_gain",
            |c| &mut c.sensing.current.amplifier_gain,
            1e4,
            "(0, 1e4]",
        ),
        (
            "sensing.current.amplifier_max_v",
            |c| &mut c.sensing.current.amplifier_max_v,
            100.0,
            "(0, 100] V",
        ),
        (
            "sensing.current.adc_full_scale_v",
            |c| &mut c.sensing.current.adc_full_scale_v,
            100.0,
            "(0, 100] V",
        ),
        (
            "control.speed_kp",
            |c| &mut c.control.speed_kp,
            1.0,
            "0..=1 A/rpm",
        ),
        (
            "control.speed_ki",
            |c| &mut c.control.speed_ki,
            1.0,
            "0..=1 A/(rpm·update)",
        ),
        (
            "control.current_kp",
            |c| &mut c.control.current_kp,
            1e6,
            "0..=1e6 counts/A",
        ),
        (
            "control.current_ki",
            |c| &mut c.control.current_ki,
            1e6,
            "0..=1e6 counts/(A·update)",
        ),
    ];
    for (key, field, limit, rule) in cases {
        let with = |x: f64| {
            let mut c = DriveConfig::default();
            // A current limit every sensing bound can read (a 10 Ω shunt or a gain of 1e4
            // bring the full scale down to 12.5 mA and 4 mA), so each bound is judged alone.
            c.control.current_limit_a = 1e-3;
            c.control.start_current_a = 1e-3;
            *field(&mut c) = x;
            c.validate()
        };
        with(limit).unwrap_or_else(|e| panic!("{key} = {limit}, its limit, refused: {e}"));
        let over = limit * (1.0 + 1e-6);
        for bad in [over, 1e300, f64::INFINITY] {
            let msg = with(bad).expect_err(key).to_string();
            // No number at all is refused as such, before any range.
            let rule = if bad.is_finite() {
                rule
            } else {
                "must be finite"
            };
            assert!(
                msg.contains(key) && msg.contains(&bad.to_string()) && msg.contains(rule),
                "`{msg}` must name `{key}`, {bad} and `{rule}`"
            );
        }
    }
}
