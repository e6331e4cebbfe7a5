//! The six-switch bridge as the controller sees it: leg states and gate signals.

use crate::abc::{Abc, Phase};
use serde::{Deserialize, Serialize};

/// What a commutation pattern asks of one leg (docs/chip.md).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LegState {
    /// "V": the phase is tied to the supply V_DD (high-side switch, subject to PWM).
    High,
    /// "G": the phase is tied to ground (low-side switch).
    Low,
    /// "F": both switches off; the phase floats once its current has decayed.
    #[default]
    Float,
}

/// The leg states of all three phases: what a commutation strategy returns.
pub type Pattern = Abc<LegState>;

/// The all-floating pattern (chip flag 0110).
pub const ALL_FLOAT: Pattern = Abc::splat(LegState::Float);

/// The 120° six-step table of docs/chip.md, states 1..6 (index 0..5): state k spans
/// θe = −30° + 60°·(k−1) .. +60°, the floating phase's back-EMF crossing mid-state.
pub const SIX_STEP_120: [Pattern; 6] = {
    use LegState::{Float as F, High as V, Low as G};
    [
        Abc { u: F, v: G, w: V },
        Abc { u: V, v: G, w: F },
        Abc { u: V, v: F, w: G },
        Abc { u: F, v: V, w: G },
        Abc { u: G, v: V, w: F },
        Abc { u: G, v: F, w: V },
    ]
};

/// The floating phase of a pattern, if exactly one leg floats.
pub fn floating_phase(p: &Pattern) -> Option<Phase> {
    let mut found = None;
    for x in Phase::ALL {
        if p.get(x) == LegState::Float {
            if found.is_some() {
                return None;
            }
            found = Some(x);
        }
    }
    found
}

/// Logical gate commands of the six switches: `true` = switch on.
///
/// `high.u` is Tr1, `low.u` Tr2, `high.v` Tr3, `low.v` Tr4, `high.w` Tr5, `low.w` Tr6.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Gates {
    /// High-side switches (to V_DD).
    pub high: Abc<bool>,
    /// Low-side switches (to the shunt and ground).
    pub low: Abc<bool>,
}

/// A gate pattern that would short the supply.
#[derive(Copy, Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("shoot-through: both switches of phase {} commanded on (rule: at most one switch per leg)", .phase.name())]
pub struct ShootThrough {
    /// The leg with both switches on.
    pub phase: Phase,
}

impl Gates {
    /// Every switch off.
    pub const OFF: Gates = Gates {
        high: Abc::splat(false),
        low: Abc::splat(false),
    };

    /// Refuses a pattern with both switches of a leg on.
    pub fn validate(&self) -> Result<(), ShootThrough> {
        for p in Phase::ALL {
            if self.high.get(p) && self.low.get(p) {
                return Err(ShootThrough { phase: p });
            }
        }
        Ok(())
    }

    /// The chip's gate signals Tr1..Tr6 as the published table prints them: the high side is PMOS
    /// (signal 1 = off), the low side NMOS (signal 0 = off).
    pub fn to_chip_signals(&self) -> [u8; 6] {
        let mut s = [0u8; 6];
        for p in Phase::ALL {
            s[2 * p.index()] = u8::from(!self.high.get(p));
            s[2 * p.index() + 1] = u8::from(self.low.get(p));
        }
        s
    }

    /// Inverse of [`Gates::to_chip_signals`]; any non-zero signal counts as 1.
    pub fn from_chip_signals(s: [u8; 6]) -> Gates {
        let mut g = Gates::OFF;
        for p in Phase::ALL {
            *g.high.get_mut(p) = s[2 * p.index()] == 0;
            *g.low.get_mut(p) = s[2 * p.index() + 1] != 0;
        }
        g
    }

    /// Gates that hold every leg as `pattern` says, with no chopping.
    pub fn from_pattern(pattern: &Pattern) -> Gates {
        Gates {
            high: pattern.map(|s| s == LegState::High),
            low: pattern.map(|s| s == LegState::Low),
        }
    }
}

/// The six gate commands packed in bits, Tr1..Tr6 from bit 0 (`high.u`, `low.u`, `high.v`,
/// `low.v`, `high.w`, `low.w`): the engine's and gate driver's working form of [`Gates`].
/// A PWM edge compares, checks and copies one byte rather than six flags one at a time.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct GateMask(u8);

impl GateMask {
    /// Every switch off.
    pub const OFF: GateMask = GateMask(0);

    /// The high-side bits (even positions); a leg's low side is the bit above its high side.
    const HIGH: u8 = 0b01_01_01;

    /// Refuses a mask with both switches of a leg on, naming the first such leg.
    pub fn validate(self) -> Result<(), ShootThrough> {
        let both = self.0 & (self.0 >> 1) & Self::HIGH;
        if both == 0 {
            return Ok(());
        }
        Err(ShootThrough {
            phase: Phase::ALL[both.trailing_zeros() as usize / 2],
        })
    }

    /// Whether switch `k` (0..6: Tr1..Tr6) is on.
    pub fn is_on(self, k: usize) -> bool {
        self.0 >> k & 1 != 0
    }

    /// `self` with switch `k` (0..6: Tr1..Tr6) turned on or off.
    pub fn with(self, k: usize, on: bool) -> GateMask {
        GateMask(self.0 & !(1 << k) | u8::from(on) << k)
    }
}

impl From<Gates> for GateMask {
    fn from(g: Gates) -> GateMask {
        let mut m = 0;
        for p in Phase::ALL {
            let k = 2 * p.index();
            m |= u8::from(g.high.get(p)) << k | u8::from(g.low.get(p)) << (k + 1);
        }
        GateMask(m)
    }
}

impl From<GateMask> for Gates {
    fn from(m: GateMask) -> Gates {
        GATES_OF_MASK[usize::from(m.0 & 0b11_11_11)]
    }
}

/// The gates of every mask, built at compile time: a gate change converts by one load
/// rather than six bit tests.
const GATES_OF_MASK: [Gates; 64] = {
    let mut table = [Gates::OFF; 64];
    const fn on(m: usize, k: usize) -> bool {
        m >> k & 1 != 0
    }
    let mut m = 0;
    while m < 64 {
        table[m] = Gates {
            high: Abc::from_array([on(m, 0), on(m, 2), on(m, 4)]),
            low: Abc::from_array([on(m, 1), on(m, 3), on(m, 5)]),
        };
        m += 1;
    }
    table
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chip_signals_of_twelve_step_state_1_and_off() {
        // Published state 1: u=V, v=G, w=V → Tr1..Tr6 = 0 0 1 1 0 0.
        let g = Gates::from_pattern(&Abc {
            u: LegState::High,
            v: LegState::Low,
            w: LegState::High,
        });
        assert_eq!(g.to_chip_signals(), [0, 0, 1, 1, 0, 0]);
        // "off" (flag 0110): all floating → 1 0 1 0 1 0.
        assert_eq!(Gates::OFF.to_chip_signals(), [1, 0, 1, 0, 1, 0]);
        assert_eq!(Gates::from_chip_signals([0, 0, 1, 1, 0, 0]), g);
    }

    #[test]
    fn shoot_through_is_refused_and_named() {
        let mut g = Gates::OFF;
        g.high.v = true;
        g.low.v = true;
        let e = g.validate().unwrap_err();
        assert_eq!(e.phase, Phase::V);
        assert!(e.to_string().contains("phase v"));
    }

    #[test]
    fn a_gate_mask_holds_the_gates_and_refuses_the_same_shoot_throughs() {
        // Every combination of the six switches, both ways and checked alike.
        for bits in 0u8..64 {
            let m = GateMask(bits);
            let g = Gates::from(m);
            assert_eq!(GateMask::from(g), m);
            assert_eq!(m.validate(), g.validate(), "bits {bits:06b}");
        }
        let mut g = Gates::OFF;
        g.high.u = true;
        g.low.w = true;
        assert_eq!(GateMask::from(g), GateMask(0b10_00_01));
    }
}
