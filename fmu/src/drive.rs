//! The running drive inside an instance: the engine, the inputs applied to it, and the
//! live verdict; its dynamic state is saved and restored by value for serialized states.

use crate::variables::{Input, Output, Role, Text, table};
use bldc_drive::DriveConfig;
use bldc_drive::drive::{DriveEngine, build, build_plugin};
use bldc_drive::drive_core::error::check_finite;
use bldc_drive::drive_core::state::{Persist, Reader, Writer};
use bldc_drive::drive_core::{EngineError, ParamError, Plant, StopReason, Ticks, persist_fields};
use bldc_drive::plants::Load;
use bldc_drive::strategies::Mode;
use bldc_drive::strategies::PluginLibrary;
use bldc_drive::strategies::params::SPEED_CMD_MAX_RPM;
use bldc_drive::verdict::{LiveVerdict, Verdict, VerdictRule};
use std::path::{Path, PathBuf};

/// The rule of an input's value, as `fmi2Set*` checks it before applying anything.
pub fn check_input(name: &str, input: Input, x: f64) -> Result<(), String> {
    check_finite(name, x).map_err(|e| e.to_string())?;
    if input == Input::LoadTorque {
        // The library's rule for an active load torque (plants::Load::validate).
        Load {
            active_nm: x,
            ..Load::default()
        }
        .validate()
        .map_err(|e| ParamError::new(name, x, e.rule).to_string())?;
    }
    Ok(())
}

/// Engine + applied inputs + live verdict.
pub struct Drive {
    /// The plant and the chip.
    pub engine: DriveEngine,
    /// The variable values the drive was built from.
    pub built_from: Vec<f64>,
    /// The String values it was built from (the plugin path as set).
    pub built_from_texts: Vec<String>,
    /// Inputs in force: speed command, load torque, enable.
    applied: [f64; 3],
    /// The commutation against the true rotor, for the `in_sync` output.
    sync: Sync,
}

/// The commutation and the speed against the true rotor, for the `in_sync` and `verdict`
/// outputs: the run verdicts' rule applied while the drive runs (see
/// [`bldc_drive::verdict::LiveVerdict`]).
#[derive(Copy, Clone, Debug)]
struct Sync {
    live: LiveVerdict,
    last_state: u8,
}

persist_fields!(Sync { live, last_state });

impl Sync {
    fn new(engine: &DriveEngine) -> Self {
        let table = engine.controller.table();
        Sync {
            live: LiveVerdict::new(VerdictRule::default(), table.states_per_turn()),
            last_state: 0,
        }
    }

    /// At an engine stop: a commutation is checked against the true angle there, and the
    /// true speed feeds the verdict's low-pass.
    fn at(&mut self, e: &DriveEngine) {
        let state = e.controller.status().state;
        if state == 0 {
            self.live.restart();
        } else if state != self.last_state && self.last_state != 0 {
            let o = e.plant.observe();
            let boundary = e.controller.table().state_start_deg(state);
            self.live.commutation(o.theta_e.to_degrees(), boundary);
            self.live.speed(o.t_s, o.speed_rpm);
        }
        self.last_state = state;
    }

    /// At a communication point: the speed there too (a drive that does not commutate
    /// still has a speed).
    fn end(&mut self, e: &DriveEngine) {
        let o = e.plant.observe();
        self.live.speed(o.t_s, o.speed_rpm);
    }
}

/// The config the variable values describe: defaults, then every parameter, then the
/// speed command as the config's initial speed command.
pub fn config_of(values: &[f64]) -> Result<DriveConfig, ParamError> {
    let mut c = DriveConfig::default();
    for (v, &x) in table().iter().zip(values) {
        match v.role {
            Role::Parameter { set, .. } => set(&mut c, x)?,
            Role::Input(Input::SpeedRef) => c.control.speed_ref_rpm = clamp_speed(x),
            _ => {}
        }
    }
    c.validate()?;
    Ok(c)
}

/// The speed command the chip can hold (its register is 14 bit).
pub fn clamp_speed(rpm: f64) -> f64 {
    rpm.clamp(0.0, SPEED_CMD_MAX_RPM)
}

/// The value of String parameter `which` among `texts` (indexed by value reference).
pub fn text_of(texts: &[String], which: Text) -> &str {
    table()
        .iter()
        .position(|v| matches!(v.role, Role::Text(t) if t == which))
        .and_then(|vr| texts.get(vr))
        .map_or("", String::as_str)
}

/// The file `strategy.plugin` = `text` names: an absolute path as is, a relative one
/// inside the instance's resources folder.
pub fn plugin_path(text: &str, resources: Option<&Path>) -> Result<PathBuf, String> {
    let p = Path::new(text);
    let path = match resources {
        _ if p.is_absolute() => p.to_path_buf(),
        Some(r) => r.join(p),
        None => {
            return Err(format!(
                "strategy.plugin = `{text}` is a relative path, but fmi2Instantiate gave no file:// fmuResourceLocation to resolve it against (rule: an absolute path, or one relative to the FMU's resources folder)"
            ));
        }
    };
    if !path.is_file() {
        return Err(format!(
            "strategy.plugin = `{text}`: no file at {} (rule: an existing plugin library, absolute or relative to the FMU's resources folder)",
            path.display()
        ));
    }
    Ok(path)
}

/// The String values as a serialized state stores them: `strategy.plugin` relative to the
/// resources folder, so that a state holds no absolute path and restores wherever the FMU
/// is unpacked. An absolute path inside `resources` becomes relative; one outside it is
/// refused, naming the value and the rule.
pub fn portable_texts(texts: &[String], resources: Option<&Path>) -> Result<Vec<String>, String> {
    let mut out = texts.to_vec();
    for (t, v) in out.iter_mut().zip(table()) {
        if !matches!(v.role, Role::Text(Text::StrategyPlugin)) || !Path::new(t).is_absolute() {
            continue;
        }
        let inside = resources.and_then(|r| Path::new(t).strip_prefix(r).ok());
        *t = inside.and_then(Path::to_str).map(str::to_string).ok_or_else(|| {
            format!(
                "strategy.plugin = `{t}` lies outside the FMU's resources folder (rule: a serialized state names its plugin relative to the resources folder, never by an absolute path: pack it with `cargo xtask fmu --plugin PATH` and set its file name)"
            )
        })?;
    }
    Ok(out)
}

/// The engine the values describe: the built-in strategy, or the plugin `strategy.plugin`
/// names, loaded and checked as `drive-bench --plugin` does.
fn engine_of(
    cfg: &DriveConfig,
    texts: &[String],
    resources: Option<&Path>,
) -> Result<DriveEngine, String> {
    let text = text_of(texts, Text::StrategyPlugin);
    if text.is_empty() {
        return build(cfg).map_err(|e| e.to_string());
    }
    let path = plugin_path(text, resources)?;
    let named = |e: String| {
        let rule = if e.contains("(rule:") {
            ""
        } else {
            " (rule: a strategy plugin built against strategy-abi)"
        };
        format!("strategy.plugin = `{text}`: {e}{rule}")
    };
    let lib = PluginLibrary::load(&path).map_err(|e| named(e.to_string()))?;
    build_plugin(cfg, &lib).map_err(|e| named(e.to_string()))
}

/// Checks that `path` is a strategy plugin the FMU can run: loaded and built into a drive
/// with the default parameters, as at initialization (`cargo xtask fmu --plugin` calls it
/// through the model-description tool before packing the file).
pub fn check_plugin(path: &Path) -> Result<(), String> {
    let shown = path.display().to_string();
    // The loader's errors usually name the file already.
    let named = |e: String| {
        if e.contains(&shown) {
            e
        } else {
            format!("plugin {shown}: {e}")
        }
    };
    let lib = PluginLibrary::load(path).map_err(|e| {
        named(format!(
            "{e} (rule: a strategy plugin built against strategy-abi)"
        ))
    })?;
    build_plugin(&DriveConfig::default(), &lib)
        .map(drop)
        .map_err(|e| named(e.to_string()))
}

fn slot(input: Input) -> usize {
    match input {
        Input::SpeedRef => 0,
        Input::LoadTorque => 1,
        Input::Enable => 2,
    }
}

impl Drive {
    /// Builds the drive at t = 0 from variable values (parameters and initial inputs) and
    /// String values; a relative plugin path is resolved inside `resources`.
    pub fn new(
        values: &[f64],
        texts: &[String],
        resources: Option<&Path>,
    ) -> Result<Drive, String> {
        for (v, &x) in table().iter().zip(values) {
            if let Role::Input(i) = v.role {
                check_input(v.name, i, x)?;
            }
        }
        let cfg = config_of(values).map_err(|e| e.to_string())?;
        let engine = engine_of(&cfg, texts, resources)?;
        let mut d = Drive {
            sync: Sync::new(&engine),
            engine,
            built_from: values.to_vec(),
            built_from_texts: texts.to_vec(),
            // What `build` leaves in force: the config's speed command, no load, start held.
            applied: [cfg.control.speed_ref_rpm, 0.0, 1.0],
        };
        for (v, &x) in table().iter().zip(values) {
            if let Role::Input(i) = v.role {
                d.apply(i, x);
            }
        }
        Ok(d)
    }

    /// Hands a changed input to the plant or the chip; false if nothing changed.
    ///
    /// `enable` false drops the chip's start input and holds its reset (bridge off, restart
    /// count cleared, a given-up drive revived); true releases reset and raises start, so
    /// the chip debounces it and aligns again. The controller is woken so it sees the
    /// change even if it was asleep waiting for start.
    pub(crate) fn apply(&mut self, input: Input, x: f64) -> bool {
        let x = match input {
            Input::SpeedRef => clamp_speed(x),
            Input::Enable => f64::from(u8::from(x != 0.0)),
            Input::LoadTorque => x,
        };
        let s = slot(input);
        if self.applied[s] == x {
            return false;
        }
        self.applied[s] = x;
        let e = &mut self.engine;
        match input {
            Input::SpeedRef => e.controller.set_speed_ref(x),
            Input::LoadTorque => e.plant.set_load_torque(x),
            Input::Enable => {
                let on = x != 0.0;
                let now = e.now();
                e.controller.set_reset(!on);
                e.controller.set_start(now, on);
                e.wake_controller();
            }
        }
        true
    }

    /// The value of `input` in force (as `Drive::apply` took it).
    pub fn applied(&self, input: Input) -> f64 {
        self.applied[slot(input)]
    }

    /// Runs the engine to master tick `end` (a communication point).
    pub fn run_to(&mut self, end: Ticks) -> Result<(), EngineError> {
        let sync = &mut self.sync;
        self.engine.run_until(end, |e, reason| {
            if !matches!(reason, StopReason::Diode | StopReason::Sensing) {
                sync.at(e);
            }
        })?;
        self.sync.end(&self.engine);
        Ok(())
    }

    /// The first output that is not finite, if any: the model has left its valid range.
    pub fn non_finite_output(&self) -> Option<(&'static str, f64)> {
        let all: Vec<(&'static str, Output)> = table()
            .iter()
            .filter_map(|v| match v.role {
                Role::Output(o) => Some((v.name, o)),
                _ => None,
            })
            .collect();
        let kinds: Vec<Output> = all.iter().map(|&(_, o)| o).collect();
        let mut vals = vec![0.0; kinds.len()];
        self.outputs(&kinds, &mut vals);
        all.iter()
            .zip(vals)
            .find(|(_, x)| !x.is_finite())
            .map(|(&(n, _), x)| (n, x))
    }

    /// An independent copy in the same state (bit-identical continuation).
    pub fn try_clone(&self) -> Result<Drive, String> {
        Ok(Drive {
            engine: bldc_drive::drive::try_clone(&self.engine)?,
            built_from: self.built_from.clone(),
            built_from_texts: self.built_from_texts.clone(),
            applied: self.applied,
            sync: self.sync,
        })
    }

    /// Output values now, one per `outs` entry.
    pub fn outputs(&self, outs: &[Output], values: &mut [f64]) {
        let obs = self.engine.plant.observe();
        let st = self.engine.controller.status();
        let top = f64::from(self.engine.carrier().top);
        for (o, v) in outs.iter().zip(values) {
            *v = match o {
                Output::SpeedRpm => obs.speed_rpm,
                Output::SpeedEstRpm => f64::from(st.speed_est_rpm),
                Output::ThetaEDeg => wrap_deg(obs.theta_e.to_degrees()),
                Output::IU => obs.i.u,
                Output::IV => obs.i.v,
                Output::IW => obs.i.w,
                Output::TorqueNm => obs.torque_nm,
                Output::Duty => f64::from(st.duty) / top,
                Output::State => f64::from(st.state),
                Output::Restarts => f64::from(st.restarts.min(i32::MAX as u32)),
                Output::InSync => f64::from(u8::from(self.sync.live.in_sync())),
                Output::Verdict => {
                    let finite = obs.speed_rpm.is_finite()
                        && obs.i.u.is_finite()
                        && obs.i.v.is_finite()
                        && obs.i.w.is_finite();
                    let v = self.sync.live.verdict(
                        self.engine.controller.speed_ref_rpm(),
                        finite,
                        st.mode == Mode::GaveUp,
                    );
                    // Enumeration items count from 1, in `Verdict::ALL`'s order.
                    Verdict::ALL
                        .iter()
                        .position(|&x| x == v)
                        .map_or(0.0, |k| (k + 1) as f64)
                }
            };
        }
    }
}

/// The inputs in force, the live verdict and the engine; the drive is built from the
/// variable values first (see [`crate::state`]), so no parameter is read back.
impl Persist for Drive {
    fn save(&self, w: &mut Writer) {
        self.applied.save(w);
        self.sync.save(w);
        self.engine.save(w);
    }

    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        r.field("applied", &mut self.applied)?;
        for v in table() {
            if let Role::Input(i) = v.role {
                let x = self.applied[slot(i)];
                let ok = match i {
                    Input::SpeedRef => clamp_speed(x) == x,
                    Input::Enable => x == 0.0 || x == 1.0,
                    Input::LoadTorque => check_input(v.name, i, x).is_ok(),
                };
                if !ok {
                    return Err(format!(
                        "applied.[{}] = {x} (rule: a value the input `{}` takes, as fmi2Set* applies it)",
                        slot(i),
                        v.name
                    ));
                }
            }
        }
        r.field("sync", &mut self.sync)?;
        r.field("engine", &mut self.engine)?;
        // The verdict judges this drive: the speeds it low-passed are its rotor's, by its
        // time, and the state it last saw is one of the table's.
        let plant = &self.engine.plant;
        self.sync
            .live
            .check_restored(plant.time_s(), plant.max_speed_rpm())
            .map_err(|e| format!("sync.live.{e}"))?;
        let states = self.engine.controller.table().states_per_turn();
        let last = self.sync.last_state;
        if u32::from(last) > states {
            return Err(format!(
                "sync.last_state = {last} (rule: a state of the table, 0..={states})"
            ));
        }
        Ok(())
    }
}

/// An angle in [0, 360).
fn wrap_deg(d: f64) -> f64 {
    let w = d.rem_euclid(360.0);
    if w >= 360.0 { 0.0 } else { w }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plugin_paths_resolve_inside_resources_and_name_the_rule() {
        let dir = std::env::temp_dir().join(format!("fmu-plugin-path-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("p.so"), b"x").unwrap();
        assert_eq!(plugin_path("p.so", Some(&dir)).unwrap(), dir.join("p.so"));
        let abs = dir.join("p.so");
        let abs = abs.to_str().unwrap();
        assert_eq!(plugin_path(abs, None).unwrap(), dir.join("p.so"));
        let e = plugin_path("p.so", None).unwrap_err();
        assert!(e.contains("`p.so`") && e.contains("rule"), "{e}");
        let e = plugin_path("missing.so", Some(&dir)).unwrap_err();
        assert!(e.contains("missing.so") && e.contains("rule"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_that_is_not_a_library_is_refused_with_its_name() {
        let dir = std::env::temp_dir().join(format!("fmu-plugin-text-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("text.so"), b"not a library").unwrap();
        let values: Vec<f64> = table().iter().map(|v| v.start().unwrap_or(0.0)).collect();
        let mut texts = vec![String::new(); table().len()];
        let vr = crate::variables::vr_of("strategy.plugin").unwrap() as usize;
        texts[vr] = "text.so".into();
        let Err(e) = Drive::new(&values, &texts, Some(&dir)) else {
            panic!("a text file was loaded as a plugin")
        };
        assert!(
            e.contains("strategy.plugin = `text.so`")
                && e.contains("not a loadable shared library"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The drive built from the table's start values with some set by name, run to `t_s`.
    fn drive_after(set: &[(&str, f64)], t_s: f64) -> Drive {
        let mut values: Vec<f64> = table().iter().map(|v| v.start().unwrap_or(0.0)).collect();
        for &(name, x) in set {
            values[crate::variables::vr_of(name).unwrap() as usize] = x;
        }
        let texts = vec![String::new(); table().len()];
        let mut d = Drive::new(&values, &texts, None).unwrap();
        d.run_to(Ticks::from_seconds(t_s).unwrap()).unwrap();
        d
    }

    /// `in_sync` and the true speed after [`drive_after`].
    fn in_sync_after(set: &[(&str, f64)], t_s: f64) -> (f64, f64) {
        let mut out = [0.0; 2];
        drive_after(set, t_s).outputs(&[Output::InSync, Output::SpeedRpm], &mut out);
        (out[0], out[1])
    }

    /// The `verdict` output after [`drive_after`], as a library verdict.
    fn verdict_after(set: &[(&str, f64)], t_s: f64) -> Verdict {
        let mut out = [0.0];
        drive_after(set, t_s).outputs(&[Output::Verdict], &mut out);
        Verdict::ALL[out[0] as usize - 1]
    }

    /// The same cases the run verdicts judge (tests/integration/verdicts.rs), judged live.
    #[test]
    fn the_verdict_output_judges_as_a_run_does() {
        assert_eq!(verdict_after(&[], 3.0), Verdict::Running);
        // Before the hand-over (≈ 0.75 s) nothing has started.
        assert_eq!(verdict_after(&[], 0.5), Verdict::NotStarted);
        // Beyond the top speed the voltage allows: in synchronism, off-speed.
        assert_eq!(
            verdict_after(&[("speed_ref_rpm", 16000.0)], 3.0),
            Verdict::OffSpeed
        );
        // Locked on false crossings with the rotor stopped (the shipped chip without its
        // supervisor and its descent after the start, as the published chip does it).
        let v = verdict_after(
            &[
                ("speed_ref_rpm", 500.0),
                ("control.supervisor", 0.0),
                ("control.start_descent_rpm_s", 0.0),
            ],
            3.0,
        );
        assert!(matches!(v, Verdict::Stalled | Verdict::LostSync), "{v}");
    }

    #[test]
    fn in_sync_follows_the_true_rotor_not_the_chip() {
        let (sync, rpm) = in_sync_after(&[], 1.5);
        assert_eq!(sync, 1.0, "nominal drive at {rpm} rpm");
        // 500 rpm, below what the 15-bit meter reads, the shipped chip without its
        // supervisor and its descent after the start: like the published chip, it lets the
        // rotor coast to a stop and then commutates on false crossings.
        let (sync, rpm) = in_sync_after(
            &[
                ("speed_ref_rpm", 500.0),
                ("control.supervisor", 0.0),
                ("control.start_descent_rpm_s", 0.0),
            ],
            3.0,
        );
        assert_eq!(sync, 0.0, "locked on false crossings at {rpm} rpm");
        assert!(rpm.abs() < 100.0, "{rpm}");
    }

    #[test]
    fn angles_wrap_into_0_360() {
        assert_eq!(wrap_deg(-1e-20), 0.0);
        assert_eq!(wrap_deg(370.0), 10.0);
        assert_eq!(wrap_deg(-90.0), 270.0);
    }
}
