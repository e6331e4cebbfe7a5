//! What the plant shows of itself: the true signals now, the energy ledger and the
//! torque's integrals.

use super::{BldcPlant, E_SUPPLY, OMEGA, THETA};
use crate::circuit::Conduction;
use drive_core::Abc;
use std::f64::consts::TAU;

/// Energies integrated along the run \[J\].
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct EnergyLedger {
    /// Drawn from V_DD (negative when regenerating).
    pub supply: f64,
    /// Winding copper loss.
    pub copper: f64,
    /// Switch conduction loss.
    pub switch: f64,
    /// Diode loss.
    pub diode: f64,
    /// Shunt loss.
    pub shunt: f64,
    /// Friction loss ∫(Bm·ωm + Tc·tanh(ωm/ω0))·ωm.
    pub friction: f64,
    /// Work done on the load ∫TL·ωm.
    pub load: f64,
    /// Electromechanical conversion ∫Σe·i.
    pub airgap: f64,
    /// Absorbed by the dynamometer holding a speed-locked rotor ∫(Te − friction − TL)·ωm.
    pub dynamometer: f64,
    /// Magnetic energy stored now: ½(Lp + M)·Σi².
    pub magnetic: f64,
    /// Kinetic energy now: ½J·ωm².
    pub kinetic: f64,
}

/// A snapshot of the true plant signals (for traces and tests).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Observation {
    /// Time \[s\].
    pub t_s: f64,
    /// Electrical angle θe \[rad\], 0..2π, with e_u = λr·ωe·sin θe for the sinusoidal shape.
    pub theta_e: f64,
    /// Mechanical speed [rad/s].
    pub omega_m: f64,
    /// Mechanical speed \[rpm\].
    pub speed_rpm: f64,
    /// Phase currents into the windings \[A\].
    pub i: Abc<f64>,
    /// Terminal voltages to ground \[V\].
    pub v_term: Abc<f64>,
    /// Neutral voltage to ground \[V\].
    pub v_n: f64,
    /// Back-EMFs \[V\].
    pub emf: Abc<f64>,
    /// Electromagnetic torque [N·m].
    pub torque_nm: f64,
    /// Conduction state of each leg.
    pub conduction: Abc<Conduction>,
    /// Shunt current, positive to ground \[A\].
    pub i_shunt: f64,
}

impl BldcPlant {
    /// True signals now.
    pub fn observe(&self) -> Observation {
        let x = self.state();
        let (f, e) = self.emf_of(&x);
        let i = Self::currents(&x);
        let s = self.circuit.solve(&self.modes, &i, &e);
        Observation {
            t_s: self.t,
            theta_e: x[THETA],
            omega_m: x[OMEGA],
            speed_rpm: x[OMEGA] * 60.0 / TAU,
            i,
            v_term: s.v_term,
            v_n: s.v_n,
            emf: e,
            torque_nm: self.pp * self.lambda * (i.u * f.u + i.v * f.v + i.w * f.w),
            conduction: self.modes,
            i_shunt: s.i_shunt,
        }
    }

    /// Energy integrals since t = 0 and the energies stored now.
    pub fn energy(&self) -> EnergyLedger {
        let x = &self.state();
        EnergyLedger {
            supply: x[E_SUPPLY],
            copper: x[E_SUPPLY + 1],
            switch: x[E_SUPPLY + 2],
            diode: x[E_SUPPLY + 3],
            shunt: x[E_SUPPLY + 4],
            friction: x[E_SUPPLY + 5],
            load: x[E_SUPPLY + 6],
            airgap: x[E_SUPPLY + 7],
            dynamometer: x[E_SUPPLY + 8],
            magnetic: 0.5 * self.inductance * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]),
            kinetic: 0.5 * self.inertia * x[OMEGA] * x[OMEGA],
        }
    }

    /// ∫Te dt \[N·m·s\] and ∫Te² dt \[N²·m²·s\] since t = 0: differences over a window give
    /// the torque's exact time mean and mean square.
    pub fn torque_integrals(&self) -> (f64, f64) {
        let x = self.state();
        (x[E_SUPPLY + 9], x[E_SUPPLY + 10])
    }
}
