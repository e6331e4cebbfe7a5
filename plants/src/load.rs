//! The driven machine: the torque it takes from the shaft and the inertia it adds.
//!
//! T_L(ωm) = T_a + T_c·tanh(ωm/ω0) + B_L·ωm + K_f·ωm·|ωm|   \[N·m\], opposing positive rotation
//!
//! - T_a, the active torque: a torque that acts whatever the shaft does (a hanging weight,
//!   a test bench's torque motor). It turns a stopped rotor backwards.
//! - T_c, the Coulomb load: dry friction, a brake, a cutting tool. Passive: it opposes
//!   motion and never drives a rotor at rest. It shares the motor friction's smoothing
//!   speed ω0 (`motor.coulomb_speed_rad_s`): below ω0 it acts as a steep viscous term, so a
//!   stopped rotor sees no torque from it and there are no stick-slip events.
//! - B_L, viscous: a generator into a resistor, a fluid film.
//! - K_f, fan or pump: aerodynamic drag, ∝ ωm² with the sign of ωm.
//! - J_L, inertia coupled rigidly to the rotor: added to the motor's J.
//!
//! Passive terms only take energy out; the plant integrates T_L·ωm as the work done on the
//! load.

use drive_core::ParamError;
use drive_core::error::check_range;
use serde::{Deserialize, Serialize};

/// A load model's parameters. Every term defaults to 0: no load.
#[derive(Copy, Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Load {
    /// Active torque T_a [N·m], positive opposing positive rotation. Rule: |T_a| <= 1 N·m.
    pub active_nm: f64,
    /// Coulomb load T_c [N·m]. Rule: 0..=1 N·m.
    pub coulomb_nm: f64,
    /// Viscous load B_L [N·m·s/rad]. Rule: 0..=1.
    pub viscous_nms: f64,
    /// Fan/pump coefficient K_f [N·m·s²/rad²]. Rule: 0..=1e-3 (1 N·m at 300 rpm).
    pub fan_nms2: f64,
    /// Inertia coupled to the rotor J_L [kg·m²]. Rule: 0..=1.
    pub inertia_kgm2: f64,
}

/// The largest load torque term \[N·m\]: about 30 times the built-in motor's locked-rotor
/// torque, far beyond what any drive this model describes can turn.
pub(crate) const MAX_TORQUE_NM: f64 = 1.0;

impl Load {
    /// The largest load the rules allow, term by term.
    pub(crate) const MAX: Load = Load {
        active_nm: MAX_TORQUE_NM,
        coulomb_nm: MAX_TORQUE_NM,
        viscous_nms: 1.0,
        fan_nms2: 1e-3,
        inertia_kgm2: 1.0,
    };

    /// Checks every rule; the error names the first term that breaks one.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range(
            "load.active_nm",
            self.active_nm,
            -Self::MAX.active_nm,
            Self::MAX.active_nm,
            "must be finite, |T| <= 1 N·m",
        )?;
        check_range(
            "load.coulomb_nm",
            self.coulomb_nm,
            0.0,
            Self::MAX.coulomb_nm,
            "must be 0..=1 N·m",
        )?;
        check_range(
            "load.viscous_nms",
            self.viscous_nms,
            0.0,
            Self::MAX.viscous_nms,
            "must be 0..=1 N·m·s/rad",
        )?;
        check_range(
            "load.fan_nms2",
            self.fan_nms2,
            0.0,
            Self::MAX.fan_nms2,
            "must be 0..=1e-3 N·m·s²/rad²",
        )?;
        check_range(
            "load.inertia_kgm2",
            self.inertia_kgm2,
            0.0,
            Self::MAX.inertia_kgm2,
            "must be 0..=1 kg·m²",
        )
    }

    /// The passive part (every term but T_a) at speed `wm` \[rad/s\], with `s` = tanh(ωm/ω0)
    /// \[N·m\].
    #[inline]
    pub fn passive_nm(&self, wm: f64, s: f64) -> f64 {
        self.coulomb_nm * s + (self.viscous_nms + self.fan_nms2 * wm.abs()) * wm
    }

    /// The whole load torque T_L at speed `wm` \[rad/s\] with the smoothing speed `omega0`
    /// \[rad/s\] (`motor.coulomb_speed_rad_s`) \[N·m\], opposing positive rotation: what a
    /// trace shows as the load (the plant itself adds the terms in its step).
    pub fn torque_nm(&self, wm: f64, omega0: f64) -> f64 {
        self.active_nm + self.passive_nm(wm, (wm / omega0).tanh())
    }

    /// d(passive)/dωm at speed `wm`, with `ds` = d tanh(ωm/ω0)/dωm \[N·m·s/rad\].
    #[inline]
    pub fn passive_slope(&self, wm: f64, ds: f64) -> f64 {
        self.coulomb_nm * ds + self.viscous_nms + 2.0 * self.fan_nms2 * wm.abs()
    }

    /// Sets torque term `k` in the order active, Coulomb, viscous, fan (others: nothing).
    pub fn set_term(&mut self, k: usize, v: f64) {
        match k {
            0 => self.active_nm = v,
            1 => self.coulomb_nm = v,
            2 => self.viscous_nms = v,
            3 => self.fan_nms2 = v,
            _ => {}
        }
    }

    /// Whether any passive term is present (the plant skips them otherwise).
    pub fn has_passive(&self) -> bool {
        self.coulomb_nm != 0.0 || self.viscous_nms != 0.0 || self.fan_nms2 != 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passive_terms_oppose_motion_and_vanish_at_rest() {
        let l = Load {
            coulomb_nm: 1e-3,
            viscous_nms: 1e-6,
            fan_nms2: 1e-9,
            ..Load::default()
        };
        assert_eq!(l.passive_nm(0.0, 0.0), 0.0);
        for wm in [-300.0, -1.0, 1.0, 300.0] {
            let s = (wm / 0.5f64).tanh();
            let t = l.passive_nm(wm, s);
            assert!(t * wm > 0.0, "{t} at {wm}");
        }
        // 300 rad/s: 1e-3 + 3e-4 + 9e-5.
        let t = l.passive_nm(300.0, 1.0);
        assert!((t - 1.39e-3).abs() < 1e-12, "{t}");
    }

    #[test]
    fn slope_matches_a_finite_difference() {
        let l = Load {
            coulomb_nm: 1e-3,
            viscous_nms: 1e-6,
            fan_nms2: 1e-9,
            ..Load::default()
        };
        let w0 = 0.5;
        for wm in [-3.0, 0.2, 40.0] {
            let f = |w: f64| l.passive_nm(w, (w / w0).tanh());
            let h = 1e-6;
            let fd = (f(wm + h) - f(wm - h)) / (2.0 * h);
            let th = (wm / w0).tanh();
            let slope = l.passive_slope(wm, (1.0 - th * th) / w0);
            assert!(
                (fd - slope).abs() < 1e-9 * (1.0 + slope.abs()),
                "{fd} {slope}"
            );
        }
    }

    #[test]
    fn rules_name_the_term() {
        let bad = [
            Load {
                active_nm: f64::NAN,
                ..Load::default()
            },
            Load {
                coulomb_nm: -1e-3,
                ..Load::default()
            },
            Load {
                fan_nms2: 1.0,
                ..Load::default()
            },
            Load {
                inertia_kgm2: f64::INFINITY,
                ..Load::default()
            },
        ];
        let names = ["active_nm", "coulomb_nm", "fan_nms2", "inertia_kgm2"];
        for (l, n) in bad.iter().zip(names) {
            let e = l.validate().unwrap_err().to_string();
            assert!(e.contains(n), "{e}");
        }
        Load::default().validate().unwrap();
    }
}
