//! One FMU variable: its FMI type, its role (parameter, input, output or text) and where
//! its value comes from, its unit, description and declared range; and the items of the
//! model's enumerations.

use crate::DriveConfig;
use crate::drive_core::ParamError;
use crate::drive_core::pwm::PwmSchemeKind;
use crate::strategies::{GuardKind, StrategyName};
use crate::verdict::Verdict;

/// Reads a value from a config (as the f64 every variable is stored as).
pub type Getter = fn(&DriveConfig) -> f64;
/// Writes a value into a config; fails with the field, the value and the rule.
pub type Setter = fn(&mut DriveConfig, f64) -> Result<(), ParamError>;

/// FMI base type of a variable.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `fmi2Real`.
    Real,
    /// `fmi2Integer`.
    Integer,
    /// `fmi2Boolean`.
    Boolean,
    /// `fmi2String` (its value lives in the model's texts, not in the f64 values).
    String,
    /// An enumeration (accessed with `fmi2Get/SetInteger`), items numbered from 1.
    Enumeration(EnumType),
}

/// The enumeration types of the model.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum EnumType {
    /// Built-in strategy and guard ([`strategy_choices`]).
    Strategy,
    /// PWM scheme ([`PwmSchemeKind::ALL`]).
    PwmScheme,
    /// The run verdict ([`Verdict::ALL`], with `_` for `-`).
    Verdict,
}

impl EnumType {
    /// Name of the `SimpleType` in the model description.
    pub fn type_name(self) -> &'static str {
        match self {
            EnumType::Strategy => "Strategy",
            EnumType::PwmScheme => "PwmScheme",
            EnumType::Verdict => "Verdict",
        }
    }

    /// Item names, in value order (value = position + 1): the library's names with `_`
    /// for `-`, so that each is a Modelica identifier (`twelve_step_df`, `high_side_chop`).
    pub fn items(self) -> Vec<String> {
        let names: Vec<String> = match self {
            EnumType::Strategy => strategy_choices()
                .iter()
                .map(|&(n, g)| choice_name(n, g))
                .collect(),
            EnumType::PwmScheme => PwmSchemeKind::ALL
                .iter()
                .map(|k| k.name().to_string())
                .collect(),
            EnumType::Verdict => Verdict::ALL
                .iter()
                .map(|v| v.as_str().to_string())
                .collect(),
        };
        names.into_iter().map(|n| n.replace('-', "_")).collect()
    }

    /// Every enumeration type of the model.
    pub const ALL: [EnumType; 3] = [EnumType::Strategy, EnumType::PwmScheme, EnumType::Verdict];
}

/// A drive input, set by the master between steps.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Input {
    /// Speed command \[rpm\] → `Strategy::set_speed_ref`.
    SpeedRef,
    /// Load torque on the shaft [N·m] → `BldcPlant::set_load_torque`.
    LoadTorque,
    /// Drive enable → the chip's start input (and reset while low).
    Enable,
}

/// A drive output, read from the plant's observation or the chip's status.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Output {
    /// True mechanical speed \[rpm\].
    SpeedRpm,
    /// The chip's FG speed measurement \[rpm\].
    SpeedEstRpm,
    /// Electrical angle θe \[deg\] in 0..360.
    ThetaEDeg,
    /// Phase current u \[A\].
    IU,
    /// Phase current v \[A\].
    IV,
    /// Phase current w \[A\].
    IW,
    /// Electromagnetic torque [N·m].
    TorqueNm,
    /// PWM duty, fraction 0..1 of the carrier top.
    Duty,
    /// Commutation state.
    State,
    /// Restarts so far.
    Restarts,
    /// 1 while the last two electrical turns of commutations followed the true rotor.
    InSync,
    /// The run verdict now (an item of [`EnumType::Verdict`]).
    Verdict,
}

/// What a variable is and where its value comes from.
#[derive(Copy, Clone, Debug)]
pub enum Role {
    /// Fixed after initialization; lives in the config the drive is built from.
    Parameter {
        /// Reads it (the start value is `get(&DriveConfig::default())`).
        get: Getter,
        /// Writes it at `fmi2ExitInitializationMode`.
        set: Setter,
    },
    /// Set by the master at any communication point.
    Input(Input),
    /// Computed by the drive.
    Output(Output),
    /// A String parameter: fixed after initialization, read when the drive is built.
    Text(Text),
}

/// A String parameter.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Text {
    /// Path of a strategy plugin (empty: the built-in `strategy.name`).
    StrategyPlugin,
}

/// One FMU variable.
#[derive(Copy, Clone, Debug)]
pub struct Variable {
    /// Unique name (structured: the dotted config path for parameters).
    pub name: &'static str,
    /// FMI type.
    pub kind: Kind,
    /// Role and value source.
    pub role: Role,
    /// Unit (Real only; other types carry it in the description).
    pub unit: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// Lower bound (inclusive, as FMI defines it), where a rule has one.
    pub min: Option<f64>,
    /// Upper bound, where a rule has one.
    pub max: Option<f64>,
}

impl Variable {
    /// The start value: defaults of the config for parameters and the speed command.
    pub fn start(&self) -> Option<f64> {
        match self.role {
            Role::Parameter { get, .. } => Some(get(&DriveConfig::default())),
            Role::Input(Input::SpeedRef) => Some(DriveConfig::default().control.speed_ref_rpm),
            Role::Input(Input::LoadTorque) => Some(0.0),
            Role::Input(Input::Enable) => Some(1.0),
            Role::Output(_) | Role::Text(_) => None,
        }
    }

    /// The start value of a String variable.
    pub fn start_text(&self) -> Option<&'static str> {
        match self.role {
            Role::Text(Text::StrategyPlugin) => Some(""),
            _ => None,
        }
    }
}

/// Every built-in strategy with each guard it can take: twelve-step names fix their
/// guard, six-step-120 takes any.
pub fn strategy_choices() -> Vec<(StrategyName, Option<GuardKind>)> {
    const GUARDS: [GuardKind; 4] = [GuardKind::Df, GuardKind::Raw, GuardKind::Nd, GuardKind::Lm];
    let mut out = Vec::new();
    for name in StrategyName::ALL {
        match name.fixed_guard() {
            Some(_) => out.push((name, None)),
            None => out.extend(GUARDS.iter().map(|&g| (name, Some(g)))),
        }
    }
    out
}

fn choice_name(name: StrategyName, guard: Option<GuardKind>) -> String {
    match guard {
        Some(g) => format!("{name}-{}", g.as_str()),
        None => name.to_string(),
    }
}
