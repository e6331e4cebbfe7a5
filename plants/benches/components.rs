//! The plant's hot components alone, on inputs typical of the default drive at 3000 rpm
//! (a 20 kHz PWM, steps of a few µs, one floating phase):
//!
//! - `comparator`: the comparator front end over one PWM period of steps, a floating
//!   phase crossing its threshold (filters, ringing, noise, tick-by-tick decisions);
//! - `modal_step`: the exact currents over one step in a two-phase conduction state
//!   (particular solution, mode decays, currents at the end);
//! - `network_solve`: terminal voltages, di/dt and powers of a conduction state, and the
//!   re-resolve of the conduction state after a gate change.
//!
//! `cargo bench -p plants --bench components`. The drive's own figure is
//! `scripts/instructions.sh`; these isolate one part when it changes.

use criterion::{Criterion, criterion_group, criterion_main};
use drive_core::{Abc, Gates, Phase};
use plants::PlantParams;
use plants::circuit::{Circuit, Conduction};
use plants::modal::{Forcing, Modal, Response};
use plants::sensing::{ComparatorBank, Knot};
use std::hint::black_box;

/// u switched high, v low, w floating: a six-step state.
fn uv_w_open() -> Abc<Conduction> {
    Abc {
        u: Conduction::SwitchHigh,
        v: Conduction::SwitchLow,
        w: Conduction::Open,
    }
}

fn comparator(c: &mut Criterion) {
    let p = PlantParams::default();
    let (vdd, vn) = (p.power_stage.supply_v, p.power_stage.supply_v / 2.0);
    let fresh = || {
        ComparatorBank::new(
            &p.sensing.comparator,
            p.sensing.seed,
            &Abc {
                u: vdd,
                v: 0.0,
                w: vn - 0.3,
            },
            vn,
        )
    };
    // One 50 µs PWM period in ten 5 µs steps; the floating terminal w ramps through the
    // neutral (a zero crossing) while u chops between the rails.
    let knot = |k: usize| {
        let t = k as f64 * 5e-6;
        let on = k % 10 < 6;
        let mut kn = Knot::driven(
            Abc {
                u: if on { vdd } else { 0.0 },
                v: 0.0,
                w: vn - 0.3 + 0.6 * t / 50e-6,
            },
            vn,
        );
        kn.emf_rate = Abc {
            u: None,
            v: None,
            w: Some(0.6 / 50e-6),
        };
        kn
    };
    let knots: Vec<(f64, Knot)> = (0..=10).map(|k| (k as f64 * 5e-6, knot(k))).collect();
    let watched = Abc {
        u: false,
        v: false,
        w: true,
    };
    c.bench_function("comparator/pwm_period_watched_crossing", |b| {
        b.iter_batched_ref(
            fresh,
            |bank| {
                for w in knots.windows(2) {
                    let ((t0, k0), (t1, k1)) = (&w[0], &w[1]);
                    bank.update(*t0, *t1, k0, k1, watched);
                }
                black_box(bank.toggle_count())
            },
            criterion::BatchSize::SmallInput,
        )
    });
}

fn modal_step(c: &mut Criterion) {
    let p = PlantParams::default();
    let circuit = Circuit::new(&p.motor, &p.power_stage);
    let modes = uv_w_open();
    let lin = circuit.linearise(&modes);
    let md = Modal::new(&modes, &lin).expect("a two-phase state has a modal form");
    let f = Forcing {
        omega: 2.0 * std::f64::consts::PI * 400.0,
        amp: 0.3,
        slope: 1.0,
        quad: 0.0,
        d1: 0.0,
        d2: 0.0,
    };
    let i0 = [0.1, -0.1, 0.0];
    let (s0, c0) = 0.7f64.sin_cos();
    let h = 5e-6;
    c.bench_function("modal_step/two_phase_5us", |b| {
        b.iter(|| {
            let r = Response::new(black_box(&md), black_box(&i0), (s0, c0), black_box(&f));
            let d = md.decays(black_box(h));
            let (s1, c1) = (0.7 + f.omega * h).sin_cos();
            black_box(r.currents(h, (s1, c1), d))
        })
    });
}

fn network_solve(c: &mut Criterion) {
    let p = PlantParams::default();
    let circuit = Circuit::new(&p.motor, &p.power_stage);
    let modes = uv_w_open();
    let i = Abc {
        u: 0.1,
        v: -0.1,
        w: 0.0,
    };
    let e = Abc {
        u: 0.2,
        v: -0.25,
        w: 0.05,
    };
    c.bench_function("network_solve/solve", |b| {
        b.iter(|| black_box(circuit.solve(black_box(&modes), black_box(&i), black_box(&e))))
    });
    // u's high side turns off: its current freewheels through the low-side diode.
    let mut gates = Gates::default();
    *gates.low.get_mut(Phase::V) = true;
    c.bench_function("network_solve/resolve_after_turn_off", |b| {
        b.iter(|| {
            black_box(circuit.resolve(black_box(&gates), black_box(&i), black_box(&e), None, None))
        })
    });
}

criterion_group!(benches, comparator, modal_step, network_solve);
criterion_main!(benches);
