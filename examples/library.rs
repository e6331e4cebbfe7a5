//! The library in 15 lines: a drive on the built-in motor, a speed step under a fan load,
//! judged from the true rotor. `cargo run --release --example library`
use bldc_drive::DriveConfig;
use bldc_drive::profile::Profile;
use bldc_drive::scenario::{Scenario, run};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut config = DriveConfig::default(); // the built-in motor and chip (twelve-step-df)
    config.motor.resistance_ohm *= 1.1; // a warm winding
    let mut sc = Scenario::hold(config, 3000.0, 6.0); // 3000 rpm from standstill, 6 s
    sc.speed_rpm = Profile::constant(3000.0).step_to(2.0, 5000.0); // 5000 rpm from 2 s
    sc.load.fan_nms2 = Profile::constant(3e-10); // a fan: 3e-10 N·m·s² × ω·|ω|
    let s = run(&sc, |_trace_row| {})?.summary; // steady window: the last third
    println!("{}: {} ({})", s.strategy, s.verdict, s.verdict_reason);
    println!("{:.1} rpm, {:.3} A rms", s.speed_mean_rpm, s.current_rms_a);
    std::process::exit(s.verdict.exit_code()); // 0 only when running
}
