//! Start-up Monte-Carlo of every built-in strategy (and the digital-filter twelve-step at
//! 135° and 165°): `cargo run --release --example startup_mc -- [samples] [seed] [threads]`.
//! Environment: `ONLY=label-part` runs the matching variants only, `RPM=x` changes the
//! command (default 3000), `DUMP=dir` writes each failed sample's config there.

use bldc_drive::DriveConfig;
use bldc_drive::bench::standard_variants;
use bldc_drive::bench::startup::{Spread, monte_carlo};

fn main() {
    let args: Vec<u64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("numeric arguments"))
        .collect();
    let samples = args.first().copied().unwrap_or(100) as usize;
    let seed = args.get(1).copied().unwrap_or(1);
    let threads = args.get(2).copied().unwrap_or(1) as usize;
    let only = std::env::var("ONLY").ok();
    let mut base = DriveConfig::default();
    if let Ok(rpm) = std::env::var("RPM") {
        base.control.speed_ref_rpm = rpm.parse().expect("numeric RPM");
    }
    for v in standard_variants(&base.strategy) {
        if only.as_ref().is_some_and(|o| !v.label.contains(o.as_str())) {
            continue;
        }
        let s = monte_carlo(
            &base,
            &v.strategy,
            samples,
            seed,
            Spread::default(),
            threads,
        )
        .expect("runs");
        let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len().max(1) as f64;
        let max = |x: &[f64]| x.iter().cloned().fold(0.0, f64::max);
        println!(
            "{:24} {:4}/{:4} started ({:5.1} %), hand-over {:.3} s, within 5 % mean {:.3} s max {:.3} s",
            v.label,
            s.successes,
            s.runs,
            100.0 * s.successes as f64 / s.runs as f64,
            mean(&s.handover_s),
            mean(&s.within_s),
            max(&s.within_s),
        );
        for (k, f) in s.failures.iter().enumerate() {
            let p = &f.sampled;
            if let Ok(dir) = std::env::var("DUMP") {
                let mut c = base.clone();
                c.strategy = v.strategy.clone();
                c.motor.resistance_ohm = p.resistance_ohm;
                c.motor.self_inductance_h = p.self_inductance_h;
                c.motor.mutual_inductance_h = p.mutual_inductance_h;
                c.motor.flux_linkage_wb = p.flux_linkage_wb;
                c.motor.inertia_kgm2 = p.inertia_kgm2;
                c.motor.viscous_friction_nms = p.viscous_friction_nms;
                c.motor.coulomb_friction_nm = p.coulomb_friction_nm;
                c.power_stage.supply_v = p.supply_v;
                c.sensing.comparator.offset_v.u = p.offset_v[0];
                c.sensing.comparator.offset_v.v = p.offset_v[1];
                c.sensing.comparator.offset_v.w = p.offset_v[2];
                c.sensing.seed = p.seed;
                let path = format!("{dir}/fail_{}_{k}.toml", v.label);
                std::fs::write(path, c.to_toml()).expect("writable");
            }
            println!(
                "    fail: R {:.3} L {:.3e} M {:.3e} λ {:.3e} J {:.3e} B {:.2e} Tc {:.2e} V {:.2} off {:?} seed {} → mean {:.0} rpm, {} restarts",
                p.resistance_ohm,
                p.self_inductance_h,
                p.mutual_inductance_h,
                p.flux_linkage_wb,
                p.inertia_kgm2,
                p.viscous_friction_nms,
                p.coulomb_friction_nm,
                p.supply_v,
                p.offset_v.map(|o| (o * 1e4).round() / 10.0),
                p.seed,
                f.mean_rpm,
                f.restarts
            );
        }
    }
}
