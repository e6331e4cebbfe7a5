//! Closed loop on the built-in motor: start from standstill, lock, hold speed, reject a
//! load step, commutate on the table boundaries. Numbers come from the true plant state.

use bldc_drive::DriveConfig;
use bldc_drive::drive::{build, run_to};
use bldc_drive::drive_core::pwm::PwmSchemeKind;
use bldc_drive::strategies::{Mode, StrategyName};

/// What a closed-loop run produced.
struct Run {
    /// (t \[s\], true mechanical speed \[rpm\]) at every engine stop.
    speed: Vec<(f64, f64)>,
    /// (t \[s\], voltage command in force [carrier counts]) at every engine stop.
    duty: Vec<(f64, u32)>,
    /// (t \[s\], current-PI integrator [carrier counts]) at every engine stop.
    integrator: Vec<(f64, f64)>,
    /// Signed error of the true electrical angle at each commutation after `settle_s`
    /// against the boundary of the state entered [electrical degrees].
    angle_err: Vec<f64>,
    /// Time spent after `settle_s` in 3-phase (odd) and 2-phase (even) states \[s\].
    post_pre_s: (f64, f64),
    restarts: u32,
    forced: u64,
    mode: Mode,
}

/// Something that happens during a run at a given time \[s\].
#[derive(Copy, Clone)]
enum Event {
    /// Load torque [N·m] from then on.
    Load(f64),
    /// Speed command \[rpm\] from then on.
    SpeedRef(f64),
    /// Twelve-step conduction angle [electrical degrees] from then on.
    Conduction(f64),
}

fn run(name: StrategyName, rpm: f64, secs: f64, load: Option<(f64, f64)>, settle_s: f64) -> Run {
    let mut cfg = DriveConfig::default();
    cfg.strategy.name = name;
    let events: Vec<(f64, Event)> = load
        .map(|(t, nm)| (t, Event::Load(nm)))
        .into_iter()
        .collect();
    run_events(cfg, rpm, secs, &events, settle_s)
}

fn run_config(
    cfg: DriveConfig,
    rpm: f64,
    secs: f64,
    load: Option<(f64, f64)>,
    settle_s: f64,
) -> Run {
    let events: Vec<(f64, Event)> = load
        .map(|(t, nm)| (t, Event::Load(nm)))
        .into_iter()
        .collect();
    run_events(cfg, rpm, secs, &events, settle_s)
}

fn run_events(
    mut cfg: DriveConfig,
    rpm: f64,
    secs: f64,
    events: &[(f64, Event)],
    settle_s: f64,
) -> Run {
    cfg.control.speed_ref_rpm = rpm;
    let mut eng = build(&cfg).expect("config is valid");
    let mut out = Run {
        speed: Vec::new(),
        duty: Vec::new(),
        integrator: Vec::new(),
        angle_err: Vec::new(),
        post_pre_s: (0.0, 0.0),
        restarts: 0,
        forced: 0,
        mode: Mode::Off,
    };
    let mut last_state = 0u8;
    let mut last_t = 0.0;
    let mut pending: Vec<(f64, Event)> = events.to_vec();
    let mut t = 0.0;
    while t < secs {
        let next = (t + 0.05).min(secs);
        while let Some(&(at, ev)) = pending.first()
            && next > at
        {
            run_to(&mut eng, at, |_, _| {}).unwrap();
            match ev {
                Event::Load(nm) => eng.plant.set_load_torque(nm),
                Event::SpeedRef(r) => eng.controller.set_speed_ref(r),
                Event::Conduction(a) => eng.controller.set_conduction_angle(a).unwrap(),
            }
            pending.remove(0);
        }
        run_to(&mut eng, next, |e, _| {
            let o = e.plant.observe();
            out.speed.push((o.t_s, o.speed_rpm));
            let s = e.controller.status();
            let table = e.controller.table();
            out.duty.push((o.t_s, s.duty));
            out.integrator.push((o.t_s, s.current_integrator));
            if o.t_s > settle_s && last_state != 0 {
                let dt = o.t_s - last_t;
                if last_state % 2 == 1 {
                    out.post_pre_s.0 += dt;
                } else {
                    out.post_pre_s.1 += dt;
                }
            }
            if s.state != last_state && s.state != 0 && last_state != 0 && o.t_s > settle_s {
                let th = o.theta_e.to_degrees();
                let err = (th - table.state_start_deg(s.state) + 540.0).rem_euclid(360.0) - 180.0;
                out.angle_err.push(err);
            }
            last_state = s.state;
            last_t = o.t_s;
        })
        .unwrap();
        t = next;
    }
    let s = eng.controller.status();
    out.restarts = s.restarts;
    out.forced = s.forced_crossings;
    out.mode = s.mode;
    out
}

/// Time-weighted mean of the speed over [a, b].
fn mean_speed(r: &Run, a: f64, b: f64) -> f64 {
    let mut acc = 0.0;
    let mut w = 0.0;
    for p in r.speed.windows(2) {
        let (t0, s0) = p[0];
        let (t1, _) = p[1];
        if t0 >= a && t1 <= b {
            acc += s0 * (t1 - t0);
            w += t1 - t0;
        }
    }
    acc / w
}

/// From standstill every guarded strategy aligns, hands over, locks and holds the command
/// within 2 % (mean over the last second). ND only above its floor (see
/// `nd_linear_region_sets_a_floor_on_the_speed`). LM may need one restart: its 1° window at
/// unknown speed leaves detection unguarded, and a late crossing extends the full-voltage
/// region into a stall-current pulse. With the former round speeds (ωm 1000, ωM 8000 rpm)
/// its first hand-over failed at 2000 and 6000 rpm (with the calibrated ones it does not),
/// and at 3000 rpm it stayed locked but wandered ±8 % over ≈ 1 s: its window grew 1° per
/// 500 rpm (positive feedback of speed on voltage, in whole-degree steps), and the one
/// current sample per PI update sometimes fell in the full-voltage window; so 3000 rpm is
/// not listed here.
#[test]
fn every_guarded_strategy_starts_locks_and_holds_the_commanded_speed() {
    for (name, rpm, restarts) in [
        (StrategyName::TwelveStepDf, 2000.0, 0),
        (StrategyName::TwelveStepDf, 6000.0, 0),
        (StrategyName::TwelveStepRaw, 3000.0, 0),
        (StrategyName::TwelveStepNd, 6000.0, 0),
        (StrategyName::TwelveStepNd, 8000.0, 0),
        (StrategyName::TwelveStepLm, 2000.0, 1),
        (StrategyName::TwelveStepLm, 6000.0, 1),
        (StrategyName::SixStep120, 3000.0, 0),
    ] {
        let r = run(name, rpm, 4.0, None, 3.0);
        assert_eq!(r.mode, Mode::Running, "{name} {rpm} rpm");
        assert!(
            r.restarts <= restarts,
            "{name} {rpm} rpm: {} restarts",
            r.restarts
        );
        let m = mean_speed(&r, 3.0, 4.0);
        println!("{name} {rpm} rpm: mean {m:.0} rpm, {} restarts", r.restarts);
        assert!(
            (m - rpm).abs() < 0.02 * rpm,
            "{name} {rpm} rpm: mean {m:.0}"
        );
    }
}

/// ND applies full voltage for 15° of every 60°, which floors the average voltage.
/// On this motor the floor alone drives it to ≈ 4700 rpm: commanded below that, the speed
/// PI asks for no current, the PWM duty sits at 0, and the speed is the same whatever the
/// command — but the drive stays locked (commutations on the boundaries, no restart).
/// DF holds the same commands (previous test), so the floor is ND's.
#[test]
fn nd_linear_region_sets_a_floor_on_the_speed() {
    let mut floor = Vec::new();
    for rpm in [2000.0, 3000.0] {
        let r = run(StrategyName::TwelveStepNd, rpm, 4.0, None, 3.0);
        assert_eq!((r.mode, r.restarts), (Mode::Running, 0), "{rpm}");
        let m = mean_speed(&r, 3.0, 4.0);
        let off_window: Vec<u32> = r
            .duty
            .iter()
            .filter(|d| d.0 > 3.0 && d.1 < 2000)
            .map(|d| d.1)
            .collect();
        let cv_max = off_window.iter().copied().max();
        println!(
            "nd commanded {rpm}: runs at {m:.0} rpm, PWM duty outside the window ≤ {cv_max:?}"
        );
        // The floor is ≈ 4700 rpm: well above the commands, well below full voltage.
        assert!(m > 1.3 * 3000.0 && m < 6000.0, "{rpm}: {m:.0}");
        // Outside the 15° windows the duty is (near) zero, and there are such samples.
        assert!(
            off_window.len() >= 10,
            "{rpm}: {} samples",
            off_window.len()
        );
        assert!(cv_max.is_some_and(|c| c < 100), "{rpm}: duty {cv_max:?}");
        let mean_abs = r.angle_err.iter().map(|e| e.abs()).sum::<f64>() / r.angle_err.len() as f64;
        assert!(mean_abs < 2.0, "{rpm}: {mean_abs:.2}°");
        floor.push(m);
    }
    assert!((floor[0] - floor[1]).abs() < 0.01 * floor[1], "{floor:?}");
}

#[test]
fn every_pwm_scheme_drives_the_same_strategy() {
    for scheme in PwmSchemeKind::ALL {
        let mut cfg = DriveConfig::default();
        cfg.power_stage.pwm_scheme = scheme;
        cfg.power_stage.dead_time_s = 0.5e-6;
        let r = run_config(cfg, 3000.0, 3.0, None, 9.0);
        let m = mean_speed(&r, 2.5, 3.0);
        assert_eq!(r.restarts, 0, "{}", scheme.name());
        assert!((m - 3000.0).abs() < 60.0, "{}: mean {m:.0}", scheme.name());
    }
}

#[test]
fn a_load_step_is_rejected() {
    // 0.4 mN·m is about half the no-load drag at 3000 rpm again, ≈ 0.05 A more current.
    let r = run(
        StrategyName::TwelveStepDf,
        3000.0,
        5.5,
        Some((3.0, 4e-4)),
        9.0,
    );
    let before = mean_speed(&r, 2.5, 3.0);
    let dip = r
        .speed
        .iter()
        .filter(|p| p.0 > 3.0 && p.0 < 4.0)
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min);
    let after = mean_speed(&r, 5.0, 5.5);
    assert!((before - 3000.0).abs() < 60.0, "before {before:.0}");
    assert!(dip < before - 20.0, "the load must be felt: dip {dip:.0}");
    assert!((after - 3000.0).abs() < 60.0, "after {after:.0}");
    assert_eq!(r.restarts, 0);
}

#[test]
fn commutations_fall_on_the_table_boundaries() {
    for (name, rpm) in [
        (StrategyName::TwelveStepDf, 3000.0),
        (StrategyName::TwelveStepRaw, 3000.0),
        (StrategyName::TwelveStepLm, 3000.0),
        (StrategyName::SixStep120, 3000.0),
        (StrategyName::TwelveStepNd, 6000.0),
    ] {
        let r = run(name, rpm, 4.0, None, 3.0);
        angle_stats(&format!("{name} {rpm} rpm"), &r, rpm);
    }
}

/// Without a guard the comparator's PWM-edge glitches reach the phase shifter. At 1500 rpm
/// (duty ≈ 15 %, small back-EMF, long 60° intervals) a glitch late in the pre part passes
/// the ¾·t_60 plausibility test and is taken as the crossing: raw commutates up to ≈ 20°
/// early (two thirds of a state). The digital filter removes most of them (glitches from
/// the default 5 % comparator RC mismatch are ≈ 3 µs, the filter's window 1.92 µs, so a few
/// still pass): its worst error stays near 10°. Both stay locked (plausibility), so the
/// damage is mis-commutation, not restarts. Default plant parameters throughout.
#[test]
fn raw_guard_mis_commutates_at_low_speed_where_df_does_not() {
    let raw = run(StrategyName::TwelveStepRaw, 1500.0, 3.5, None, 2.5);
    let df = run(StrategyName::TwelveStepDf, 1500.0, 3.5, None, 2.5);
    let bad = |r: &Run| r.angle_err.iter().filter(|e| e.abs() > 15.0).count();
    let (sr, sd) = (stats(&raw.angle_err), stats(&df.angle_err));
    println!(
        "1500 rpm raw: mean {:+.2}°, mean |e| {:.2}°, max {:.1}°, {} of {} beyond 15°",
        sr.0,
        sr.1,
        sr.2,
        bad(&raw),
        raw.angle_err.len()
    );
    println!(
        "1500 rpm df:  mean {:+.2}°, mean |e| {:.2}°, max {:.1}°, {} of {} beyond 15°",
        sd.0,
        sd.1,
        sd.2,
        bad(&df),
        df.angle_err.len()
    );
    assert_eq!(df.restarts, 0);
    assert_eq!(bad(&df), 0, "df mis-commutated");
    assert!(
        bad(&raw) >= 10,
        "raw: {} commutations beyond 15°",
        bad(&raw)
    );
    assert!(
        sr.1 > 1.2 * sd.1,
        "raw mean |e| {:.2} vs df {:.2}",
        sr.1,
        sd.1
    );
    assert!(
        sr.2 > 15.0 && sd.2 < 15.0,
        "max raw {:.1} df {:.1}",
        sr.2,
        sd.2
    );
}

/// Conduction angles other than 150°. The drive starts at 150° and at 2 s moves to 135° or
/// 165° in closed loop (the source's future work: a variable conduction angle). It holds
/// 3000 rpm, commutates on the shifted boundaries, and the 3-phase (post) states fill
/// (α − 120)/60 of the time: 1/4 at 135°, 3/4 at 165° (state times from the true timeline).
///
/// At 165° the 2-phase part, the only place a crossing can be seen, is 15° wide: a crossing
/// found late or missed there forces a commutation and the drive can lose step. Whether it
/// does depends on the comparator noise, so 165° is a statistical claim over 24 seeds: in a
/// 40-seed sample 29 held 3000 rpm for the 2 s (72 %; 150° held all 20 of an earlier
/// sample), so at least half must hold (a 1-in-200 chance of failing by bad luck at 72 %:
/// the seeds that hold change with any rounding-level change of the trajectory); the runs
/// that hold have the predicted 3-phase fraction.
///
/// From standstill only angles up to 150° start: above it the first post part, timed from
/// the hand-over's assumed 60° (15 ms), outlasts the slow rotor's next crossing, which then
/// cannot be detected, and step-miss restarts follow (see the README's status).
#[test]
fn conduction_angle_135_and_165_hold_speed_on_their_boundaries() {
    let holds = |angle: f64, seed: u64| {
        let mut cfg = DriveConfig::default();
        cfg.sensing.seed = seed;
        let r = run_events(cfg, 3000.0, 4.0, &[(2.0, Event::Conduction(angle))], 3.0);
        let m = mean_speed(&r, 3.0, 4.0);
        let (post, pre) = r.post_pre_s;
        let frac = post / (post + pre);
        let (_, mean_abs, max) = stats(&r.angle_err);
        println!(
            "{angle}° seed {seed}: mean {m:.0} rpm, 3-phase fraction {frac:.3}, \
             {} forced, angle error mean |e| {mean_abs:.2}° max {max:.1}°",
            r.forced
        );
        if (r.mode, r.restarts) != (Mode::Running, 0) || (m - 3000.0).abs() >= 60.0 {
            return false;
        }
        let want = (angle - 120.0) / 60.0;
        // A commutation late or early by the mean |error| (≈ 1–2°) moves the split by e/60.
        assert!((frac - want).abs() < 0.04, "{angle}: {frac:.3} vs {want}");
        assert!(mean_abs < 3.0, "{angle}: mean |error| {mean_abs:.2}°");
        true
    };
    let seed = DriveConfig::default().sensing.seed;
    assert!(holds(135.0, seed), "135° holds with the default seed");
    let held = (1..=24).filter(|&seed| holds(165.0, seed)).count();
    assert!(held >= 12, "165° held 3000 rpm for {held} of 24 seeds");
}

/// The default speed gains give a damped response to a small step (no saturation):
/// 3000 → 3300 rpm at 2.5 s. A second-order loop with ζ ≥ 0.35 overshoots at most 31 %;
/// allowing for the ±20 rpm speed ripple (7 % of the step) the peak must stay below 35 % of
/// the step, and the mean of the last second within 1 % of the new command.
/// Measured: peak 3372 rpm (24 %, 50 ms means), settled in ≈ 0.8 s.
#[test]
fn a_small_speed_step_is_well_damped() {
    let r = run_events(
        DriveConfig::default(),
        3000.0,
        4.5,
        &[(2.5, Event::SpeedRef(3300.0))],
        9.0,
    );
    assert_eq!((r.mode, r.restarts), (Mode::Running, 0));
    let before = mean_speed(&r, 2.0, 2.5);
    // Peak of the 50 ms means, so the per-commutation ripple does not count.
    let peak = (50..80)
        .map(|k| mean_speed(&r, k as f64 * 0.05, (k + 1) as f64 * 0.05))
        .fold(0.0, f64::max);
    let after = mean_speed(&r, 3.5, 4.5);
    let overshoot = (peak - 3300.0) / 300.0;
    println!(
        "step 3000 → 3300: before {before:.0}, peak {peak:.0} ({:.0} %), after {after:.0}",
        overshoot * 100.0
    );
    assert!((before - 3000.0).abs() < 60.0, "{before:.0}");
    assert!(peak > 3300.0, "it must get there: {peak:.0}");
    assert!(overshoot < 0.35, "peak {peak:.0}");
    assert!((after - 3300.0).abs() < 33.0, "{after:.0}");
}

/// The current PI's back-calculation anti-windup (docs/chip.md), on and off. A command beyond
/// reach (16 000 rpm; the drive tops out near 13 000) holds the voltage command at full
/// scale for seconds; at 3.5 s the command drops to 8000 rpm.
///
/// Expected from the structure alone: with anti-windup the integrator never exceeds the
/// limit (it is pulled to limit − Kp·e), so the output leaves full scale as soon as the
/// speed PI drops the current command: within two 5.24 ms PI updates. Without it the
/// integrator winds up to its 23-bit register (≈ 2.05× full scale = 4096 counts) and must be
/// integrated back below 1900 at no more than Ki·0.5 A = 300 counts per update (the sense
/// clips at 0.5 A), plus one proportional step of ≤ 150: at least 7 updates, 36 ms.
/// The cost of the chip's k_s = 32 shows too: each update over the limit cuts the integrator
/// (k_s − 1)·excess below it (a sawtooth, deepest after a low current sample; pi.rs), so the
/// mean duty on the plateau is lower (0.93 against 1.00 measured) and so is the top speed.
#[test]
fn anti_windup_releases_the_saturated_current_loop_at_once() {
    let mut release = Vec::new();
    let mut wound = Vec::new();
    for aw in [true, false] {
        let mut cfg = DriveConfig::default();
        // The published current PI (Kp 300, Ki 600, no schedule): the figures above are
        // its; the shipped integral-only PI winds up more slowly, to ≈ 3000 counts here.
        cfg.control.current_kp = 300.0;
        cfg.control.current_ki = 600.0;
        cfg.control.gain_schedule = false;
        cfg.control.speed_kp = 5e-5;
        cfg.control.speed_ki = 1e-6;
        cfg.control.anti_windup = aw;
        let r = run_events(cfg, 16_000.0, 4.5, &[(3.5, Event::SpeedRef(8000.0))], 9.0);
        assert_eq!((r.mode, r.restarts), (Mode::Running, 0), "aw {aw}");
        let integrator_max = r
            .integrator
            .iter()
            .filter(|d| d.0 > 2.5 && d.0 < 3.5)
            .map(|d| d.1)
            .fold(0.0, f64::max);
        // Commanded 16 000 rpm, out of reach: just before the step the duty is often at
        // ≥ 95 % (else there is nothing to release). With anti-windup the current loop
        // still modulates, and how often it sits at full scale depends on the noise: 34–81 %
        // of the samples over seeds 1–6 (measured); without, all of them.
        let before: Vec<_> = r.duty.iter().filter(|d| d.0 > 3.4 && d.0 < 3.5).collect();
        let full = before.iter().filter(|d| d.1 >= 1900).count();
        assert!(
            !before.is_empty() && full as f64 > 0.25 * before.len() as f64,
            "aw {aw}: duty ≥ 95 % in {full} of {} samples before the step",
            before.len()
        );
        // First PI update after the step whose output is off full scale, and from when on the
        // duty stays below 95 % of it.
        let left = r
            .duty
            .iter()
            .rev()
            .take_while(|d| d.0 > 3.5)
            .filter(|d| d.1 >= 1900)
            .map(|d| d.0 - 3.5)
            .fold(0.0, f64::max);
        let top = r
            .speed
            .iter()
            .filter(|p| p.0 < 3.5)
            .map(|p| p.1)
            .fold(0.0, f64::max);
        println!(
            "anti-windup {aw}: top speed {top:.0} rpm, integrator up to {integrator_max:.0} counts, duty ≥ 95 % until {:.1} ms after the step",
            left * 1e3
        );
        release.push(left);
        wound.push(integrator_max);
    }
    assert!(release[0] < 0.0106, "with anti-windup: {:.4} s", release[0]);
    assert!(
        release[1] > 0.036,
        "without anti-windup: {:.4} s",
        release[1]
    );
    assert!(wound[0] <= 2000.0 && wound[1] > 4000.0, "{wound:?}");
}

fn stats(e: &[f64]) -> (f64, f64, f64) {
    let n = e.len() as f64;
    let mean = e.iter().sum::<f64>() / n;
    let mean_abs = e.iter().map(|e| e.abs()).sum::<f64>() / n;
    let max = e.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    (mean, mean_abs, max)
}

fn angle_stats(name: &str, r: &Run, rpm: f64) {
    let n = r.angle_err.len() as f64;
    let (mean, mean_abs, max) = stats(&r.angle_err);
    println!(
        "{name}: {n} commutations, error mean {mean:+.2}°, mean |e| {mean_abs:.2}°, max |e| {max:.2}°"
    );
    // One second is rpm/10 electrical turns, 6 (six-step) or 12 commutations each; allow
    // 10 % for the speed error and the edges of the window.
    assert!(n > 0.9 * 6.0 * rpm / 10.0, "{name}: {n}");
    assert!(mean_abs < 3.0, "{name}: mean |error| {mean_abs:.2}°");
    assert!(max < 15.0, "{name}: max |error| {max:.2}°");
}

/// Which anti-windup acts where. A step 1500 → 6000 rpm (after turning down from 3000)
/// saturates the speed PI at the current limit (Kp·4500 rpm = 0.225 A plus its integrator
/// against 0.25 A), while the current PI keeps duty to spare (it reaches 0.25 A at ≈ 60 %
/// duty there): so the chip's anti-windup, on the current PI alone, cannot change anything
/// (the back-calculation term is zero unless the voltage command exceeds full scale) and
/// the runs must be identical; back-calculation on the speed PI takes the current command
/// off the limit as soon as the error shrinks (pi.rs), so the overshoot must drop.
///
/// How much it drops depends on where the comparator noise puts the commutations during
/// the step, and the runs with and without are two separate trajectories: a seed does not
/// pair them, and any rounding-level change of the model draws them anew. Over seeds 1–48
/// the overshoot measured 794 rpm without and 608 rpm with on average (standard deviations
/// 48 and 45 rpm; at most 738 with); paired by seed, "with" was the higher in 0 of 48
/// seeds on one build and in 2 of 48 on another whose results differ only in the last
/// digits (same means, same spreads). So the claim is against the population without:
/// every run with it overshoots less than the runs without do on average (seeds 1–6), and
/// the mean overshoot with is at most 0.85 of the mean without.
#[test]
fn anti_windup_acts_only_on_the_pi_that_saturates() {
    let step = |aw: bool, speed_aw: bool, seed: u64| {
        let mut cfg = DriveConfig::default();
        cfg.control.anti_windup = aw;
        cfg.control.speed_anti_windup = speed_aw;
        cfg.sensing.seed = seed;
        run_events(
            cfg,
            3000.0,
            5.0,
            &[
                (1.5, Event::SpeedRef(1500.0)),
                (3.0, Event::SpeedRef(6000.0)),
            ],
            9.0,
        )
    };
    let peak = |r: &Run| {
        r.speed
            .iter()
            .filter(|p| p.0 > 3.0)
            .map(|p| p.1)
            .fold(0.0, f64::max)
            - 6000.0
    };
    let mut runs = Vec::new();
    for seed in 1..=6 {
        let (off, both) = (step(false, false, seed), step(true, true, seed));
        for r in [&off, &both] {
            assert_eq!((r.mode, r.restarts), (Mode::Running, 0), "seed {seed}");
        }
        if seed == 1 {
            let full = off.duty.iter().filter(|d| d.0 > 3.0 && d.1 >= 2000).count();
            assert_eq!(full, 0, "the voltage command never reaches full scale");
            assert_eq!(
                off.speed,
                step(true, false, seed).speed,
                "the chip's anti-windup cannot act here"
            );
        }
        let (p_off, p_both) = (peak(&off), peak(&both));
        println!(
            "seed {seed}: step 1500 → 6000: overshoot {p_off:.0} rpm without, {p_both:.0} rpm with the speed PI's anti-windup"
        );
        assert!(
            p_off > 0.0,
            "seed {seed}: no overshoot without ({p_off:.0} rpm)"
        );
        runs.push((p_off, p_both));
    }
    let n = runs.len() as f64;
    let off_mean = runs.iter().map(|r| r.0).sum::<f64>() / n;
    let both_mean = runs.iter().map(|r| r.1).sum::<f64>() / n;
    for (seed, (_, p_both)) in (1..).zip(&runs) {
        assert!(
            *p_both < off_mean,
            "seed {seed}: {p_both:.0} rpm with, against {off_mean:.0} rpm on average without"
        );
    }
    assert!(
        both_mean < 0.85 * off_mean,
        "mean overshoot {both_mean:.0} rpm with, {off_mean:.0} rpm without (seeds 1–6)"
    );
}
