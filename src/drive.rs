//! A complete drive: the plant and the chip on the engine, built from a [`DriveConfig`].

use crate::config::DriveConfig;
use drive_core::error::ParamError;
use drive_core::pwm::PwmSchemeKind;
use drive_core::{Carrier, Engine, EngineError, Ticks};
use plants::BldcPlant;
use strategies::plugin::DriveInfo;
use strategies::{Chip, PluginError, PluginLibrary, Strategy};

/// The engine type of a drive: the PWM scheme is chosen by `[power_stage] pwm_scheme`.
/// The strategy is a trait object so built-in and plugin strategies are interchangeable.
pub type DriveEngine = Engine<BldcPlant, Box<dyn Strategy>, PwmSchemeKind>;

/// Builds the plant and the chip from `config` and puts them on an engine at t = 0, with
/// the start input held from t = 0.
pub fn build(config: &DriveConfig) -> Result<DriveEngine, ParamError> {
    assemble(config, |info| {
        Ok::<_, ParamError>(Box::new(Chip::new(
            config.control.clone(),
            config.strategy.clone(),
            info.pole_pairs,
            info.amps_per_code,
            info.carrier_top,
        )?))
    })
}

/// Why a drive with a plugin strategy could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// A config value breaks its rule.
    #[error("{0}")]
    Param(#[from] ParamError),
    /// The plugin refused the config or failed.
    #[error("{0}")]
    Plugin(#[from] PluginError),
}

/// Like [`build`], with the strategy created by `plugin` from the whole config (as TOML)
/// instead of the built-in chip.
pub fn build_plugin(
    config: &DriveConfig,
    plugin: &PluginLibrary,
) -> Result<DriveEngine, BuildError> {
    assemble(config, |info| {
        let s = plugin.instantiate(&config.to_toml(), info, config.control.speed_ref_rpm)?;
        Ok::<_, BuildError>(Box::new(s))
    })
}

/// The plant, carrier and PWM scheme of `config` on an engine, with the strategy made by
/// `strategy` from the facts it needs about the drive.
fn assemble<E: From<ParamError>>(
    config: &DriveConfig,
    strategy: impl FnOnce(DriveInfo) -> Result<Box<dyn Strategy>, E>,
) -> Result<DriveEngine, E> {
    config.validate()?;
    let plant = BldcPlant::new(config.plant_params())?;
    let carrier = Carrier {
        top: config.control.carrier_top,
    };
    let strategy = strategy(DriveInfo {
        pole_pairs: config.motor.poles / 2,
        amps_per_code: plant.current_sense().amps_per_code(),
        carrier_top: carrier.top,
    })?;
    Ok(Engine::new(
        plant,
        strategy,
        config.power_stage.pwm_scheme,
        carrier,
        config.power_stage.dead_time(),
    ))
}

/// An independent copy of a drive in the same state (for FMU state saving, forks of a
/// run); fails if the strategy cannot copy itself.
pub fn try_clone(engine: &DriveEngine) -> Result<DriveEngine, String> {
    engine.try_clone_with(|s| s.try_clone())
}

/// Runs `engine` until `t_end_s`, calling `each` after every engine stop.
pub fn run_to(
    engine: &mut DriveEngine,
    t_end_s: f64,
    each: impl FnMut(&DriveEngine, drive_core::StopReason),
) -> Result<(), EngineError> {
    let end = Ticks::from_seconds(t_end_s).unwrap_or(Ticks::NEVER);
    engine.run_until(end, each)
}
