//! The chip's discrete PI (docs/chip.md), with optional back-calculation anti-windup.
//!
//! Per update k, with error e(k):
//!
//! ```text
//! uc(k) = Kp·e(k) + ui(k−1) + Ki·e(k)                     (pre-saturation command)
//! ui(k) = sat(ui(k−1) + Ki·e(k) − k_s·max(uc(k) − hi, 0))  (k_s = 0 without anti-windup)
//! u(k)  = sat(uc(k))
//! ```
//!
//! sat clamps the output to [lo, hi] and the integrator to [lo, ui_hi] (its register's
//! range, ≥ hi), after the integrator and at the output as in the chip. Without
//! anti-windup the integrator runs up to its own limit while the output is saturated and
//! must be unwound by an error of the other sign; with it, any excess over the limit is
//! fed back k_s-fold, which pulls the integrator out of saturation within one update.
//!
//! The back-calculation acts on the upper limit only (the chip: "when uc exceeds the
//! limit", the chip's 4 096 000). Mirrored at the lower limit, a k_s ≫ 1 turns a large
//! negative proportional term (one high current sample) into a k_s-fold *positive* kick
//! that flings the integrator to full duty; there the integrator clamp alone suffices.
//!
//! Per update, with excess x = uc(k) − hi > 0, the rule gives
//! ui(k) = hi − Kp·e(k) − (k_s − 1)·x: k_s = 1 puts the output exactly on the limit
//! (tracking), 0 < k_s < 2 converges to it, and larger k_s lands (k_s − 1)·x *below* it.
//! The chip's k_s = 32 on the current PI thus turns every update with an excess into a
//! cut: even under a constant error the output climbs Ki·e per update to the limit, is cut
//! (k_s − 1)·x ≤ 31·Ki·e below it, and climbs again (a sawtooth). At full duty the current
//! error is one ADC sample of a commutation-rippled shunt current, and a low sample (large
//! e, large x) cuts deepest. A wound-up integrator (≈ 2× the limit, anti-windup off) keeps
//! the output at full duty through all of it, which is why with anti-windup the mean duty,
//! and so the top speed, is lower at full voltage: the cost of the chip's gain, not of
//! anti-windup as such (k_s = 1 keeps the output on the limit under a constant error).

/// Gains, limits and anti-windup of one PI.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct PiGains {
    /// Proportional gain.
    pub kp: f64,
    /// Integral gain per update.
    pub ki: f64,
    /// Lower limit of output and integrator.
    pub lo: f64,
    /// Upper limit of the output (and, with anti-windup, the back-calculation reference).
    pub hi: f64,
    /// Upper limit of the integrator: the range of its register, ≥ `hi`. Without
    /// anti-windup the integrator winds up to this while the output sits at `hi`.
    pub ui_hi: f64,
    /// Back-calculation gain k_s (0 disables anti-windup).
    pub k_s: f64,
}

/// A discrete PI controller.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Pi {
    /// Gains and limits.
    pub gains: PiGains,
    ui: f64,
    out: f64,
}

impl Pi {
    /// A PI with its integrator at `ui0` (clamped to the limits).
    pub fn new(gains: PiGains, ui0: f64) -> Self {
        Pi {
            gains,
            ui: ui0.clamp(gains.lo, gains.ui_hi.max(gains.hi)),
            out: ui0.clamp(gains.lo, gains.hi),
        }
    }

    /// One update with error `e`; returns the saturated output.
    pub fn update(&mut self, e: f64) -> f64 {
        let g = self.gains;
        let integ = self.ui + g.ki * e;
        let uc = g.kp * e + integ;
        let out = uc.clamp(g.lo, g.hi);
        let excess = (uc - g.hi).max(0.0);
        self.ui = (integ - g.k_s * excess).clamp(g.lo, g.ui_hi.max(g.hi));
        self.out = out;
        out
    }

    /// Integrator state ui.
    pub fn integrator(&self) -> f64 {
        self.ui
    }

    /// Last output.
    pub fn output(&self) -> f64 {
        self.out
    }

    /// Sets the integrator (bumpless hand-over), clamped to the limits.
    pub fn set_integrator(&mut self, ui: f64) {
        self.ui = ui.clamp(self.gains.lo, self.gains.ui_hi.max(self.gains.hi));
        self.out = self.ui.min(self.gains.hi);
    }
}

// The integrator and output; the gains are parameters.
drive_core::persist_fields!(Pi { ui, out } then Pi::check_restored);

impl Pi {
    /// Integrator and output within their clamps, as every update and set leaves them.
    fn check_restored(&self) -> Result<(), String> {
        let g = &self.gains;
        let ui_hi = g.ui_hi.max(g.hi);
        drive_core::state::check((g.lo..=ui_hi).contains(&self.ui), || {
            format!(
                "ui = {} (rule: the integrator's clamp {}..={ui_hi})",
                self.ui, g.lo
            )
        })?;
        drive_core::state::check((g.lo..=g.hi).contains(&self.out), || {
            format!(
                "out = {} (rule: the output's clamp {}..={})",
                self.out, g.lo, g.hi
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gains(k_s: f64) -> PiGains {
        PiGains {
            kp: 2.0,
            ki: 0.5,
            lo: 0.0,
            hi: 10.0,
            ui_hi: 10.0,
            k_s,
        }
    }

    #[test]
    fn a_restored_integrator_and_output_keep_their_clamps() {
        use drive_core::Persist;
        let mut pi = Pi::new(gains(0.0), 0.0);
        pi.update(3.0);
        let ok = Pi::new(gains(0.0), 0.0).restore_from(&pi.to_bytes().unwrap());
        assert_eq!(ok, Ok(()));
        for (ui, out, want) in [
            (
                1e30,
                1.0,
                "ui = 1000000000000000000000000000000 (rule: the integrator's clamp 0..=10)",
            ),
            (-1.0, 1.0, "ui = -1 (rule: the integrator's clamp 0..=10)"),
            (1.0, 10.5, "out = 10.5 (rule: the output's clamp 0..=10)"),
        ] {
            let forged = Pi { ui, out, ..pi };
            let e = Pi::new(gains(0.0), 0.0)
                .restore_from(&forged.to_bytes().unwrap())
                .unwrap_err();
            assert_eq!(e, want);
        }
    }

    #[test]
    fn difference_equation_inside_the_limits() {
        let mut pi = Pi::new(gains(0.0), 0.0);
        // e = 1, 1, −0.5: ui = 0.5, 1.0, 0.75; u = 2·e + ui.
        assert_eq!(pi.update(1.0), 2.5);
        assert_eq!(pi.update(1.0), 3.0);
        // uc = −1 + 0.75 = −0.25 is clamped at the output only.
        assert_eq!(pi.update(-0.5), 0.0);
        assert_eq!(pi.integrator(), 0.75);
    }

    #[test]
    fn output_and_integrator_saturate() {
        let mut pi = Pi::new(gains(0.0), 0.0);
        for _ in 0..100 {
            assert!(pi.update(3.0) <= 10.0);
        }
        assert_eq!(pi.output(), 10.0);
        assert_eq!(
            pi.integrator(),
            10.0,
            "no anti-windup: integrator runs to its limit"
        );
        assert_eq!(Pi::new(gains(0.0), 0.0).update(-5.0), 0.0);
    }

    #[test]
    fn anti_windup_pulls_the_integrator_out_of_saturation() {
        let g = |k_s| PiGains {
            kp: 1.0,
            ki: 1.0,
            lo: 0.0,
            hi: 10.0,
            ui_hi: 10.0,
            k_s,
        };
        // A large error saturates the output for 5 updates, then the error vanishes.
        let mut off = Pi::new(g(0.0), 0.0);
        let mut on = Pi::new(g(32.0), 0.0);
        for _ in 0..5 {
            assert_eq!(off.update(20.0), 10.0);
            assert_eq!(on.update(20.0), 10.0);
        }
        // Without anti-windup the integrator is wound to the limit and the output stays
        // saturated with zero error; with k_s = 32 the excess (≥ 30) wiped it out.
        assert_eq!(off.integrator(), 10.0);
        assert_eq!(off.update(0.0), 10.0);
        assert_eq!(on.integrator(), 0.0);
        assert_eq!(on.update(0.0), 0.0);
        // Partial correction, by hand: ui = 5, e = 3 → integ 8, uc 11, excess 1, k_s 2 → 6.
        let mut p = Pi::new(g(2.0), 5.0);
        assert_eq!(p.update(3.0), 10.0);
        assert_eq!(p.integrator(), 6.0);
    }

    #[test]
    fn anti_windup_does_not_kick_the_integrator_up_at_the_lower_limit() {
        // ui = 2, e = −3: integ = 0.5 (Ki 0.5), uc = −5.5 → output 0. Mirrored back-calculation
        // would add 32·5.5 and fling ui to the top (10); the chip's acts on the upper limit only.
        let mut p = Pi::new(gains(32.0), 2.0);
        assert_eq!(p.update(-3.0), 0.0);
        assert_eq!(p.integrator(), 0.5);
    }

    #[test]
    fn back_calculation_lands_k_s_minus_one_excesses_below_the_tracking_point() {
        let g = |k_s| PiGains {
            ui_hi: 20.0,
            ..gains(k_s)
        };
        // ui = 9, e = 0.5: integ 9.25, uc 10.25, x = 0.25. Tracking point hi − Kp·e = 9.
        let mut one = Pi::new(g(1.0), 9.0);
        assert_eq!(one.update(0.5), 10.0);
        assert_eq!(one.integrator(), 9.0, "k_s = 1: exactly hi − Kp·e");
        let mut chip = Pi::new(g(32.0), 9.0);
        assert_eq!(chip.update(0.5), 10.0);
        // 9.25 − 32·0.25 = 1.25 = 9 − 31·0.25.
        assert_eq!(chip.integrator(), 1.25, "k_s = 32: 31 excesses below it");
        // The same error again: the output has fallen from the limit to 1.25 + 0.25 + 1.
        assert_eq!(chip.update(0.5), 2.5);
        assert_eq!(one.update(0.5), 10.0);
    }

    #[test]
    fn one_large_error_sample_cuts_a_tracking_output_but_not_a_wound_up_one() {
        // Saturated with e = 0.5 (kp 2, ki 0.5, hi 10), then one sample of e = 1.5 (a low
        // current reading), then e = 0.5 again: the output right after the spike.
        let run = |k_s: f64| {
            let mut p = Pi::new(
                PiGains {
                    ui_hi: 20.5,
                    ..gains(k_s)
                },
                0.0,
            );
            for _ in 0..200 {
                p.update(0.5);
            }
            let settled = p.integrator();
            p.update(1.5);
            (settled, p.update(0.5))
        };
        // Off: the integrator winds to its register's 20.5 and the output never leaves 10.
        assert_eq!(run(0.0), (20.5, 10.0));
        // k_s = 1: settled at hi − Kp·e = 9; the spike sets it to 10 − 2·1.5 = 7, so the
        // next output is 7 + 0.25 + 1 = 8.25.
        assert_eq!(run(1.0), (9.0, 8.25));
    }

    #[test]
    fn the_chips_k_s_turns_a_constant_saturating_error_into_a_sawtooth() {
        // k_s = 32, e = 0.5 throughout (kp 2, ki 0.5, hi 10), from ui = 0. Below the limit
        // ui climbs 0.25 per update; uc = ui + 1.25 first exceeds 10 from ui = 9 (x = 0.25),
        // which sets ui = 9.25 − 8 = 1.25. From there the outputs are 2.5, 2.75, …, 10.0
        // (31 updates) and 10 at the next excess, which sets ui = 1.25 again: period 32,
        // mean (31·2.5 + 0.25·465 + 10)/32 = 203.75/32 = 6.367 where k_s = 1 holds 10.
        let mut chip = Pi::new(gains(32.0), 0.0);
        let mut one = Pi::new(gains(1.0), 0.0);
        for _ in 0..37 {
            chip.update(0.5);
            one.update(0.5);
        }
        assert_eq!(chip.integrator(), 1.25, "first cut");
        let (mut sum, mut cuts) = (0.0, 0);
        for _ in 0..32 * 10 {
            sum += chip.update(0.5);
            assert_eq!(one.update(0.5), 10.0);
            if chip.integrator() == 1.25 {
                cuts += 1;
            }
        }
        assert_eq!(cuts, 10, "one cut every 32 updates");
        assert!(
            (sum / 320.0 - 203.75 / 32.0).abs() < 1e-9,
            "{}",
            sum / 320.0
        );
    }

    #[test]
    fn at_a_limit_without_headroom_the_clamp_still_holds_the_output_saturated() {
        // The speed PI: integrator clamped at the output limit (ui_hi = hi = 10).
        let mut clamp = Pi::new(gains(0.0), 0.0);
        let mut track = Pi::new(gains(1.0), 0.0);
        for _ in 0..100 {
            clamp.update(3.0);
            track.update(3.0);
        }
        // Clamp: ui = 10. Tracking: ui = hi − Kp·e = 10 − 6 = 4.
        assert_eq!((clamp.integrator(), track.integrator()), (10.0, 4.0));
        // The error shrinks to 1 (the speed approaches the command): clamped, uc = 2 + 10.5
        // stays above the limit; tracking, uc = 2 + 4.5 = 6.5 leaves it at once.
        assert_eq!(clamp.update(1.0), 10.0);
        assert_eq!(track.update(1.0), 6.5);
        // Past the command (e = −1) the clamped one still pushes 10 − 2 − 0.5 = 7.5.
        assert_eq!(clamp.update(-1.0), 7.5);
        assert_eq!(track.update(-1.0), 2.0);
    }

    #[test]
    fn a_wider_integrator_register_winds_up_past_the_output_limit() {
        let g = |k_s| PiGains {
            ui_hi: 20.0,
            ..gains(k_s)
        };
        let mut off = Pi::new(g(0.0), 0.0);
        let mut on = Pi::new(g(32.0), 0.0);
        for _ in 0..100 {
            off.update(3.0);
            on.update(3.0);
        }
        // Without anti-windup: wound to the register's 20 while the output shows 10; it
        // takes (20 − 10)/(0.5·1) = 20 updates of e = −1 before the output leaves the limit.
        assert_eq!((off.output(), off.integrator()), (10.0, 20.0));
        assert_eq!(off.update(-1.0), 10.0);
        // With it: uc − hi is fed back, the integrator stays below hi − Kp·e.
        assert!(
            on.integrator() <= 10.0 - 2.0 * 3.0 + 1e-9,
            "{}",
            on.integrator()
        );
        assert!(on.update(-1.0) < 10.0);
    }
}
