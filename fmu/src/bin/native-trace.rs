//! The reference the FMU is compared with (fmu/tests/simulate.py): the same scenario run
//! natively on the drive, without the FMU layer.
//!
//! `native-trace PROFILE.csv STOP_S STEP_S OUT.csv`: PROFILE has a header
//! `time,speed_ref_rpm,load_torque_nm` and piecewise-constant rows (a repeated time is a
//! step). At each communication point t_k = k·STEP the values in force (the last row with
//! time <= t_k) are handed to the drive if they changed, then the drive runs to t_(k+1), as
//! a co-simulation master does; OUT gets the outputs at every t_k.

use bldc_drive::DriveConfig;
use bldc_drive::drive::{build, run_to};
use std::fmt::Write as _;

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [profile, stop, step, out] = args.as_slice() else {
        return Err("usage: native-trace PROFILE.csv STOP_S STEP_S OUT.csv".into());
    };
    let num = |s: &str| s.trim().parse::<f64>().map_err(|e| format!("`{s}`: {e}"));
    let (stop, step) = (num(stop)?, num(step)?);
    let text = std::fs::read_to_string(profile).map_err(|e| format!("{profile}: {e}"))?;
    let rows: Vec<[f64; 3]> = text
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            match f.as_slice() {
                [a, b, c] => Ok([num(a)?, num(b)?, num(c)?]),
                _ => Err(format!("bad row `{l}`")),
            }
        })
        .collect::<Result<_, _>>()?;
    let at = |t: f64| {
        rows.iter()
            .rev()
            .find(|r| r[0] <= t + 1e-9)
            .or(rows.first())
            .copied()
            .unwrap_or([0.0, 3000.0, 0.0])
    };

    let mut cfg = DriveConfig::default();
    let first = at(0.0);
    cfg.control.speed_ref_rpm = first[1];
    let mut eng = build(&cfg).map_err(|e| e.to_string())?;
    let (mut speed, mut load) = (first[1], 0.0);
    let mut csv = String::from(
        "time,speed_rpm,speed_est_rpm,theta_e_deg,i_u,i_v,i_w,torque_nm,duty,state,restarts\n",
    );
    let n = (stop / step).round() as u64;
    for k in 0..=n {
        let t = k as f64 * step;
        let o = eng.plant.observe();
        let s = eng.controller.status();
        let th = o.theta_e.to_degrees().rem_euclid(360.0);
        let _ = writeln!(
            csv,
            "{t:?},{:?},{},{:?},{:?},{:?},{:?},{:?},{:?},{},{}",
            o.speed_rpm,
            s.speed_est_rpm,
            if th >= 360.0 { 0.0 } else { th },
            o.i.u,
            o.i.v,
            o.i.w,
            o.torque_nm,
            f64::from(s.duty) / f64::from(eng.carrier().top),
            s.state,
            s.restarts
        );
        if k == n {
            break;
        }
        let [_, sp, ld] = at(t);
        if sp != speed {
            speed = sp;
            eng.controller.set_speed_ref(sp);
        }
        if ld != load {
            load = ld;
            eng.plant.set_load_torque(ld);
        }
        run_to(&mut eng, (k + 1) as f64 * step, |_, _| {}).map_err(|e| e.to_string())?;
    }
    std::fs::write(out, csv).map_err(|e| format!("{out}: {e}"))
}
