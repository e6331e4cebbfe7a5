//! The library in a few lines: a drive on the built-in motor, a speed step under a fan
//! load, judged from the true rotor. `cargo run --release --example library`

use bldc_drive::DriveConfig;
use bldc_drive::profile::{LoadProfile, Profile};
use bldc_drive::scenario::{Scenario, run};
use bldc_drive::strategies::StrategyName;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut config = DriveConfig::default();
    config.strategy.name = StrategyName::TwelveStepLm;
    config.motor.resistance_ohm *= 1.1; // a warm winding

    // 3000 rpm from standstill, 5000 rpm from 2 s; steady window: the last second.
    let mut sc = Scenario::hold(config, 3000.0, 4.0);
    sc.speed_rpm = Profile::constant(3000.0).step_to(2.0, 5000.0);
    sc.steady_from_s = 3.0;
    sc.load = LoadProfile {
        fan_nms2: Profile::constant(3e-10), // 0.08 mN·m at 5000 rpm
        ..LoadProfile::default()
    };

    let s = run(&sc, |_trace_row| {})?.summary;
    println!("{}: {} ({})", s.strategy, s.verdict, s.verdict_reason);
    if s.verdict.is_running() {
        println!(
            "mean {:.1} rpm, torque {:.3} mN·m, low-frequency torque ripple {:.4} mN·m, I rms {:.3} A",
            s.speed_mean_rpm,
            s.torque_mean_nm * 1e3,
            s.torque_ripple_lf_nm * 1e3,
            s.current_rms_a
        );
    }
    // The verdict as a process status, as drive-bench does.
    std::process::exit(s.verdict.exit_code());
}
