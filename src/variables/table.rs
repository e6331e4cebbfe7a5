//! The rows of the variable table ([`crate::variables`]): each input, output and parameter
//! with its unit, range, description and the config field it reads and writes.

use super::variable::Kind::{Boolean, Integer, Real};
use super::variable::{EnumType, Input, Kind, Output, Role, Text, Variable, strategy_choices};
use crate::DriveConfig;
use crate::drive_core::ParamError;
use crate::drive_core::pwm::PwmSchemeKind;
use crate::strategies::StrategyName;
use crate::strategies::params::SPEED_CMD_MAX_RPM;

pub(super) fn get_strategy(c: &DriveConfig) -> f64 {
    let s = &c.strategy;
    let guard = s.name.fixed_guard().is_none().then(|| s.guard_kind());
    strategy_choices()
        .iter()
        .position(|&(n, g)| n == s.name && g == guard)
        .map_or(0.0, |i| (i + 1) as f64)
}

pub(super) fn set_strategy(c: &mut DriveConfig, v: f64) -> Result<(), ParamError> {
    let choices = strategy_choices();
    let (name, guard) = item(&choices, v).ok_or_else(|| {
        ParamError::new(
            "strategy.name",
            v,
            "must be an item of the Strategy enumeration (1 ..= number of items)",
        )
    })?;
    c.strategy.name = name;
    c.strategy.guard = guard;
    Ok(())
}

fn get_pwm(c: &DriveConfig) -> f64 {
    PwmSchemeKind::ALL
        .iter()
        .position(|&k| k == c.power_stage.pwm_scheme)
        .map_or(0.0, |i| (i + 1) as f64)
}

fn set_pwm(c: &mut DriveConfig, v: f64) -> Result<(), ParamError> {
    c.power_stage.pwm_scheme = item(&PwmSchemeKind::ALL, v).ok_or_else(|| {
        ParamError::new(
            "power_stage.pwm_scheme",
            v,
            "must be an item of the PwmScheme enumeration (1 ..= 3)",
        )
    })?;
    Ok(())
}

/// Item `v` (1-based) of `items`.
fn item<T: Copy>(items: &[T], v: f64) -> Option<T> {
    (v >= 1.0 && v.fract() == 0.0)
        .then(|| items.get(v as usize - 1).copied())
        .flatten()
}

/// An unsigned config field from an FMI Integer (which may be negative).
fn to_u32(field: &'static str, v: f64) -> Result<u32, ParamError> {
    if v >= 0.0 && v <= f64::from(u32::MAX) && v.fract() == 0.0 {
        Ok(v as u32)
    } else {
        Err(ParamError::new(field, v, "must be a whole number >= 0"))
    }
}

/// The conduction angle applies to twelve-step names only; six-step-120 ignores it (so
/// an importer that writes every start value does not break a six-step selection).
fn set_conduction(c: &mut DriveConfig, v: f64) -> Result<(), ParamError> {
    c.strategy.conduction_angle_deg = (c.strategy.name != StrategyName::SixStep120).then_some(v);
    Ok(())
}

/// A Real parameter at config path `$($f).+`.
macro_rules! real {
    ($name:literal, $($f:ident).+ $([$i:literal])?, $unit:literal, $min:expr, $max:expr, $desc:literal) => {
        Variable {
            name: $name,
            kind: Kind::Real,
            role: Role::Parameter {
                get: |c| c.$($f).+ $([$i])?,
                set: |c, v| {
                    c.$($f).+ $([$i])? = v;
                    Ok(())
                },
            },
            unit: $unit,
            description: $desc,
            min: $min,
            max: $max,
        }
    };
}

/// An unsigned Integer parameter at config path `$($f).+`.
macro_rules! int {
    ($name:literal, $($f:ident).+, $min:expr, $max:expr, $desc:literal) => {
        Variable {
            name: $name,
            kind: Kind::Integer,
            role: Role::Parameter {
                get: |c| c.$($f).+ as f64,
                set: |c, v| {
                    c.$($f).+ = to_u32($name, v)?;
                    Ok(())
                },
            },
            unit: "",
            description: $desc,
            min: $min,
            max: $max,
        }
    };
}

fn var(
    name: &'static str,
    kind: Kind,
    role: Role,
    unit: &'static str,
    desc: &'static str,
) -> Variable {
    Variable {
        name,
        kind,
        role,
        unit,
        description: desc,
        min: None,
        max: None,
    }
}

fn output(
    name: &'static str,
    kind: Kind,
    o: Output,
    unit: &'static str,
    desc: &'static str,
) -> Variable {
    var(name, kind, Role::Output(o), unit, desc)
}

/// The declared min of a `> 0` rule. FMI bounds are inclusive, so `min="0"` would declare a
/// value the rule refuses: the smallest positive normal f64 is the smallest one it accepts.
const POSITIVE: Option<f64> = Some(f64::MIN_POSITIVE);
/// The declared max of a `< 180°` rule: the largest f64 below 180 (at 180° nothing floats).
const BELOW_180: Option<f64> = Some(f64::from_bits(180f64.to_bits() - 1));
/// A declared bound at zero.
const Z: Option<f64> = Some(0.0);

/// The rows, one per variable, in value-reference order: the groups of the first layout,
/// then the variables appended since.
pub(super) fn build_table() -> Vec<Variable> {
    [
        inputs(),
        outputs(),
        strategy(),
        motor(),
        power_stage(),
        sensing(),
        solver(),
        control(),
        appended(),
    ]
    .concat()
}

/// The inputs, set by the master between steps: speed command, load torque, enable.
#[rustfmt::skip]
fn inputs() -> Vec<Variable> {
    vec![
        Variable {
            min: Some(0.0),
            max: Some(SPEED_CMD_MAX_RPM),
            ..var("speed_ref_rpm", Real, Role::Input(Input::SpeedRef), "rpm",
                "Speed command ωc (14-bit register: clamped to 0..16383 with a warning)")
        },
        // The library's rule for an active load torque (plants::Load): |T_a| <= 1 N·m.
        Variable {
            min: Some(-1.0),
            max: Some(1.0),
            ..var("load_torque_nm", Real, Role::Input(Input::LoadTorque), "N.m",
                "Load torque on the shaft, opposing positive rotation (|T| <= 1 N.m)")
        },
        var("enable", Boolean, Role::Input(Input::Enable), "",
            "Drive enable: true holds the chip's start input (alignment, then closed loop after 31 master clocks); false drops start and holds reset (bridge off, restart count cleared)"),
    ]
}

/// The outputs, computed by the drive (`in_sync` and `verdict` came later: [`appended`]).
#[rustfmt::skip]
fn outputs() -> Vec<Variable> {
    vec![
        output("speed_rpm", Real, Output::SpeedRpm, "rpm", "True mechanical speed of the rotor"),
        output("speed_est_rpm", Real, Output::SpeedEstRpm, "rpm",
            "The chip's FG speed measurement (39 062 500 / N, 0 before the first measurement)"),
        output("theta_e_deg", Real, Output::ThetaEDeg, "deg",
            "True electrical angle θe in [0, 360), with e_u = λr·ωe·sin θe"),
        output("i_u", Real, Output::IU, "A", "Phase current u into the winding"),
        output("i_v", Real, Output::IV, "A", "Phase current v into the winding"),
        output("i_w", Real, Output::IW, "A", "Phase current w into the winding"),
        output("torque_nm", Real, Output::TorqueNm, "N.m", "Electromagnetic torque"),
        output("duty", Real, Output::Duty, "1",
            "Voltage command as a fraction 0..1 of the PWM carrier top (duty counts / 2000)"),
        output("state", Integer, Output::State, "",
            "Commutation state [1]: 1..12 twelve-step, 1..6 six-step, 0 when off, aligning or starting"),
        output("restarts", Integer, Output::Restarts, "",
            "Restarts after step-miss errors so far [count]; cleared while enable is false"),
    ]
}

/// The built-in strategy, its guard and their windows.
#[rustfmt::skip]
fn strategy() -> Vec<Variable> {
    vec![
        var("strategy.name", Kind::Enumeration(EnumType::Strategy),
            Role::Parameter { get: get_strategy, set: set_strategy }, "",
            "Commutation strategy and zero-crossing guard (six-step-120 with any guard; twelve-step names fix theirs)"),
        Variable { min: Some(120.0), max: BELOW_180, ..var("strategy.conduction_angle_deg", Real,
            Role::Parameter { get: |c| c.strategy.conduction_deg(), set: set_conduction }, "deg",
            "Conduction angle per half cycle of the twelve-step strategies (120 <= x < 180); ignored by six-step-120") },
        int!("strategy.linear_region_deg", strategy.linear_region_deg, Some(1.0), Some(60.0),
            "Linear-region window before each expected crossing (nd; upper end of lm) [electrical degrees]"),
        int!("strategy.lm_speed_max_rpm", strategy.lm_speed_max_rpm, Z, Some(SPEED_CMD_MAX_RPM),
            "ωM: speed from which lm uses the full window [rpm]; must exceed strategy.lm_speed_min_rpm: with the other defaults at least 552"),
        int!("strategy.lm_speed_min_rpm", strategy.lm_speed_min_rpm, Z, Some(SPEED_CMD_MAX_RPM - 1.0),
            "ωm: speed at and below which lm uses a 1° window [rpm]; must be below strategy.lm_speed_max_rpm: with the other defaults at most 13429"),
        int!("strategy.filter_samples", strategy.filter_samples, Some(1.0), Some(64.0),
            "Flip-flops of the digital filter, clocked at 0.64 µs [count]"),
    ]
}

/// The motor.
#[rustfmt::skip]
fn motor() -> Vec<Variable> {
    vec![
        int!("motor.poles", motor.poles, Some(2.0), Some(200.0), "Number of poles P, even [count]"),
        real!("motor.flux_linkage_wb", motor.flux_linkage_wb, "Wb", Some(1e-6), Some(1.0),
            "PM flux-linkage amplitude per phase λr; with the other defaults at most 0.0416, by the coupling rule solver.max_step_s × max(k/√(2(motor.self_inductance_h + motor.mutual_inductance_h)·motor.inertia_kgm2), k²/(2·motor.resistance_ohm·motor.inertia_kgm2)) <= 2, k = √3·(motor.poles/2)·motor.flux_linkage_wb"),
        real!("motor.self_inductance_h", motor.self_inductance_h, "H", Some(1e-7), Some(1.0),
            "Phase self inductance Lp; must exceed motor.mutual_inductance_h: with the other defaults above 3.7e-4"),
        real!("motor.mutual_inductance_h", motor.mutual_inductance_h, "H", Z, Some(1.0),
            "Mutual inductance between two phases M; must be below motor.self_inductance_h: with the other defaults below 6.3e-4"),
        real!("motor.resistance_ohm", motor.resistance_ohm, "Ohm", Some(1e-4), Some(1e3),
            "Phase resistance R; with the other defaults at least 7.38e-4, by the coupling rule solver.max_step_s × max(k/√(2(motor.self_inductance_h + motor.mutual_inductance_h)·motor.inertia_kgm2), k²/(2·motor.resistance_ohm·motor.inertia_kgm2)) <= 2, k = √3·(motor.poles/2)·motor.flux_linkage_wb"),
        real!("motor.inertia_kgm2", motor.inertia_kgm2, "kg.m2", Some(1e-9), Some(10.0),
            "Rotor inertia J; with the other defaults at least 2.01e-8, by the step rule solver.max_step_s × (motor.viscous_friction_nms + motor.coulomb_friction_nm / motor.coulomb_speed_rad_s) / motor.inertia_kgm2 <= 2 (and the coupling rule solver.max_step_s × max(k/√(2(motor.self_inductance_h + motor.mutual_inductance_h)·motor.inertia_kgm2), k²/(2·motor.resistance_ohm·motor.inertia_kgm2)) <= 2, k = √3·(motor.poles/2)·motor.flux_linkage_wb)"),
        real!("motor.viscous_friction_nms", motor.viscous_friction_nms, "N.m.s/rad", Z, Some(1.0),
            "Viscous friction Bm; with the other defaults below 0.042, by the step rule solver.max_step_s × (motor.viscous_friction_nms + motor.coulomb_friction_nm / motor.coulomb_speed_rad_s) / motor.inertia_kgm2 <= 2"),
        real!("motor.coulomb_friction_nm", motor.coulomb_friction_nm, "N.m", Z, Some(1.0),
            "Coulomb bearing drag Tc, applied as Tc·tanh(ωm/ω0); with the other defaults at most 0.0212, by the step rule solver.max_step_s × (motor.viscous_friction_nms + motor.coulomb_friction_nm / motor.coulomb_speed_rad_s) / motor.inertia_kgm2 <= 2"),
        real!("motor.coulomb_speed_rad_s", motor.coulomb_speed_rad_s, "rad/s", Some(1e-3), Some(1e3),
            "Regularisation speed ω0 of the Coulomb drag; with the other defaults at least 5.89e-3, by the step rule solver.max_step_s × (motor.viscous_friction_nms + motor.coulomb_friction_nm / motor.coulomb_speed_rad_s) / motor.inertia_kgm2 <= 2"),
    ]
}

/// The power stage.
#[rustfmt::skip]
fn power_stage() -> Vec<Variable> {
    vec![
        real!("power_stage.supply_v", power_stage.supply_v, "V", Some(1e-3), Some(1000.0),
            "Supply V_DD"),
        real!("power_stage.switch_on_resistance_ohm", power_stage.switch_on_resistance_ohm, "Ohm", Z,
            Some(10.0), "On-resistance of each switch"),
        real!("power_stage.diode_forward_v", power_stage.diode_forward_v, "V", Z, Some(10.0),
            "Diode forward voltage"),
        real!("power_stage.diode_resistance_ohm", power_stage.diode_resistance_ohm, "Ohm", Z, Some(10.0),
            "Diode slope resistance"),
        real!("power_stage.shunt_ohm", power_stage.shunt_ohm, "Ohm", Z, Some(10.0),
            "Current-sense shunt between the low-side switches and ground; with the other defaults below 0.5, as the current sense's full scale min(sensing.current.amplifier_max_v, sensing.current.adc_full_scale_v) / (sensing.current.amplifier_gain · power_stage.shunt_ohm) must exceed control.current_limit_a"),
        real!("power_stage.dead_time_s", power_stage.dead_time_s, "s", Z, Some(10e-6),
            "Dead time before every switch turn-on, rounded to 20 ns (complementary needs > 0)"),
        var("power_stage.pwm_scheme", Kind::Enumeration(EnumType::PwmScheme),
            Role::Parameter { get: get_pwm, set: set_pwm }, "", "Which switches chop"),
    ]
}

/// The current sense, the comparators and the seed of their noise.
#[rustfmt::skip]
fn sensing() -> Vec<Variable> {
    vec![
        real!("sensing.current.amplifier_gain", sensing.current.amplifier_gain, "1", POSITIVE,
            Some(1e4), "Shunt amplifier gain (> 0); with the other defaults below 160, as the current sense's full scale min(sensing.current.amplifier_max_v, sensing.current.adc_full_scale_v) / (sensing.current.amplifier_gain · power_stage.shunt_ohm) must exceed control.current_limit_a"),
        real!("sensing.current.amplifier_max_v", sensing.current.amplifier_max_v, "V",
            POSITIVE, Some(100.0), "Amplifier output swing (> 0); with the other defaults above 5, as the current sense's full scale min(sensing.current.amplifier_max_v, sensing.current.adc_full_scale_v) / (sensing.current.amplifier_gain · power_stage.shunt_ohm) must exceed control.current_limit_a"),
        real!("sensing.current.filter_cutoff_hz", sensing.current.filter_cutoff_hz, "Hz", Some(10.0),
            Some(10e6), "Anti-alias low-pass cut-off"),
        int!("sensing.current.adc_bits", sensing.current.adc_bits, Some(1.0), Some(16.0),
            "ADC resolution [bits]"),
        real!("sensing.current.adc_full_scale_v", sensing.current.adc_full_scale_v, "V",
            POSITIVE, Some(100.0), "ADC full scale (> 0); with the other defaults above 5, as the current sense's full scale min(sensing.current.amplifier_max_v, sensing.current.adc_full_scale_v) / (sensing.current.amplifier_gain · power_stage.shunt_ohm) must exceed control.current_limit_a"),
        real!("sensing.current.adc_conversion_s", sensing.current.adc_conversion_s, "s", Some(0.1e-6),
            Some(1.0), "ADC conversion time"),
        real!("sensing.comparator.phase_filter_tau_s", sensing.comparator.phase_filter_tau_s, "s",
            Some(1e-9), Some(1e-3), "RC time constant of the phase-terminal paths"),
        real!("sensing.comparator.neutral_filter_tau_s", sensing.comparator.neutral_filter_tau_s, "s",
            Some(1e-9), Some(1e-3), "RC time constant of the neutral path"),
        real!("sensing.comparator.offset_v.u", sensing.comparator.offset_v.u, "V", Some(-1.0),
            Some(1.0), "Input offset of comparator u"),
        real!("sensing.comparator.offset_v.v", sensing.comparator.offset_v.v, "V", Some(-1.0),
            Some(1.0), "Input offset of comparator v"),
        real!("sensing.comparator.offset_v.w", sensing.comparator.offset_v.w, "V", Some(-1.0),
            Some(1.0), "Input offset of comparator w"),
        real!("sensing.comparator.hysteresis_v", sensing.comparator.hysteresis_v, "V", Z, Some(1.0),
            "Comparator hysteresis, full width"),
        real!("sensing.comparator.delay_s", sensing.comparator.delay_s, "s", Z, Some(100e-6),
            "Comparator propagation delay, rounded to 20 ns"),
        real!("sensing.comparator.noise_v", sensing.comparator.noise_v, "V", Z, Some(1.0),
            "Peak input-referred comparator noise"),
        real!("sensing.comparator.noise_interval_s", sensing.comparator.noise_interval_s, "s",
            Some(20e-9), Some(1e-3), "Interval between independent noise samples"),
        real!("sensing.comparator.ring_gain", sensing.comparator.ring_gain, "1", Z, Some(1.0),
            "Switching ringing coupled into the comparator inputs per volt of step"),
        real!("sensing.comparator.ring_frequency_hz", sensing.comparator.ring_frequency_hz, "Hz",
            Some(1e3), Some(1e9), "Ringing frequency"),
        real!("sensing.comparator.ring_decay_s", sensing.comparator.ring_decay_s, "s", Some(1e-9),
            Some(1e-3), "Ringing decay time constant"),
        Variable {
            min: Z,
            max: Some(f64::from(i32::MAX)),
            ..var("seed", Integer, Role::Parameter {
                get: |c| c.sensing.seed as f64,
                set: |c, v| {
                    c.sensing.seed = u64::from(to_u32("seed", v)?);
                    Ok(())
                },
            }, "", "Seed of the comparator noise (sensing.seed); the same seed reproduces every glitch")
        },
    ]
}

/// The solver.
#[rustfmt::skip]
fn solver() -> Vec<Variable> {
    vec![
        real!("solver.max_step_s", solver.max_step_s, "s", Some(0.1e-6), Some(100e-6),
            "Longest step of the plant between events"),
    ]
}

/// The chip's speed and current loops, alignment and start-up, restarts and the speed
/// meter.
#[rustfmt::skip]
fn control() -> Vec<Variable> {
    vec![
        real!("control.speed_kp", control.speed_kp, "A/rpm", Z, Some(1.0),
            "Speed PI proportional gain"),
        real!("control.speed_ki", control.speed_ki, "A/rpm", Z, Some(1.0),
            "Speed PI integral gain per PI update (5.24 ms)"),
        real!("control.current_kp", control.current_kp, "1/A", Z, Some(1e6),
            "Current PI proportional gain [carrier counts/A]"),
        real!("control.current_ki", control.current_ki, "1/A", Z, Some(1e6),
            "Current PI integral gain per PI update [carrier counts/A]"),
        real!("control.current_limit_a", control.current_limit_a, "A", POSITIVE,
            Some(10.0), "Current command limit (> 0); with the other defaults at least 0.15, control.start_current_a, and below 0.5, as the current sense's full scale min(sensing.current.amplifier_max_v, sensing.current.adc_full_scale_v) / (sensing.current.amplifier_gain · power_stage.shunt_ohm) must exceed control.current_limit_a"),
        real!("control.start_current_a", control.start_current_a, "A", POSITIVE,
            Some(10.0), "Current command from the hand-over to the first speed measurement (> 0, <= control.current_limit_a): with the other defaults at most 0.25"),
        var("control.anti_windup", Boolean, Role::Parameter {
            get: |c| f64::from(u8::from(c.control.anti_windup)),
            set: |c, v| {
                c.control.anti_windup = v != 0.0;
                Ok(())
            },
        }, "", "Back-calculation anti-windup on the current PI"),
        real!("control.anti_windup_gain", control.anti_windup_gain, "1", Z, Some(1024.0),
            "Back-calculation gain k_s"),
        real!("control.startup_duty", control.startup_duty, "1", POSITIVE,
            Some(1.0), "Voltage command during alignment and start-up, fraction of the carrier top (> 0)"),
        real!("control.align_s[0]", control.align_s[0], "s", Some(327.68e-6), Some(10.0),
            "Duration of alignment step u→v"),
        real!("control.align_s[1]", control.align_s[1], "s", Some(327.68e-6), Some(10.0),
            "Duration of alignment step v→w"),
        real!("control.align_s[2]", control.align_s[2], "s", Some(327.68e-6), Some(10.0),
            "Duration of alignment step v→u"),
        real!("control.handover_t60_s", control.handover_t60_s, "s", Some(1e-5), Some(0.02),
            "Assumed first 60° interval after the hand-over to closed loop"),
        real!("control.step_miss_s", control.step_miss_s, "s", Some(0.001), Some(10.0),
            "Step-miss limit: FG unchanged longer than this restarts the drive"),
        int!("control.max_restarts", control.max_restarts, Z, Some(1000.0),
            "Restarts allowed before the drive gives up [count]"),
        int!("control.speed_periods", control.speed_periods, Some(1.0), Some(100.0),
            "FG periods per speed measurement k [count]"),
        int!("control.speed_counter_bits", control.speed_counter_bits, Some(8.0), Some(32.0),
            "Width of the speed counter [bits]"),
    ]
}

/// The variables appended after the first layout, in the order they came, so that no
/// earlier value reference moved: the strategy plugin, the speed PI's anti-windup, `in_sync`,
/// the supervisor and the start-up's confirmation, lm's capped window, `verdict`.
#[rustfmt::skip]
fn appended() -> Vec<Variable> {
    vec![
        // Strategy plugin: last, so adding it left every other value reference unchanged.
        var("strategy.plugin", Kind::String, Role::Text(Text::StrategyPlugin), "",
            "Strategy plugin: a shared library built against strategy-abi, as an absolute path or relative to the FMU's resources folder; its strategy replaces strategy.name. Empty: the built-in strategy.name"),
        // Appended after the plugin so that every earlier value reference stays unchanged.
        var("control.speed_anti_windup", Boolean, Role::Parameter {
            get: |c| f64::from(u8::from(c.control.speed_anti_windup)),
            set: |c, v| {
                c.control.speed_anti_windup = v != 0.0;
                Ok(())
            },
        }, "", "Back-calculation anti-windup on the speed PI (not in the chip)"),
        real!("control.speed_anti_windup_gain", control.speed_anti_windup_gain, "1", POSITIVE,
            Some(2.0), "Back-calculation gain of the speed PI (> 0)"),
        output("in_sync", Boolean, Output::InSync, "",
            "True while the last two electrical turns of commutations each fell within ±30° of their table boundary at the true rotor angle: the commutation follows the rotor, whatever the chip believes"),
        var("control.supervisor", Boolean, Role::Parameter {
            get: |c| f64::from(u8::from(c.control.supervisor)),
            set: |c, v| {
                c.control.supervisor = v != 0.0;
                Ok(())
            },
        }, "", "Plausibility supervisor (not in the published chip): restarts when the measured current could not flow against the back-EMF of the believed speed, a coast speeds up, or the comparator shows no crossing for control.supervisor_blind_sectors in a row"),
        real!("control.supervisor_no_load_rpm", control.supervisor_no_load_rpm, "rpm", Some(100.0), Some(1e6),
            "No-load speed at full voltage the supervisor assumes"),
        real!("control.supervisor_emf_fraction", control.supervisor_emf_fraction, "1", POSITIVE,
            Some(1.0), "Fraction of the believed back-EMF the applied voltage must reach for a measured current to be plausible (> 0)"),
        real!("control.supervisor_current_a", control.supervisor_current_a, "A", POSITIVE,
            Some(10.0), "Smallest measured current that proves conduction (> 0)"),
        int!("control.supervisor_updates", control.supervisor_updates, Some(2.0), Some(32.0),
            "PI updates the supervisor looks back over [count]"),
        real!("control.supervisor_coast_rise", control.supervisor_coast_rise, "1", Some(0.01), Some(10.0),
            "Rise of the speed measurement over the lowest of a coast that trips the supervisor"),
        real!("control.supervisor_locked_rotor_a", control.supervisor_locked_rotor_a, "A", POSITIVE,
            Some(1000.0), "Locked-rotor current at full voltage the supervisor assumes, V_DD/(2R) (> 0)"),
        real!("control.supervisor_locked_share", control.supervisor_locked_share, "1", Z, Some(1.0),
            "Share of the locked-rotor current at the duty in force a measured current must reach to count as implausible"),
        int!("control.startup_confirm_deg", control.startup_confirm_deg, Z, Some(15.0),
            "Until the first speed measurement, a crossing needs the comparator at its new level for this many electrical degrees of the last 60° time (0: off) [deg]"),
        real!("control.startup_conduction_deg", control.startup_conduction_deg, "deg", Some(120.0), BELOW_180,
            "Twelve-step conduction angle until the first speed measurement, when narrower than strategy.conduction_angle_deg (120 <= x < 180)"),
        int!("control.supervisor_blind_sectors", control.supervisor_blind_sectors, Some(2.0), Some(1000.0),
            "Crossings in a row taken by the demagnetisation timeout (never shown by the comparator) that trip the supervisor [count]"),
        var("strategy.lm_window_capped", Boolean, Role::Parameter {
            get: |c| f64::from(u8::from(c.strategy.lm_window_capped)),
            set: |c, v| {
                c.strategy.lm_window_capped = v != 0.0;
                Ok(())
            },
        }, "", "lm only (not in the published chip): the linear region ends θZC after it began even if the crossing has not been detected, so a region opened early cannot hold full voltage for several θZC"),
        output("verdict", Kind::Enumeration(EnumType::Verdict), Output::Verdict, "",
            "The run verdict now, judged from the true rotor as drive-bench judges a run, on the recent past: running, off_speed (in synchronism, the true speed low-passed over 0.1 s outside ±2 % of the command), lost_sync (a commutation beyond ±30° of the true rotor since the last two turns in synchronism), stalled (below 10 % of the command), not_started (no two turns in synchronism since the last start), gave_up, non_finite, stopped (a command of 0 with the low-passed true speed below 5 rpm: told to stop, at rest); unsettled is never given live (it says a run's window fell in the start-up)"),
        // The loops and start-up of issue 36, appended after `verdict`.
        int!("control.current_reads", control.current_reads, Some(1.0), Some(64.0),
            "ADC reads of the shunt current averaged per PI update, spread over it one carrier period / n apart in phase (1: the published single read) [count]"),
        real!("control.speed_window_s", control.speed_window_s, "s", Z, Some(1.0),
            "Longest span of one speed measurement: it ends at the first FG edge past it (0: off, the published meter; else at least 1e-3)"),
        var("control.gain_schedule", Boolean, Role::Parameter {
            get: |c| f64::from(u8::from(c.control.gain_schedule)),
            set: |c, v| {
                c.control.gain_schedule = v != 0.0;
                Ok(())
            },
        }, "", "Gain schedule on the measured speed (not in the published chip): the speed PI's error scaled by the duty d̂ the speed needs, the current PI's by 1/d̂; the gains are those at full duty"),
        real!("control.schedule_min_duty", control.schedule_min_duty, "1", Some(1e-3), Some(1.0),
            "Lowest duty the gain schedule assumes"),
        var("control.stop_at_zero", Boolean, Role::Parameter {
            get: |c| f64::from(u8::from(c.control.stop_at_zero)),
            set: |c, v| {
                c.control.stop_at_zero = v != 0.0;
                Ok(())
            },
        }, "", "A speed command of 0 switches the bridge off and the chip waits, without aligning or restarting, until the command rises (not in the published chip)"),
        real!("control.align_current_a", control.align_current_a, "A", Z, Some(10.0),
            "Phase current the first alignment step regulates its duty to, held through the other two (0: the published fixed control.startup_duty)"),
        real!("control.start_phase_current_a", control.start_phase_current_a, "A", Z, Some(10.0),
            "Phase current commanded from the hand-over to the first speed measurement, as d × this shunt current (0: the published control.start_current_a)"),
        var("control.speed_resume", Boolean, Role::Parameter {
            get: |c| f64::from(u8::from(c.control.speed_resume)),
            set: |c, v| {
                c.control.speed_resume = v != 0.0;
                Ok(())
            },
        }, "", "After a fall at the speed PI's lower limit, the first update below the command presets the speed PI to the phase current it held before the fall and the current PI to the duty that needs; raw and DF guards (not in the published chip)"),
        real!("control.start_descent_rpm_s", control.start_descent_rpm_s, "rpm/s", Z, Some(1e6),
            "After a start that ran past the command, the speed PI's reference follows the rotor down no faster than this (0: off, the published chip); must be 0 or at least 1"),
    ]
}
