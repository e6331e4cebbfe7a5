//! Profiles the default closed-loop drive in steady state: runs 0–2 s, then times 2–3 s and
//! prints the real-time factor, the plant's work counters and why the engine stopped.
//!
//! `cargo run --release --example profile [speed_rpm [strategy [load_nm]]]` (defaults 3000,
//! the config's strategy, no load). Wall time is noisy; instruction counts are not:
//! `scripts/instructions.sh` takes the same arguments and counts the timed second alone with
//! callgrind (it collects inside `steady_second`, by that name).

use bldc_drive::DriveConfig;
use bldc_drive::drive::{DriveEngine, build};
use bldc_drive::drive_core::{StopReason, Ticks};
use std::io::Write;
use std::time::Instant;

fn main() {
    let arg = std::env::args().nth(1);
    let rpm = match arg.as_deref().map(str::parse::<f64>) {
        None => 3000.0,
        Some(Ok(r)) if r.is_finite() && r > 0.0 => r,
        Some(_) => {
            eprintln!("error: speed_rpm must be a positive number, got {arg:?}");
            std::process::exit(2);
        }
    };
    let mut cfg = DriveConfig::default();
    cfg.control.speed_ref_rpm = rpm;
    if let Some(name) = std::env::args().nth(2) {
        match name.parse() {
            Ok(n) => cfg.strategy.name = n,
            Err(err) => {
                eprintln!("error: {err}");
                std::process::exit(2);
            }
        }
    }
    let arg = std::env::args().nth(3);
    let load_nm = match arg.as_deref().map(str::parse::<f64>) {
        None => 0.0,
        Some(Ok(x)) if x.is_finite() => x,
        Some(_) => {
            eprintln!("error: load_nm must be a finite number, got {arg:?}");
            std::process::exit(2);
        }
    };
    let mut e = match build(&cfg) {
        Ok(e) => e,
        Err(err) => {
            eprintln!("error: {err}");
            std::process::exit(2);
        }
    };
    e.plant.set_load_torque(load_nm);
    let at = |s: f64| Ticks::from_seconds(s).expect("a few seconds fit in ticks");
    if let Err(err) = e.run_until(at(2.0), |_, _| {}) {
        eprintln!("error: {err}");
        std::process::exit(1);
    }
    let (p0, c0) = (e.plant.stats(), e.plant.comparators().work());
    // A handful of reasons: a linear search is cheaper inside the timed second than hashing.
    let mut reasons: Vec<(StopReason, u64)> = Vec::with_capacity(8);
    let wall = Instant::now();
    let run = steady_second(&mut e, &mut reasons);
    let dt = wall.elapsed().as_secs_f64();
    if let Err(err) = run {
        eprintln!("error: {err}");
        std::process::exit(1);
    }
    let (p1, c1) = (e.plant.stats(), e.plant.comparators().work());
    let mut reasons: Vec<_> = reasons
        .into_iter()
        .map(|(r, n)| (format!("{r:?}"), n))
        .collect();
    reasons.sort();
    let report = format!(
        "{:.0} rpm, {:.1}× real time over 2–3 s\n\
         per simulated second: {} steps, {} diode events, {} retries\n\
         comparators: {} scans, {} ticks walked, {} noise segments, {} blocks of them\n\
         stops: {reasons:?}\n",
        e.plant.observe().speed_rpm,
        1.0 / dt,
        p1.steps - p0.steps,
        p1.diode_events - p0.diode_events,
        p1.retries - p0.retries,
        c1.scans - c0.scans,
        c1.ticks_scanned - c0.ticks_scanned,
        c1.segments - c0.segments,
        c1.blocks - c0.blocks
    );
    // A reader that stops early (`| head -1`) is not an error worth a panic.
    let _ = std::io::stdout().write_all(report.as_bytes());
}

/// The timed part, 2–3 s, kept out of line so that a profiler can collect it alone.
#[inline(never)]
fn steady_second(
    e: &mut DriveEngine,
    reasons: &mut Vec<(StopReason, u64)>,
) -> Result<(), bldc_drive::drive_core::EngineError> {
    let end = Ticks::from_seconds(3.0).expect("a few seconds fit in ticks");
    e.run_until(end, |_, r| {
        match reasons.iter_mut().find(|(q, _)| *q == r) {
            Some((_, n)) => *n += 1,
            None => reasons.push((r, 1)),
        }
    })
}
