//! The safe core of one FMU instance: the FMI 2.0 co-simulation state machine, variable
//! access by value reference, and the communication steps on an exact tick clock. No C
//! types here, so all of it is unit-tested without loading the library.

use crate::drive::{Drive, check_input, clamp_speed};
use crate::variables::{Input, Kind, Output, Role, by_vr, table};
use bldc_drive::drive_core::error::check_finite;
use bldc_drive::drive_core::{ParamError, TICK_S, Ticks};
use std::path::PathBuf;

/// Where an instance is in the co-simulation state machine (FMI 2.0 §4.2.4).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Phase {
    /// After `fmi2Instantiate` or `fmi2Reset`.
    Instantiated,
    /// Between `fmi2EnterInitializationMode` and `fmi2ExitInitializationMode`.
    InitializationMode,
    /// Initialized, ready for `fmi2DoStep`.
    StepComplete,
    /// After `fmi2Terminate`.
    Terminated,
    /// A step failed or an internal error happened: only reset, free or a state restore.
    Error,
}

/// Why a call did not simply succeed: the message for the logger names the value and rule.
#[derive(Clone, Debug, PartialEq)]
pub enum Fault {
    /// Done, but not quite as asked (`fmi2Warning`).
    Warning(String),
    /// Refused (`fmi2Error`); the instance is unchanged unless the phase says otherwise.
    Error(String),
}

/// Which `fmi2Get/Set*` family a call belongs to.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Access {
    /// `fmi2Get/SetReal`.
    Real,
    /// `fmi2Get/SetInteger` (Integer and enumeration variables).
    Integer,
    /// `fmi2Get/SetBoolean`.
    Boolean,
    /// `fmi2Get/SetString`.
    String,
}

impl Access {
    fn admits(self, k: Kind) -> bool {
        matches!(
            (self, k),
            (Access::Real, Kind::Real)
                | (Access::Integer, Kind::Integer | Kind::Enumeration(_))
                | (Access::Boolean, Kind::Boolean)
                | (Access::String, Kind::String)
        )
    }
}

/// Everything an FMU state captures.
pub struct Model {
    /// State-machine phase.
    pub phase: Phase,
    /// Value of every variable, indexed by value reference (outputs are not stored).
    pub values: Vec<f64>,
    /// Value of every String variable, indexed by value reference (empty for the others).
    pub texts: Vec<String>,
    /// The instance's `resources` folder (from `fmuResourceLocation`), against which a
    /// relative `strategy.plugin` is resolved. Belongs to the instance, not to its states.
    pub resources: Option<PathBuf>,
    /// `fmi2SetupExperiment` start time \[s\]: master tick 0 of the engine.
    pub start_time: f64,
    /// Stop time, if the master defined one \[s\].
    pub stop_time: Option<f64>,
    /// The current communication point as the master counts it \[s\].
    pub time: f64,
    /// The drive, once built (at initialization, or earlier to answer output queries).
    pub drive: Option<Drive>,
}

impl Default for Model {
    fn default() -> Self {
        Model::new()
    }
}

fn err<T>(msg: impl Into<String>) -> Result<T, Fault> {
    Err(Fault::Error(msg.into()))
}

impl Model {
    /// A fresh instance: every variable at its start value.
    pub fn new() -> Model {
        Model {
            phase: Phase::Instantiated,
            values: table().iter().map(|v| v.start().unwrap_or(0.0)).collect(),
            texts: table()
                .iter()
                .map(|v| v.start_text().unwrap_or_default().to_string())
                .collect(),
            resources: None,
            start_time: 0.0,
            stop_time: None,
            time: 0.0,
            drive: None,
        }
    }

    /// An independent copy (an FMU state).
    pub fn try_clone(&self) -> Result<Model, String> {
        Ok(Model {
            phase: self.phase,
            values: self.values.clone(),
            texts: self.texts.clone(),
            resources: self.resources.clone(),
            start_time: self.start_time,
            stop_time: self.stop_time,
            time: self.time,
            drive: self.drive.as_ref().map(Drive::try_clone).transpose()?,
        })
    }

    fn require(&self, allowed: &[Phase], call: &str) -> Result<(), Fault> {
        if allowed.contains(&self.phase) {
            Ok(())
        } else {
            err(format!(
                "{call} is not allowed in phase {:?} (rule: allowed in {allowed:?})",
                self.phase
            ))
        }
    }

    /// Whether the status of the last step (`fmi2Get*Status`, named `call`) may be asked:
    /// once a step can have been taken, not before initialization ends.
    pub fn status_query(&self, call: &str) -> Result<(), Fault> {
        self.require(
            &[Phase::StepComplete, Phase::Terminated, Phase::Error],
            call,
        )
    }

    /// `fmi2SetupExperiment`.
    pub fn setup_experiment(&mut self, start: f64, stop: Option<f64>) -> Result<(), Fault> {
        self.require(&[Phase::Instantiated], "fmi2SetupExperiment")?;
        if !start.is_finite() {
            return err(format!("startTime = {start} (rule: must be finite)"));
        }
        if let Some(s) = stop
            && !(s.is_finite() && s >= start)
        {
            return err(format!(
                "stopTime = {s} (rule: finite and >= startTime = {start})"
            ));
        }
        self.start_time = start;
        self.time = start;
        self.stop_time = stop;
        Ok(())
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization(&mut self) -> Result<(), Fault> {
        self.require(&[Phase::Instantiated], "fmi2EnterInitializationMode")?;
        self.phase = Phase::InitializationMode;
        Ok(())
    }

    /// `fmi2ExitInitializationMode`: checks every parameter against its rule and builds
    /// the drive.
    pub fn exit_initialization(&mut self) -> Result<(), Fault> {
        self.require(&[Phase::InitializationMode], "fmi2ExitInitializationMode")?;
        self.ensure_drive()?;
        self.phase = Phase::StepComplete;
        Ok(())
    }

    fn ensure_drive(&mut self) -> Result<&mut Drive, Fault> {
        if self.drive.is_none() {
            let d = Drive::new(&self.values, &self.texts, self.resources.as_deref())
                .map_err(Fault::Error)?;
            self.drive = Some(d);
        }
        // Just built or kept: present either way.
        self.drive
            .as_mut()
            .ok_or_else(|| Fault::Error("no drive".into()))
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Result<(), Fault> {
        self.require(&[Phase::StepComplete], "fmi2Terminate")?;
        self.phase = Phase::Terminated;
        Ok(())
    }

    /// `fmi2Reset`: back to the state right after instantiation, every start value again
    /// (the resources folder is the instance's and stays).
    pub fn reset(&mut self) {
        let resources = self.resources.take();
        *self = Model::new();
        self.resources = resources;
    }

    /// Marks the instance failed (after a panic or an engine error).
    pub fn fail(&mut self) {
        self.phase = Phase::Error;
    }

    /// `fmi2Get*`: values of `vrs` into `out`.
    pub fn get(&mut self, access: Access, vrs: &[u32], out: &mut [f64]) -> Result<(), Fault> {
        self.require(
            &[
                Phase::InitializationMode,
                Phase::StepComplete,
                Phase::Terminated,
                Phase::Error,
            ],
            "fmi2Get*",
        )?;
        let mut outs = Vec::new();
        for (&vr, o) in vrs.iter().zip(out.iter_mut()) {
            let v = checked(access, vr)?;
            match v.role {
                Role::Output(k) => outs.push((k, o)),
                _ => *o = self.values[vr as usize],
            }
        }
        if !outs.is_empty() {
            let d = self.ensure_drive()?;
            let kinds: Vec<Output> = outs.iter().map(|(k, _)| *k).collect();
            let mut vals = vec![0.0; kinds.len()];
            d.outputs(&kinds, &mut vals);
            for ((_, o), v) in outs.into_iter().zip(vals) {
                *o = v;
            }
        }
        Ok(())
    }

    /// `fmi2Set*` of one variable: [`Model::check_set`], then [`Model::apply_set`].
    pub fn set(&mut self, access: Access, vr: u32, x: f64) -> Result<(), Fault> {
        let warning = self.check_set(access, vr, x)?;
        self.apply_set(vr, x);
        warning.map_or(Ok(()), |w| Err(Fault::Warning(w)))
    }

    /// Whether `vr` = `x` may be set now, changing nothing: `Err` names the variable and
    /// the rule; `Ok(Some(w))` will be applied with warning `w`. Parameters only before
    /// initialization ends, each within its declared range and its own rule (rules that
    /// tie parameters together are checked when the drive is built); inputs at any time
    /// before termination (they act from the next step on).
    pub fn check_set(&self, access: Access, vr: u32, x: f64) -> Result<Option<String>, Fault> {
        let v = checked(access, vr)?;
        if let Err(e) = check_finite(v.name, x) {
            return err(e.to_string());
        }
        let before_init = matches!(self.phase, Phase::Instantiated | Phase::InitializationMode);
        match v.role {
            Role::Output(_) => err(format!("`{}` is an output and cannot be set", v.name)),
            // `checked` admits String variables only to Access::String (set_text).
            Role::Text(_) => err(format!(
                "`{}` is a String: set it with fmi2SetString",
                v.name
            )),
            Role::Parameter { .. } if !before_init => err(format!(
                "`{}` is a fixed parameter: it can only be set before fmi2ExitInitializationMode (phase is {:?})",
                v.name, self.phase
            )),
            Role::Parameter { .. } => check_held(v, x).map(|()| None).map_err(Fault::Error),
            Role::Input(input) => {
                if !(before_init || self.phase == Phase::StepComplete) {
                    return err(format!(
                        "input `{}` cannot be set in phase {:?}",
                        v.name, self.phase
                    ));
                }
                check_input(v.name, input, x).map_err(Fault::Error)?;
                Ok((input == Input::SpeedRef && clamp_speed(x) != x).then(|| {
                    format!(
                        "`speed_ref_rpm` = {x} is outside 0..=16383 rpm (the 14-bit speed register); clamped to {}",
                        clamp_speed(x)
                    )
                }))
            }
        }
    }

    /// Applies a value [`Model::check_set`] accepted. The variable holds the value in
    /// force: a speed command outside the chip's register is held clamped (what the
    /// model uses, and what `fmi2GetReal` reads back), as the warning said.
    pub fn apply_set(&mut self, vr: u32, x: f64) {
        let Some(v) = by_vr(vr) else { return };
        let before_init = matches!(self.phase, Phase::Instantiated | Phase::InitializationMode);
        let x = match v.role {
            Role::Input(Input::SpeedRef) => clamp_speed(x),
            _ => x,
        };
        self.values[vr as usize] = x;
        match (v.role, self.drive.as_mut()) {
            (Role::Input(input), Some(d)) if !before_init => {
                d.apply(input, x);
            }
            _ => self.drive = None,
        }
    }

    /// `fmi2GetString`: the values of `vrs`, borrowed until the model changes.
    pub fn get_texts(&self, vrs: &[u32]) -> Result<Vec<&str>, Fault> {
        self.require(
            &[
                Phase::InitializationMode,
                Phase::StepComplete,
                Phase::Terminated,
                Phase::Error,
            ],
            "fmi2GetString",
        )?;
        vrs.iter()
            .map(|&vr| {
                checked(Access::String, vr)?;
                Ok(self.texts[vr as usize].as_str())
            })
            .collect()
    }

    /// `fmi2SetString` of one variable: a fixed parameter, so only before initialization
    /// ends. The text is copied; whether it names a usable plugin is checked when the
    /// drive is built.
    pub fn set_text(&mut self, vr: u32, x: &str) -> Result<(), Fault> {
        self.check_text(vr)?;
        self.texts[vr as usize] = x.to_string();
        self.drive = None;
        Ok(())
    }

    /// Whether String variable `vr` may be set now, changing nothing.
    pub fn check_text(&self, vr: u32) -> Result<(), Fault> {
        let v = checked(Access::String, vr)?;
        if !matches!(self.phase, Phase::Instantiated | Phase::InitializationMode) {
            return err(format!(
                "`{}` is a fixed parameter: it can only be set before fmi2ExitInitializationMode (phase is {:?})",
                v.name, self.phase
            ));
        }
        Ok(())
    }

    /// `fmi2DoStep`: advances from `tc` to `tc + h`. The engine's clock is whole master
    /// ticks; each target instant is rounded from its absolute time, so steps of any size
    /// (even below one tick) never accumulate drift.
    pub fn do_step(&mut self, tc: f64, h: f64) -> Result<(), Fault> {
        self.require(&[Phase::StepComplete], "fmi2DoStep")?;
        if !tc.is_finite() {
            return err(format!(
                "currentCommunicationPoint = {tc} (rule: must be finite)"
            ));
        }
        if !(h.is_finite() && h > 0.0) {
            return err(format!(
                "communicationStepSize = {h} (rule: must be finite and > 0)"
            ));
        }
        // Half a tick: the engine cannot tell instants closer than that apart.
        let tol = 0.5 * TICK_S;
        if (tc - self.time).abs() > tol {
            return err(format!(
                "currentCommunicationPoint = {tc} but the last step ended at {} (rule: each step starts where the previous one ended)",
                self.time
            ));
        }
        let end = tc + h;
        if end == tc {
            return err(format!(
                "communicationStepSize = {h} at currentCommunicationPoint = {tc}: tc + h = tc in double precision (rule: a step advances time; at this time a step must be at least {})",
                next_after(tc) - tc
            ));
        }
        if let Some(stop) = self.stop_time
            && end > stop + tol
        {
            return err(format!(
                "step to {end} goes beyond stopTime = {stop} (rule: no step past the stop time)"
            ));
        }
        let Some(target) = Ticks::from_seconds(end - self.start_time) else {
            return err(format!(
                "step to {end} s is beyond the engine's tick counter"
            ));
        };
        let d = self.ensure_drive()?;
        if let Err(e) = d.run_to(target) {
            self.fail();
            return err(format!("the drive stopped: {e}"));
        }
        if let Some((name, x)) = d.non_finite_output() {
            // The engine did reach `end`: the clock follows it, so a state taken now agrees.
            self.time = end;
            self.fail();
            return err(format!(
                "at t = {end} s output `{name}` = {x} (rule: every output finite; the parameters or inputs drove the model out of its valid range); the instance is now in the error state"
            ));
        }
        self.time = end;
        Ok(())
    }
}

/// The next double above `t` (finite).
fn next_after(t: f64) -> f64 {
    if t == 0.0 {
        f64::from_bits(1)
    } else if t > 0.0 {
        f64::from_bits(t.to_bits() + 1)
    } else {
        f64::from_bits(t.to_bits() - 1)
    }
}

/// The rule a value that variable `v` holds obeys, whatever the phase: the one
/// `fmi2Set*` applies when it is first set (for a speed command, once clamped), and the
/// one every value restored from a serialized state passes. Finite; whole for Integer,
/// enumeration and Boolean variables (0 or 1 for a Boolean); within the declared range;
/// a parameter by the library's own rule, the load torque by the plant's; an output or a
/// String variable holds no number (its slot is 0).
pub fn check_held(v: &crate::variables::Variable, x: f64) -> Result<(), String> {
    let name = v.name;
    check_finite(name, x).map_err(|e| e.to_string())?;
    if matches!(v.role, Role::Output(_) | Role::Text(_)) {
        return if x == 0.0 {
            Ok(())
        } else {
            Err(format!(
                "`{name}` = {x} (rule: an output or String variable holds no number: 0)"
            ))
        };
    }
    match v.kind {
        Kind::Boolean if x != 0.0 && x != 1.0 => {
            return Err(format!("`{name}` = {x} (rule: a Boolean, 0 or 1)"));
        }
        Kind::Integer | Kind::Enumeration(_)
            if x.fract() != 0.0 || x < f64::from(i32::MIN) || x > f64::from(i32::MAX) =>
        {
            return Err(format!(
                "`{name}` = {x} (rule: a whole number within a C int)"
            ));
        }
        _ => {}
    }
    if v.min.is_some_and(|m| x < m) || v.max.is_some_and(|m| x > m) {
        // Refused in the library's words where the library has a rule for it.
        if let Some(e) = own_rule(v, x) {
            return Err(e.to_string());
        }
        let (lo, hi) = (
            v.min.unwrap_or(f64::NEG_INFINITY),
            v.max.unwrap_or(f64::INFINITY),
        );
        return Err(format!(
            "`{name}` = {x} (rule: within its declared range {lo}..={hi})"
        ));
    }
    match v.role {
        Role::Parameter { set, .. } => {
            let mut scratch = bldc_drive::DriveConfig::default();
            set(&mut scratch, x).map_err(|e| e.to_string())
        }
        Role::Input(input) => check_input(name, input, x),
        Role::Output(_) | Role::Text(_) => Ok(()),
    }
}

/// The library's refusal of parameter `v` = `x` with every other parameter at its
/// default, when it blames `v` itself: the wording the command line and Python give.
fn own_rule(v: &crate::variables::Variable, x: f64) -> Option<ParamError> {
    let Role::Parameter { set, .. } = v.role else {
        return None;
    };
    let mut c = bldc_drive::DriveConfig::default();
    let e = match set(&mut c, x) {
        Err(e) => e,
        Ok(()) => c.validate().err()?,
    };
    (e.field == v.name).then_some(e)
}

/// The variable `vr`, if `access` may read or write it.
fn checked(access: Access, vr: u32) -> Result<&'static crate::variables::Variable, Fault> {
    let Some(v) = by_vr(vr) else {
        return err(format!(
            "unknown value reference {vr} (rule: 0..={} for this model)",
            table().len() - 1
        ));
    };
    if !access.admits(v.kind) {
        return err(format!(
            "value reference {vr} (`{}`) is {:?}, not accessible with fmi2Get/Set{access:?}",
            v.name, v.kind
        ));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::variables::vr_of;

    fn vr(name: &str) -> u32 {
        vr_of(name).unwrap()
    }

    fn initialized() -> Model {
        let mut m = Model::new();
        m.setup_experiment(0.0, None).unwrap();
        m.enter_initialization().unwrap();
        m.exit_initialization().unwrap();
        m
    }

    fn get1(m: &mut Model, name: &str) -> f64 {
        let mut o = [0.0];
        let a = match by_vr(vr(name)).unwrap().kind {
            Kind::Real => Access::Real,
            Kind::Boolean => Access::Boolean,
            _ => Access::Integer,
        };
        m.get(a, &[vr(name)], &mut o).unwrap();
        o[0]
    }

    #[test]
    fn calls_out_of_order_are_refused_without_changing_the_phase() {
        let mut m = Model::new();
        assert!(matches!(m.do_step(0.0, 1e-3), Err(Fault::Error(_))));
        assert!(m.exit_initialization().is_err());
        assert!(m.terminate().is_err());
        assert!(m.get(Access::Real, &[vr("speed_rpm")], &mut [0.0]).is_err());
        assert_eq!(m.phase, Phase::Instantiated);
        let mut m = initialized();
        assert!(m.setup_experiment(0.0, None).is_err());
        assert!(m.enter_initialization().is_err());
        assert_eq!(m.phase, Phase::StepComplete);
    }

    #[test]
    fn step_status_is_refused_before_initialization_ends() {
        let mut m = Model::new();
        for phase in [Phase::Instantiated, Phase::InitializationMode] {
            m.phase = phase;
            let Err(Fault::Error(msg)) = m.status_query("fmi2GetRealStatus") else {
                panic!("a status query in {phase:?} was accepted")
            };
            assert!(
                msg.contains("fmi2GetRealStatus") && msg.contains("rule"),
                "{msg}"
            );
        }
        for phase in [Phase::StepComplete, Phase::Terminated, Phase::Error] {
            m.phase = phase;
            m.status_query("fmi2GetStatus").unwrap();
        }
    }

    #[test]
    fn bad_steps_name_the_value_and_rule() {
        let mut m = initialized();
        for (tc, h) in [
            (0.0, -1e-3),
            (0.0, 0.0),
            (0.0, f64::NAN),
            (0.0, f64::INFINITY),
            (0.5, 1e-3),
        ] {
            let Err(Fault::Error(msg)) = m.do_step(tc, h) else {
                panic!("step ({tc}, {h}) accepted")
            };
            assert!(msg.contains("rule"), "{msg}");
        }
        assert_eq!(m.phase, Phase::StepComplete);
        m.do_step(0.0, 1e-3).unwrap();
    }

    #[test]
    fn a_step_that_cannot_advance_time_is_refused_naming_the_rule() {
        let mut m = Model::new();
        m.setup_experiment(1e15, None).unwrap();
        m.enter_initialization().unwrap();
        m.exit_initialization().unwrap();
        let Err(Fault::Error(msg)) = m.do_step(1e15, 1e-3) else {
            panic!("a step that does not advance time was accepted")
        };
        assert!(
            msg.contains("1000000000000000") && msg.contains("rule: a step advances time"),
            "{msg}"
        );
        assert_eq!(m.time, 1e15);
        m.do_step(1e15, 0.125).unwrap();
    }

    #[test]
    fn a_clamped_speed_command_reads_back_as_the_command_in_force() {
        let mut m = initialized();
        let speed = vr("speed_ref_rpm");
        assert!(matches!(
            m.set(Access::Real, speed, 20_000.0),
            Err(Fault::Warning(_))
        ));
        assert_eq!(get1(&mut m, "speed_ref_rpm"), 16_383.0);
        assert_eq!(
            m.drive.as_ref().unwrap().applied(Input::SpeedRef),
            16_383.0,
            "the value held is the one in force"
        );
        m.set(Access::Real, speed, -5.0).unwrap_err();
        assert_eq!(get1(&mut m, "speed_ref_rpm"), 0.0);
        // A state then restores (the value held passes the rule on restore).
        let bytes = crate::state::serialize(&m).unwrap();
        crate::state::deserialize(&bytes, None).unwrap();
    }

    #[test]
    fn stop_time_is_enforced() {
        let mut m = Model::new();
        m.setup_experiment(0.0, Some(2e-3)).unwrap();
        m.enter_initialization().unwrap();
        m.exit_initialization().unwrap();
        m.do_step(0.0, 1e-3).unwrap();
        m.do_step(1e-3, 1e-3).unwrap();
        assert!(m.do_step(2e-3, 1e-3).is_err());
    }

    #[test]
    fn steps_that_are_not_whole_ticks_do_not_drift() {
        // 7 ns steps: each ends between ticks; the engine must sit at round(t / 20 ns).
        let mut m = initialized();
        let h = 7e-9;
        let mut t = 0.0;
        for k in 1..=1000u32 {
            m.do_step(t, h).unwrap();
            let end = t + h;
            t = f64::from(k) * h; // the master's next point, as fmpy computes it
            let now = m.drive.as_ref().unwrap().engine.now();
            assert_eq!(now, Ticks::from_seconds(end).unwrap(), "step {k}");
            assert!(
                (now.seconds() - t).abs() <= 0.5 * TICK_S + 1e-15,
                "step {k}"
            );
        }
        assert_eq!(m.drive.as_ref().unwrap().engine.now(), Ticks(350));
    }

    #[test]
    fn parameters_are_checked_when_set_fixed_after_initialization_and_tied_at_its_end() {
        let mut m = Model::new();
        m.enter_initialization().unwrap();
        let r = vr("motor.resistance_ohm");
        let before = m.values[r as usize];
        let Err(Fault::Error(msg)) = m.set(Access::Real, r, -1.0) else {
            panic!("a resistance below its range was accepted")
        };
        assert!(
            msg.contains("motor.resistance_ohm") && msg.contains("-1") && msg.contains("rule"),
            "{msg}"
        );
        assert_eq!(m.values[r as usize], before, "nothing applied");
        // Within its own range, but not below the self inductance: the tie is checked
        // when the drive is built.
        m.set(Access::Real, vr("motor.mutual_inductance_h"), 0.9)
            .unwrap();
        let Err(Fault::Error(msg)) = m.exit_initialization() else {
            panic!()
        };
        assert!(msg.contains("inductance"), "{msg}");
        assert_eq!(m.phase, Phase::InitializationMode);
        m.set(Access::Real, vr("motor.mutual_inductance_h"), 0.0)
            .unwrap();
        m.set(Access::Real, r, 2.0).unwrap();
        m.exit_initialization().unwrap();
        assert!(m.set(Access::Real, r, 3.0).is_err());
        assert_eq!(m.values[r as usize], 2.0);
    }

    #[test]
    fn a_refused_parameter_reads_as_the_command_line_words_it() {
        // The words of `drive-bench run --config` for the same values (tests/integration/cli.rs).
        let mut m = Model::new();
        let r = vr("motor.resistance_ohm");
        for (x, want) in [
            (
                -1.0,
                "`motor.resistance_ohm` = -1 (rule: must be 1e-4..=1e3 Ω)",
            ),
            (
                f64::NAN,
                "`motor.resistance_ohm` = NaN (rule: must be finite)",
            ),
        ] {
            assert_eq!(m.set(Access::Real, r, x), Err(Fault::Error(want.into())));
        }
    }

    #[test]
    fn the_load_torque_follows_the_librarys_rule() {
        let mut m = initialized();
        let load = vr("load_torque_nm");
        for x in [1.0 + 1e-9, -1.5, 1e300, -1e300, f64::INFINITY] {
            let Err(Fault::Error(msg)) = m.set(Access::Real, load, x) else {
                panic!("load {x} accepted")
            };
            assert!(
                msg.contains("load_torque_nm") && msg.contains("rule"),
                "{msg}"
            );
            assert_eq!(m.values[load as usize], 0.0);
        }
        m.set(Access::Real, load, -1.0).unwrap();
        m.set(Access::Real, load, 1.0).unwrap();
        let v = by_vr(load).unwrap();
        assert_eq!((v.min, v.max), (Some(-1.0), Some(1.0)), "declared range");
    }

    #[test]
    fn a_model_driven_out_of_range_ends_the_step_with_an_error_not_nan() {
        // Every parameter now has a finite bound, so the test puts the plant out of range
        // itself: a rotor spun to an infinite speed (no checked input reaches there).
        let mut m = initialized();
        m.do_step(0.0, 1e-3).unwrap();
        m.drive
            .as_mut()
            .unwrap()
            .engine
            .plant
            .set_rotor(0.0, f64::INFINITY, false);
        let mut k = 0;
        let msg = loop {
            match m.do_step(m.time, 1e-3) {
                Ok(()) => {
                    for name in ["speed_rpm", "i_u", "torque_nm", "theta_e_deg"] {
                        let x = get1(&mut m, name);
                        assert!(x.is_finite(), "{name} = {x} after an OK step {k}");
                    }
                }
                Err(Fault::Error(msg)) => break msg,
                Err(w) => panic!("{w:?}"),
            }
            k += 1;
            assert!(k < 300, "the model stayed finite: pick another case");
        };
        assert!(msg.contains("rule"), "{msg}");
        assert_eq!(m.phase, Phase::Error);
        assert!(m.do_step(m.time, 1e-3).is_err(), "no step after it");
    }

    #[test]
    fn bad_values_and_references_are_refused() {
        let mut m = initialized();
        assert!(m.set(Access::Real, vr("load_torque_nm"), f64::NAN).is_err());
        assert!(m.set(Access::Real, 10_000, 1.0).is_err());
        assert!(m.set(Access::Integer, vr("speed_ref_rpm"), 1.0).is_err());
        assert!(m.set(Access::Real, vr("speed_rpm"), 1.0).is_err());
        assert!(m.get(Access::Boolean, &[vr("state")], &mut [0.0]).is_err());
        assert!(matches!(
            m.set(Access::Real, vr("speed_ref_rpm"), 20_000.0),
            Err(Fault::Warning(_))
        ));
    }

    #[test]
    fn the_plugin_path_is_a_fixed_string_parameter_checked_when_the_drive_is_built() {
        let mut m = Model::new();
        let p = vr("strategy.plugin");
        m.resources = Some(PathBuf::from("/nonexistent/resources"));
        assert!(
            m.get_texts(&[p]).is_err(),
            "no get before initialization mode"
        );
        m.enter_initialization().unwrap();
        assert_eq!(m.get_texts(&[p]).unwrap(), [""]);
        assert!(m.set(Access::Real, p, 1.0).is_err());
        assert!(m.set_text(vr("motor.poles"), "12").is_err());
        m.set_text(p, "plugin.so").unwrap();
        assert_eq!(m.get_texts(&[p]).unwrap(), ["plugin.so"]);
        let Err(Fault::Error(msg)) = m.exit_initialization() else {
            panic!("a missing plugin was accepted")
        };
        assert!(
            msg.contains("`plugin.so`") && msg.contains("/nonexistent/resources/plugin.so"),
            "{msg}"
        );
        assert!(msg.contains("rule"), "{msg}");
        assert_eq!(m.phase, Phase::InitializationMode);
        m.set_text(p, "").unwrap();
        m.exit_initialization().unwrap();
        assert!(
            m.set_text(p, "plugin.so").is_err(),
            "fixed after initialization"
        );
        m.reset();
        assert_eq!(m.texts[p as usize], "");
        assert!(
            m.resources.is_some(),
            "the instance keeps its resources folder"
        );
    }

    #[test]
    fn enable_false_stops_the_drive_and_true_starts_it_again() {
        let mut m = initialized();
        let step = |m: &mut Model, to: f64| {
            while m.time < to - 1e-12 {
                let t = m.time;
                m.do_step(t, 1e-3).unwrap();
            }
        };
        step(&mut m, 0.1);
        assert!(get1(&mut m, "duty") > 0.0, "aligning");
        m.set(Access::Boolean, vr("enable"), 0.0).unwrap();
        step(&mut m, 0.2);
        assert_eq!(get1(&mut m, "duty"), 0.0);
        assert_eq!(get1(&mut m, "i_u").abs() + get1(&mut m, "i_v").abs(), 0.0);
        m.set(Access::Boolean, vr("enable"), 1.0).unwrap();
        step(&mut m, 0.3);
        assert!(get1(&mut m, "duty") > 0.0, "aligning again");
    }
}
