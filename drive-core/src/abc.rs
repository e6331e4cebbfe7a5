//! Three-phase triples with named phases.

use serde::{Deserialize, Serialize};

/// One of the three motor phases.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Phase {
    /// Phase u.
    U,
    /// Phase v.
    V,
    /// Phase w.
    W,
}

/// Phase u: a placeholder to restore a saved value into (see [`crate::state`]).
impl Default for Phase {
    fn default() -> Self {
        Phase::U
    }
}

impl Phase {
    /// The phases in order u, v, w.
    pub const ALL: [Phase; 3] = [Phase::U, Phase::V, Phase::W];

    /// 0, 1, 2 for u, v, w.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Lower-case name as used in traces and errors.
    pub fn name(self) -> &'static str {
        ["u", "v", "w"][self.index()]
    }
}

/// A value per phase (`u`, `v`, `w`): currents, voltages, comparator outputs, leg states.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Abc<T> {
    /// Phase u.
    pub u: T,
    /// Phase v.
    pub v: T,
    /// Phase w.
    pub w: T,
}

impl<T: Copy> Abc<T> {
    /// The same value on every phase.
    pub const fn splat(x: T) -> Self {
        Abc { u: x, v: x, w: x }
    }

    /// Builds a triple from a function of the phase.
    pub fn from_fn(mut f: impl FnMut(Phase) -> T) -> Self {
        Abc {
            u: f(Phase::U),
            v: f(Phase::V),
            w: f(Phase::W),
        }
    }

    /// The value of one phase.
    pub fn get(&self, p: Phase) -> T {
        match p {
            Phase::U => self.u,
            Phase::V => self.v,
            Phase::W => self.w,
        }
    }

    /// Mutable access to one phase.
    pub fn get_mut(&mut self, p: Phase) -> &mut T {
        match p {
            Phase::U => &mut self.u,
            Phase::V => &mut self.v,
            Phase::W => &mut self.w,
        }
    }

    /// Applies `f` to every phase.
    pub fn map<R: Copy>(self, mut f: impl FnMut(T) -> R) -> Abc<R> {
        Abc {
            u: f(self.u),
            v: f(self.v),
            w: f(self.w),
        }
    }

    /// From values in order u, v, w.
    pub const fn from_array([u, v, w]: [T; 3]) -> Self {
        Abc { u, v, w }
    }

    /// The values in order u, v, w.
    pub fn to_array(self) -> [T; 3] {
        [self.u, self.v, self.w]
    }
}
