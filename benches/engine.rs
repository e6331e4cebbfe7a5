//! Engine + plant speed: simulated seconds per wall second at full fidelity (exact PWM
//! edges, diodes, comparator front end, 0.64 µs controller clock).
//!
//! Real-time factor = simulated time / time per iteration; criterion prints it as the
//! throughput, one element per simulated microsecond, so `thrpt: 25.0 Melem/s` reads as 25×
//! real time. Each iteration simulates `SIM_S` of drive: open-loop six-step on a speed-locked
//! or free rotor (engine and plant alone); or `CLOSED_LOOP_S` of the default closed-loop
//! drive (chip controller, twelve-step with the digital filter) in steady state at 3000 rpm,
//! copied from a drive run up to 2 s once.

use bldc_drive::DriveConfig;
use bldc_drive::drive::{build, run_to, try_clone};
use bldc_drive::drive_core::pwm::HighSideChop;
use bldc_drive::drive_core::{Carrier, Engine, OpenLoopSixStep, Ticks};
use bldc_drive::plants::{BldcPlant, PlantParams};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;

const SIM_S: f64 = 0.02;
/// The closed loop's window: a 20 ms one varies by ±10 % in work with where it falls in the
/// drive's speed ripple, so a change that moves the trajectory would move the figure.
const CLOSED_LOOP_S: f64 = 0.1;

/// Six-step at `rpm` (rotor held at that speed by a dynamometer), `duty` counts.
fn spinning(rpm: f64, duty: u32) -> Engine<BldcPlant, OpenLoopSixStep, HighSideChop> {
    let step = Ticks::from_seconds(1.0 / (rpm / 60.0 * 36.0)).unwrap();
    let plant = BldcPlant::new(PlantParams::default()).unwrap();
    let mut e = Engine::new(
        plant,
        OpenLoopSixStep::new(step, duty, 1),
        HighSideChop,
        Carrier::default(),
        Ticks(0),
    );
    e.plant.set_rotor(30f64.to_radians(), rpm, true);
    e
}

/// Free rotor started from rest by open-loop stepping at 600 rpm.
fn free_rotor() -> Engine<BldcPlant, OpenLoopSixStep, HighSideChop> {
    let step = Ticks::from_seconds(1.0 / (600.0 / 60.0 * 36.0)).unwrap();
    let plant = BldcPlant::new(PlantParams::default()).unwrap();
    Engine::new(
        plant,
        OpenLoopSixStep::new(step, 800, 1),
        HighSideChop,
        Carrier::default(),
        Ticks(0),
    )
}

/// One throughput element per simulated microsecond: elements per second over 1e6 are the
/// real-time factor.
fn simulated_us(seconds: f64) -> Throughput {
    Throughput::Elements((seconds * 1e6).round() as u64)
}

fn bench(c: &mut Criterion) {
    let end = Ticks::from_seconds(SIM_S).unwrap();
    let mut g = c.benchmark_group("engine");
    g.sample_size(20);
    g.throughput(simulated_us(SIM_S));
    for (name, rpm, duty) in [
        ("3000rpm_duty50_20ms", 3000.0, 1000),
        ("8000rpm_duty80_20ms", 8000.0, 1600),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut e = spinning(rpm, duty);
                e.run_until(end, |_, _| {}).unwrap();
                black_box(e.plant.observe())
            })
        });
    }
    g.bench_function("free_rotor_600rpm_20ms", |b| {
        b.iter(|| {
            let mut e = free_rotor();
            e.run_until(end, |_, _| {}).unwrap();
            black_box(e.plant.observe())
        })
    });
    let mut warm = build(&DriveConfig::default()).expect("defaults are valid");
    run_to(&mut warm, 2.0, |_, _| {}).expect("the default drive starts");
    g.throughput(simulated_us(CLOSED_LOOP_S));
    g.bench_function("closed_loop_3000rpm_100ms", |b| {
        b.iter(|| {
            let mut e = try_clone(&warm).expect("the built-in drive copies");
            run_to(&mut e, 2.0 + CLOSED_LOOP_S, |_, _| {}).unwrap();
            black_box(e.plant.observe())
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
