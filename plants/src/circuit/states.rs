//! The legs' conduction states: how each leg conducts, the 125 states of the three
//! together by index, and the tables the plant reads by that index at every step.

use drive_core::Abc;

/// How one leg conducts.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum Conduction {
    /// High-side switch on.
    SwitchHigh,
    /// Low-side switch on.
    SwitchLow,
    /// Current returning to V_DD through the high-side diode (i_x < 0).
    DiodeHigh,
    /// Current drawn from the low rail through the low-side diode (i_x > 0).
    DiodeLow,
    /// No current; the terminal floats at v_n + e_x.
    #[default]
    Open,
}

impl Conduction {
    /// Whether the leg carries (or may carry) current.
    pub fn conducts(self) -> bool {
        self != Conduction::Open
    }
    /// Whether the leg is tied to the low rail (through the shunt).
    pub fn is_low(self) -> bool {
        matches!(self, Conduction::SwitchLow | Conduction::DiodeLow)
    }
    /// Whether the leg is tied to V_DD.
    pub fn is_high(self) -> bool {
        matches!(self, Conduction::SwitchHigh | Conduction::DiodeHigh)
    }
    /// Whether a diode conducts.
    pub fn is_diode(self) -> bool {
        matches!(self, Conduction::DiodeHigh | Conduction::DiodeLow)
    }
}

/// How many conduction states the three legs have together: five each.
pub const STATES: usize = 125;

/// The index, 0..[`STATES`], of the legs' conduction states `modes` (base 5, u first).
pub fn state_index(modes: &Abc<Conduction>) -> usize {
    let m = modes.map(|c| c as usize);
    m.u * 25 + m.v * 5 + m.w
}

/// [`Circuit::follows_neutral`](super::Circuit::follows_neutral) of each conduction state,
/// by [`state_index`]: made at compile time, since the plant asks at every step.
pub(super) const FOLLOWS_NEUTRAL: [[bool; 3]; STATES] = {
    let mut t = [[false; 3]; STATES];
    let mut k = 0;
    while k < STATES {
        // The legs' base-5 digits, as `state_index` makes them.
        let d = [k / 25 % 5, k / 5 % 5, k % 5];
        let (open, dh, dl) = (
            Conduction::Open as usize,
            Conduction::DiodeHigh as usize,
            Conduction::DiodeLow as usize,
        );
        let n_c = (d[0] != open) as usize + (d[1] != open) as usize + (d[2] != open) as usize;
        let mut p = 0;
        while p < 3 {
            t[k][p] = d[p] == open || (n_c < 2 && (d[p] == dh || d[p] == dl));
            p += 1;
        }
        k += 1;
    }
    t
};

/// The open legs of each conduction state as a mask (bit 0 for u), by [`state_index`].
pub(super) const OPEN_LEGS: [u8; STATES] = {
    let mut t = [0u8; STATES];
    let mut k = 0;
    while k < STATES {
        let d = [k / 25 % 5, k / 5 % 5, k % 5];
        let open = Conduction::Open as usize;
        t[k] = (d[0] == open) as u8 | ((d[1] == open) as u8) << 1 | ((d[2] == open) as u8) << 2;
        k += 1;
    }
    t
};

/// The legs tied to the low rail (through the shunt) in each conduction state, by
/// [`state_index`].
const LOW_LEGS: [[bool; 3]; STATES] = {
    let mut t = [[false; 3]; STATES];
    let mut k = 0;
    while k < STATES {
        let d = [k / 25 % 5, k / 5 % 5, k % 5];
        let mut p = 0;
        while p < 3 {
            t[k][p] =
                d[p] == Conduction::SwitchLow as usize || d[p] == Conduction::DiodeLow as usize;
            p += 1;
        }
        k += 1;
    }
    t
};

/// [`Conduction::is_low`] of each leg in the conduction state at index `k` (see
/// [`state_index`]), for a caller that keeps the index.
pub(crate) fn low_legs_at(k: usize) -> [bool; 3] {
    LOW_LEGS[k]
}

/// The legs' conduction states at index `k` (see [`state_index`]).
pub fn state_at(k: usize) -> Abc<Conduction> {
    const ALL: [Conduction; 5] = [
        Conduction::SwitchHigh,
        Conduction::SwitchLow,
        Conduction::DiodeHigh,
        Conduction::DiodeLow,
        Conduction::Open,
    ];
    Abc {
        u: ALL[k / 25 % 5],
        v: ALL[k / 5 % 5],
        w: ALL[k % 5],
    }
}
