//! Shared helpers for the integration tests.
#![allow(dead_code)]

use bldc_drive::drive_core::pwm::HighSideChop;
use bldc_drive::drive_core::{
    Abc, Carrier, Command, Controller, Engine, LegState, Pattern, Sensed, Ticks,
};
use bldc_drive::plants::{BldcPlant, PlantParams};

pub mod plugins;

/// An engine with the chip's high-side chopping and the default 12.5 kHz carrier.
pub fn engine<C: Controller>(
    params: PlantParams,
    controller: C,
) -> Engine<BldcPlant, C, HighSideChop> {
    let dead = params.power_stage.dead_time();
    Engine::new(
        BldcPlant::new(params).expect("valid parameters"),
        controller,
        HighSideChop,
        Carrier::default(),
        dead,
    )
}

/// `u`, `v`, `w` leg states from the table letters V / G / F.
pub fn pattern(s: &str) -> Pattern {
    let leg = |c: char| match c {
        'V' => LegState::High,
        'G' => LegState::Low,
        _ => LegState::Float,
    };
    let c: Vec<char> = s.chars().collect();
    Abc {
        u: leg(c[0]),
        v: leg(c[1]),
        w: leg(c[2]),
    }
}

/// A command holding `pattern` at `duty` counts, watching `watch`.
pub fn hold(p: &str, duty: u32, watch: Abc<bool>) -> Command {
    Command {
        pattern: pattern(p),
        duty,
        watch,
        reads: Command::READS_ALL,
        wake_at: Ticks::NEVER,
    }
}

/// Holds one command until `at`, another afterwards.
pub struct Switch {
    pub at: Ticks,
    pub before: Command,
    pub after: Command,
}

impl Controller for Switch {
    fn clock(&self) -> Ticks {
        Ticks(1)
    }
    fn tick(&mut self, now: Ticks, _sensed: &Sensed) -> Command {
        if now < self.at {
            Command {
                wake_at: self.at,
                ..self.before
            }
        } else {
            self.after
        }
    }
}

/// The back-EMF of every phase for the sinusoidal shape, computed independently.
pub fn spec_emf(p: &PlantParams, theta_e: f64, omega_m: f64) -> Abc<f64> {
    let m = &p.motor;
    let k = m.flux_linkage_wb * (m.poles as f64 / 2.0) * omega_m;
    let third = 2.0 * std::f64::consts::PI / 3.0;
    Abc {
        u: k * theta_e.sin(),
        v: k * (theta_e - third).sin(),
        w: k * (theta_e + third).sin(),
    }
}

pub fn rpm_to_rad_s(rpm: f64) -> f64 {
    rpm * 2.0 * std::f64::consts::PI / 60.0
}
