//! The comparator bank's tests: closed forms, history, and a brute-force reference.

use super::records::RECORDS;
use super::*;
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
    let mut rng = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
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
        let mut r = Reference {
            p: p.clone(),
            seed,
            y: [0.0; 3],
            y_n: 0.0,
            out: init,
            ring: (0.0, 0.0),
            ring_k: 0,
            toggles: [Vec::new(), Vec::new(), Vec::new()],
        };
        let (mut t, mut cm) = (0.0, 0.0);
        let mut diff = [0.0; 3];
        let (mut reads, mut undecided_steps) = (0, 0);
        let mut read_from = Abc::splat(Ticks::ZERO);
        for step in 0..600 {
            // A PWM edge now and then: the common mode jumps by up to ±6 V.
            if step % 4 == 3 {
                let dv = 12.0 * (next() - 0.5);
                cm += dv;
                bank.excite(t, dv);
                r.excite(t, dv);
            }
            let knot = |cm: f64, d: [f64; 3]| Knot::driven(Abc::from_array(d.map(|d| cm + d)), cm);
            let k0 = knot(cm, diff);
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
                        bank.catch_up(mid);
                        let read = bank.outputs_at(mid).to_array();
                        let q = mid.0.saturating_sub(p.delay().0);
                        for (j, x) in Phase::ALL.into_iter().enumerate() {
                            if watched.get(x) || read_from.get(x) <= mid {
                                let want = r.output_at(j, q, init[j]);
                                assert_eq!(read[j], want, "channel {j} at {mid:?}, step {step}");
                                reads += 1;
                            }
                        }
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
            let k = at.0.saturating_sub(p.delay().0);
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
                bank.catch_up(at);
                let read = bank.outputs_at(at).to_array();
                for (j, x) in Phase::ALL.into_iter().enumerate() {
                    if !watched.get(x) && read_from.get(x) > at {
                        continue; // not decided
                    }
                    assert_eq!(
                        read[j],
                        r.output_at(j, k, init[j]),
                        "{mode:?}: channel {j} read at tick {}, step {step}",
                        at.0
                    );
                    reads += 1;
                }
            }
            t = t1;
        }
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
        let mut r = Reference {
            p: p.clone(),
            seed,
            y: [0.0; 3],
            y_n: 0.0,
            out: [false; 3],
            ring: (0.0, 0.0),
            ring_k: 0,
            toggles: [Vec::new(), Vec::new(), Vec::new()],
        };
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

/// The tick walk ([`Front::walk`]: two ticks a step on two lanes, stepped by two ticks'
/// factors) decides every tick as the signal evaluated tick by tick with exp and sin does:
/// s(τ) = P(τ) + noise + A·e^{−τ/τp} − B·e^{−τ/τn} + Im(z·e^{(−1/τr + jω)(t − t_z)}) \[V\]
/// against ±h/2, over noise segments of 7 and 8 ticks (so pairs start on either parity)
/// with filter transients and ringing. The brute-force test above walks mostly single
/// ticks (its noise changes every tick); this one walks long segments, with a pair whose
/// two ticks both toggle. And the LINEAR loop (P as c0 + τ·c1) records what the cubic
/// one does for a P without τ² and τ³ terms.
#[test]
fn the_paired_tick_walk_decides_each_tick_as_a_scalar_evaluation_does() {
    // Without hysteresis and with ringing near Nyquist (2.2 ticks a period), a tick
    // between two of the other sign toggles twice in a row; with a 2 mV band and slower
    // ringing, the band matters.
    let mut both_in_pair = 0;
    for (hyst, ring_hz) in [(0.0, 23e6), (2e-3, 3.1e6)] {
        let p = ComparatorParams {
            offset_v: Abc::splat(0.0),
            hysteresis_v: hyst,
            ring_frequency_hz: ring_hz,
            ring_decay_s: 2e-6, // 100 ticks: the ringing lasts over the whole walk
            ..ComparatorParams::default()
        };
        let (tp, tn, tr) = (p.phase_filter_tau_s, p.neutral_filter_tau_s, p.ring_decay_s);
        let w = TAU * ring_hz;
        // Ringing excited at tick 40 [V], the step from 0.37 ticks before tick 50 [s].
        let (rk, z) = (40u64, (4e-3, -7e-3));
        let (k_s, t0) = (50u64, 49.63 * TICK_S);
        let front = || {
            let mut f = ComparatorBank::new(&p, 3, &Abc::splat(0.0), 0.0).front;
            f.ring = Ring {
                z,
                t: tick_instant(rk),
                k: rk,
                mag: z.0.hypot(z.1),
            };
            f
        };
        let tau_s = tick_instant(k_s) - t0;
        // A and B [V] at τ = 0: their difference decays slowly (τp ≠ τn).
        let (a, b) = (0.02, 0.015);
        // P [V, V/s, V/s², V/s³]: −4 mV rising by 12 mV over the walk's 6 µs, bent.
        for poly in [[-4e-3, 2e3, -2e8, 1e13], [-4e-3, 2e3, 0.0, 0.0]] {
            let c = Channel {
                x: Phase::U,
                t0,
                k_s,
                base: ((-tau_s / tp).exp(), (-tau_s / tn).exp()),
                poly,
                beta: 0.0,
                dev: (0.0, 0.0),
                a,
                b,
                ap: a / tp,
                bn: b / tn,
                stationary: std::cell::Cell::new(None),
            };
            // 40 segments of 7 and 8 ticks, each with its own noise sample (±1 mV).
            let key = noise::channel_key(5, 0);
            let mut segs = Vec::new();
            let mut k = k_s;
            for m in 0..40 {
                let n = 7 + m % 2;
                segs.push((k, k + n - 1, noise::uniform_keyed(key, m, 1e-3)));
                k += n;
            }
            let mut f = front();
            for &(k, last, noise) in &segs {
                f.walk(&c, k, last, noise);
            }
            let hist: Vec<_> = f.hist[0].toggles.iter().copied().collect();
            let out_at = |k: u64| hist.iter().rev().find(|t| t.0 <= k).is_some_and(|t| t.1);
            assert!(hist.len() > 10, "few toggles: {}", hist.len());
            assert!(hist.iter().all(|t| (k_s..k).contains(&t.0)));
            assert_eq!(f.out.u, out_at(k));
            // Each tick from the walk's output before it: a tick too close to call (the
            // lanes' rounding differs from this evaluation's) is skipped without letting
            // the comparison drift.
            let mut skipped = 0;
            for &(k0, last, noise) in &segs {
                for k in k0..=last {
                    let tau = k as f64 * TICK_S - t0;
                    let dt = (k - rk) as f64 * TICK_S;
                    let terms = [
                        horner(&poly, tau) + noise,
                        a * (-tau / tp).exp(),
                        -b * (-tau / tn).exp(),
                        (-dt / tr).exp() * (z.0 * (w * dt).sin() + z.1 * (w * dt).cos()),
                    ];
                    let s: f64 = terms.iter().sum();
                    let before = out_at(k - 1);
                    let margin = if before { -s } else { s } - hyst / 2.0;
                    if margin.abs() <= 1e-12 * terms.iter().map(|t| t.abs()).sum::<f64>() {
                        skipped += 1;
                        continue;
                    }
                    let want = before != (margin > 0.0);
                    assert_eq!(out_at(k), want, "tick {k}, h {hyst} V, P {poly:?}");
                }
                // Pairs start at the segment's first tick.
                both_in_pair += (k0..last)
                    .step_by(2)
                    .filter(|&j| out_at(j) != out_at(j - 1) && out_at(j + 1) != out_at(j))
                    .count();
            }
            assert!(skipped < 3, "{skipped} ticks too close to call");
        }
        // A linear P: both loops, with and without ringing, over 301 ticks (an odd one
        // left after the pairs), record the same toggles.
        let poly = [-4e-3, 2e3, 0.0, 0.0];
        let f = front();
        let e = (a * (-tau_s / tp).exp(), b * (-tau_s / tn).exp());
        for zk in [f.ring_at(k_s), (0.0, 0.0)] {
            let from = (k_s, tau_s, e, zk);
            let last = k_s + 300;
            let (mut lin, mut cub) = (f.clone(), f.clone());
            let (o_lin, o_cub) = if zk == (0.0, 0.0) {
                (
                    lin.walk_ticks::<false, true>(Phase::U, from, last, &poly),
                    cub.walk_ticks::<false, false>(Phase::U, from, last, &poly),
                )
            } else {
                (
                    lin.walk_ticks::<true, true>(Phase::U, from, last, &poly),
                    cub.walk_ticks::<true, false>(Phase::U, from, last, &poly),
                )
            };
            assert_eq!(o_lin, o_cub);
            assert!(!lin.hist[0].toggles.is_empty());
            assert_eq!(lin.hist[0].toggles, cub.hist[0].toggles, "ringing {zk:?}");
        }
    }
    assert!(both_in_pair > 0, "no pair with both ticks toggling");
}

/// A channel over a step without a bend (P linear) is built on its own path; it must be
/// the general path's channel with a zero bend, to the bit, signed zeros included.
#[test]
fn a_channel_without_a_bend_is_the_zero_bend_case_to_the_bit() {
    let zero = Bend::default();
    let taus = ((1.0e-6, 1.05e-6), (1.0e6, 1.0 / 1.05e-6));
    let fohs = [
        Foh::ramp(0.3, 0.1, 2e4, 1.0e-6),
        Foh::ramp(-2.0, 12.0, -3e5, 1.05e-6),
        Foh::new(0.0, 0.0, 0.0, 1e-6, 1.0e-6),
        Foh {
            a: -0.0,
            b: -0.0,
            c: -0.0,
        },
    ];
    for fx in &fohs {
        for fn_ in &fohs {
            for offset in [2e-3, 0.0, -0.0, -1.5e-3] {
                for h in [20e-9, 0.37e-6, 25e-6] {
                    let paths = |b| (fx, b, fn_);
                    let lin = Channel::new(Phase::V, 1e-3, paths(None), taus, offset, h);
                    let general = Channel::new(Phase::V, 1e-3, paths(Some(&zero)), taus, offset, h);
                    let bits = |c: &Channel| {
                        let mut v: Vec<u64> = c.poly.iter().map(|x| x.to_bits()).collect();
                        v.extend(
                            [c.beta, c.dev.0, c.dev.1, c.a, c.b, c.ap, c.bn].map(f64::to_bits),
                        );
                        v
                    };
                    assert_eq!(bits(&lin), bits(&general), "{fx:?} {fn_:?} {offset} {h}");
                }
            }
        }
    }
}

/// The bounds a scan rules ticks out by hold at every tick they cover: over spans of a
/// step with filter transients, a floating leg's bend and ringing, the range a bound
/// gives contains the noise-free signal (ringing included) evaluated tick by tick with
/// `exp` and `sin`, and a span ruled out with the noise anywhere in its range holds no
/// tick where the output could toggle.
#[test]
fn the_bounds_hold_at_every_tick_they_cover() {
    let p = ComparatorParams {
        ring_decay_s: 0.4e-6,
        ..ComparatorParams::default()
    };
    let (tp, tn, tr) = (p.phase_filter_tau_s, p.neutral_filter_tau_s, p.ring_decay_s);
    let w = TAU * p.ring_frequency_hz;
    let (half_h, noise) = (p.hysteresis_v / 2.0, p.noise_v);
    // Ringing excited at tick 90; the step from 0.4 ticks before tick 100, 30 µs long.
    let (rk, z) = (90u64, (0.05, -0.12));
    let (t0, h) = (99.6 * TICK_S, 30e-6);
    let mut f = ComparatorBank::new(&p, 3, &Abc::splat(0.0), 0.0).front;
    f.ring = Ring {
        z,
        t: tick_instant(rk),
        k: rk,
        mag: z.0.hypot(z.1),
    };
    let taus = ((tp, tn), (1.0 / tp, 1.0 / tn));
    // A floating leg's bend (a cubic from rest through the phase filter), and none.
    let q = hermite(1.0 / h, (0.0, 3e3), (0.0, -5e3));
    let bend = Bend::new(&CubicRc::new(0.0, 0.0, q, tp));
    let (mut ruled_out, mut spans) = (0, 0);
    for (fx, fn_) in [
        // A common-mode step's filter spike about a rising back-EMF.
        (
            Foh::ramp(0.2, 6.0, 2e3, tp),
            Foh::ramp(0.2, 6.0 - 4e-3, 0.0, tn),
        ),
        // Falling through the thresholds.
        (
            Foh::ramp(0.01, 0.01, -1.5e3, tp),
            Foh::ramp(0.0, 0.0, 0.0, tn),
        ),
    ] {
        for b in [None, Some(&bend)] {
            let mut c = Channel::new(Phase::U, t0, (&fx, b, &fn_), taus, 1e-3, h);
            c.k_s = 100;
            let ta = tick_instant(c.k_s) - t0;
            c.base = ((-ta / tp).exp(), (-ta / tn).exp());
            let k_end = Ticks::at_or_before(t0 + h).0;
            let s = |k: u64| {
                let tau = tick_instant(k) - t0;
                let dt = (k - rk) as f64 * TICK_S;
                horner(&c.poly, tau) + c.a * (-tau / tp).exp() - c.b * (-tau / tn).exp()
                    + (-dt / tr).exp() * (z.0 * (w * dt).sin() + z.1 * (w * dt).cos())
            };
            // Spans of 1 to 1024 ticks from ticks spread over the step.
            for (i, a) in (c.k_s..=k_end).step_by(37).enumerate() {
                for len in [1, 2, 7, 25, 64, 200, 1024] {
                    let b = (a + len - 1).min(k_end);
                    let (ta, tb, wd, env) = f.over(&c, a, b);
                    let (lo, hi) = f.range(&c, ta, tb, wd, env);
                    let tol = 1e-12 * (c.a.abs() + c.b.abs() + c.poly[0].abs() + 1.0);
                    for k in a..=b {
                        let v = s(k);
                        assert!(
                            lo - tol <= v && v <= hi + tol,
                            "tick {k} in {a}..={b}: {v} outside [{lo}, {hi}]"
                        );
                    }
                    for out in [false, true] {
                        spans += 1;
                        if !f.may_toggle_over(&c, out, a, b, -noise, noise) {
                            ruled_out += 1;
                            let crossing = (a..=b).any(|k| {
                                let v = s(k);
                                if out {
                                    v - noise < -half_h + tol
                                } else {
                                    v + noise > half_h - tol
                                }
                            });
                            assert!(!crossing, "span {a}..={b} (out {out}, {i}) ruled out");
                        }
                    }
                }
            }
        }
    }
    // Both kinds of span occur: some ruled out, some not.
    assert!(
        ruled_out > spans / 10 && ruled_out < spans,
        "{ruled_out} of {spans}"
    );
}
