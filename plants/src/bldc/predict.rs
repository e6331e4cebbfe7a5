//! Diode events predicted before a step: a freewheeling current whose tangent reaches zero
//! within the step is located on the step's modal response (Newton's method), and the step
//! is integrated to that zero alone rather than past it.

use super::integrate::StepResponse;
use super::{BldcPlant, State};
use crate::circuit::Conduction;
use crate::emf;
use crate::modal::{Modal, Response};
use drive_core::Phase;

impl BldcPlant {
    /// The freewheeling phase whose diode event may end the step of `h` from `x0`
    /// (derivative `f0`): only the phase whose current's tangent reaches zero first within
    /// the step is tried (a freewheeling current's fall slows as its resistive drop fades,
    /// so the tangent reaches zero first); an event the prediction misses is found after
    /// the step as before.
    #[inline(always)]
    pub(super) fn diode_candidate(&self, x0: &State, f0: &State, h: f64) -> Option<Phase> {
        let mut first: Option<(f64, Phase)> = None;
        for p in Phase::ALL {
            let k = p.index();
            let sign = match self.modes.get(p) {
                Conduction::DiodeLow => 1.0,
                Conduction::DiodeHigh => -1.0,
                _ => continue,
            };
            // The current, conducting (y0 > 0), and its slope g0 \[A, A/s\]: y0 < −g0·h
            // also means g0 < 0.
            let (y0, g0) = (sign * x0[k], sign * f0[k]);
            if !self.muted[k] && y0 > 0.0 && y0 < -g0 * h {
                let t = y0 / -g0;
                if first.is_none_or(|(t1, _)| t < t1) {
                    first = Some((t, p));
                }
            }
        }
        first.map(|(_, p)| p)
    }

    /// Where freewheeling phase `p`'s current (`i0` \[A\] at the start) reaches zero on
    /// the step's response `b` within the step of `h` \[s\]: a diode event predicted before
    /// the step is integrated, so that it is not integrated past it. `None` where that
    /// zero or the iteration leaves the step.
    /// Out of line: inlined into the step loop it measured worse.
    #[inline(never)]
    pub(super) fn diode_zero(b: &StepResponse, i0: f64, p: Phase, h: f64) -> Option<f64> {
        Self::newton_zero(b.md, &b.rsp, i0, p.index(), b.sc0, b.omega_e, h)
    }

    /// The zero of phase `k`'s current on `rsp` (starting at `i0` \[A\], sin θ and cos θ
    /// `sc0`, the forcing's Ω `omega_e` [rad/s]) within a step of `h` \[s\], by Newton's
    /// method from the zero of its quadratic Taylor polynomial at the start.
    #[inline(always)]
    fn newton_zero(
        md: &Modal,
        rsp: &Response,
        i0: f64,
        k: usize,
        sc0: (f64, f64),
        omega_e: f64,
        h: f64,
    ) -> Option<f64> {
        // The zero of i0 + g·t + a·t²/2, the nearer root in its stable form.
        let (g, a) = rsp.start_rates(k, sc0, omega_e);
        let disc = g * g - 2.0 * a * i0;
        let mut t = 2.0 * i0 / (-g + g.signum() * -disc.sqrt());
        let mut last = (0.0, g);
        for _ in 0..8 {
            if !(0.0..=h).contains(&t) {
                return None; // beyond the step (or NaN): the step as usual
            }
            let (rs, rc) = emf::rotation(omega_e * t);
            let sc = (sc0.0 * rc + sc0.1 * rs, sc0.1 * rc - sc0.0 * rs);
            let (i, di) = rsp.current_and_rate(k, t, sc, omega_e, md.decays(t));
            // The curvature [A/s²]: the mean since the last iterate, at least the start's.
            // By the start's alone, a current that dips towards zero where it bends harder
            // and turns back unreversed could pass for a zero. (f64::max drops the NaN of
            // t = last.0; an infinite one stops nothing, and the search gives up.)
            let curv = a.abs().max(((di - last.1) / (t - last.0)).abs());
            last = (t, di);
            let dt = i / di;
            t -= dt;
            // Newton's error after this correction, ≈ curv·dt²/2 in current \[A\]: far
            // below the 1e-9 A the step's end must meet.
            if 0.5 * curv * dt * dt < 1e-12 {
                return (0.0..=h).contains(&t).then_some(t);
            }
        }
        None
    }
}
