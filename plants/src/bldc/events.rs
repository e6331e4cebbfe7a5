//! Diode events found after a step and located in time (Illinois regula falsi on the
//! step's solution, to 0.1 ns): a freewheeling diode's current reaching zero (the current
//! is then set to exactly zero and the phase floats), and an open terminal reaching a diode
//! clamp (the diode starts conducting). A freewheeling current that crosses zero and turns
//! back inside the step is found on the step's cubic Hermite interpolant.

use super::{BldcPlant, State, dynamic};
use crate::circuit::{Conduction, Solution};
use drive_core::{Phase, PlantStop};

/// A freewheeling current this close to zero \[A\] at the dense output's guess of its zero
/// is taken there by one Newton step along the state's derivative, x + f·dh, rather than a
/// new step from the start, where that errs by less than [`SHORTCUT_ERR_A`].
const NEAR_ZERO_A: f64 = 1e-6;

/// The most the one-step shortcut to a current's zero may err, ½·dh²·|d²i/dt²| \[A\]:
/// three orders below the 1e-9 A the search accepts.
const SHORTCUT_ERR_A: f64 = 1e-12;

/// Cubic Hermite interpolation of one step (states and derivatives at both ends), used
/// to find where a freewheeling current crosses zero. It borrows the step's states: a
/// copy of four states per step costs more than the search usually does. Of the end's
/// derivative it takes the currents' alone (the network's di/dt there), which is all the
/// search interpolates.
struct Dense<'a> {
    x0: &'a State,
    f0: &'a State,
    x1: &'a State,
    di1: [f64; 3],
    h: f64,
}

impl Dense<'_> {
    /// Current `k` (0..3) of the interpolated state at fraction `s` ∈ [0, 1] of the step.
    fn component(&self, k: usize, s: f64) -> f64 {
        let (s2, s3) = (s * s, s * s * s);
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = (s3 - 2.0 * s2 + s) * self.h;
        let h01 = 3.0 * s2 - 2.0 * s3;
        let h11 = (s3 - s2) * self.h;
        self.x0[k] * h00 + self.f0[k] * h10 + self.x1[k] * h01 + self.di1[k] * h11
    }
}

impl BldcPlant {
    /// The first diode event found after the step of `h` from `x0` (derivative `f0`, angle
    /// base `b0`) to `x1` (network `s1`): its step length, phase, and the state there when
    /// already known. A `predicted` phase's event is the step's end already; others may
    /// come first.
    pub(super) fn event_after(
        &mut self,
        (x0, f0): (&State, &State),
        (x1, s1): (&State, &Solution),
        h: f64,
        b0: (f64, f64, f64),
        predicted: Option<Phase>,
    ) -> Option<(f64, Phase, Option<State>)> {
        let step = Dense {
            x0,
            f0,
            x1,
            di1: s1.di.to_array(),
            h,
        };
        let muted = self.muted;
        if let Some(p) = predicted {
            self.muted[p.index()] = true;
        }
        let found = self.first_event(&step, s1, b0);
        self.muted = muted;
        found
    }

    /// Applies phase `p`'s event at the end of the step just committed (`instant`: a step
    /// of zero length) and re-resolves the conduction state.
    pub(super) fn apply_event(&mut self, p: Phase, instant: bool) -> PlantStop {
        if self.modes.get(p).is_diode() {
            // The diode current reached zero: exactly zero, sum kept at zero.
            let k = p.index();
            let residual = self.x[k];
            self.x[k] = 0.0;
            let others = Phase::ALL
                .iter()
                .filter(|&&q| q != p && self.modes.get(q).conducts())
                .count();
            if others == 1 {
                // Two-phase conduction: the other current is minus this one, zero too.
                for q in Phase::ALL
                    .into_iter()
                    .filter(|&q| q != p && self.modes.get(q).conducts())
                {
                    self.x[q.index()] = 0.0;
                }
            } else if let Some(q) = Phase::ALL
                .into_iter()
                .filter(|&q| q != p && self.modes.get(q).conducts())
                .max_by(|a, b| self.x[a.index()].abs().total_cmp(&self.x[b.index()].abs()))
            {
                self.x[q.index()] += residual;
            }
        }
        self.same_instant_events = if instant {
            // Saturating: only its reaching 4 matters (a restored count may be any).
            self.same_instant_events.saturating_add(1)
        } else {
            0
        };
        if self.same_instant_events >= 4 {
            // Zero-length events repeating at one instant: this phase's event is ignored
            // for the next step, while every other phase is still watched.
            self.muted[p.index()] = true;
        }
        let was_open = self.modes.get(p) == Conduction::Open;
        // A diode that had just been switched on at zero current and whose current would
        // reverse at once never conducted: it stays open now instead of chattering.
        let never_conducted = !was_open && instant;
        self.refresh_start_at(was_open.then_some(p), never_conducted.then_some(p));
        self.stats.diode_events += 1;
        PlantStop::Diode
    }

    /// Per-phase event functions: ≥ 0 while nothing happens, < 0 once a diode current has
    /// crossed zero or an open terminal has left the clamps.
    fn event_margin(&self, x: &State, s: &Solution, p: Phase) -> f64 {
        match self.modes.get(p) {
            Conduction::DiodeLow => x[p.index()],
            Conduction::DiodeHigh => -x[p.index()],
            Conduction::Open => self.circuit.clamp_margin(s.v_term.get(p), s.i_shunt),
            _ => f64::INFINITY,
        }
    }

    /// The phases whose event function went negative over the step from `x0` to `x`. An
    /// open terminal already outside the clamps at the start (the network refused the
    /// diode) is not an event.
    fn triggered(&self, x0: &State, x: &State, s: &Solution) -> [bool; 3] {
        Phase::ALL.map(|p| {
            self.event_margin(x, s, p) < 0.0
                && (self.modes.get(p) != Conduction::Open
                    || self.event_margin(x0, &self.start, p) >= 0.0)
        })
    }

    /// Where a freewheeling diode's current crosses zero inside a step, from the step's
    /// cubic Hermite dense output (fourth-order accurate, like the step itself). Returns the
    /// fraction of the step.
    fn locate_diode(&self, d: &Dense, p: Phase) -> f64 {
        let k = p.index();
        let sign = if self.modes.get(p) == Conduction::DiodeLow {
            1.0
        } else {
            -1.0
        };
        let g = |s: f64| sign * d.component(k, s);
        let (mut a, mut b) = (0.0, 1.0);
        if g(0.0) < 0.0 {
            return 0.0;
        }
        if g(0.0) == 0.0 {
            // Switched on at zero current: the pulse may rise and end inside the step.
            match (1..=32).map(|k| k as f64 / 32.0).find(|&s| g(s) > 0.0) {
                Some(s) => a = s,
                None => return 0.0,
            }
        }
        // Regula falsi with the Illinois weighting: superlinear on the smooth cubic, and
        // the bracket keeps the answer on the side where the current has crossed.
        let (mut ga, mut gb) = (g(a), g(b));
        let mut side = 0i8;
        for _ in 0..60 {
            if b - a < 1e-14 || gb >= 0.0 {
                break;
            }
            let m = (a - ga * (b - a) / (gb - ga)).clamp(a, b);
            let gm = g(m);
            if gm > 0.0 {
                (a, ga) = (m, gm);
                if side == 1 {
                    gb *= 0.5;
                }
                side = 1;
            } else {
                (b, gb) = (m, gm);
                if gm == 0.0 {
                    break;
                }
                if side == -1 {
                    ga *= 0.5;
                }
                side = -1;
            }
        }
        b
    }

    /// Earliest h in (0, h_full] where phase p's event function reaches zero, for the
    /// step from `x0` (angle base `base`) whose derivative there is `k1`.
    fn locate(
        &mut self,
        x0: &State,
        k1: State,
        h_full: f64,
        p: Phase,
        base: (f64, f64, f64),
    ) -> f64 {
        let g = |pl: &Self, h: f64| {
            let x = pl.integrate_from(x0, h, base, &k1);
            let s = pl.solve_near(&x, base);
            pl.event_margin(&x, &s, p)
        };
        let (mut a, mut fa) = (0.0, self.event_margin(x0, &self.start, p));
        let (mut b, mut fb) = (h_full, g(self, h_full));
        if fa < 0.0 {
            return 0.0;
        }
        if fa == 0.0 {
            // Starting exactly on the boundary: find where the step first moves inside.
            match (1..8)
                .map(|k| k as f64 * h_full / 8.0)
                .map(|h| (h, g(self, h)))
                .find(|&(_, v)| v > 0.0)
            {
                Some((h, v)) => (a, fa) = (h, v),
                None => return 0.0,
            }
        }
        let mut side = 0i8;
        for _ in 0..60 {
            if b - a < 1e-10 {
                break;
            }
            let c = (b - fb * (b - a) / (fb - fa)).clamp(a + 0.01 * (b - a), b - 0.01 * (b - a));
            let fc = g(self, c);
            self.stats.retries += 1;
            if fc <= 0.0 {
                (b, fb) = (c, fc);
                if fc > -1e-12 {
                    break; // close enough: the state is snapped exactly at the event anyway
                }
                if side == -1 {
                    fa *= 0.5;
                }
                side = -1;
            } else {
                (a, fa) = (c, fc);
                if side == 1 {
                    fb *= 0.5;
                }
                side = 1;
            }
        }
        b
    }

    /// The earliest event of the step `d` (network `s1` at its end, angle base `b0`): its
    /// step length, phase, and the state there when already known. Besides event
    /// functions negative at the end, a freewheeling current that crosses zero and turns
    /// back inside the step is found from the step's cubic Hermite interpolant.
    fn first_event(
        &mut self,
        d: &Dense,
        s1: &Solution,
        b0: (f64, f64, f64),
    ) -> Option<(f64, Phase, Option<State>)> {
        let (x0, x1, h_full) = (d.x0, d.x1, d.h);
        let mut hit = self.triggered(x0, x1, s1);
        for (h, m) in hit.iter_mut().zip(self.muted) {
            *h &= !m;
        }
        let diode_left = Phase::ALL
            .into_iter()
            .any(|p| self.modes.get(p).is_diode() && !hit[p.index()] && !self.muted[p.index()]);
        if !hit.contains(&true) && !diode_left {
            return None;
        }
        // Freewheeling currents that cross zero inside the step but not at its end: the
        // step up to where the interpolant is most negative brackets the crossing.
        let mut bracket = [h_full; 3];
        for p in Phase::ALL {
            let k = p.index();
            if hit[k] || self.muted[k] || !self.modes.get(p).is_diode() {
                continue;
            }
            if let Some(s) = self.interior_reversal(d, p) {
                let h = s * h_full;
                let x = self.integrate_from(x0, h, b0, d.f0);
                if self.event_margin(&x, &self.start, p) < 0.0 {
                    hit[k] = true;
                    bracket[k] = h;
                }
            }
        }
        // Locate every event of the step and keep the earliest.
        let mut first: Option<(f64, Phase, Option<State>)> = None;
        for p in Phase::ALL.into_iter().filter(|p| hit[p.index()]) {
            let k = p.index();
            let mut at = None;
            let h = if self.modes.get(p).is_diode() && bracket[k] == h_full {
                // The dense output's root is usually exact enough; where the current
                // approaches zero slowly it is not, and the step's solution decides.
                let mut h = self.locate_diode(d, p) * h_full;
                let mut done = false;
                for _ in 0..3 {
                    // Newton on the step's solution itself, from the dense guess.
                    let x = self.integrate_from(x0, h, b0, d.f0);
                    if x[k].abs() < 1e-9 {
                        done = true;
                        at = Some(x);
                        break;
                    }
                    let f = self.deriv(&dynamic(&x), b0);
                    if f[k] == 0.0 {
                        break;
                    }
                    let dh = -x[k] / f[k];
                    // The first-order state's error, ½·dh²·|d²i/dt²|, with the current's
                    // curvature taken from its slopes at the step's start and here, h apart
                    // (h = 0 gives no finite estimate, and the loop goes on).
                    let curl = 0.5 * dh * dh * (f[k] - d.f0[k]).abs() / h;
                    if x[k].abs() < NEAR_ZERO_A
                        && curl < SHORTCUT_ERR_A
                        && (0.0..=h_full).contains(&(h + dh))
                    {
                        // So close that the state there is x + f·dh: no second step from x0.
                        done = true;
                        at = Some(x + f * dh);
                        h += dh;
                        break;
                    }
                    h = (h + dh).clamp(0.0, h_full);
                }
                if done {
                    h
                } else {
                    self.locate(x0, *d.f0, h_full, p, b0)
                }
            } else {
                self.locate(x0, *d.f0, bracket[k], p, b0)
            };
            if first.is_none_or(|(h0, _, _)| h < h0) {
                first = Some((h, p, at));
            }
        }
        first
    }

    /// Where the interpolated current of freewheeling phase `p` is most reversed inside
    /// the step (fraction of the step), if it reverses there while both ends conduct.
    fn interior_reversal(&self, d: &Dense, p: Phase) -> Option<f64> {
        let k = p.index();
        let sign = if self.modes.get(p) == Conduction::DiodeLow {
            1.0
        } else {
            -1.0
        };
        let (y0, y1) = (sign * d.x0[k], sign * d.x1[k]);
        if y0 <= 0.0 || y1 < 0.0 {
            return None;
        }
        let (g0, g1) = (sign * d.f0[k] * d.h, sign * d.di1[k] * d.h);
        // d/ds of the Hermite cubic: a·s² + b·s + c.
        let a = 6.0 * (y0 - y1) + 3.0 * (g0 + g1);
        let b = 6.0 * (y1 - y0) - 4.0 * g0 - 2.0 * g1;
        let c = g0;
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        let roots = [
            if q != 0.0 { c / q } else { -1.0 },
            if a != 0.0 { q / a } else { -1.0 },
        ];
        roots
            .into_iter()
            .filter(|s| *s > 0.0 && *s < 1.0)
            .map(|s| (s, sign * d.component(k, s)))
            .filter(|(_, v)| *v < 0.0)
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .map(|(s, _)| s)
    }
}
