use bldc_drive::drive_core::*;
use bldc_drive::plants::*;
use std::time::Instant;

fn main() {
    let params = PlantParams::default();
    let plant = BldcPlant::new(params.clone()).unwrap();
    // open-loop at 1000 rpm electrical-step rate: 60° at 1000 rpm = 1/(1000/60*6*6) s
    let rpm: f64 = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(2000.0);
    let duty: u32 = std::env::args().nth(2).map(|s| s.parse().unwrap()).unwrap_or(1000);
    let step_s = 1.0 / (rpm / 60.0 * 6.0 * 6.0);
    let ctrl = OpenLoopSixStep::new(Ticks::from_seconds(step_s).unwrap(), duty, 1);
    let mut eng = Engine::new(plant, ctrl, pwm::HighSideChop, Carrier::default(), Ticks(0));
    eng.plant.set_rotor(30f64.to_radians(), rpm, true);
    let end = Ticks::from_seconds(0.2).unwrap();
    let mut counts = std::collections::HashMap::new();
    let t0 = Instant::now();
    eng.run_until(end, |_, r| *counts.entry(format!("{r:?}")).or_insert(0u64) += 1).unwrap();
    let wall = t0.elapsed().as_secs_f64();
    println!("wall {wall:.3}s for 0.2 s -> RTF {:.1}", 0.2 / wall);
    println!("{counts:?}");
    println!("{:?}", eng.plant.stats());
    println!("toggles {} zc_edges {} scans {} ticks {}", eng.plant.comparator_toggles(), eng.controller.zc_edges, eng.plant.comparators().scans, eng.plant.comparators().ticks_scanned);
    let o = eng.plant.observe();
    println!("{o:#?}");
    println!("{:#?}", eng.plant.energy());
}
