//! Serialized states hold the drive by value: a run serialized at any point, deserialized
//! and continued gives every output bit for bit as the run that went on uninterrupted,
//! through start-up, restarts, comparator noise and ringing, dead time, each guard of each
//! strategy, and load and speed-command changes set through the FMU. A component whose
//! state were left out of the bytes would show here as a mismatch.

use fmu::model::{Access, Model};
use fmu::state::{deserialize, serialize};
use fmu::variables::{Kind, Role, table, vr_of};

/// A run: parameters set in initialization mode, inputs set at times, communication
/// steps cycling through sizes off the 1 ms grid, states taken at times.
struct Case {
    name: &'static str,
    params: &'static [(&'static str, f64)],
    inputs: &'static [(f64, &'static str, f64)],
    end: f64,
    saves: &'static [f64],
    /// The communication step after `k` steps, at time `t`.
    step: fn(usize, f64) -> f64,
}

const STEPS: [f64; 5] = [1e-3, 0.7e-3, 1.3e-3, 0.25e-3, 2.1e-3];

fn cycling(k: usize, _t: f64) -> f64 {
    STEPS[k % STEPS.len()]
}

fn access(name: &str) -> Access {
    match table()[vr_of(name).unwrap() as usize].kind {
        Kind::Real => Access::Real,
        Kind::Boolean => Access::Boolean,
        _ => Access::Integer,
    }
}

fn set(m: &mut Model, name: &str, x: f64) {
    match m.set(access(name), vr_of(name).unwrap(), x) {
        Ok(()) | Err(fmu::model::Fault::Warning(_)) => {}
        Err(e) => panic!("{name} = {x}: {e:?}"),
    }
}

/// Every output's bits.
fn outputs(m: &mut Model) -> Vec<u64> {
    table()
        .iter()
        .enumerate()
        .filter(|(_, v)| matches!(v.role, Role::Output(_)))
        .map(|(vr, v)| {
            let mut o = [0.0];
            m.get(access(v.name), &[vr as u32], &mut o).unwrap();
            o[0].to_bits()
        })
        .collect()
}

/// Runs from step `from` to the end, applying the inputs due at each step (`due[k]`)
/// and taking steps of `sizes[k]`, and returns the outputs after every step.
fn run_from(
    m: &mut Model,
    c: &Case,
    (due, sizes): (&[Vec<usize>], &[f64]),
    from: usize,
) -> Vec<Vec<u64>> {
    let mut log = Vec::new();
    for (k, due) in due.iter().enumerate().skip(from) {
        for &i in due {
            let (_, name, x) = c.inputs[i];
            set(m, name, x);
        }
        let t = m.time;
        m.do_step(t, sizes[k]).unwrap();
        log.push(outputs(m));
    }
    log
}

fn check(c: &Case) {
    let mut m = Model::new();
    m.enter_initialization().unwrap();
    for &(name, x) in c.params {
        set(&mut m, name, x);
    }
    m.exit_initialization().unwrap();
    // The step sizes, and the step index at which each input is set and each state
    // taken (the first step starting at or after its time).
    let (mut due, mut saves, mut sizes, mut t) = (Vec::new(), Vec::new(), Vec::new(), 0.0);
    while t < c.end {
        let k = due.len();
        let after = |at: f64| at <= t && (k == 0 || at > t - sizes[k - 1]);
        due.push(
            (0..c.inputs.len())
                .filter(|&i| after(c.inputs[i].0))
                .collect::<Vec<_>>(),
        );
        if c.saves.iter().any(|&s| after(s)) {
            saves.push(k);
        }
        sizes.push((c.step)(k, t));
        t += sizes[k];
    }
    // (Times closer than a step apart share it.)
    assert!(
        saves.len() * 10 >= c.saves.len() * 9,
        "{}: {} of {} states taken",
        c.name,
        saves.len(),
        c.saves.len()
    );
    // The uninterrupted run, serializing on the way.
    let mut states = Vec::new();
    let mut log = Vec::new();
    for k in 0..due.len() {
        if saves.contains(&k) {
            states.push((k, m.time, serialize(&m).unwrap()));
        }
        log.extend(run_from(&mut m, c, (&due[..k + 1], &sizes), k));
    }
    let end_state = serialize(&m).unwrap();
    for (k, at, bytes) in states {
        let mut copy = deserialize(&bytes, None).unwrap();
        assert_eq!(serialize(&copy).unwrap(), bytes, "{}: step {k}", c.name);
        let rest = run_from(&mut copy, c, (&due, &sizes), k);
        for (j, (a, b)) in log[k..].iter().zip(&rest).enumerate() {
            assert_eq!(
                a,
                b,
                "{}: restored at t = {at:.6} s, outputs differ {} steps later",
                c.name,
                j + 1
            );
        }
        assert_eq!(
            serialize(&copy).unwrap(),
            end_state,
            "{}: restored at t = {at:.6} s, the state at the end differs",
            c.name
        );
    }
}

#[test]
fn twelve_step_df_through_start_up_load_and_speed_steps() {
    check(&Case {
        name: "twelve_step_df",
        params: &[],
        inputs: &[
            (0.85, "load_torque_nm", 2e-4),
            (0.95, "speed_ref_rpm", 2200.0),
            (1.1, "load_torque_nm", -1e-4),
            (1.15, "speed_ref_rpm", 4000.0),
        ],
        end: 1.25,
        saves: &[0.0, 0.02, 0.4, 0.745, 0.76, 0.8, 0.9, 1.0, 1.12, 1.2],
        step: cycling,
    });
}

#[test]
fn six_step_guards_with_noise_ringing_and_dead_time() {
    for (name, code) in [
        ("six_step_120_df", 1.0),
        ("six_step_120_nd", 3.0),
        ("six_step_120_lm", 4.0),
    ] {
        let params: &'static [(&'static str, f64)] = Box::leak(
            vec![
                ("strategy.name", code),
                ("sensing.comparator.noise_v", 0.02),
                ("sensing.comparator.ring_gain", 0.1),
                ("power_stage.dead_time_s", 1e-6),
                ("seed", 7.0),
            ]
            .into_boxed_slice(),
        );
        check(&Case {
            name,
            params,
            inputs: &[
                (0.9, "speed_ref_rpm", 5000.0),
                (1.0, "load_torque_nm", 3e-4),
            ],
            end: 1.1,
            saves: &[0.3, 0.78, 0.85, 0.95, 1.05],
            step: cycling,
        });
    }
}

#[test]
fn twelve_step_nd_and_lm_and_raw() {
    for (name, code) in [
        ("twelve_step_nd", 6.0),
        ("twelve_step_lm", 7.0),
        ("twelve_step_raw", 5.0),
    ] {
        let params: &'static [(&'static str, f64)] = Box::leak(
            vec![
                ("strategy.name", code),
                ("strategy.conduction_angle_deg", 160.0),
                ("sensing.comparator.noise_v", 0.01),
            ]
            .into_boxed_slice(),
        );
        check(&Case {
            name,
            params,
            inputs: &[(0.9, "speed_ref_rpm", 1500.0)],
            end: 1.05,
            saves: &[0.77, 0.88, 1.0],
            step: cycling,
        });
    }
}

#[test]
fn restarts_and_enable_cycles() {
    // Far below what the meter reads, the chip as published loses the rotor and restarts;
    // enable dropped and raised aligns again.
    check(&Case {
        name: "restarts",
        params: &[("control.supervisor", 0.0), ("control.max_restarts", 2.0)],
        inputs: &[
            (0.0, "speed_ref_rpm", 500.0),
            (1.6, "enable", 0.0),
            (1.65, "enable", 1.0),
        ],
        end: 2.0,
        saves: &[0.5, 0.9, 1.3, 1.62, 1.7, 1.9],
        step: cycling,
    });
}

#[test]
fn states_taken_every_few_microseconds_through_a_pi_update() {
    // Some state matters only for microseconds: the ADC conversion taken but not yet
    // readable, a dead-time turn-on pending, a comparator toggle on its way through the
    // delay. States taken every 7 µs over a PI update period (5.24 ms) land on each.
    const SAVES: [f64; 760] = {
        let mut s = [0.0; 760];
        let mut k = 0;
        while k < s.len() {
            s[k] = 0.9 + 7e-6 * k as f64;
            k += 1;
        }
        s
    };
    check(&Case {
        name: "fine",
        params: &[("power_stage.dead_time_s", 5e-7)],
        inputs: &[(0.9, "load_torque_nm", 2e-4)],
        end: 0.9 + 7e-6 * 770.0,
        saves: &SAVES,
        step: |k, t| if t < 0.9 - 1e-9 { cycling(k, t) } else { 7e-6 },
    });
}

#[test]
fn supervisor_trips() {
    // Below what the meter reads, the plausibility supervisor finds the drive implausible
    // and restarts it.
    check(&Case {
        name: "supervisor",
        params: &[],
        inputs: &[(0.0, "speed_ref_rpm", 500.0)],
        end: 3.2,
        // It trips at ≈ 2.12 s: states over the updates it judges first.
        saves: &[1.0, 2.0, 2.08, 2.09, 2.1, 2.105, 2.11, 2.115, 2.6],
        step: cycling,
    });
    // Six-step losing its rotor at full duty, caught by the crossings never shown.
    check(&Case {
        name: "supervisor six-step",
        params: &[("strategy.name", 1.0)],
        inputs: &[(1.5, "speed_ref_rpm", 16000.0)],
        end: 3.0,
        saves: &[1.6, 1.8, 2.0, 2.2, 2.4, 2.6, 2.8],
        step: cycling,
    });
}
