//! Loop design: the chip's speed/current cascade as a sampled-data model, and the gains
//! that keep its margins over a speed range (`drive-bench tune`; docs/chip.md, "Loop
//! design").
//!
//! The model linearises the drive about a steady operating point at speed n with no
//! external load (SI units unless stated):
//! - motor: line-to-line back-EMF E = Kt·ω_m (its mean over a 60° conduction),
//!   Kt = (3/π)·√3·λr·(P/2); friction B·ω_m + Tc needs the phase current i = T/Kt and the
//!   duty d = (E + 2R·i)/V_DD (two phases in series, R_ll = 2R).
//! - current loop: at a PI period T = 5.24 ms ≫ L/R the mean shunt current read at update
//!   k is g·cv(k−1), g = ∂(d·i)/∂cv = (2d·V_DD − E)/(R_ll·top) \[A/count\].
//! - speed plant: a shunt current Δi_s changes the phase current by Δi_s/d_e,
//!   d_e = d + R_ll·i/V_DD, so the torque by Kt·Δi_s/d_e, and J·dω/dt = T − B·ω.
//! - speed meter: the reading averages ω over W = k'·T_FG (k' the periods it spans, see
//!   `strategies::speed`) and is held until the next one: two zero-order holds of W.
//! - the PIs run every T; with the gain schedule the speed PI's error is scaled by d̂ and
//!   the current PI's by 1/d̂ (`strategies::chip::scheduled_duty`).
//!
//! Open loop, cut at the speed error, with z = e^{jΩT} and H_X = (1 − e^{−jΩX})/(jΩX):
//!
//! ```text
//! L(jΩ) = d̂·C_s(z) · C_i'(z)/(1 + C_i'(z)·g·z⁻¹) · H_T · (Kt·g/d_e)/(jΩJ + B) · (60/2π) · H_W²
//! C(z) = Kp + Ki/(1 − z⁻¹),   C_i' = C_i/d̂
//! ```
//!
//! Criterion: the current loop is integral only (the plant is static over an update, so a
//! proportional term adds no phase and passes the read's ripple straight to the duty), its
//! pole 1 − Ki·g/d̂ at [`CURRENT_POLE`] where g/d̂ is largest; the speed PI's gain and zero
//! give the highest lowest crossover over the range with a phase margin of at least
//! [`PHASE_MARGIN_DEG`] and a gain margin of at least [`GAIN_MARGIN_DB`] at every speed of
//! it, the zero no further than [`ZERO_RATIO_MAX`] below that crossover.
//! What the model leaves out (the commutation's torque ripple, the meter's quantisation,
//! saturation) is checked by simulation, not here.

use crate::DriveConfig;
use drive_core::clocks;
use num_complex::Complex64;
use serde::Serialize;
use std::f64::consts::PI;
use strategies::ControlParams;
use strategies::chip::scheduled_duty;

/// Smallest phase margin the tuned speed loop keeps at every speed of the range \[°\].
pub const PHASE_MARGIN_DEG: f64 = 50.0;
/// Smallest gain margin the tuned speed loop keeps at every speed of the range \[dB\].
pub const GAIN_MARGIN_DB: f64 = 10.0;
/// Largest ratio of the lowest crossover to the speed PI's zero: a zero further below
/// leaves a slow tail (time constant 1/zero) after every step and start, as the
/// integrator that wound while the rotor accelerated unwinds.
pub const ZERO_RATIO_MAX: f64 = 3.0;
/// The current loop's pole 1 − Ki·g/d̂ at its fastest: 0.6, a loop gain of 0.4 per
/// update (no overshoot, gain margin 2/0.4 = 14 dB).
pub const CURRENT_POLE: f64 = 0.6;

/// The speed loop at one speed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Margins {
    /// Speed \[rpm\].
    pub rpm: f64,
    /// Duty of the operating point \[1\].
    pub duty: f64,
    /// Periods the speed meter spans there, k'.
    pub meter_periods: u32,
    /// The current loop's pole, 1 − Ki·g/d̂ (stable inside −1..1).
    pub current_pole: f64,
    /// Crossover of the speed loop \[rad/s\] (`None`: the loop gain never reaches 1).
    pub crossover_rad_s: Option<f64>,
    /// Phase margin \[°\] (`None` without a crossover).
    pub phase_margin_deg: Option<f64>,
    /// Gain margin \[dB\] (`None`: the phase never reaches −180° below Nyquist).
    pub gain_margin_db: Option<f64>,
}

impl Margins {
    /// Whether this point meets the criterion.
    pub fn meets(&self) -> bool {
        self.phase_margin_deg.is_some_and(|p| p >= PHASE_MARGIN_DEG)
            && self.gain_margin_db.is_none_or(|g| g >= GAIN_MARGIN_DB)
            && self.current_pole.abs() < 1.0
    }
}

/// The gains `tune` chose, with the margins they give.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Tuned {
    /// Speed PI proportional gain (at full duty with the schedule) [A/rpm].
    pub speed_kp: f64,
    /// Speed PI integral gain per update [A/(rpm·update)].
    pub speed_ki: f64,
    /// Current PI integral gain per update (at full duty with the schedule)
    /// [counts/(A·update)]; its proportional gain is 0.
    pub current_ki: f64,
    /// The motor's no-load speed at full voltage V_DD/Kt \[rpm\] (the schedule's ω0).
    pub no_load_rpm: f64,
    /// Locked-rotor current V_DD/(2R) \[A\] (the schedule's I_lr).
    pub locked_rotor_a: f64,
    /// Alignment current \[A\] and start phase current \[A\]: the built-in motor's
    /// defaults scaled by (Kt₀/Kt)·(J/J₀), so that the rotor swings at the rate the timed
    /// alignment steps (38 ms, 15 ms) were designed for (the angular acceleration per
    /// ampere is Kt/J).
    pub align_current_a: f64,
    /// See `align_current_a`.
    pub start_phase_current_a: f64,
    /// The hand-over's assumed first 60° time \[s\]: [`first_sector_s`] at
    /// `start_phase_current_a`.
    pub handover_t60_s: f64,
    /// The speed reference's descent after a start that ran past the command \[rpm/s\]:
    /// [`descent_rpm_s`].
    pub start_descent_rpm_s: f64,
    /// The margins at each speed of the range.
    pub margins: Vec<Margins>,
}

impl Tuned {
    /// The `[control]` lines to paste into a config.
    pub fn to_toml(&self) -> String {
        format!(
            "[control]\nspeed_kp = {:.3e}\nspeed_ki = {:.3e}\ncurrent_kp = 0.0\ncurrent_ki = {:.1}\n\
             supervisor_no_load_rpm = {:.0}\nsupervisor_locked_rotor_a = {:.3}\n\
             align_current_a = {:.3}\nstart_phase_current_a = {:.3}\nhandover_t60_s = {:.4}\n\
             start_descent_rpm_s = {:.0}\n",
            self.speed_kp,
            self.speed_ki,
            self.current_ki,
            self.no_load_rpm,
            self.locked_rotor_a,
            self.align_current_a,
            self.start_phase_current_a,
            self.handover_t60_s,
            self.start_descent_rpm_s
        )
    }

    /// `config` with these gains and motor figures in its `[control]`.
    pub fn apply(&self, config: &DriveConfig) -> DriveConfig {
        let mut c = config.clone();
        c.control.speed_kp = self.speed_kp;
        c.control.speed_ki = self.speed_ki;
        c.control.current_kp = 0.0;
        c.control.current_ki = self.current_ki;
        c.control.supervisor_no_load_rpm = self.no_load_rpm;
        c.control.supervisor_locked_rotor_a = self.locked_rotor_a;
        c.control.align_current_a = self.align_current_a;
        c.control.start_phase_current_a = self.start_phase_current_a;
        c.control.handover_t60_s = self.handover_t60_s;
        c.control.start_descent_rpm_s = self.start_descent_rpm_s;
        c
    }
}

/// The share of the rotor's coast on its Coulomb friction, Tc/J, that the speed reference
/// descends at after a start that ran past the command (`control.start_descent_rpm_s`).
/// Descending at a share s, the rotor needs (1 − s) of the friction's torque, which the
/// speed PI holds when the descent ends; the rest it must build then, at the low-speed
/// loop's pace, while the rotor dips. At 0.4 a start straight to 550 or 600 rpm dips
/// 60–80 rpm and is held by twelve-step-df; at 0.7 (983 rpm/s) it dips 214–242 rpm.
pub const DESCENT_SHARE: f64 = 0.4;

/// The start's descent rate \[rpm/s\]: [`DESCENT_SHARE`] of the rotor's coast at
/// `from_rpm`, the bottom of the tuned range, on its Coulomb friction alone, Tc/J, or,
/// for a rotor without any, on its viscous friction, B·ω/J; within the parameter's rule
/// 1..=1e6 rpm/s (0, off, for a rotor with no friction at all, which never coasts down).
pub fn descent_rpm_s(model: &LoopModel, from_rpm: f64) -> f64 {
    let coast = if model.tc > 0.0 {
        model.tc / model.j
    } else {
        model.b * from_rpm * 2.0 * PI / 60.0 / model.j
    };
    let rpm_s = (DESCENT_SHARE * coast * 60.0 / (2.0 * PI)).round();
    if rpm_s > 0.0 {
        rpm_s.clamp(1.0, 1e6)
    } else {
        0.0
    }
}

/// The time the rotor takes from rest through its first 60° electrical under the torque
/// of a phase current `i` \[s\]: θ = ½·α·t² with α = p·Kt·i/J (friction left out, so a
/// little short), t = √(2·(π/3)·J/(p·Kt·i)). The hand-over times the first commutations
/// by it (`control.handover_t60_s`), rounded to 0.1 ms as `tune` prints it; a rotor that
/// covers its first sectors faster than assumed leads the commutation by tens of degrees
/// and passes crossings before their windows open (docs/chip.md, "Start-up").
pub fn first_sector_s(model: &LoopModel, i: f64) -> f64 {
    let alpha = model.pole_pairs * model.kt * i / model.j;
    let t = (2.0 * (PI / 3.0) / alpha).sqrt();
    ((t * 1e4).round() / 1e4).clamp(1e-4, 0.02)
}

/// Why `tune` found no gains.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TuneError {
    /// The config breaks a rule.
    #[error("{0}")]
    Config(String),
    /// The speed range is not a range.
    #[error(
        "speed range {from_rpm}..{to_rpm} rpm (rule: 0 < from < to ≤ the no-load speed {no_load_rpm:.0} rpm)"
    )]
    Range {
        /// Lowest speed asked.
        from_rpm: f64,
        /// Highest speed asked.
        to_rpm: f64,
        /// The motor's no-load speed.
        no_load_rpm: f64,
    },
    /// No gains of the search meet the criterion at every speed.
    #[error(
        "no speed-PI gains keep a {PHASE_MARGIN_DEG}° phase margin and a {GAIN_MARGIN_DB} dB gain margin from {from_rpm} to {to_rpm} rpm (narrow the range, or enable control.gain_schedule and control.speed_window_s)"
    )]
    Infeasible {
        /// Lowest speed asked.
        from_rpm: f64,
        /// Highest speed asked.
        to_rpm: f64,
    },
}

/// The drive's loops as the model sees them (see the module docs).
#[derive(Clone, Debug)]
pub struct LoopModel {
    pole_pairs: f64,
    kt: f64,
    r_ll: f64,
    j: f64,
    b: f64,
    tc: f64,
    v: f64,
    top: f64,
    t: f64,
    control: ControlParams,
}

impl LoopModel {
    /// The model of `config`'s drive (its motor, supply, carrier and control).
    pub fn new(config: &DriveConfig) -> Result<Self, TuneError> {
        config
            .validate()
            .map_err(|e| TuneError::Config(e.to_string()))?;
        let m = &config.motor;
        let pole_pairs = f64::from(m.poles / 2);
        Ok(LoopModel {
            pole_pairs,
            kt: 3.0 / PI * 3f64.sqrt() * m.flux_linkage_wb * pole_pairs,
            r_ll: 2.0 * m.resistance_ohm,
            j: m.inertia_kgm2,
            b: m.viscous_friction_nms,
            tc: m.coulomb_friction_nm,
            v: config.power_stage.supply_v,
            top: f64::from(config.control.carrier_top),
            t: clocks::PI_UPDATE.seconds(),
            control: config.control.clone(),
        })
    }

    /// The no-load speed at full voltage, V_DD/Kt \[rpm\].
    pub fn no_load_rpm(&self) -> f64 {
        self.v / self.kt * 60.0 / (2.0 * PI)
    }

    /// The locked-rotor current V_DD/R_ll \[A\].
    pub fn locked_rotor_a(&self) -> f64 {
        self.v / self.r_ll
    }

    /// Duty d, shunt-current gain g \[A/count\], d_e and the schedule's d̂ at `rpm`.
    fn point(&self, rpm: f64) -> (f64, f64, f64, f64) {
        let w = rpm * 2.0 * PI / 60.0;
        let i = (self.b * w + self.tc) / self.kt;
        let e = self.kt * w;
        let d = ((e + self.r_ll * i) / self.v).min(1.0);
        let g = (2.0 * d * self.v - e) / (self.r_ll * self.top);
        let d_e = d + self.r_ll * i / self.v;
        let d_hat = if self.control.gain_schedule {
            scheduled_duty(&self.control, rpm, d * i)
        } else {
            1.0
        };
        (d, g, d_e, d_hat)
    }

    /// FG periods one speed reading spans at `rpm`, and its span W \[s\].
    fn meter(&self, rpm: f64) -> (u32, f64) {
        let t_fg = 60.0 / (self.pole_pairs * rpm);
        let k = self.control.speed_periods.max(1);
        let k = if self.control.speed_window_s > 0.0 {
            k.min((self.control.speed_window_s / t_fg).ceil().max(1.0) as u32)
        } else {
            k
        };
        (k, f64::from(k) * t_fg)
    }

    /// The open speed loop L(jΩ) at `rpm` with `control`'s gains.
    fn open_loop(&self, rpm: f64, omega: f64) -> Complex64 {
        let c = &self.control;
        let (_, g, d_e, d_hat) = self.point(rpm);
        let (_, w) = self.meter(rpm);
        let s = Complex64::new(0.0, omega);
        let z_inv = (-s * self.t).exp();
        let pi = |kp: f64, ki: f64| kp + ki / (1.0 - z_inv);
        let hold = |x: f64| (1.0 - (-s * x).exp()) / (s * x);
        let c_s = pi(c.speed_kp, c.speed_ki) * d_hat;
        let c_i = pi(c.current_kp, c.current_ki) / d_hat;
        let current = c_i / (1.0 + c_i * g * z_inv);
        let mech = self.kt * g / d_e / (s * self.j + self.b) * (60.0 / (2.0 * PI));
        c_s * current * hold(self.t) * mech * hold(w) * hold(w)
    }

    /// The speed loop's margins at `rpm` with the model's control gains.
    pub fn margins(&self, rpm: f64) -> Margins {
        let (d, g, _, d_hat) = self.point(rpm);
        let c = &self.control;
        // Kp + Ki·z/(z − 1) at z = −1 (Nyquist) with Kp = 0 is Ki/2; the pole of an
        // integral loop with a one-update delay is 1 − Ki·g.
        let current_pole = 1.0 - (c.current_ki + c.current_kp) * g / d_hat;
        // Frequencies from 0.01 rad/s to just below Nyquist, log-spaced.
        let nyquist = PI / self.t;
        let n = 2000;
        let (lo, hi) = (0.01f64.ln(), (0.999 * nyquist).ln());
        let mut crossover = None;
        let mut gain_margin = None;
        let mut phase = 0.0;
        let mut last_arg: Option<f64> = None;
        for k in 0..=n {
            let omega = (lo + (hi - lo) * f64::from(k) / f64::from(n)).exp();
            let l = self.open_loop(rpm, omega);
            // Unwrapped phase: follow the argument continuously from low frequency.
            let arg = l.arg();
            phase = match last_arg {
                None => arg,
                Some(a) => phase + wrap(arg - a),
            };
            last_arg = Some(arg);
            if crossover.is_none() && l.norm() < 1.0 {
                crossover = Some((omega, 180.0 + phase.to_degrees()));
            }
            if gain_margin.is_none() && phase <= -PI {
                gain_margin = Some(-20.0 * l.norm().log10());
            }
        }
        Margins {
            rpm,
            duty: d,
            meter_periods: self.meter(rpm).0,
            current_pole,
            crossover_rad_s: crossover.map(|c| c.0),
            phase_margin_deg: crossover.map(|c| c.1),
            gain_margin_db: gain_margin,
        }
    }
}

/// An angle difference brought into (−π, π].
fn wrap(x: f64) -> f64 {
    let y = x.rem_euclid(2.0 * PI);
    if y > PI { y - 2.0 * PI } else { y }
}

/// `n` speeds spaced evenly in log from `from` to `to` \[rpm\].
pub fn speed_grid(from: f64, to: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| (from.ln() + (to.ln() - from.ln()) * k as f64 / (n - 1).max(1) as f64).exp())
        .collect()
}

/// Picks the gains for `config`'s motor and drive by the criterion (module docs), over
/// `from_rpm..=to_rpm`, keeping the rest of its `[control]` (reads, meter window,
/// schedule).
pub fn tune(config: &DriveConfig, from_rpm: f64, to_rpm: f64) -> Result<Tuned, TuneError> {
    let mut model = LoopModel::new(config)?;
    let no_load_rpm = model.no_load_rpm();
    let locked_rotor_a = model.locked_rotor_a();
    if !(from_rpm > 0.0 && from_rpm < to_rpm && to_rpm <= no_load_rpm) {
        return Err(TuneError::Range {
            from_rpm,
            to_rpm,
            no_load_rpm,
        });
    }
    model.control.supervisor_no_load_rpm = no_load_rpm;
    model.control.supervisor_locked_rotor_a = locked_rotor_a;
    let speeds = speed_grid(from_rpm, to_rpm, 16);
    // The current loop: the pole where g/d̂ is largest over the range.
    let g_max = speeds
        .iter()
        .map(|&n| {
            let (_, g, _, d_hat) = model.point(n);
            g / d_hat
        })
        .fold(0.0, f64::max);
    model.control.current_kp = 0.0;
    model.control.current_ki = (1.0 - CURRENT_POLE) / g_max;
    let mut best: Option<(f64, f64, f64, Vec<Margins>)> = None;
    for k in 0..=72 {
        let kp = 10f64.powf(-7.0 + 6.0 * f64::from(k) / 72.0);
        for zero_rad_s in [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 8.0] {
            model.control.speed_kp = kp;
            model.control.speed_ki = kp * zero_rad_s * model.t;
            let margins: Vec<Margins> = speeds.iter().map(|&n| model.margins(n)).collect();
            if !margins.iter().all(Margins::meets) {
                continue;
            }
            let lowest = margins
                .iter()
                .filter_map(|m| m.crossover_rad_s)
                .fold(f64::INFINITY, f64::min);
            // The integral's tail (time constant 1/zero) within a few crossover periods.
            if zero_rad_s < lowest / ZERO_RATIO_MAX {
                continue;
            }
            if best.as_ref().is_none_or(|b| lowest > b.0) {
                best = Some((lowest, kp, model.control.speed_ki, margins));
            }
        }
    }
    let (_, speed_kp, speed_ki, margins) =
        best.ok_or(TuneError::Infeasible { from_rpm, to_rpm })?;
    // The start-up currents for the same angular acceleration as the built-in motor's.
    let builtin = LoopModel::new(&DriveConfig::default())?;
    let scale = (builtin.kt / model.kt) * (model.j / builtin.j);
    let start = ControlParams::default();
    let current = |a: f64| (a * scale).clamp(0.01, 10.0);
    let start_phase_current_a = current(start.start_phase_current_a);
    Ok(Tuned {
        align_current_a: current(start.align_current_a),
        start_phase_current_a,
        handover_t60_s: first_sector_s(&model, start_phase_current_a),
        start_descent_rpm_s: descent_rpm_s(&model, from_rpm),
        speed_kp,
        speed_ki,
        current_ki: model.control.current_ki,
        no_load_rpm,
        locked_rotor_a,
        margins,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shipped hand-over time is this derivation's for the built-in motor at the
    /// shipped start current (docs/chip.md, "The assumed first 60°"), 11.9 ms.
    #[test]
    fn the_shipped_first_sector_time_is_the_built_in_rotors() {
        let c = DriveConfig::default();
        let model = LoopModel::new(&c).unwrap();
        let t = first_sector_s(&model, c.control.start_phase_current_a);
        assert_eq!(t, c.control.handover_t60_s);
        assert_eq!(t, 0.0119);
    }

    /// The shipped descent rate is 0.4·Tc/J of the built-in rotor: 0.4 × 2.5e-4 N·m /
    /// 1.7e-6 kg·m² = 58.8 rad/s² = 561.7 rpm/s.
    #[test]
    fn the_shipped_descent_is_the_built_in_rotors() {
        let c = DriveConfig::default();
        let model = LoopModel::new(&c).unwrap();
        assert_eq!(descent_rpm_s(&model, 1000.0), c.control.start_descent_rpm_s);
        assert_eq!(descent_rpm_s(&model, 1000.0), 562.0);
    }

    /// Without Coulomb friction the descent is 0.4 of the viscous coast at the range's
    /// bottom: B = 1e-6 N·m·s/rad at 1000 rpm over J = 1.7e-6 kg·m² is 61.6 rad/s², 588.2
    /// rpm/s, so 235 rpm/s; with no friction at all it is off.
    #[test]
    fn a_rotor_without_coulomb_friction_descends_on_its_viscous_coast() {
        let mut c = DriveConfig::default();
        c.motor.coulomb_friction_nm = 0.0;
        let model = LoopModel::new(&c).unwrap();
        assert_eq!(descent_rpm_s(&model, 1000.0), 235.0);
        c.motor.viscous_friction_nms = 0.0;
        let model = LoopModel::new(&c).unwrap();
        assert_eq!(descent_rpm_s(&model, 1000.0), 0.0);
    }

    #[test]
    fn the_current_loop_of_an_integral_pi_has_its_pole_at_one_minus_the_loop_gain() {
        // With Kp = 0 and no schedule the pole is 1 − Ki·g, g from the operating point:
        // at 3000 rpm on the built-in motor d = (E + R_ll·i)/V with E = Kt·ω.
        let mut c = DriveConfig::default();
        c.control.gain_schedule = false;
        c.control.current_kp = 0.0;
        c.control.current_ki = 300.0;
        let m = LoopModel::new(&c).unwrap();
        let kt = 3.0 / PI * 3f64.sqrt() * 7.62e-4 * 6.0;
        let w = 3000.0 * 2.0 * PI / 60.0;
        let i = (1.0e-6 * w + 2.5e-4) / kt;
        let d = (kt * w + 4.4 * i) / 12.0;
        let g = (2.0 * d * 12.0 - kt * w) / (4.4 * 2000.0);
        let p = m.margins(3000.0);
        assert!((p.duty - d).abs() < 1e-12);
        assert!((p.current_pole - (1.0 - 300.0 * g)).abs() < 1e-12);
    }

    #[test]
    fn a_pure_integrator_behind_a_delay_crosses_over_where_the_analytic_formula_says() {
        // Check the frequency sweep on a loop whose margins are known in closed form: a
        // unit-gain integrator k/s behind a delay τ has its crossover at k and a phase
        // margin of 90° − k·τ. The model's speed loop at high speed with a fast current
        // loop approaches that shape only roughly, so the check is on `wrap` and the
        // sweep's unwrapping: the phase of e^{−jΩτ}/(jΩ) at Ω = 50 after unwrapping.
        let tau = 0.02;
        let mut phase = 0.0f64;
        let mut last: Option<f64> = None;
        for k in 0..=1000 {
            let omega = 0.01 * (5000f64).powf(f64::from(k) / 1000.0);
            let l = (Complex64::new(0.0, -omega * tau)).exp() / Complex64::new(0.0, omega);
            let a = l.arg();
            phase = match last {
                None => a,
                Some(b) => phase + wrap(a - b),
            };
            last = Some(a);
        }
        let expected = -PI / 2.0 - 50.0 * tau;
        assert!((phase - expected).abs() < 1e-9, "{phase} vs {expected}");
    }

    #[test]
    fn the_published_fixed_gains_lose_their_margin_as_the_speed_falls() {
        // The published meter (10 FG periods, no window) with fixed gains: the delay W
        // grows as 1/n while the loop gain Kt/d grows too, so the phase margin falls with
        // the speed and is gone well above 500 rpm; with the window and the schedule the
        // tuned gains keep it.
        let mut c = DriveConfig::default();
        c.control.gain_schedule = false;
        c.control.speed_window_s = 0.0;
        c.control.speed_kp = 5e-5;
        c.control.speed_ki = 1e-6;
        c.control.current_kp = 300.0;
        c.control.current_ki = 600.0;
        let m = LoopModel::new(&c).unwrap();
        let high = m.margins(3000.0).phase_margin_deg.unwrap();
        let low = m.margins(500.0).phase_margin_deg.unwrap();
        assert!(low < 0.0 && high > low + 30.0, "{low} {high}");
    }

    #[test]
    fn a_second_motor_tuned_starts_and_holds_its_speed() {
        // Flux ×1.5 and R ×2: with the built-in start-up currents (phase amperes, so 1.5×
        // the torque) the timed alignment hands the rotor over near 290° and it does not
        // start; tuned, its start-up currents give the built-in swing and its loops its
        // own gain: running at 1000 and 6000 rpm.
        let mut c = DriveConfig::default();
        c.motor.flux_linkage_wb *= 1.5;
        c.motor.resistance_ohm *= 2.0;
        let m = LoopModel::new(&c).unwrap();
        let t = tune(&c, 250.0, 0.8 * m.no_load_rpm()).unwrap();
        assert!((t.align_current_a - 0.39 / 1.5).abs() < 1e-9);
        let tuned = t.apply(&c);
        for rpm in [1000.0, 6000.0] {
            let s = crate::scenario::run(
                &crate::scenario::Scenario::hold(tuned.clone(), rpm, 4.0),
                |_| {},
            )
            .unwrap()
            .summary;
            assert_eq!(
                s.verdict,
                crate::verdict::Verdict::Running,
                "{rpm}: {}",
                s.verdict_reason
            );
        }
    }

    #[test]
    fn tuned_gains_meet_the_criterion_over_the_range_and_a_narrow_range_is_refused() {
        let c = DriveConfig::default();
        let t = tune(&c, 250.0, 12000.0).unwrap();
        assert!(t.margins.iter().all(Margins::meets));
        assert!(t.margins.len() == 16);
        assert!(matches!(
            tune(&c, 500.0, 400.0),
            Err(TuneError::Range { .. })
        ));
        assert!(matches!(tune(&c, 100.0, 1e6), Err(TuneError::Range { .. })));
    }
}
