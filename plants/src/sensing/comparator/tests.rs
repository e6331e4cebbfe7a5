//! The comparator bank's tests: closed forms, history, and a brute-force reference.

use super::records::RECORDS;
use super::*;
use crate::sensing::noise;
use crate::sensing::rc::{hermite, horner};
use std::f64::consts::TAU;

const ALL: Abc<bool> = Abc::splat(true);

/// Updates over [t0, t1] with the terminals held at `v` and the neutral at 0 V.
fn hold(c: &mut ComparatorBank, (t0, t1): (f64, f64), v: Abc<f64>, watched: Abc<bool>) {
    let k = Knot::driven(v, 0.0);
    c.update(t0, t1, &k, &k, watched);
}

/// A noisy comparator sitting on its threshold toggles every few ticks.
fn chattering() -> ComparatorParams {
    ComparatorParams {
        offset_v: Abc::splat(0.0),
        hysteresis_v: 0.0,
        noise_v: 5e-3,
        noise_interval_s: 20e-9,
        ring_gain: 0.0,
        delay_s: 2e-6,
        ..ComparatorParams::default()
    }
}

#[test]
fn one_long_update_equals_many_short_ones_however_many_toggles() {
    let p = chattering();
    let v = Abc::splat(0.0);
    let mut long = ComparatorBank::new(&p, 7, &v, 0.0);
    let mut short = ComparatorBank::new(&p, 7, &v, 0.0);
    let n = 2000u64;
    hold(&mut long, (0.0, n as f64 * TICK_S), v, ALL);
    let w = Abc::splat(true);
    for k in 0..n {
        // Queried at each instant as the engine would, before the plant moves on.
        let t = Ticks(k);
        assert_eq!(long.outputs_at(t), short.outputs_at(t), "tick {k}");
        if k > 0 {
            assert_eq!(
                long.next_visible_change(t, w),
                short.next_visible_change(t, w),
                "tick {k}"
            );
        }
        hold(
            &mut short,
            (k as f64 * TICK_S, (k + 1) as f64 * TICK_S),
            v,
            ALL,
        );
    }
    assert!(
        long.toggle_count() > 500,
        "chatter expected: {}",
        long.toggle_count()
    );
    assert_eq!(long.toggle_count(), short.toggle_count());
}

/// A floating leg's input bent by its back-EMF's Hermite cubic (rising at 2e4 V/s, then
/// falling: its chord is flat at −50 mV and never crosses): the toggles, the filter at
/// the step's end and after a cut agree with RK4 on the filter ODE with 1 ns steps.
#[test]
fn a_floating_legs_bent_input_is_filtered_exactly() {
    let p = ComparatorParams {
        noise_v: 0.0,
        ring_gain: 0.0,
        offset_v: Abc::splat(0.0),
        ..ComparatorParams::default()
    };
    let (h, v0, d0, d1) = (80e-6, -0.05, 2e4, -2e4);
    let w = |rate: f64| Knot {
        v: Abc {
            u: 0.0,
            v: 0.0,
            w: v0,
        },
        vn: 0.0,
        emf_rate: Abc {
            u: None,
            v: None,
            w: Some(rate),
        },
    };
    let bank = || {
        ComparatorBank::new(
            &p,
            1,
            &Abc {
                u: 0.0,
                v: 0.0,
                w: v0,
            },
            0.0,
        )
    };
    // The reference: the phase filter on the Hermite cubic, the neutral's at rest at 0.
    let cubic = hermite(1.0 / h, (v0, d0), (v0, d1));
    let tau = p.phase_filter_tau_s;
    let dy = |t: f64, y: f64| (horner(&cubic, t) - y) / tau;
    let n = (h / TICK_S).round() as u64;
    let (mut y, mut y_at) = (v0, vec![v0]);
    for k in 0..n {
        for j in 0..20 {
            let (t, dt) = ((k * 20 + j) as f64 * 1e-9, 1e-9);
            let k1 = dy(t, y);
            let k2 = dy(t + dt / 2.0, y + dt / 2.0 * k1);
            let k3 = dy(t + dt / 2.0, y + dt / 2.0 * k2);
            let k4 = dy(t + dt, y + dt * k3);
            y += dt / 6.0 * (k1 + 2.0 * (k2 + k3) + k4);
        }
        y_at.push(y);
    }
    let (mut out, mut want) = (false, Vec::new());
    for (k, &y) in y_at.iter().enumerate().skip(1) {
        if (!out && y > p.hysteresis_v / 2.0) || (out && y < -p.hysteresis_v / 2.0) {
            out = !out;
            want.push((k as u64, out));
        }
    }
    assert_eq!(want.len(), 2, "a rise and a fall: {want:?}");
    let mut c = bank();
    c.update(0.0, h, &w(d0), &w(d1), Abc::splat(true));
    let got: Vec<_> = c.front.hist[Phase::W.index()]
        .toggles
        .iter()
        .copied()
        .collect();
    assert_eq!(got, want);
    assert!((c.filtered().0.w - y_at[n as usize]).abs() < 1e-9);
    // Cut in the middle: the filter takes its value there.
    let mid = n / 2;
    let mut c = bank();
    c.update(0.0, h, &w(d0), &w(d1), Abc::splat(false));
    c.truncate_at(Ticks(mid));
    assert!((c.filtered().0.w - y_at[mid as usize]).abs() < 1e-9);
}

#[test]
fn ringing_never_reaches_back_before_the_edge_that_excites_it() {
    // 3 mV inside the ±5 mV hysteresis band, ringing from an edge at t = 0: the scans of
    // a step nobody watches stay pending. A much larger edge at the step's end must not
    // change what is read before it.
    let p = ComparatorParams {
        noise_v: 0.0,
        offset_v: Abc::splat(0.0),
        ..ComparatorParams::default()
    };
    let v = Abc::splat(3e-3);
    let end = 100u64; // 2 µs, the ringing's decay time ten times over
    let run = |second_edge: bool| {
        let mut c = ComparatorBank::new(&p, 1, &v, 0.0);
        c.excite(0.0, 1.0);
        hold(&mut c, (0.0, end as f64 * TICK_S), v, Abc::splat(false));
        assert!(c.pending.iter().all(Option::is_some), "scans pending");
        if second_edge {
            c.excite(end as f64 * TICK_S, 10.0);
        }
        c.finish_pending(u64::MAX);
        (0..=end + c.front.delay)
            .map(|k| c.outputs_at(Ticks(k)))
            .collect::<Vec<_>>()
    };
    let quiet = run(false);
    assert!(
        quiet.iter().any(|o| !o.u),
        "the first edge's ringing toggles them"
    );
    assert_eq!(run(true), quiet);
}

#[test]
fn a_step_cut_at_its_start_leaves_the_pending_scans_untouched() {
    // Channels nobody watches, sitting on their threshold: their scans stay pending.
    let p = chattering();
    let v = Abc::splat(0.0);
    let mut c = ComparatorBank::new(&p, 7, &v, 0.0);
    let none = Abc::splat(false);
    hold(&mut c, (0.0, 1000.0 * TICK_S), v, none);
    assert!(c.pending.iter().all(Option::is_some), "scans pending");
    // Cut at the step's start, before its first tick: nothing of it remains.
    c.truncate_at(Ticks(0));
    assert_eq!(c.toggle_count(), 0);
    assert!(c.pending.iter().all(Option::is_none));
    assert_eq!(
        c.outputs_at(Ticks(0)),
        ComparatorBank::new(&p, 7, &v, 0.0).outputs_at(Ticks(0))
    );
}

#[test]
fn history_keeps_a_change_the_controller_has_not_been_told_about() {
    let p = chattering();
    let v = Abc::splat(0.0);
    let mut c = ComparatorBank::new(&p, 7, &v, 0.0);
    hold(&mut c, (0.0, 1000.0 * TICK_S), v, ALL);
    let all = Abc::splat(true);
    let first = c.next_visible_change(Ticks(0), all).expect("chatter");
    // Long after it became visible, but unreported: it must still be found.
    c.forget_history(Ticks(5000), Some(first));
    assert_eq!(c.next_visible_change(Ticks(0), all), Some(first));
    // Once reported, everything before the query horizon may go.
    c.forget_history(Ticks(5000), None);
    assert!(
        c.next_visible_change(Ticks(0), all)
            .is_none_or(|t| t > first)
    );
}

/// The comparators by brute force: both filters in closed form at every tick from the
/// step's start, the ringing as a phasor re-referred at each excitation, the noise
/// sample of each tick, the hysteresis applied tick by tick. Returns the toggles.
struct Reference {
    p: ComparatorParams,
    seed: u64,
    y: [f64; 3],
    y_n: f64,
    out: [bool; 3],
    /// Ringing phasor referred to tick `ring_k`.
    ring: (f64, f64),
    ring_k: u64,
    toggles: [Vec<(u64, bool)>; 3],
}

impl Reference {
    /// At rest, with outputs `out`.
    fn new(p: &ComparatorParams, seed: u64, out: [bool; 3]) -> Self {
        Reference {
            p: p.clone(),
            seed,
            y: [0.0; 3],
            y_n: 0.0,
            out,
            ring: (0.0, 0.0),
            ring_k: 0,
            toggles: [Vec::new(), Vec::new(), Vec::new()],
        }
    }

    fn rot(&self, dt: f64) -> (f64, f64) {
        let m = (-dt / self.p.ring_decay_s).exp();
        let (s, c) = (TAU * self.p.ring_frequency_hz * dt).sin_cos();
        (m * c, m * s)
    }

    fn excite(&mut self, t: f64, dv: f64) {
        let k = Ticks::at_or_after(t).0.0;
        let a = self.rot((k - self.ring_k) as f64 * TICK_S);
        let b = self.rot(k as f64 * TICK_S - t);
        let g = self.p.ring_gain * dv;
        let z = self.ring;
        self.ring = (
            z.0 * a.0 - z.1 * a.1 + g * b.0,
            z.0 * a.1 + z.1 * a.0 + g * b.1,
        );
        self.ring_k = k;
    }

    /// The ramps from `k0` to `k1` over [t0, t1].
    fn update(&mut self, (t0, t1): (f64, f64), k0: &Knot, k1: &Knot) {
        let h = t1 - t0;
        // y(τ) = u0 + b·(τ − T) + (y0 − u0 + b·T)·e^{−τ/T} for u = u0 + b·τ.
        let filter = |y0: f64, u0: f64, u1: f64, tf: f64, tau: f64| {
            let b = (u1 - u0) / h;
            u0 + b * (tau - tf) + (y0 - u0 + b * tf) * (-tau / tf).exp()
        };
        let (tp, tn) = (self.p.phase_filter_tau_s, self.p.neutral_filter_tau_s);
        let (v0, v1) = (k0.v.to_array(), k1.v.to_array());
        let first = Ticks::at_or_before(t0).0 + 1;
        let last = Ticks::at_or_before(t1).0;
        for k in first..=last {
            let tau = k as f64 * TICK_S - t0;
            let yn = filter(self.y_n, k0.vn, k1.vn, tn, tau);
            let r = self.rot((k - self.ring_k) as f64 * TICK_S);
            let ring = self.ring.0 * r.1 + self.ring.1 * r.0;
            for j in 0..3 {
                let y = filter(self.y[j], v0[j], v1[j], tp, tau);
                let n = noise::uniform(
                    self.seed,
                    j as u64,
                    k / self.p.noise_interval().0,
                    self.p.noise_v,
                );
                let s = y - yn - self.p.offset_v.to_array()[j] + ring + n;
                let half = self.p.hysteresis_v / 2.0;
                if (!self.out[j] && s > half) || (self.out[j] && s < -half) {
                    self.out[j] = !self.out[j];
                    self.toggles[j].push((k, self.out[j]));
                }
            }
        }
        for j in 0..3 {
            self.y[j] = filter(self.y[j], v0[j], v1[j], tp, h);
        }
        self.y_n = filter(self.y_n, k0.vn, k1.vn, tn, h);
    }

    fn output_at(&self, j: usize, k: u64, initial: bool) -> bool {
        self.toggles[j]
            .iter()
            .rev()
            .find(|t| t.0 <= k)
            .map_or(initial, |t| t.1)
    }
}

/// A drive-like sequence: steps of whole and fractional ticks, the terminals a few
/// millivolts from the neutral and ramping through it, common-mode PWM edges of several
/// volts that excite the ringing, some steps cut short. Every toggle the bank finds
/// (all watched), or every output read (watched at random, read at each step's end),
/// equals the brute-force one; and so does every output read that was declared, with
/// channels declared read from random instants (now, within the step, later, never),
/// and declarations changed between steps and at their ends, so that channels are left
/// undecided over many steps and decided again when read.
#[test]
fn the_scans_find_exactly_the_toggles_of_a_tick_by_tick_evaluation() {
    let p = ComparatorParams::default();
    let mut next = uniform_draws(0x2545_F491_4F6C_DD1D);
    // Three runs with declarations: each draws other inputs and other declarations.
    let modes = [
        Mode::AllWatched,
        Mode::SomeWatched,
        Mode::Declared,
        Mode::Declared,
        Mode::Declared,
    ];
    for mode in modes {
        let v = Abc::splat(0.0);
        let seed = 11;
        let mut bank = ComparatorBank::new(&p, seed, &v, 0.0);
        let init = Abc::from_fn(|x| -p.offset_v.get(x) > 0.0).to_array();
        let mut r = Reference::new(&p, seed, init);
        let (mut t, mut cm) = (0.0, 0.0);
        let mut diff = [0.0; 3];
        let (mut reads, mut undecided_steps) = (0, 0);
        let mut read_from = Abc::splat(Ticks::ZERO);
        for step in 0..600 {
            let what = format!("{mode:?}, step {step}");
            // A PWM edge now and then: the common mode jumps by up to ±6 V.
            if step % 4 == 3 {
                let dv = 12.0 * (next() - 0.5);
                cm += dv;
                bank.excite(t, dv);
                r.excite(t, dv);
            }
            let knot = |cm: f64, d: [f64; 3]| Knot::driven(Abc::from_array(d.map(|d| cm + d)), cm);
            let k0 = knot(cm, diff);
            let (h, d1, cm1) = draw_step(&mut next, cm, diff);
            let k1 = knot(cm1, d1);
            let watched = match mode {
                Mode::AllWatched => ALL,
                Mode::SomeWatched => Abc::from_fn(|_| next() < 0.3),
                Mode::Declared => Abc::from_fn(|_| next() < 0.03),
            };
            let now = Ticks::at_or_after(t).0;
            if mode == Mode::Declared {
                read_from = random_reads(&mut next, read_from, now, 2.0 * h);
            }
            bank.declare(now, watched, read_from);
            bank.watch(watched);
            bank.update(t, t + h, &k0, &k1, watched);
            let first = Ticks::at_or_before(t).0 + 1;
            let last = Ticks::at_or_before(t + h).0;
            let cut = (last > first + 2 && next() < 0.15)
                .then(|| first + ((last - first) as f64 * next()) as u64);
            let t1 = match cut {
                Some(k) => {
                    // The cut step's inputs at the cut: the same ramps.
                    let f = (k as f64 * TICK_S - t) / h;
                    let at = knot(
                        cm + f * (cm1 - cm),
                        std::array::from_fn(|j| diff[j] + f * (d1[j] - diff[j])),
                    );
                    r.update((t, k as f64 * TICK_S), &k0, &at);
                    if mode == Mode::Declared && next() < 0.5 {
                        // A controller tick inside the step, before the cut, declares
                        // anew and reads there.
                        let mid = Ticks(first + ((k - first) as f64 * next()) as u64);
                        read_from = random_reads(&mut next, read_from, mid, 20e-6);
                        bank.declare(mid, watched, read_from);
                        reads +=
                            compare_reads(&mut bank, &r, init, mid, (watched, read_from), &what);
                    }
                    bank.truncate_at(Ticks(k));
                    cm += f * (cm1 - cm);
                    diff = at.v.to_array().map(|v| v - cm);
                    k as f64 * TICK_S
                }
                None => {
                    r.update((t, t + h), &k0, &k1);
                    (cm, diff) = (cm1, d1);
                    t + h
                }
            };
            undecided_steps += usize::from(bank.dormant.iter().any(Option::is_some));
            let at = Ticks::at_or_after(t1).0;
            // Read at the step's end, and in a third of them again after a new
            // declaration there (as a controller tick's command would make).
            for again in [false, true] {
                if again {
                    if mode != Mode::Declared || next() > 0.3 {
                        break;
                    }
                    read_from = random_reads(&mut next, read_from, at, 100e-6);
                    bank.declare(at, watched, read_from);
                }
                reads += compare_reads(&mut bank, &r, init, at, (watched, read_from), &what);
            }
            t = t1;
        }
        check_run(mode, &bank, &r, reads, undecided_steps);
    }
}

/// Uniform draws in [0, 1) from a xorshift generator seeded with `rng`.
fn uniform_draws(mut rng: u64) -> impl FnMut() -> f64 {
    move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A step of the drive-like sequence, drawn: its length \[s\], and at its end the
/// terminals' differences from the common mode and the common mode \[V\].
fn draw_step(next: &mut impl FnMut() -> f64, cm: f64, diff: [f64; 3]) -> (f64, [f64; 3], f64) {
    // Lengths from a tick to 80 µs, a fifth of them ending between ticks.
    let mut h = (1.0 + (4000.0 * next() * next()).floor()) * TICK_S;
    if next() < 0.2 {
        h += 0.37 * TICK_S;
    }
    // Slow, fast or hovering inputs: the hovering ones stay undecidable at the
    // ends of steps for a while, the fast ones cross within a step.
    let scale = [0.0, 400.0, 3000.0][(3.0 * next()) as usize];
    let slope = scale * (next() - 0.5); // V/s: 75 mV over 50 µs at most
    // u jumps about its thresholds from step to step: it toggles in most steps
    // and is seldom certain at their ends, so its undecided stretches are long.
    let d1: [f64; 3] = std::array::from_fn(|j| {
        if j == 0 {
            0.016 * (next() - 0.5)
        } else {
            (diff[j] + slope * h + 4e-3 * (next() - 0.5)).clamp(-0.03, 0.03)
        }
    });
    let cm1 = cm + 0.2 * (next() - 0.5);
    (h, d1, cm1)
}

/// Reads `bank` at `at` (caught up to it) and compares every channel decided there
/// (watched, or declared read by then) with the reference's output a delay earlier,
/// `init` before its first toggle; returns how many were compared.
fn compare_reads(
    bank: &mut ComparatorBank,
    r: &Reference,
    init: [bool; 3],
    at: Ticks,
    (watched, read_from): (Abc<bool>, Abc<Ticks>),
    what: &str,
) -> usize {
    let k = at.0.saturating_sub(r.p.delay().0);
    bank.catch_up(at);
    let read = bank.outputs_at(at).to_array();
    let mut reads = 0;
    for (j, x) in Phase::ALL.into_iter().enumerate() {
        if !watched.get(x) && read_from.get(x) > at {
            continue; // not decided
        }
        assert_eq!(
            read[j],
            r.output_at(j, k, init[j]),
            "{what}: channel {j} read at tick {}",
            at.0
        );
        reads += 1;
    }
    reads
}

/// A run of the sequence compared enough (toggles, reads, undecided stretches), and with
/// every channel watched, the bank's toggles are the reference's.
fn check_run(
    mode: Mode,
    bank: &ComparatorBank,
    r: &Reference,
    reads: usize,
    undecided_steps: usize,
) {
    let found: usize = r.toggles.iter().map(Vec::len).sum();
    assert!(found > 300, "few toggles to compare: {found}");
    if mode == Mode::Declared {
        assert!(reads > 600, "{reads} reads");
        assert!(
            undecided_steps > 200,
            "{undecided_steps} steps with undecided channels"
        );
    } else {
        assert_eq!(reads, 1800);
        assert_eq!(undecided_steps, 0);
    }
    if mode == Mode::AllWatched {
        for j in 0..3 {
            let got: Vec<_> = bank.front.hist[j].toggles.iter().copied().collect();
            assert_eq!(got, r.toggles[j], "channel {j}");
        }
    }
}

/// A channel left undecided over more steps than are recorded: its input sits inside
/// the hysteresis band (no step's end is certain), toggled by the ringing of edges in
/// the first steps only, so that its output at the end is decided by steps long gone
/// from the records. Read again, it agrees with the brute-force evaluation, for every
/// noise seed and number of edges tried.
#[test]
fn a_channel_undecided_over_more_steps_than_are_recorded_is_decided_exactly() {
    let p = ComparatorParams {
        offset_v: Abc::splat(0.0),
        ..ComparatorParams::default()
    };
    let (none, all) = (Abc::splat(false), Abc::splat(Ticks::ZERO));
    let (n, h) = (3 * RECORDS as u64, 2e-6);
    let mut differs = 0;
    for seed in 1..=12 {
        let mut bank = ComparatorBank::new(&p, seed, &Abc::splat(0.0), 0.0);
        let mut r = Reference::new(&p, seed, [false; 3]);
        for step in 0..n {
            let t = step as f64 * h;
            let now = Ticks::at_or_after(t).0;
            // Unread but for the last step.
            let reads = if step + 1 < n {
                Abc::splat(Ticks::NEVER)
            } else {
                all
            };
            bank.declare(now, none, reads);
            // Edges of ±6 V in the first steps; between them everything sits at 0 V
            // but u, 2 mV above: inside the ±5 mV band.
            if step < RECORDS as u64 / 2 + seed % 3 {
                let dv = if step % 2 == 0 { 6.0 } else { -6.0 };
                bank.excite(t, dv);
                r.excite(t, dv);
            }
            let k = Knot::driven(
                Abc {
                    u: 2e-3,
                    v: 0.0,
                    w: 0.0,
                },
                0.0,
            );
            bank.update(t, t + h, &k, &k, none);
            r.update((t, t + h), &k, &k);
            assert!(step + 1 == n || bank.dormant.iter().all(Option::is_some));
        }
        assert!(r.toggles[0].len() > 4, "the ringing toggles u");
        let at = Ticks::at_or_after(n as f64 * h).0;
        bank.catch_up(at);
        let read = bank.outputs_at(at).to_array();
        let k = at.0 - p.delay().0;
        for (j, &got) in read.iter().enumerate() {
            assert_eq!(got, r.output_at(j, k, false), "seed {seed}, channel {j}");
        }
        // How often the output now differs from the one before the unread stretch.
        differs += usize::from(read[0] != bank.front.hist[0].base);
    }
    assert!(
        differs >= 2,
        "the read must depend on the stretch: {differs} of 12"
    );
}

/// Each channel's declaration `prev` kept (four times in five: channels stay undecided
/// over runs of steps), or else read from now, never, or a random instant within
/// `span` \[s\].
fn random_reads(
    next: &mut impl FnMut() -> f64,
    prev: Abc<Ticks>,
    now: Ticks,
    span: f64,
) -> Abc<Ticks> {
    Abc::from_fn(|x| {
        if next() < 0.8 {
            return prev.get(x);
        }
        match next() {
            u if u < 0.3 => Ticks::ZERO,
            u if u < 0.7 => Ticks::NEVER,
            u => Ticks(now.0 + ((u - 0.7) / 0.3 * span / TICK_S) as u64),
        }
    })
}

#[derive(Copy, Clone, Debug, PartialEq)]
enum Mode {
    AllWatched,
    SomeWatched,
    Declared,
}

#[test]
fn filters_settle_to_the_input_and_the_output_follows_its_sign() {
    let p = ComparatorParams {
        noise_v: 0.0,
        ring_gain: 0.0,
        ..ComparatorParams::default()
    };
    let lo = Abc::splat(0.0);
    let hi = Abc {
        u: 0.5,
        v: -0.5,
        w: 0.5,
    };
    let mut c = ComparatorBank::new(&p, 1, &lo, 0.0);
    hold(&mut c, (0.0, 20e-6), hi, ALL);
    let (y, yn) = c.filtered();
    assert!((y.u - 0.5).abs() < 1e-6 && (y.v + 0.5).abs() < 1e-6 && yn.abs() < 1e-12);
    let out = c.outputs_at(Ticks(1000));
    assert!(out.u && !out.v && out.w, "{out:?}");
}
