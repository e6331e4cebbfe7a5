//! PWM: the chip's up-down carrier and the schemes that turn a pattern + duty into gates.

use crate::bridge::{Gates, LegState, Pattern};
use crate::error::ParamError;
use crate::time::Ticks;
use serde::{Deserialize, Serialize};

/// A voltage command in carrier counts: duty = `cv / top` (the chip's duty = cv/2000).
pub type DutyCounts = u32;

/// Symmetric triangle carrier counting 0 → `top` → 0, one count per master tick.
///
/// Period = 2·`top` ticks (default 4000 ticks = 80 µs = 12.5 kHz). The output is on while the
/// continuous carrier is below `cv`: an on-interval of 2·cv ticks centred on each valley,
/// so the duty is exactly `cv/top` and every edge falls on a whole tick.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Carrier {
    /// Peak count of the carrier \[counts\]; default 2000; rule: 1 ≤ top ≤ 1 000 000.
    pub top: u32,
}

impl Default for Carrier {
    fn default() -> Self {
        Carrier { top: 2000 }
    }
}

impl Carrier {
    /// Checks the parameter rules.
    pub fn validate(&self) -> Result<(), ParamError> {
        if !(1..=1_000_000).contains(&self.top) {
            return Err(ParamError::new(
                "pwm.top",
                self.top as f64,
                "must be 1 ..= 1000000 counts",
            ));
        }
        Ok(())
    }

    /// Carrier period in ticks.
    pub fn period(&self) -> Ticks {
        Ticks(2 * self.top as u64)
    }

    /// PWM frequency in hertz.
    pub fn frequency_hz(&self) -> f64 {
        1.0 / self.period().seconds()
    }

    /// Whether the PWM output is on during the tick starting at `t`.
    pub fn is_on(&self, t: Ticks, cv: DutyCounts) -> bool {
        self.on_and_next_edge(t, cv).0
    }

    /// The first instant `> t` at which the output changes, or `None` at 0 % and 100 %.
    pub fn next_edge(&self, t: Ticks, cv: DutyCounts) -> Option<Ticks> {
        self.on_and_next_edge(t, cv).1
    }

    /// [`Carrier::is_on`] and [`Carrier::next_edge`] from one carrier phase: the engine
    /// asks both at every PWM edge and controller tick.
    pub fn on_and_next_edge(&self, t: Ticks, cv: DutyCounts) -> (bool, Option<Ticks>) {
        let cv = cv.min(self.top) as u64;
        let n = self.period().0;
        let p = t.0 % n;
        let on = p < cv || p >= n - cv;
        if cv == 0 || cv == self.top as u64 {
            return (on, None);
        }
        let base = t.0 - p;
        let next = if p < cv {
            base + cv
        } else if p < n - cv {
            base + n - cv
        } else {
            base + n + cv
        };
        (on, Some(Ticks(next)))
    }
}

/// Which switches chop: turns a commutation pattern and the carrier comparison into gates.
///
/// Implementations never add dead time; the gate driver does that.
pub trait PwmScheme {
    /// Gates for `pattern` while the PWM output is `on` (true) or off (false). A function
    /// of these two alone: the engine asks once per pattern and keeps both answers.
    fn gates(&self, pattern: &Pattern, on: bool) -> Gates;
}

/// The chip's scheme: high-side switches chop, low-side switches stay on.
#[derive(Copy, Clone, Debug, Default)]
pub struct HighSideChop;

impl PwmScheme for HighSideChop {
    fn gates(&self, pattern: &Pattern, on: bool) -> Gates {
        Gates {
            high: pattern.map(|s| s == LegState::High && on),
            low: pattern.map(|s| s == LegState::Low),
        }
    }
}

/// Low-side switches chop, high-side switches stay on.
#[derive(Copy, Clone, Debug, Default)]
pub struct LowSideChop;

impl PwmScheme for LowSideChop {
    fn gates(&self, pattern: &Pattern, on: bool) -> Gates {
        Gates {
            high: pattern.map(|s| s == LegState::High),
            low: pattern.map(|s| s == LegState::Low && on),
        }
    }
}

/// Complementary (synchronous) chopping: a "V" leg alternates high-side / low-side switch,
/// so freewheeling current flows through a switch instead of a diode (needs dead time).
#[derive(Copy, Clone, Debug, Default)]
pub struct Complementary;

impl PwmScheme for Complementary {
    fn gates(&self, pattern: &Pattern, on: bool) -> Gates {
        Gates {
            high: pattern.map(|s| s == LegState::High && on),
            low: pattern.map(|s| s == LegState::Low || (s == LegState::High && !on)),
        }
    }
}

/// Lone-switch chopping: the switch alone on its side chops. In a three-phase state with
/// two legs high that is the low switch, in every other state the high switch(es), as the
/// chip does. Why: under [`HighSideChop`] the two high legs both chop, and in an off-time
/// each current freewheels through a diode, which stops at zero: the leg just switched
/// on, carrying little current, is cut off where in the mirror state (two legs low, their
/// switches on throughout) it is not, so alternate three-phase states give unequal
/// torques. Chopping the lone switch makes every state the mirror image of its opposite,
/// keeps the single-switch off-time (one diode freewheels, the shunt reads the on-time
/// current only) and leaves the two-phase states, where the crossings are sensed, as the
/// chip chops them.
#[derive(Copy, Clone, Debug, Default)]
pub struct LoneSwitchChop;

impl PwmScheme for LoneSwitchChop {
    fn gates(&self, pattern: &Pattern, on: bool) -> Gates {
        let highs = pattern
            .to_array()
            .iter()
            .filter(|&&s| s == LegState::High)
            .count();
        if highs == 2 {
            LowSideChop.gates(pattern, on)
        } else {
            HighSideChop.gates(pattern, on)
        }
    }
}

/// The built-in schemes by name, for configs and front ends (`[power_stage] pwm_scheme`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PwmSchemeKind {
    /// [`HighSideChop`], the chip's.
    #[default]
    HighSideChop,
    /// [`LowSideChop`].
    LowSideChop,
    /// [`Complementary`]; needs a dead time to be safe.
    Complementary,
    /// [`LoneSwitchChop`].
    LoneSwitchChop,
}

impl PwmSchemeKind {
    /// Every built-in scheme, in a fixed order.
    pub const ALL: [PwmSchemeKind; 4] = [
        PwmSchemeKind::HighSideChop,
        PwmSchemeKind::LowSideChop,
        PwmSchemeKind::Complementary,
        PwmSchemeKind::LoneSwitchChop,
    ];

    /// The config name (`high-side-chop`, `low-side-chop`, `complementary`,
    /// `lone-switch-chop`).
    pub fn name(self) -> &'static str {
        match self {
            PwmSchemeKind::HighSideChop => "high-side-chop",
            PwmSchemeKind::LowSideChop => "low-side-chop",
            PwmSchemeKind::Complementary => "complementary",
            PwmSchemeKind::LoneSwitchChop => "lone-switch-chop",
        }
    }
}

impl PwmScheme for PwmSchemeKind {
    fn gates(&self, pattern: &Pattern, on: bool) -> Gates {
        match self {
            PwmSchemeKind::HighSideChop => HighSideChop.gates(pattern, on),
            PwmSchemeKind::LowSideChop => LowSideChop.gates(pattern, on),
            PwmSchemeKind::Complementary => Complementary.gates(pattern, on),
            PwmSchemeKind::LoneSwitchChop => LoneSwitchChop.gates(pattern, on),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::abc::Abc;

    #[test]
    fn duty_is_cv_over_top_exactly() {
        let c = Carrier::default();
        assert!((c.frequency_hz() - 12_500.0).abs() < 1e-6);
        for cv in [0u32, 1, 500, 1000, 1999, 2000] {
            let on = (0..c.period().0).filter(|&t| c.is_on(Ticks(t), cv)).count();
            assert_eq!(on as u64, 2 * cv as u64, "cv = {cv}");
        }
    }

    #[test]
    fn next_edge_finds_every_change() {
        let c = Carrier { top: 50 };
        for cv in [1u32, 7, 25, 49] {
            let mut t = Ticks(0);
            let mut edges = 0;
            while t.0 < 3 * c.period().0 {
                let e = c.next_edge(t, cv).unwrap();
                for k in t.0..e.0 {
                    assert_eq!(c.is_on(Ticks(k), cv), c.is_on(t, cv), "cv={cv} k={k}");
                }
                assert_ne!(c.is_on(e, cv), c.is_on(Ticks(e.0 - 1), cv));
                t = e;
                edges += 1;
            }
            assert_eq!(edges, 7); // two per period, plus the one after the last period starts
        }
        assert_eq!(c.next_edge(Ticks(3), 0), None);
        assert_eq!(c.next_edge(Ticks(3), 50), None);
    }

    #[test]
    fn schemes_chop_the_right_switch() {
        let p = Abc {
            u: LegState::High,
            v: LegState::Low,
            w: LegState::Float,
        };
        let off = HighSideChop.gates(&p, false);
        assert!(!off.high.u && off.low.v && !off.low.u);
        let off = LowSideChop.gates(&p, false);
        assert!(off.high.u && !off.low.v);
        let off = Complementary.gates(&p, false);
        assert!(!off.high.u && off.low.u && off.low.v && !off.high.w && !off.low.w);
        for s in [
            &HighSideChop as &dyn PwmScheme,
            &LowSideChop,
            &Complementary,
        ] {
            for on in [false, true] {
                assert!(s.gates(&p, on).validate().is_ok());
            }
        }
    }

    /// Every three-phase pattern and its mirror image (high and low swapped) get mirrored
    /// gates from lone-switch chopping, on and off; high-side chopping breaks that in the
    /// off-time, which is the asymmetry the scheme exists to remove.
    #[test]
    fn lone_switch_chopping_mirrors_every_three_phase_state() {
        let mirror = |s: LegState| match s {
            LegState::High => LegState::Low,
            LegState::Low => LegState::High,
            LegState::Float => LegState::Float,
        };
        let swap = |g: Gates| Gates {
            high: g.low,
            low: g.high,
        };
        let legs = [LegState::High, LegState::Low];
        let mut asymmetric_hsc = 0;
        let states: Vec<(LegState, LegState, LegState)> = legs
            .iter()
            .flat_map(|&u| legs.iter().flat_map(move |&v| legs.map(|w| (u, v, w))))
            .filter(|&(u, v, w)| !(u == v && v == w))
            .collect();
        assert_eq!(states.len(), 6);
        for (u, v, w) in states {
            let p = Abc { u, v, w };
            let m = p.map(mirror);
            for on in [false, true] {
                let g = LoneSwitchChop.gates(&p, on);
                assert!(g.validate().is_ok());
                assert_eq!(swap(g), LoneSwitchChop.gates(&m, on), "{p:?} on={on}");
                if swap(HighSideChop.gates(&p, on)) != HighSideChop.gates(&m, on) {
                    asymmetric_hsc += 1;
                }
            }
            // One switch chops: the lone one on its side.
            let (on, off) = (
                LoneSwitchChop.gates(&p, true),
                LoneSwitchChop.gates(&p, false),
            );
            let flips = |a: Abc<bool>, b: Abc<bool>| {
                a.to_array()
                    .iter()
                    .zip(b.to_array())
                    .filter(|(x, y)| **x != *y)
                    .count()
            };
            assert_eq!(
                flips(on.high, off.high) + flips(on.low, off.low),
                1,
                "{p:?}"
            );
        }
        assert!(asymmetric_hsc > 0);
    }

    #[test]
    fn scheme_kind_dispatches_to_its_scheme() {
        let p = Abc {
            u: LegState::High,
            v: LegState::Low,
            w: LegState::Float,
        };
        for on in [false, true] {
            assert_eq!(
                PwmSchemeKind::HighSideChop.gates(&p, on),
                HighSideChop.gates(&p, on)
            );
            assert_eq!(
                PwmSchemeKind::LowSideChop.gates(&p, on),
                LowSideChop.gates(&p, on)
            );
            assert_eq!(
                PwmSchemeKind::Complementary.gates(&p, on),
                Complementary.gates(&p, on)
            );
        }
    }
}
