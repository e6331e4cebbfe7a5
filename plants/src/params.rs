//! Plant parameters: motor, power stage, sensing and solver, each serde-able and validated.
//!
//! Defaults are the published motor (docs/model.md) plus the values this project chose where the
//! source is silent or unreliable; each such choice is justified on its field.

use drive_core::error::{ParamError, check_non_negative, check_positive_max, check_range};
use drive_core::pwm::PwmSchemeKind;
use drive_core::{Abc, Ticks};
use serde::{Deserialize, Serialize};

/// Shape of the per-phase back-EMF, `e_x = λr·ωe·f(θx)`, with θu = θe, θv = θe − 120°,
/// θw = θe + 120°. Every shape is odd and half-wave symmetric, so crossings stay at 0°/180°.
#[derive(Copy, Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum BackEmfShape {
    /// f(θ) = sin θ: the published model.
    Sinusoidal,
    /// Trapezoid of peak 1 with a flat top of `flat_top_deg` (0..180) and linear ramps through
    /// the crossings; 120° is the classic BLDC shape.
    Trapezoidal {
        /// Width of the flat top [electrical degrees].
        flat_top_deg: f64,
    },
    /// f(θ) = sin θ + h3·sin 3θ + h5·sin 5θ (per-unit harmonic amplitudes).
    Harmonic {
        /// Third-harmonic amplitude [p.u. of the fundamental].
        third: f64,
        /// Fifth-harmonic amplitude [p.u. of the fundamental].
        fifth: f64,
    },
}

/// The motor: 9-slot, 12-pole outer-rotor spindle, Y-connected, neutral brought out.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotorParams {
    /// Number of poles P (θe = P/2·θm). Default 12. Rule: even, 2..=200.
    pub poles: u32,
    /// PM flux-linkage amplitude per phase λr [Wb·turn]. Default 7.62e-4. Rule: 1e-6..=1,
    /// and the coupling rule ([`PlantParams::check_coupling`]): with the other defaults at most 0.0416.
    pub flux_linkage_wb: f64,
    /// Phase self inductance Lp \[H\]. Default 0.63e-3. Rule: 1e-7..=1, above
    /// `mutual_inductance_h`: with the other defaults above 3.7e-4.
    pub self_inductance_h: f64,
    /// Mutual inductance between two phases M \[H\] (enters as −M·di_y/dt). Default 0.37e-3.
    /// Rule: 0 ≤ M < Lp (with the other defaults below 6.3e-4). With no neutral current the
    /// phases see L = Lp + M.
    pub mutual_inductance_h: f64,
    /// Phase resistance R \[Ω\]. Default 2.2. Rule: 1e-4..=1e3, and the coupling rule
    /// ([`PlantParams::check_coupling`], here R ≥ h·k²/(4J)): with the other defaults at least 7.38e-4.
    pub resistance_ohm: f64,
    /// Rotor inertia J [kg·m²]. Default 17e-7. Rule: 1e-9..=10, and large enough for the
    /// friction's slope ([`PlantParams::check_mechanics`], J ≥ h·(Bm + Tc/ω0)/2) and for the coupling
    /// ([`PlantParams::check_coupling`]): with the other defaults at least 2.01e-8.
    pub inertia_kgm2: f64,
    /// Viscous friction Bm [N·m·s/rad]. Default 1.0e-6. Rule: 0..=1, and the speed's step
    /// ([`PlantParams::check_mechanics`]): with the other defaults below 0.042.
    ///
    /// The printed 5e-3 N·m/(rad/s) would need 0.52 N·m (≈ 70 A) at 1000 rpm, impossible for
    /// a motor sensed over 0–0.5 A. 1.0e-6 gives 0.52 mN·m at 5000 rpm; with the Coulomb
    /// drag below the no-load torque is 0.77 mN·m, i.e. ≈ 0.1 A with this motor's torque
    /// constant (≈ 7.6 mN·m/A in 120° drive): typical of optical-drive spindles and leaves
    /// the 0.5 A range for load and acceleration. J/Bm is 1.7 s.
    pub viscous_friction_nms: f64,
    /// Coulomb (bearing) drag torque Tc [N·m], applied as Tc·tanh(ωm/ω0). Default 2.5e-4.
    /// Rule: 0..=1, and the speed's step ([`PlantParams::check_mechanics`]): with the other defaults at most 0.0212.
    ///
    /// Viscous friction alone leaves a rotor held by an aligning current an almost undamped
    /// oscillator (ζ ≈ 0.003 at ≈ 19 Hz with 0.5 A), so the chip's 0.7 s alignment would never
    /// settle. A dry drag torque of 0.25 mN·m removes ≈ 2·Tc/k ≈ 7° electrical of swing per
    /// half cycle, settling a 180° initial error well within the 0.7 s.
    pub coulomb_friction_nm: f64,
    /// Regularisation speed ω0 of the Coulomb drag [rad/s]: below it the drag acts as a
    /// steep viscous term instead of a discontinuity (no stick-slip events). Default 0.5.
    /// Rule: 1e-3..=1e3, and the speed's step ([`PlantParams::check_mechanics`]): with the other defaults at least
    /// 5.89e-3.
    pub coulomb_speed_rad_s: f64,
    /// Back-EMF shape. Default sinusoidal (published).
    pub back_emf: BackEmfShape,
}

impl Default for MotorParams {
    fn default() -> Self {
        MotorParams {
            poles: 12,
            flux_linkage_wb: 7.62e-4,
            self_inductance_h: 0.63e-3,
            mutual_inductance_h: 0.37e-3,
            resistance_ohm: 2.2,
            inertia_kgm2: 17e-7,
            viscous_friction_nms: 1.0e-6,
            coulomb_friction_nm: 2.5e-4,
            coulomb_speed_rad_s: 0.5,
            back_emf: BackEmfShape::Sinusoidal,
        }
    }
}

impl MotorParams {
    /// Checks every rule; the error names the first field that breaks one.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.poles == 0 || self.poles % 2 != 0 || self.poles > 200 {
            return Err(ParamError::new(
                "motor.poles",
                self.poles as f64,
                "must be even and 2..=200",
            ));
        }
        // The bounds hold every motor this model describes with margin; beyond them the
        // numbers overflow or the model's assumptions (a small drive) break down.
        check_range(
            "motor.flux_linkage_wb",
            self.flux_linkage_wb,
            1e-6,
            1.0,
            "must be 1e-6..=1 Wb·turn",
        )?;
        check_range(
            "motor.self_inductance_h",
            self.self_inductance_h,
            1e-7,
            1.0,
            "must be 1e-7..=1 H",
        )?;
        check_non_negative("motor.mutual_inductance_h", self.mutual_inductance_h)?;
        if self.mutual_inductance_h >= self.self_inductance_h {
            return Err(ParamError::new(
                "motor.mutual_inductance_h",
                self.mutual_inductance_h,
                format!(
                    "must be below motor.self_inductance_h = {} (two coils cannot couple more than fully)",
                    self.self_inductance_h
                ),
            ));
        }
        check_range(
            "motor.resistance_ohm",
            self.resistance_ohm,
            1e-4,
            1e3,
            "must be 1e-4..=1e3 Ω",
        )?;
        check_range(
            "motor.inertia_kgm2",
            self.inertia_kgm2,
            1e-9,
            10.0,
            "must be 1e-9..=10 kg·m²",
        )?;
        check_range(
            "motor.viscous_friction_nms",
            self.viscous_friction_nms,
            0.0,
            1.0,
            "must be 0..=1 N·m·s/rad",
        )?;
        check_range(
            "motor.coulomb_friction_nm",
            self.coulomb_friction_nm,
            0.0,
            1.0,
            "must be 0..=1 N·m",
        )?;
        check_range(
            "motor.coulomb_speed_rad_s",
            self.coulomb_speed_rad_s,
            1e-3,
            1e3,
            "must be 1e-3..=1e3 rad/s",
        )?;
        match self.back_emf {
            BackEmfShape::Sinusoidal => {}
            BackEmfShape::Trapezoidal { flat_top_deg } => check_range(
                "motor.back_emf.flat_top_deg",
                flat_top_deg,
                0.0,
                179.0,
                "must be 0..=179 electrical degrees",
            )?,
            BackEmfShape::Harmonic { third, fifth } => {
                check_range(
                    "motor.back_emf.third",
                    third,
                    -1.0,
                    1.0,
                    "must be -1..=1 per unit",
                )?;
                check_range(
                    "motor.back_emf.fifth",
                    fifth,
                    -1.0,
                    1.0,
                    "must be -1..=1 per unit",
                )?;
            }
        }
        Ok(())
    }

    /// Pole pairs P/2.
    pub fn pole_pairs(&self) -> f64 {
        self.poles as f64 / 2.0
    }

    /// Inductance seen by each phase current when the neutral carries no current: Lp + M \[H\].
    pub fn phase_inductance_h(&self) -> f64 {
        self.self_inductance_h + self.mutual_inductance_h
    }
}

/// The highest supply `power_stage.supply_v` takes \[V\]; a supply changed during a run
/// (`BldcPlant::set_supply_v`) stays within it too.
pub const MAX_SUPPLY_V: f64 = 1000.0;

/// Six-switch bridge with anti-parallel diodes and a ground shunt.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PowerStageParams {
    /// Supply V_DD \[V\]. Default 12. Rule: > 0, ≤ 1000.
    ///
    /// Not published. 12 V is the supply of optical-drive spindles; with this motor's
    /// line-to-line back-EMF (≈ 1.3 mV per electrical rad/s) it allows ≈ 15 000 rpm no-load,
    /// which covers the chip's 14-bit speed command, while the current loop keeps the
    /// winding current inside the 0–0.5 A sensing range.
    pub supply_v: f64,
    /// On-resistance of each switch \[Ω\]. Default 0.2. Rule: 0..=10.
    pub switch_on_resistance_ohm: f64,
    /// Diode forward voltage \[V\]. Default 0.7. Rule: 0..=10.
    pub diode_forward_v: f64,
    /// Diode slope resistance \[Ω\]. Default 0.05. Rule: 0..=10.
    pub diode_resistance_ohm: f64,
    /// Current-sense shunt between the low-side switches and ground \[Ω\]. Default 0.25.
    /// Rule: 0..=10, and the current sense's full scale, min(amplifier swing, ADC range)/(gain ×
    /// shunt), must exceed `control.current_limit_a` (`DriveConfig::validate`): with the
    /// other defaults below 0.5. It is part of the power circuit (its drop lifts the low rail).
    pub shunt_ohm: f64,
    /// Dead time inserted before every switch turn-on \[s\]. Default 0 (one switch of a leg
    /// chops, the other stays off). Rule: 0..=10 µs; rounded to whole 20 ns ticks.
    pub dead_time_s: f64,
    /// Which switches chop (`high-side-chop`, `low-side-chop`, `complementary`,
    /// `lone-switch-chop`). Default `lone-switch-chop`, a designer's choice: the published
    /// chip chops the high side only, whose diode freewheeling makes alternate three-phase
    /// states unequal (docs/chip.md, "The chopping"). Rule: `complementary` needs `dead_time_s > 0`, since
    /// it turns one switch of a leg on as the other turns off. Used by the engine, not by
    /// the plant equations.
    pub pwm_scheme: PwmSchemeKind,
}

impl Default for PowerStageParams {
    fn default() -> Self {
        PowerStageParams {
            supply_v: 12.0,
            switch_on_resistance_ohm: 0.2,
            diode_forward_v: 0.7,
            diode_resistance_ohm: 0.05,
            shunt_ohm: 0.25,
            dead_time_s: 0.0,
            pwm_scheme: PwmSchemeKind::LoneSwitchChop,
        }
    }
}

impl PowerStageParams {
    /// Checks every rule.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range(
            "power_stage.supply_v",
            self.supply_v,
            1e-3,
            MAX_SUPPLY_V,
            "must be > 0 and <= 1000 V",
        )?;
        // Upper bounds: far beyond any real part, low enough that the network stays finite.
        // A power switch or diode above 10 Ω, a diode drop above 10 V (SiC body diodes
        // reach ≈ 4 V), or a sense shunt above 10 Ω (milliohms to ≈ 1 Ω) is not a drive.
        check_range(
            "power_stage.switch_on_resistance_ohm",
            self.switch_on_resistance_ohm,
            0.0,
            10.0,
            "must be in 0..=10 Ω (a switch above 10 Ω is no power switch)",
        )?;
        check_range(
            "power_stage.diode_forward_v",
            self.diode_forward_v,
            0.0,
            10.0,
            "must be in 0..=10 V (silicon ≈ 0.7 V, SiC body diodes ≈ 4 V)",
        )?;
        check_range(
            "power_stage.diode_resistance_ohm",
            self.diode_resistance_ohm,
            0.0,
            10.0,
            "must be in 0..=10 Ω (a diode above 10 Ω is no power diode)",
        )?;
        check_range(
            "power_stage.shunt_ohm",
            self.shunt_ohm,
            0.0,
            10.0,
            "must be in 0..=10 Ω (sense shunts are milliohms to about 1 Ω)",
        )?;
        check_range(
            "power_stage.dead_time_s",
            self.dead_time_s,
            0.0,
            10e-6,
            "must be 0..=10e-6 s",
        )?;
        if self.pwm_scheme == PwmSchemeKind::Complementary && self.dead_time().0 == 0 {
            return Err(ParamError::new(
                "power_stage.dead_time_s",
                self.dead_time_s,
                "must be >= 20e-9 s (one tick) with pwm_scheme = complementary",
            ));
        }
        Ok(())
    }

    /// Dead time in master ticks.
    pub fn dead_time(&self) -> Ticks {
        Ticks::from_seconds(self.dead_time_s).unwrap_or(Ticks::ZERO)
    }
}

/// Shunt amplifier, anti-alias filter and ADC (docs/model.md).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CurrentSenseParams {
    /// Amplifier gain [V/V]. Default 80 (0.125 V → 10 V). Rule: 0 < x ≤ 1e4, and the full
    /// scale above `control.current_limit_a` (see `power_stage.shunt_ohm`): with the other
    /// defaults below 160.
    pub amplifier_gain: f64,
    /// Amplifier output swing: the output is clipped to 0..this \[V\]. Default 10. Rule: 0 < x ≤
    /// 100, and the full scale above `control.current_limit_a` (see `power_stage.shunt_ohm`):
    /// with the other defaults above 5.
    pub amplifier_max_v: f64,
    /// First-order low-pass cut-off \[Hz\]. Default 25 000. Rule: 10 Hz ..= 10 MHz.
    pub filter_cutoff_hz: f64,
    /// ADC resolution \[bits\]. Default 12. Rule: 1..=16.
    pub adc_bits: u32,
    /// ADC full scale \[V\]. Default 10. Rule: 0 < x ≤ 100, and the full scale above
    /// `control.current_limit_a` (see `power_stage.shunt_ohm`): with the other defaults above 5.
    pub adc_full_scale_v: f64,
    /// Conversion time \[s\]: samples are taken back to back at this period and each result
    /// becomes readable one period after its sample. Default 20 µs. Rule: 0.1 µs ..= 1 s.
    pub adc_conversion_s: f64,
}

impl Default for CurrentSenseParams {
    fn default() -> Self {
        CurrentSenseParams {
            amplifier_gain: 80.0,
            amplifier_max_v: 10.0,
            filter_cutoff_hz: 25e3,
            adc_bits: 12,
            adc_full_scale_v: 10.0,
            adc_conversion_s: 20e-6,
        }
    }
}

impl CurrentSenseParams {
    /// Checks every rule.
    pub fn validate(&self) -> Result<(), ParamError> {
        // Upper bounds: decades beyond real shunt amplifiers (gains of 10..200 V/V,
        // instrumentation amplifiers up to 1e4; rails up to a few tens of volts).
        check_positive_max(
            "sensing.current.amplifier_gain",
            self.amplifier_gain,
            1e4,
            "must be in (0, 1e4] V/V",
        )?;
        check_positive_max(
            "sensing.current.amplifier_max_v",
            self.amplifier_max_v,
            100.0,
            "must be in (0, 100] V (an amplifier's output swing)",
        )?;
        check_range(
            "sensing.current.filter_cutoff_hz",
            self.filter_cutoff_hz,
            10.0,
            10e6,
            "must be 10 Hz ..= 10 MHz",
        )?;
        if !(1..=16).contains(&self.adc_bits) {
            return Err(ParamError::new(
                "sensing.current.adc_bits",
                self.adc_bits as f64,
                "must be 1..=16",
            ));
        }
        check_positive_max(
            "sensing.current.adc_full_scale_v",
            self.adc_full_scale_v,
            100.0,
            "must be in (0, 100] V (an ADC's input range)",
        )?;
        check_range(
            "sensing.current.adc_conversion_s",
            self.adc_conversion_s,
            0.1e-6,
            1.0,
            "must be 0.1e-6 ..= 1 s",
        )?;
        Ok(())
    }

    /// Conversion period in ticks (at least one).
    pub fn conversion(&self) -> Ticks {
        Ticks(Ticks::from_seconds(self.adc_conversion_s).map_or(1, |t| t.0.max(1)))
    }
}

/// The phase-vs-neutral comparators and their analog front end (docs/model.md).
///
/// Each comparator sees `s_x = y_x − y_n − offset_x + ring_x + noise_x`, where `y_x` and
/// `y_n` are the terminal and neutral voltages through separate first-order RC filters.
/// The defaults are typical of a discrete front end: 1 µs RC with a 5 % mismatch between
/// the phase path and the neutral path, a few mV of offset, 10 mV hysteresis, 100 ns delay.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ComparatorParams {
    /// RC time constant of the phase-terminal paths \[s\]. Default 1.0 µs. Rule: 1 ns ..= 1 ms.
    pub phase_filter_tau_s: f64,
    /// RC time constant of the neutral path \[s\]. Default 1.05 µs (5 % mismatch: a common-mode
    /// step of ΔV leaves a differential spike of ≈ ΔV·0.05/e). Rule: 1 ns ..= 1 ms.
    pub neutral_filter_tau_s: f64,
    /// Input offset per comparator \[V\] (positive: output switches later on a rising input).
    /// Default u +2 mV, v −1.5 mV, w +1 mV. Rule: |offset| ≤ 1 V.
    pub offset_v: Abc<f64>,
    /// Hysteresis, full width \[V\]: the output rises above +h/2 and falls below −h/2.
    /// Default 10 mV. Rule: 0 ..= 1 V.
    pub hysteresis_v: f64,
    /// Propagation delay \[s\], rounded to 20 ns ticks. Default 100 ns. Rule: 0 ..= 100 µs.
    pub delay_s: f64,
    /// Peak input-referred noise \[V\], uniform in ±this, held for `noise_interval_s`.
    /// Default 1 mV (peak-to-peak below the hysteresis, so a clean input never chatters).
    /// Rule: 0 ..= 1 V.
    pub noise_v: f64,
    /// Interval between independent noise samples \[s\] (noise bandwidth ≈ 1/(2·interval)).
    /// Default 0.5 µs. Rule: 20 ns ..= 1 ms, rounded to ticks.
    pub noise_interval_s: f64,
    /// Ringing coupled into every comparator input per volt of switching-node step
    /// [V/V]. Default 0.02. Rule: 0 ..= 1.
    pub ring_gain: f64,
    /// Ringing frequency \[Hz\] (parasitic L–C of the switching node). Default 5 MHz.
    /// Rule: 1 kHz ..= 1 GHz.
    pub ring_frequency_hz: f64,
    /// Ringing decay time constant \[s\]. Default 0.2 µs. Rule: 1 ns ..= 1 ms.
    pub ring_decay_s: f64,
}

impl Default for ComparatorParams {
    fn default() -> Self {
        ComparatorParams {
            phase_filter_tau_s: 1.0e-6,
            neutral_filter_tau_s: 1.05e-6,
            offset_v: Abc {
                u: 2e-3,
                v: -1.5e-3,
                w: 1e-3,
            },
            hysteresis_v: 10e-3,
            delay_s: 100e-9,
            noise_v: 1e-3,
            noise_interval_s: 0.5e-6,
            ring_gain: 0.02,
            ring_frequency_hz: 5e6,
            ring_decay_s: 0.2e-6,
        }
    }
}

impl ComparatorParams {
    /// Checks every rule.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range(
            "sensing.comparator.phase_filter_tau_s",
            self.phase_filter_tau_s,
            1e-9,
            1e-3,
            "must be 1e-9 ..= 1e-3 s",
        )?;
        check_range(
            "sensing.comparator.neutral_filter_tau_s",
            self.neutral_filter_tau_s,
            1e-9,
            1e-3,
            "must be 1e-9 ..= 1e-3 s",
        )?;
        for p in drive_core::Phase::ALL {
            let f = [
                "sensing.comparator.offset_v.u",
                "sensing.comparator.offset_v.v",
                "sensing.comparator.offset_v.w",
            ];
            check_range(
                f[p.index()],
                self.offset_v.get(p),
                -1.0,
                1.0,
                "must be -1 ..= 1 V",
            )?;
        }
        check_range(
            "sensing.comparator.hysteresis_v",
            self.hysteresis_v,
            0.0,
            1.0,
            "must be 0 ..= 1 V",
        )?;
        check_range(
            "sensing.comparator.delay_s",
            self.delay_s,
            0.0,
            100e-6,
            "must be 0 ..= 100e-6 s",
        )?;
        check_range(
            "sensing.comparator.noise_v",
            self.noise_v,
            0.0,
            1.0,
            "must be 0 ..= 1 V",
        )?;
        check_range(
            "sensing.comparator.noise_interval_s",
            self.noise_interval_s,
            20e-9,
            1e-3,
            "must be 20e-9 ..= 1e-3 s",
        )?;
        check_range(
            "sensing.comparator.ring_gain",
            self.ring_gain,
            0.0,
            1.0,
            "must be 0 ..= 1",
        )?;
        check_range(
            "sensing.comparator.ring_frequency_hz",
            self.ring_frequency_hz,
            1e3,
            1e9,
            "must be 1e3 ..= 1e9 Hz",
        )?;
        check_range(
            "sensing.comparator.ring_decay_s",
            self.ring_decay_s,
            1e-9,
            1e-3,
            "must be 1e-9 ..= 1e-3 s",
        )?;
        Ok(())
    }

    /// Propagation delay in ticks.
    pub fn delay(&self) -> Ticks {
        Ticks::from_seconds(self.delay_s).unwrap_or(Ticks::ZERO)
    }

    /// Noise hold interval in ticks (at least one).
    pub fn noise_interval(&self) -> Ticks {
        Ticks(Ticks::from_seconds(self.noise_interval_s).map_or(1, |t| t.0.max(1)))
    }
}

/// All sensing: current channel, comparators, and the seed of every random process.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensingParams {
    /// Shunt-current channel.
    pub current: CurrentSenseParams,
    /// Zero-crossing comparators.
    pub comparator: ComparatorParams,
    /// Seed of the comparator noise. Default 1. The same seed reproduces every glitch.
    pub seed: u64,
}

impl Default for SensingParams {
    fn default() -> Self {
        SensingParams {
            current: CurrentSenseParams::default(),
            comparator: ComparatorParams::default(),
            seed: 1,
        }
    }
}

impl SensingParams {
    /// Checks every rule.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.current.validate()?;
        self.comparator.validate()
    }
}

/// Numerical settings of the plant integrator.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverParams {
    /// Longest step between events \[s\]. Default 80 µs, the PWM period: a step then spans
    /// a whole PWM interval. With the sinusoidal back-EMF the currents are integrated in
    /// closed form (off by 1e-7..1e-6 A per 80 µs step with 0.3 A rising and the rotor
    /// accelerating from standstill, from the speed's change within the step; fourth
    /// order); the other shapes take RK4 steps, whose local error with τe = L/R = 0.45 ms
    /// is ≈ (h/τe)^5/120 ≈ 1.5e-6. The comparators see each voltage along its chord over a
    /// step, and on steps longer than 40 µs (`bldc::CHORD_S`) a floating terminal's back-EMF
    /// as its cubic Hermite interpolant on top (see `sensing::Knot`): crossings agree with
    /// 0.8 µs steps within a tick (`tests/integration/step_fidelity.rs`; chords alone over 80 µs moved
    /// one by 9 ticks at 8000 rpm).
    /// Rule: 0.1 µs ..= 100 µs.
    pub max_step_s: f64,
}

impl Default for SolverParams {
    fn default() -> Self {
        SolverParams { max_step_s: 80e-6 }
    }
}

impl SolverParams {
    /// Checks every rule.
    pub fn validate(&self) -> Result<(), ParamError> {
        check_range(
            "solver.max_step_s",
            self.max_step_s,
            0.1e-6,
            100e-6,
            "must be 0.1e-6 ..= 100e-6 s",
        )
    }
}

/// The largest h·s/J the speed's explicit step takes (see [`PlantParams::check_mechanics`]).
const MAX_MECHANICAL_STEP: f64 = 2.0;

/// Everything the motor + bridge + sensing plant needs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlantParams {
    /// Motor.
    pub motor: MotorParams,
    /// Power stage.
    pub power_stage: PowerStageParams,
    /// Sensing.
    pub sensing: SensingParams,
    /// Integrator.
    pub solver: SolverParams,
}

impl PlantParams {
    /// Checks every rule of every section.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.motor.validate()?;
        self.power_stage.validate()?;
        self.sensing.validate()?;
        self.solver.validate()?;
        self.check_mechanics(0.0, 0.0)?;
        self.check_coupling()
    }

    /// The currents and the speed are coupled through the back-EMF, and a step takes the
    /// speed's change within it to first order: the coupled mode must be slow against the
    /// step. With two phases conducting, k = √3·(P/2)·λr \[V·s/rad\] (line-to-line EMF
    /// and torque constant), R_loop = 2R and L_loop = 2(Lp + M), the mode is
    /// s² + (R_loop/L_loop)·s + k²/(L_loop·J) = 0: an oscillation at ωn = k/√(L_loop·J)
    /// when underdamped, a decay at 1/τm = k²/(R_loop·J) when the winding is fast. Both
    /// must stay within 2/h for h = `solver.max_step_s`. The built-in motor is at h·ωn ≈
    /// 0.01; a flux linkage of 1 Wb·turn on its rotor (h·ωn ≈ 14) left the reals.
    pub fn check_coupling(&self) -> Result<(), ParamError> {
        let m = &self.motor;
        let k = 3f64.sqrt() * m.pole_pairs() * m.flux_linkage_wb;
        let (r, l) = (2.0 * m.resistance_ohm, 2.0 * m.phase_inductance_h());
        let omega_n = k / (l * m.inertia_kgm2).sqrt();
        let inv_tau = k * k / (r * m.inertia_kgm2);
        let product = self.solver.max_step_s * omega_n.max(inv_tau);
        if product > MAX_MECHANICAL_STEP {
            return Err(ParamError::new(
                "motor.flux_linkage_wb",
                m.flux_linkage_wb,
                format!(
                    "too strong a coupling for the step, a rule of seven keys together: with k = √3·(motor.poles/2)·motor.flux_linkage_wb, solver.max_step_s × max(k/√(2(motor.self_inductance_h + motor.mutual_inductance_h)·motor.inertia_kgm2), k²/(2·motor.resistance_ohm·motor.inertia_kgm2)) must be <= 2, here {product:.3} (lower the flux linkage or solver.max_step_s, raise the resistance or the inertia)"
                ),
            ));
        }
        Ok(())
    }

    /// The speed's explicit step must be stable: with every drag torque's slope over speed
    /// at its steepest, s = Bm + Tc/ω0 + `load_slope` [N·m·s/rad], and the inertia
    /// J + `load_inertia`, it needs h·s/(J + J_L) <= 2 for h = `solver.max_step_s` (RK4
    /// is stable to 2.78 on the real axis). A rotor too light for its friction would
    /// otherwise oscillate about standstill, then leave the reals.
    pub fn check_mechanics(&self, load_slope: f64, load_inertia: f64) -> Result<(), ParamError> {
        let m = &self.motor;
        let slope = m.viscous_friction_nms + m.coulomb_friction_nm / m.coulomb_speed_rad_s;
        let j = m.inertia_kgm2 + load_inertia;
        let product = self.solver.max_step_s * (slope + load_slope) / j;
        if product > MAX_MECHANICAL_STEP {
            let (field, value) = if load_slope > 0.0 {
                ("load", load_slope)
            } else {
                ("motor.inertia_kgm2", m.inertia_kgm2)
            };
            return Err(ParamError::new(
                field,
                value,
                format!(
                    "too stiff for the step, a rule of several keys together: solver.max_step_s × (motor.viscous_friction_nms + motor.coulomb_friction_nm / motor.coulomb_speed_rad_s + the load's slope) / (motor.inertia_kgm2 + the load's inertia) must be <= 2, here {product:.3} (raise the inertia or motor.coulomb_speed_rad_s, lower solver.max_step_s or the friction, or lighten the load)"
                ),
            ));
        }
        Ok(())
    }
}
