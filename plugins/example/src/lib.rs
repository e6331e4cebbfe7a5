//! An example strategy plugin: the built-in `twelve-step-df` re-exported through the
//! plugin ABI, so a run with the plugin can be compared with the built-in strategy step
//! for step. A new scheme would replace [`Chip`] with its own state machine and keep the
//! same glue: parse the config, translate the C-layout inputs and outputs.

use drive_core::{Abc, Controller, LegState, Persist, Sensed, Ticks};
use serde::Deserialize;
use strategies::{Chip, ControlParams, Mode, Strategy, StrategyName, StrategyParams, Table};
use strategy_abi::{
    CCommand, CSensed, CStatus, CTable, DriveInfo, Inputs, LEG_HIGH, LEG_LOW, Plugin,
};

/// The sections of the drive's config this strategy reads; the others are ignored.
#[derive(Deserialize, Default)]
struct Sections {
    #[serde(default)]
    control: ControlParams,
    #[serde(default)]
    strategy: StrategyParams,
}

#[derive(Clone)]
struct ExampleDf {
    chip: Chip,
}

fn bit(b: bool) -> u8 {
    b.into()
}

fn leg(l: LegState) -> u8 {
    match l {
        LegState::High => LEG_HIGH,
        LegState::Low => LEG_LOW,
        LegState::Float => 0,
    }
}

impl Plugin for ExampleDf {
    fn create(config_toml: &str, info: &DriveInfo) -> Result<Self, String> {
        let mut s: Sections = toml::from_str(config_toml).map_err(|e| e.to_string())?;
        s.strategy.name = StrategyName::TwelveStepDf;
        s.strategy.guard = None;
        let chip = Chip::new(
            s.control,
            s.strategy,
            info.pole_pairs,
            info.amps_per_code,
            info.carrier_top,
        )
        .map_err(|e| e.to_string())?;
        Ok(ExampleDf { chip })
    }

    fn clock(&self) -> u64 {
        self.chip.clock().0
    }

    fn table(&self) -> CTable {
        match Strategy::table(&self.chip) {
            Table::SixStep => CTable {
                kind: 0,
                conduction_deg: 120.0,
            },
            Table::TwelveStep { conduction_deg } => CTable {
                kind: 1,
                conduction_deg,
            },
        }
    }

    fn set_inputs(&mut self, i: &Inputs) {
        self.chip.set_reset(i.reset != 0);
        self.chip.set_start(Ticks(i.now), i.start != 0);
        self.chip.set_speed_ref(i.speed_ref_rpm);
    }

    fn step(&mut self, now: u64, sensed: &CSensed) -> Result<(CCommand, CStatus), String> {
        let s = Sensed::new(
            Abc {
                u: sensed.zc[0] != 0,
                v: sensed.zc[1] != 0,
                w: sensed.zc[2] != 0,
            },
            sensed.current_code,
        );
        let c = self.chip.tick(Ticks(now), &s);
        let st = self.chip.status();
        Ok((
            CCommand {
                legs: [leg(c.pattern.u), leg(c.pattern.v), leg(c.pattern.w)],
                duty: c.duty,
                watch: [bit(c.watch.u), bit(c.watch.v), bit(c.watch.w)],
                wake_at: if c.wake_at == Ticks::NEVER {
                    u64::MAX
                } else {
                    c.wake_at.0
                },
            },
            CStatus {
                mode: match st.mode {
                    Mode::Off => 0,
                    Mode::Aligning { .. } => 1,
                    Mode::Running => 2,
                    Mode::GaveUp => 3,
                },
                state: st.state,
                zd: bit(st.zd),
                zdf: bit(st.zdf),
                linear: bit(st.linear),
                duty: st.duty,
                speed_est_rpm: st.speed_est_rpm,
                current_ref_a: st.current_ref_a,
                current_integrator: st.current_integrator,
                restarts: st.restarts,
                crossings: st.crossings,
                forced_crossings: st.forced_crossings,
            },
        ))
    }

    // The chip's own encoding (drive_core::state): a plugin may use any format, since
    // only it reads its bytes back.
    fn save(&self) -> Result<Vec<u8>, String> {
        self.chip.to_bytes()
    }

    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        self.chip.restore_from(state)
    }

    fn planned_change(&self) -> Option<(u64, [u8; 3])> {
        let (at, p) = self.chip.planned_change()?;
        Some((at.0, [leg(p.u), leg(p.v), leg(p.w)]))
    }
}

strategy_abi::export_strategy!(
    ExampleDf,
    "example-twelve-step-df",
    "Example plugin: the chip's 150° twelve-step with the digital filter, through the plugin ABI"
);
