//! The plant may integrate ahead of the instant the engine asks for, up to the next known
//! gate change (`Watch::horizon`), and serve the instants in between from that step. What
//! the controller can see must not depend on it: the comparator outputs and the ADC codes
//! at every controller tick, and the sensing stops, are the same as when the plant steps
//! only to each instant asked for.

use bldc_drive::drive_core::{
    Abc, Command, Gates, LegState, Phase, Plant, PlantStop, Sensed, Ticks, Watch, floating_phase,
};
use bldc_drive::plants::{BldcPlant, PlantParams};

/// Controller clock of the test: 0.64 µs, like the chip's fastest.
const CLOCK: Ticks = Ticks(32);
/// PWM period 80 µs (4000 ticks); the high side of `u` is on for the first `ON` ticks.
const PERIOD: u64 = 4000;

/// Drives u (chopped) → v with w floating, the rotor locked at 3000 rpm through a w
/// crossing, and reads everything the controller could read at every clock edge. The
/// pattern steps on to u → w halfway, as a commutation at a controller tick would.
/// `ahead` lets the plant integrate to the next PWM edge.
fn record(ahead: bool, on: u64, watch_all: bool) -> Vec<(u64, Sensed, Option<u64>)> {
    let mut p = BldcPlant::new(PlantParams::default()).expect("defaults are valid");
    p.set_rotor(40f64.to_radians(), 3000.0, true);
    let pattern = |t: u64, chop_on: bool| {
        let mut legs = Abc {
            u: if chop_on {
                LegState::High
            } else {
                LegState::Float
            },
            v: LegState::Low,
            w: LegState::Float,
        };
        if t >= 50_000 {
            (legs.v, legs.w) = (LegState::Float, LegState::Low);
        }
        legs
    };
    let gates_at = |t: u64| Gates::from_pattern(&pattern(t, t % PERIOD < on));
    let mut gates = gates_at(0);
    p.set_gates(&gates);
    let mut out = Vec::new();
    let mut t = 0;
    while t < 100_000 {
        let until = Ticks(t + CLOCK.0);
        let next_edge = if on == PERIOD {
            Ticks::NEVER
        } else {
            let base = (t / PERIOD) * PERIOD;
            let edge = if t % PERIOD < on {
                base + on
            } else {
                base + PERIOD
            };
            Ticks(edge)
        };
        let float = floating_phase(&pattern(t, true)).expect("one leg floats");
        let watch = Watch {
            channels: Abc::from_fn(|x| watch_all || x == float),
            reads: Command::READS_ALL,
            clock: CLOCK,
            horizon: if ahead { next_edge.max(until) } else { until },
        };
        let mut sensing = None;
        loop {
            match p.advance(until, &watch) {
                PlantStop::Reached => break,
                // As the engine does: a change already sampled at the last tick (on a
                // channel just started watching) does not clock the controller again.
                PlantStop::Sensing(at) if at.0 > t => sensing = Some(at.0),
                PlantStop::Sensing(_) => {}
                PlantStop::Diode => {}
            }
        }
        t = until.0;
        out.push((t, p.sensed(until), sensing));
        let g = gates_at(t);
        if g != gates {
            gates = g;
            p.set_gates(&gates);
        }
    }
    out
}

fn assert_same(on: u64) {
    let (a, b) = (record(false, on, false), record(true, on, false));
    let toggles = a
        .windows(2)
        .filter(|w| w[0].1.zc_all() != w[1].1.zc_all())
        .count();
    assert!(toggles >= 2, "the comparators must be active: {toggles}");
    // The watched channel changes and stops the plant: sensing stops are compared too.
    let w = a
        .windows(2)
        .filter(|w| w[0].1.zc(Phase::W) != w[1].1.zc(Phase::W))
        .count();
    let stops = a.iter().filter(|x| x.2.is_some()).count();
    assert!(
        w >= 1 && stops >= 1,
        "w toggles {w} times, {stops} sensing stops"
    );
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x, y, "stepping to each instant vs integrating ahead");
    }
}

#[test]
fn integrating_ahead_changes_nothing_the_controller_sees_with_pwm() {
    assert_same(1500);
}

#[test]
fn integrating_ahead_changes_nothing_the_controller_sees_at_full_duty() {
    assert_same(PERIOD);
}

/// The comparators nobody watches are walked only as far as they are read (skipping the
/// ticks before a reading that is certain anyway); what is read must be exactly what
/// walking every tick gives. Sensing stops differ (only watched channels stop the plant),
/// so they are left out.
#[test]
fn unwatched_comparators_read_the_same_as_watched_ones() {
    for on in [1500, PERIOD] {
        let read = |all| {
            record(true, on, all)
                .into_iter()
                .map(|(t, s, _)| (t, s))
                .collect::<Vec<_>>()
        };
        let (lazy, eager) = (read(false), read(true));
        let toggles = |v: &[(u64, Sensed)], f: fn(&Sensed) -> bool| {
            v.windows(2).filter(|w| f(&w[0].1) != f(&w[1].1)).count()
        };
        // With PWM the driven legs' comparators follow it: plenty to get right.
        let u = toggles(&eager, |s| s.zc(Phase::U));
        assert!(on == PERIOD || u >= 10, "u toggles {u} times");
        assert_eq!(lazy, eager, "on = {on}");
    }
}

/// Tracing must not perturb the simulation: the closed-loop drive sampled every 10 µs ends
/// in exactly the state it reaches unobserved.
#[test]
fn sampling_the_drive_does_not_change_its_trajectory() {
    use bldc_drive::DriveConfig;
    use bldc_drive::drive::build;
    let end = Ticks::from_seconds(1.5).unwrap();
    let run = |sample: Option<Ticks>| {
        let mut e = build(&DriveConfig::default()).expect("defaults are valid");
        let mut samples = 0u32;
        if let Some(p) = sample {
            e.set_sample_period(p);
        }
        e.run_until(end, |e, _| {
            samples += 1;
            std::hint::black_box(e.plant.observe());
        })
        .unwrap();
        (e.plant.observe(), e.plant.energy(), samples)
    };
    let (quiet, sampled) = (run(None), run(Some(Ticks(500))));
    assert!(
        sampled.2 > quiet.2 + 149_000,
        "{} vs {} stops",
        sampled.2,
        quiet.2
    );
    assert!(
        quiet.0.speed_rpm > 1000.0,
        "the drive is running: {:?}",
        quiet.0
    );
    assert_eq!(quiet.0, sampled.0);
    assert_eq!(quiet.1, sampled.1);
}

/// Nor does the size of the pieces a co-simulation master runs it in: the drive run to
/// 1.5 s in one call, in 1 ms pieces and in 37 µs pieces (not a divisor of anything the
/// chip uses) ends in the same state.
#[test]
fn running_in_pieces_does_not_change_the_trajectory() {
    use bldc_drive::DriveConfig;
    use bldc_drive::drive::{build, run_to};
    let run = |piece_s: f64| {
        let mut e = build(&DriveConfig::default()).expect("defaults are valid");
        let n = (1.5 / piece_s).round() as u32;
        for k in 1..=n {
            run_to(&mut e, (f64::from(k) * piece_s).min(1.5), |_, _| {}).unwrap();
        }
        run_to(&mut e, 1.5, |_, _| {}).unwrap();
        (e.plant.observe(), e.plant.energy())
    };
    let whole = run(1.5);
    assert!(
        whole.0.speed_rpm > 1000.0,
        "the drive is running: {:?}",
        whole.0
    );
    assert_eq!(whole, run(1e-3));
    assert_eq!(whole, run(37e-6));
}
