//! Serialized FMU states and outputs of a few fixed runs, written to files for
//! `scripts/bit-identity.sh` to compare between two builds byte for byte.
//!
//! `state-bytes OUT_DIR` writes `OUT_DIR/CASE.bin` per case: the bits of every output
//! after every communication step, then each state taken on the way (its length, then its
//! bytes), then the state at the end of a run continued from a restored mid-run state.
//! That continuation must end in the uninterrupted run's state (else exit 1): the file
//! covers restoring as well as stepping.

use fmu::model::{Access, Model};
use fmu::state::{deserialize, serialize};
use fmu::variables::{Kind, Role, table, vr_of};
use std::path::Path;

/// A run: parameters set in initialization mode, inputs set from a time on, and the
/// times at which states are taken.
struct Case {
    name: &'static str,
    params: &'static [(&'static str, f64)],
    inputs: &'static [(f64, &'static str, f64)],
    end: f64,
    saves: &'static [f64],
}

/// Communication steps, cycled: off the 1 ms grid, so steps end between the drive's events.
const STEPS: [f64; 5] = [1e-3, 0.7e-3, 1.3e-3, 0.25e-3, 2.1e-3];

const CASES: [Case; 3] = [
    Case {
        name: "twelve-step-df",
        params: &[],
        inputs: &[
            (0.85, "load_torque_nm", 2e-4),
            (0.95, "speed_ref_rpm", 2200.0),
            (1.1, "load_torque_nm", -1e-4),
        ],
        end: 1.2,
        saves: &[0.02, 0.4, 0.76, 0.9, 1.12],
    },
    Case {
        name: "six-step-120-noisy",
        params: &[
            ("strategy.name", 1.0),
            ("sensing.comparator.noise_v", 0.02),
            ("sensing.comparator.ring_gain", 0.1),
            ("power_stage.dead_time_s", 1e-6),
            ("seed", 7.0),
        ],
        inputs: &[
            (0.9, "speed_ref_rpm", 5000.0),
            (1.0, "load_torque_nm", 3e-4),
        ],
        end: 1.1,
        saves: &[0.3, 0.85, 1.05],
    },
    Case {
        name: "twelve-step-lm",
        params: &[
            ("strategy.name", 7.0),
            ("strategy.conduction_angle_deg", 160.0),
            ("sensing.comparator.noise_v", 0.01),
        ],
        inputs: &[(0.9, "speed_ref_rpm", 1500.0)],
        end: 1.05,
        saves: &[0.77, 1.0],
    },
];

fn main() {
    if let Err(e) = run() {
        eprintln!("state-bytes: error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [out] = args.as_slice() else {
        return Err("usage: state-bytes OUT_DIR".into());
    };
    let out = Path::new(out);
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    for c in &CASES {
        let bytes = case_bytes(c).map_err(|e| format!("{}: {e}", c.name))?;
        let path = out.join(format!("{}.bin", c.name));
        std::fs::write(&path, bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(())
}

fn access(name: &str) -> Result<Access, String> {
    let vr = vr_of(name).ok_or_else(|| format!("no variable {name}"))?;
    Ok(match table()[vr as usize].kind {
        Kind::Real => Access::Real,
        Kind::Boolean => Access::Boolean,
        _ => Access::Integer,
    })
}

fn set(m: &mut Model, name: &str, x: f64) -> Result<(), String> {
    let vr = vr_of(name).ok_or_else(|| format!("no variable {name}"))?;
    match m.set(access(name)?, vr, x) {
        Ok(()) | Err(fmu::model::Fault::Warning(_)) => Ok(()),
        Err(e) => Err(format!("{name} = {x}: {e:?}")),
    }
}

/// Appends the bits of every output.
fn outputs(m: &mut Model, log: &mut Vec<u8>) -> Result<(), String> {
    for (vr, v) in table().iter().enumerate() {
        if matches!(v.role, Role::Output(_)) {
            let mut o = [0.0];
            m.get(access(v.name)?, &[vr as u32], &mut o)
                .map_err(|e| format!("{}: {e:?}", v.name))?;
            log.extend_from_slice(&o[0].to_bits().to_le_bytes());
        }
    }
    Ok(())
}

/// Steps from `m.time` (step `k0`) to the case's end, setting each input at the first step
/// that starts at or after its time; `each` sees the model before a step's inputs are set.
fn run_to_end(
    m: &mut Model,
    c: &Case,
    k0: usize,
    mut each: impl FnMut(&mut Model, usize) -> Result<(), String>,
) -> Result<(), String> {
    let mut k = k0;
    while m.time < c.end {
        let t = m.time;
        each(m, k)?;
        for &(at, name, x) in c.inputs {
            let h_prev = STEPS[(k + STEPS.len() - 1) % STEPS.len()];
            if at <= t && (k == 0 || at > t - h_prev) {
                set(m, name, x)?;
            }
        }
        m.do_step(t, STEPS[k % STEPS.len()])
            .map_err(|e| format!("step at t = {t}: {e:?}"))?;
        k += 1;
    }
    Ok(())
}

fn case_bytes(c: &Case) -> Result<Vec<u8>, String> {
    let mut m = Model::new();
    m.enter_initialization().map_err(|e| format!("{e:?}"))?;
    for &(name, x) in c.params {
        set(&mut m, name, x)?;
    }
    m.exit_initialization().map_err(|e| format!("{e:?}"))?;
    let (mut log, mut states) = (Vec::new(), Vec::new());
    let mut next = 0;
    run_to_end(&mut m, c, 0, |m, k| {
        if next < c.saves.len() && m.time >= c.saves[next] {
            states.push((k, serialize(m)?));
            next += 1;
        }
        outputs(m, &mut log)
    })?;
    outputs(&mut m, &mut log)?;
    let end = serialize(&m)?;
    for (_, s) in &states {
        log.extend_from_slice(&(s.len() as u64).to_le_bytes());
        log.extend_from_slice(s);
    }
    log.extend_from_slice(&(end.len() as u64).to_le_bytes());
    log.extend_from_slice(&end);
    // Restored from the middle state and run on: it must end where the run did.
    let (k, mid) = states.get(states.len() / 2).ok_or("no state taken")?;
    let mut copy = deserialize(mid, None)?;
    run_to_end(&mut copy, c, *k, |_, _| Ok(()))?;
    let again = serialize(&copy)?;
    if again != end {
        return Err(format!(
            "restored at step {k} and run on, the end state differs from the run's"
        ));
    }
    log.extend_from_slice(&again);
    Ok(log)
}
