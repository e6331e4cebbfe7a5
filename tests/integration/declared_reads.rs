//! Declaring which comparator outputs a controller reads (`Command::reads`) only spares
//! the plant work: a closed loop whose chip declares its reads runs bit for bit like one
//! that has every channel decided at every instant (same controller ticks, PWM edges and
//! diode events, same state at the end).

use bldc_drive::DriveConfig;
use bldc_drive::drive::build;
use bldc_drive::drive_core::{
    Carrier, Command, Controller, Engine, Pattern, Sensed, StopReason, Ticks,
};
use bldc_drive::plants::BldcPlant;
use bldc_drive::strategies::{ChipStatus, Strategy, StrategyName};

/// The chip, with every comparator output declared read at every tick.
struct ReadsAll(Box<dyn Strategy>);

impl Controller for ReadsAll {
    fn clock(&self) -> Ticks {
        self.0.clock()
    }
    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command {
        Command {
            reads: Command::READS_ALL,
            ..self.0.tick(now, sensed)
        }
    }
    fn fault(&self) -> Option<&str> {
        self.0.fault()
    }
    fn planned_change(&self) -> Option<(Ticks, Pattern)> {
        self.0.planned_change()
    }
}

type Stops = Vec<(Ticks, StopReason)>;

/// Every stop of a run to `secs` as (instant, reason), and the true state at its end; the
/// rotor is stopped and held from `stall_at` \[s\] on.
fn stops<C: Controller, S: bldc_drive::drive_core::PwmScheme>(
    mut e: Engine<BldcPlant, C, S>,
    secs: f64,
    stall_at: f64,
) -> (Stops, String, Engine<BldcPlant, C, S>) {
    let mut seen = Vec::new();
    let mut run = |e: &mut Engine<BldcPlant, C, S>, until: f64| {
        let end = Ticks::from_seconds(until).unwrap();
        e.run_until(end, |e, r| seen.push((e.now(), r))).unwrap();
    };
    if stall_at < secs {
        run(&mut e, stall_at);
        let theta = e.plant.observe().theta_e;
        e.plant.set_rotor(theta, 0.0, true);
    }
    run(&mut e, secs);
    let end_state = format!("{:?} {:?}", e.plant.observe(), e.plant.energy());
    (seen, end_state, e)
}

/// A stall that never comes.
const NEVER: f64 = f64::INFINITY;

fn without_sensing(stops: &[(Ticks, StopReason)]) -> Vec<(Ticks, StopReason)> {
    stops
        .iter()
        .copied()
        .filter(|&(_, r)| r != StopReason::Sensing)
        .collect()
}

/// Runs `name` at `rpm` for `secs` twice (the rotor stalled from `stall_at`, see
/// [`stops`]), declaring reads and reading all; returns the chip's status at the end (the
/// same for both).
fn compare(name: StrategyName, rpm: f64, secs: f64, stall_at: f64) -> ChipStatus {
    let mut cfg = DriveConfig::default();
    cfg.strategy.name = name;
    cfg.control.speed_ref_rpm = rpm;
    let declared = build(&cfg).unwrap();
    // The same drive as `build` assembles it, with the chip wrapped.
    let all = Engine::new(
        BldcPlant::new(cfg.plant_params()).unwrap(),
        ReadsAll(build(&cfg).unwrap().controller),
        cfg.power_stage.pwm_scheme,
        Carrier::default(),
        cfg.power_stage.dead_time(),
    );
    let (a, end_a, ea) = stops(declared, secs, stall_at);
    let (b, end_b, eb) = stops(all, secs, stall_at);
    // The runs are worth comparing: start-up, hand-over and glitch-driven sensing stops
    // (a restart clears the crossing count, and a held rotor is restarted).
    let end = ea.controller.status();
    assert!(end.crossings > 100 || end.restarts > 0, "{end:?}");
    assert!(a.iter().any(|&(_, r)| r == StopReason::Sensing));
    assert!(a.iter().any(|&(_, r)| r == StopReason::Diode));
    // Sensing stops are left out: a channel the chip starts reading is decided from then
    // on, not over the time nobody read it, so a change just before may be reported once
    // more or once less. Such a stop moves nothing: the controller runs at the clock edges
    // it ran at anyway, which the comparison holds.
    let (a, b) = (without_sensing(&a), without_sensing(&b));
    if let Some(k) = (0..a.len().min(b.len())).find(|&k| a[k] != b[k]) {
        panic!(
            "stop {k} differs: declared {:?}, all read {:?}; before: {:?}",
            a[k],
            b[k],
            &a[k.saturating_sub(3)..k]
        );
    }
    assert_eq!(a.len(), b.len(), "as many stops");
    assert_eq!(end_a, end_b);
    assert_eq!(ea.controller.status(), eb.controller.0.status());
    // Reading every channel cost the plant more: the declared run really left some
    // undecided (else this test would compare a run with itself).
    assert!(
        ea.plant.comparators().work().scans < eb.plant.comparators().work().scans,
        "{:?} vs {:?}",
        ea.plant.comparators().work(),
        eb.plant.comparators().work()
    );
    ea.controller.status()
}

#[test]
fn six_step_with_declared_reads_runs_like_one_reading_everything() {
    compare(StrategyName::SixStep120, 3000.0, 1.2, NEVER);
}

#[test]
fn twelve_step_with_declared_reads_runs_like_one_reading_everything() {
    compare(StrategyName::TwelveStepDf, 3000.0, 1.2, NEVER);
}

/// LM at 2000 rpm forces crossings its window missed; then the rotor is stopped and held,
/// and the restarts (the supervisor sees crossings nobody showed), their alignments and
/// hand-overs are fed only what the chip
/// declared, too.
#[test]
fn forced_crossings_and_restarts_with_declared_reads_run_like_reading_everything() {
    let s = compare(StrategyName::TwelveStepLm, 2000.0, 2.0, 1.2);
    assert!(s.forced_crossings >= 1, "{s:?}");
    assert!(s.restarts >= 1, "{s:?}");
}
