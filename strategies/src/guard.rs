//! Zero-crossing guards (docs/chip.md): what protects the crossing detection from PWM edges.
//!
//! - `raw`: the comparator output is used as is.
//! - `nd`: a linear region of θZC = `linear_region_deg` before each expected crossing, in
//!   which PWM stops (duty 1) so the comparator sees no switching edges; PWM resumes at the
//!   detected crossing. Detection itself stays on everywhere: a crossing that comes before
//!   the window (accelerating rotor, LM's narrow window at low speed) is taken under PWM.
//! - `lm`: the same window, shrunk with the measured speed ω (whole degrees, as the chip):
//!   θZC = 1° + (θmax − 1°)·(ω − ωm)/(ωM − ωm), clamped to [1°, θmax]. With
//!   `lm_window_capped` (default) the region also ends θZC after it began, so a region
//!   opened early (after a crossing taken early under PWM) cannot stretch to several θZC.
//! - `df`: PWM never stops; Z_d goes through the [`DigitalFilter`] first.
//!
//! A guard is independent of the commutation table, so any guard combines with six-step or
//! twelve-step.

use crate::filter::DigitalFilter;
use crate::params::{GuardKind, StrategyParams};
use drive_core::{Ticks, clocks};

/// A zero-crossing guard with its parameters and (for `df`) its filter state.
#[derive(Clone, Debug)]
pub struct Guard {
    /// Which guard.
    pub kind: GuardKind,
    /// θmax [whole degrees].
    pub window_deg: u32,
    /// ωm \[rpm\].
    pub lm_min_rpm: u32,
    /// ωM \[rpm\].
    pub lm_max_rpm: u32,
    /// The digital filter (clocked only by `df`).
    pub filter: DigitalFilter,
    /// Whether the linear region ends θZC after its start instead of at the crossing.
    pub capped: bool,
}

impl Guard {
    /// The guard a validated strategy config asks for.
    pub fn from_params(p: &StrategyParams) -> Self {
        Guard {
            kind: p.guard_kind(),
            window_deg: p.linear_region_deg,
            lm_min_rpm: p.lm_speed_min_rpm,
            lm_max_rpm: p.lm_speed_max_rpm,
            filter: DigitalFilter::new(p.filter_samples, clocks::COMMUTATION),
            capped: p.lm_window_capped && p.guard_kind() == GuardKind::Lm,
        }
    }

    /// The linear-region window θZC at measured speed `rpm` [whole degrees], or `None` for
    /// the guards without one.
    pub fn linear_window_deg(&self, rpm: u32) -> Option<u32> {
        match self.kind {
            GuardKind::Nd => Some(self.window_deg),
            GuardKind::Lm => Some(lm_window_deg(
                self.window_deg,
                self.lm_min_rpm,
                self.lm_max_rpm,
                rpm,
            )),
            GuardKind::Raw | GuardKind::Df => None,
        }
    }

    /// Passes the comparator level `z` sampled at clock edge `now` through the guard's
    /// signal path: the filter for `df`, unchanged otherwise.
    pub fn detect_level(&mut self, now: Ticks, z: bool) -> bool {
        match self.kind {
            GuardKind::Df => self.filter.clock_at(now, z),
            _ => z,
        }
    }
}

/// The LM window in whole degrees: 1 + (θmax − 1)·(ω − ωm)/(ωM − ωm) by integer division,
/// clamped to [1, θmax].
pub fn lm_window_deg(theta_max: u32, min_rpm: u32, max_rpm: u32, rpm: u32) -> u32 {
    if rpm <= min_rpm {
        return 1;
    }
    if rpm >= max_rpm {
        return theta_max;
    }
    let span = u64::from(max_rpm - min_rpm).max(1);
    let k = u64::from(theta_max.saturating_sub(1)) * u64::from(rpm - min_rpm) / span;
    (1 + k as u32).clamp(1, theta_max)
}

/// The chip's conversion of a window to counter ticks: t_low = t_60·θZC/60 (integer).
pub fn window_counts(t60_counts: u64, deg: u32) -> u64 {
    t60_counts * u64::from(deg) / 60
}

// The digital filter; the guard's kind and window are parameters.
drive_core::persist_fields!(Guard { filter });

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lm_window_follows_the_spec_equation_in_whole_degrees() {
        // ωm = 1000, ωM = 8000, θmax = 15: θ = 1 + 14·(ω − 1000)/7000.
        let w = |rpm| lm_window_deg(15, 1000, 8000, rpm);
        assert_eq!(w(0), 1);
        assert_eq!(w(1000), 1);
        assert_eq!(w(8000), 15);
        assert_eq!(w(12000), 15);
        assert_eq!(w(4500), 8); // 1 + 14·3500/7000 = 8 exactly
        assert_eq!(w(1499), 1); // 1 + 0.9986 → 1
        assert_eq!(w(1500), 2); // 1 + 1.0
        for rpm in (0..10_000).step_by(37) {
            let exact = 1.0 + 14.0 * (rpm as f64 - 1000.0) / 7000.0;
            let want = exact.clamp(1.0, 15.0).floor() as u32;
            assert_eq!(w(rpm), want, "rpm {rpm}");
        }
    }

    #[test]
    fn window_conversion_is_t60_times_theta_over_60() {
        assert_eq!(window_counts(6000, 15), 1500);
        assert_eq!(window_counts(6001, 15), 1500);
        assert_eq!(window_counts(59, 1), 0);
    }
}
