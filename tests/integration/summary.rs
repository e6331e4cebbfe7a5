//! The run summary's torque and current statistics are exact time averages over the
//! steady-state window (from the plant's own integrals), so they do not depend on where
//! the engine happens to stop. Sampled at the stops (PWM edges, diode events, controller
//! ticks) and held until the next, they were biased by about a third at 3000 rpm.

use bldc_drive::DriveConfig;
use bldc_drive::scenario::{Scenario, TraceSpec, run};

#[test]
fn the_summarys_torque_and_current_do_not_depend_on_where_the_engine_stops() {
    let cfg = DriveConfig::default();
    let m = cfg.motor.clone();
    let mut sc = Scenario::hold(cfg, 3000.0, 3.0);
    let plain = run(&sc, |_| {}).expect("runs").summary;
    // Stops every 2 µs as well: the trajectory is the same (the plant serves them from its
    // steps), only the instants seen differ.
    sc.trace = Some(TraceSpec {
        every_s: 2e-6,
        from_s: 0.0,
        to_s: 3.0,
    });
    let sampled = run(&sc, |_| {}).expect("runs").summary;
    assert!(
        plain.verdict.is_running() && plain.restarts == 0,
        "{plain:?}"
    );
    let pairs = [
        ("torque mean", plain.torque_mean_nm, sampled.torque_mean_nm),
        (
            "torque ripple",
            plain.torque_ripple_nm,
            sampled.torque_ripple_nm,
        ),
        ("current rms", plain.current_rms_a, sampled.current_rms_a),
    ];
    for (name, a, b) in pairs {
        // The windows start at the first stop at or after 2 s: up to a PWM period apart.
        assert!((a - b).abs() < 1e-3 * b.abs(), "{name}: {a} vs {b}");
    }
    // At a steady speed the mean torque is the drag's: Bm·ωm + Tc (tanh(ωm/ω0) = 1 here),
    // to within what the speed ripple's few rpm change over the window (J·Δω/Δt).
    let wm = plain.speed_mean_rpm * std::f64::consts::TAU / 60.0;
    let drag = m.viscous_friction_nms * wm + m.coulomb_friction_nm;
    let rel = (plain.torque_mean_nm - drag).abs() / drag;
    assert!(
        rel < 0.05,
        "mean torque {} vs drag {drag}",
        plain.torque_mean_nm
    );
    // The ripple is a sizeable fraction of the mean (commutation and PWM), and the
    // current is well inside the published 0–0.5 A range.
    assert!(
        plain.torque_ripple_nm > 0.1 * plain.torque_mean_nm,
        "{plain:?}"
    );
    assert!(
        plain.current_rms_a > 0.01 && plain.current_rms_a < 0.5,
        "{plain:?}"
    );
}

/// A trace observes: its extra stops change neither the trajectory nor the metrics, so the
/// summary of a traced run is the untraced one, bit for bit (wall time aside).
#[test]
fn a_traced_run_has_the_untraced_runs_summary() {
    let mut sc = Scenario::hold(DriveConfig::default(), 3000.0, 1.5);
    let figures = |sc: &Scenario, rows: &mut u64| {
        let s = run(sc, |_| *rows += 1).expect("runs").summary;
        let mut v = serde_json::to_value(&s).expect("serialises");
        for k in ["wall_s", "realtime_factor"] {
            v.as_object_mut().expect("an object").remove(k);
        }
        v
    };
    let mut rows = 0;
    let plain = figures(&sc, &mut rows);
    assert_eq!(rows, 0);
    sc.trace = Some(TraceSpec {
        every_s: 10e-6,
        from_s: 0.0,
        to_s: 1.5,
    });
    let traced = figures(&sc, &mut rows);
    assert_eq!(rows, 150_001, "a row every 10 µs from 0 to 1.5 s");
    assert_eq!(plain, traced);
}
