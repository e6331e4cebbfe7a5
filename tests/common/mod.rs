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

/// Runs `sc` with a trace every 1 ms over `from_s..to_s`: its summary, the restarts made
/// within the trace (from its first row to its last) and the true speed of each row
/// (t \[s\], rpm).
pub fn traced(
    mut sc: bldc_drive::scenario::Scenario,
    from_s: f64,
    to_s: f64,
) -> (bldc_drive::scenario::Summary, u32, Vec<(f64, f64)>) {
    sc.trace = Some(bldc_drive::scenario::TraceSpec {
        every_s: 1e-3,
        from_s,
        to_s,
    });
    let mut first = None;
    let mut last = 0;
    let mut speeds = Vec::new();
    let out = bldc_drive::scenario::run(&sc, |r| {
        first.get_or_insert(r.restarts);
        last = r.restarts;
        speeds.push((r.t_s, r.speed_rpm));
    })
    .expect("the run");
    (out.summary, last - first.unwrap_or(last), speeds)
}
