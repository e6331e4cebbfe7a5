//! Controller and strategy parameters: the `[control]` and `[strategy]` config sections.
//!
//! Quantities are in the units the chip works in where the chip fixes them (rpm for speed,
//! carrier counts for the voltage command) and in SI units elsewhere. Every field states its
//! unit, default and rule; [`ControlParams::validate`] and [`StrategyParams::validate`] name
//! the first field that breaks a rule.

use drive_core::error::{ParamError, check_range};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Largest speed command the chip's 14-bit speed register holds \[rpm\].
pub const SPEED_CMD_MAX_RPM: f64 = 16_383.0;

/// Speed and current control, start-up and supervision (`[control]`).
///
/// How the default gains were chosen: the "current" the chip regulates is the shunt (DC-link)
/// current, ≈ duty × phase current, read by one ADC sample per 5.24 ms PI update, so the
/// current loop is an averaging loop: with ≈ 2.7e-4 A of shunt current per carrier count
/// near 3000 rpm, Ki = 600 counts/(A·update) gives a per-update loop gain ≈ 0.16 (settling in
/// ≈ 6 updates, ≈ 30 ms) and Kp = 300 keeps the sampled PWM ripple from dominating the
/// command. The speed measurement spans 10 FG periods (33 ms at 3000 rpm) and is the
/// dominant delay, so the speed loop crosses over at a few rad/s: ≈ 2e5 rpm/s per ampere
/// of shunt current at light load times Kp = 5e-5 A/rpm gives ≈ 10 rad/s, with the PI zero
/// a decade below (Ki = 1e-6 per update ≈ 1.9e-4 A/(rpm·s)). Verified on the built-in motor:
/// a 3000 rpm step from standstill settles within ±1 % in ≈ 1 s after hand-over.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ControlParams {
    /// Speed command ωc \[rpm\]. Default 3000. Rule: 0..=16383 (14-bit register).
    pub speed_ref_rpm: f64,
    /// Speed PI proportional gain [A/rpm]. Default 5.0e-5. Rule: 0..=1.
    pub speed_kp: f64,
    /// Speed PI integral gain per PI update [A/(rpm·update)]. Default 1.0e-6. Rule: 0..=1.
    /// The continuous-time equivalent is this divided by the PI period (5.24 ms).
    pub speed_ki: f64,
    /// Current PI proportional gain [carrier counts/A]. Default 300. Rule: 0..=1e6.
    pub current_kp: f64,
    /// Current PI integral gain per PI update [carrier counts/(A·update)]. Default 600.
    /// Rule: 0..=1e6.
    pub current_ki: f64,
    /// Current command limit: output and integrator saturation of the speed PI \[A\].
    /// Default 0.25. It must stay below the current sense's full scale (0.5 A with the
    /// default sensing: the amplifier clips at 10 V), or a clipped reading can never exceed
    /// the command and the current loop stops limiting. Rule: 0 < x ≤ 10, at least
    /// `start_current_a` and below the full scale, min(`sensing.current.amplifier_max_v`,
    /// `sensing.current.adc_full_scale_v`)/(`sensing.current.amplifier_gain` ×
    /// `power_stage.shunt_ohm`): with the other defaults at least 0.15 and below 0.5.
    pub current_limit_a: f64,
    /// Current command from the hand-over until the first FG speed measurement \[A\]: the
    /// speed PI has nothing to act on before it. Default 0.15. Rule: 0 < x ≤
    /// `current_limit_a` (with the other defaults at most 0.25). Too much and the shifter, which times each commutation from the
    /// previous 60° interval, falls behind a rotor accelerating from near standstill.
    pub start_current_a: f64,
    /// Back-calculation anti-windup on the current PI (the chip's). Default true.
    /// It acts only where the voltage command saturates at full duty, i.e. near top speed:
    /// below it the current PI reaches `current_limit_a` with duty to spare.
    pub anti_windup: bool,
    /// Back-calculation gain k_s of the current PI: the integrator input is reduced by
    /// k_s·(uc − limit) \[1\]. Default 32 (the chip's). Rule: 0..=1024.
    pub anti_windup_gain: f64,
    /// Back-calculation anti-windup on the speed PI, at the current-command limit
    /// `current_limit_a`. The chip has none there (its speed PI only clamps the integrator
    /// at the limit), yet this is the PI that saturates in large speed steps and under
    /// loads it cannot carry, and unwinding a clamped integrator takes seconds at the
    /// scheduled gains. Default true (a designer's choice); false gives the published chip.
    /// (A start from standstill does not saturate it with the shipped gains: its +10 %
    /// overshoot comes from the integrator building while the rotor runs up.)
    pub speed_anti_windup: bool,
    /// Back-calculation gain of the speed PI \[1\]: ui(k) = sat(ui(k−1) + Ki·e −
    /// k·(uc − limit)). Default 1: the integrator lands exactly on limit − Kp·e, the output
    /// on the limit; above 2 the per-update correction overshoots that point by more than
    /// the excess it removes. Rule: 0 < x ≤ 2.
    pub speed_anti_windup_gain: f64,
    /// Voltage command during alignment and start-up [fraction of the carrier top, 0..1].
    /// Default 0.2 (≈ 0.5 A into a locked phase pair at 12 V). Rule: 0 < x ≤ 1.
    pub startup_duty: f64,
    /// Alignment by current (not in the published chip): the phase current the first
    /// alignment step regulates to \[A\]. The chip starts that step at zero duty and, at
    /// every PI update, moves the duty by [`ALIGN_GAIN`] per ampere of error in the phase
    /// current it infers from the averaged shunt reads, î = i_shunt/d (the shunt carries
    /// the phase current in the on-time alone); the duty reached at the end of the step is
    /// held for the other two. A fixed `startup_duty` gives a current ≈ (d·V_DD − V_diode)/
    /// (2R): 1.6 A on a 0.4 Ω winding against 0.39 A on the built-in 2.2 Ω one, and the
    /// rotor's swing between the timed steps v→w and v→u (its period ∝ 1/√I) then lands it
    /// anywhere at the hand-over (docs/chip.md, "Start-up"). Default 0.39 (what 20 % duty
    /// gives on the built-in motor, so it aligns as before). 0 gives the published chip:
    /// `startup_duty` throughout. Rule: 0 or 0.01..=10.
    ///
    /// [`ALIGN_GAIN`]: crate::chip::ALIGN_GAIN
    pub align_current_a: f64,
    /// Start-up current command as a phase current (not in the published chip) \[A\]:
    /// from the hand-over to the first speed measurement the current command is
    /// d·`start_phase_current_a` (d the duty in force) instead of `start_current_a`, so the
    /// torque, ∝ the phase current ≈ i_shunt/d, and the rotor's first acceleration do not
    /// depend on the winding's resistance. A fixed shunt command i_s needs a phase current
    /// ≈ √(i_s·(V_DD/2R)) near standstill: 2.3 times the built-in motor's on a 0.4 Ω
    /// winding, and the rotor then outruns the hand-over's assumed t_60
    /// (`handover_t60_s`), which times the first commutations. Capped at
    /// `current_limit_a`. Default 0.55 (what `start_current_a` gives on the built-in
    /// motor). 0 gives the published chip: `start_current_a`. Rule: 0 or 0.01..=10.
    pub start_phase_current_a: f64,
    /// Durations of the three alignment steps u→v, v→w, v→u \[s\]; each is rounded to the
    /// align clock (327.68 µs). Default [0.7, 0.038, 0.015] (docs/chip.md). Rule: each in
    /// 0.000 327 68..=10.
    pub align_s: [f64; 3],
    /// Time the floating-phase crossing logic assumes for the first 60° after the hand-over
    /// to closed loop, before it has measured one \[s\]. Default 0.0119: the time the
    /// rotor takes from rest through 60° under the start current's torque,
    /// √(2·(π/3)·J/(p·Kt·i)), on the built-in motor at 0.55 A (`drive-bench tune` writes it
    /// for a motor; `bldc_drive::tune::first_sector_s`). The published chip's 0.015 is that
    /// time at ≈ 0.35 A. Rule: 1e-5..=0.02 (the 15-bit 0.64 µs counter holds at most
    /// 20.97 ms).
    pub handover_t60_s: f64,
    /// Crossing confirmation from the hand-over until the first FG speed measurement
    /// [whole electrical degrees]: a crossing needs the post-crossing level to dominate
    /// the comparator for this angle of the last 60° time (an up/down count of 0.64 µs
    /// clocks), and is then dated back to where that began. Near standstill the back-EMF
    /// is smaller than the comparator's PWM-edge glitches, which outlast the digital
    /// filter; without this a glitch taken at the earliest plausible instant shortens
    /// t_60 by a quarter per sector, a runaway the rotor cannot follow. Default 2 (a glitch
    /// of a few µs per PWM edge never fills 2° of a start-up sector, ≥ 20 µs below 1700
    /// rpm). 0 turns it off. Rule: 0..=15.
    pub startup_confirm_deg: u32,
    /// Conduction angle of the twelve-step strategies from the hand-over until the first
    /// FG speed measurement [electrical degrees], when it is narrower than
    /// `strategy.conduction_angle_deg`; the configured angle takes over at the first
    /// crossing after that measurement. A wide angle leaves a short floating window
    /// (180° − angle: 15° at 165°) that, at start-up speeds, begins before the rotor has
    /// reached it when the commutation timing, still learning t_60, is late, so the
    /// crossing is missed. Default 150 (the chip's). Rule: 120 ≤ x < 180.
    pub startup_conduction_deg: f64,
    /// Step-miss limit: FG_c unchanged for longer than this raises an error and restarts
    /// \[s\]. Default 0.05 (below 100 rpm). Rule: 0.001..=10.
    pub step_miss_s: f64,
    /// Restarts allowed before the drive gives up and stays off. Default 5. Rule: ≤ 1000.
    pub max_restarts: u32,
    /// FG periods per speed measurement k. Default 10. Rule: 1..=100.
    pub speed_periods: u32,
    /// Plausibility supervisor (not in the published chip; see `supervisor.rs`): restarts
    /// when the measured current could not flow against the back-EMF of the speed the chip
    /// believes, when a coast speeds up, or when the comparator shows no crossing for
    /// `supervisor_blind_sectors` in a row. Default true; false gives the chip as published.
    pub supervisor: bool,
    /// The motor's no-load speed at full voltage ω₀ = V_DD/k_e, as the supervisor assumes it
    /// \[rpm\] (a datasheet figure; k_e the mean line-to-line back-EMF per rpm over a 60°
    /// conduction, (3/π)·√3·λr·(P/2)·2π/60). Default 15150: the built-in motor at 12 V
    /// (k_e = 0.792 mV/rpm). Rule: 100..=1e6.
    pub supervisor_no_load_rpm: f64,
    /// Fraction f of the believed back-EMF the applied voltage must reach for a measured
    /// current to be plausible \[1\]. Default 0.5 (room for drops and a wrong ω₀).
    /// Rule: 0 < x ≤ 1.
    pub supervisor_emf_fraction: f64,
    /// Smallest measured current that proves conduction \[A\]. Default 0.01 (82 ADC codes
    /// with the default sensing, 4 % of the current limit). Rule: 0 < x ≤ 10.
    pub supervisor_current_a: f64,
    /// Locked-rotor current at full voltage the supervisor assumes, V_DD/(2R) \[A\] (a
    /// datasheet figure). Default 2.73: the built-in motor at 12 V (R = 2.2 Ω).
    /// Rule: 0 < x ≤ 1000.
    pub supervisor_locked_rotor_a: f64,
    /// Share of the locked-rotor current at the duty in force, d·I_lr, that a measured
    /// current must reach to count as implausible under twelve-step \[1\]. Default 0.03 (a decelerating
    /// twelve-step drive passes ≈ 1.5 %, a rotor standing still 3–30 %). Rule: 0..=1.
    pub supervisor_locked_share: f64,
    /// PI updates the supervisor looks back over; it trips when half of them were
    /// implausible. Default 8 (42 ms). Rule: 2..=32.
    pub supervisor_updates: u32,
    /// Rise of the FG speed measurement above the lowest of a coast (no current asked, none
    /// measured) that trips the supervisor \[fraction\]. Default 0.25. Rule: 0.01..=10.
    pub supervisor_coast_rise: f64,
    /// Crossings in a row taken by the demagnetisation timeout, never shown by the
    /// comparator, that trip the supervisor \[count\]: the commutation then free-runs at
    /// a frozen rate, blind to the rotor. Default 12 (two electrical turns; healthy runs
    /// are at most 5 long, a rotor accelerating under the current limit slips 30° in
    /// ≈ 40). Rule: 2..=1000.
    pub supervisor_blind_sectors: u32,
    /// Width of the speed counter (2.56 µs counts) \[bits\]. Default 15 (the chip's "counters 15
    /// bit"): it saturates at 32767 counts, so with k = 10 and 12 poles the lowest speed it
    /// can read is 39 062 500 / 32767 ≈ 1192 rpm. Rule: 8..=32.
    pub speed_counter_bits: u32,
    /// ADC reads of the shunt current averaged per PI update \[count\]: n reads spaced
    /// (m + 1/n) carrier periods apart on the 0.64 µs clock (m the most whole periods that
    /// keep them inside one PI period), the last at the update. 1 is the published chip:
    /// the newest conversion at the update alone. The shunt carries current only in the
    /// PWM on-time, so one read sees the on-time or the off-time according to where it
    /// falls in the carrier, and with the 5.24 ms update at 65.536 carrier periods that
    /// place moves by 0.536 of a period per update: the read alternates between them (a
    /// period-2 zig-zag of the voltage command) under a 13.7 Hz beat (the aliases of the
    /// carrier's first two harmonics: 88.6, 102.1 and 13.7 Hz; docs/chip.md, "The current
    /// read"). n reads 1/n of a period apart in its phase take every carrier phase once,
    /// and spread over the update they sample the commutation ripple at n instants, so
    /// its alias shrinks as 1/√n. Default 16. Rule: 1..=64.
    pub current_reads: u32,
    /// Longest span of one speed measurement \[s\]: a measurement ends after
    /// `speed_periods` FG periods or at the first FG edge past this, whichever comes first
    /// (`strategies/src/speed.rs`). 0 is the published chip (k periods always): its reading
    /// then spans k/(P/2) mechanical turns, 0.33 s at 300 rpm, and the speed loop behind it
    /// loses its phase margin as the speed falls. Default 0.02 (6 periods at 3000 rpm, one at
    /// and below 500 rpm on the built-in motor). Rule: 0 or 1e-3..=1.
    pub speed_window_s: f64,
    /// Gain schedule on the measured speed (not the published chip's). The speed loop's
    /// plant gain, torque per ampere of the shunt current it commands, is Kt/d (the shunt
    /// carries the phase current only in the PWM on-time), and the current loop's,
    /// ∂i_shunt/∂cv ≈ I_lr·d/top, is d-fold: over the speed range d spans 0.02..1, so fixed
    /// gains are either unstable at low speed or sluggish at high speed. With the schedule
    /// the chip scales the speed PI's error by d̂ and the current PI's by 1/d̂, where d̂ is
    /// the duty the measured speed n̂ (the meter's, or the last 60° interval's before its
    /// first reading) needs at the last current command i: d̂ = a + i/(d̂·I_lr) with
    /// a = n̂/`supervisor_no_load_rpm` and I_lr = `supervisor_locked_rotor_a`, clamped to
    /// [`schedule_min_duty`, 1]; so `speed_kp`, `speed_ki`, `current_kp` and `current_ki` are the gains at
    /// full duty and the loops keep their margins at every speed (`drive-bench tune`,
    /// docs/chip.md "Loop design"). Default true; false gives the published fixed gains.
    pub gain_schedule: bool,
    /// Lowest duty d̂ the gain schedule assumes \[1\]: it bounds the current PI's gain
    /// (1/d̂-fold) at standstill with no current asked. Default 0.03. Rule: 1e-3..=1.
    pub schedule_min_duty: f64,
    /// A speed command of 0 means stop (not the published chip's): the chip switches the
    /// bridge off (flag 0110), lets the rotor coast to rest and does not start, align or
    /// restart until the command rises above 0, whereupon it starts as from power-on.
    /// The published chip keeps commutating at a command of 0 (the speed PI asks no
    /// current): the rotor coasts, and below ≈ 250 rpm the comparator's PWM-edge spikes
    /// outrun its back-EMF, so it commutates on false crossings at a rate of its own (on
    /// the built-in drive 200 µs a sector, read as ≈ 8 300 rpm on a rotor at rest), FG
    /// keeps toggling so step miss never fires, and the supervisor (or nothing, without
    /// it) restarts a rotor it was told to stop. Default true.
    pub stop_at_zero: bool,
    /// The speed PI resumes where it left off after a fall (not the published chip's).
    /// The PI asks no negative torque, so on a step down it sits at its lower limit (0 A)
    /// and the rotor coasts on its friction while the error drains both integrators; when
    /// the measured speed comes back below the command, the published PIs rebuild the
    /// friction's current from 0, at the low-speed gains, behind a meter one FG period
    /// late, and twelve-step loses a step 3000 → 600 rpm below its floor. With this on,
    /// the first update that leaves the lower limit presets the speed PI's integrator to
    /// the phase current it held at its last update off both limits (as the shunt current
    /// d̂ × that, d̂ the gain schedule's duty at the measured speed) and the current PI's
    /// to the duty d̂: the load that needed that current before the fall is assumed to
    /// need it after. Only with a guard without a linear region (raw or DF, six-step's
    /// default): ND's and LM's windows drive the rotor beside the current. Default true.
    pub speed_resume: bool,
    /// After a start that ran past the command, the speed PI's reference follows the rotor
    /// down no faster than this \[rpm/s\] (not the published chip's, 0, which turns it
    /// off). The start current runs the rotor past a low command before the first speed
    /// measurement (to ≈ 1000 rpm on the built-in drive), and no current was held yet to
    /// resume (`speed_resume`): the rotor coasted back through the command with the PI
    /// asking nothing, and twelve-step lost a start straight to 600 rpm. A reference
    /// falling slower than the rotor coasts keeps the PI asking current all the way down.
    /// Default 562: 0.4 of the built-in rotor's coast on its Coulomb friction, Tc/J
    /// (`drive-bench tune` writes it for a motor). Rule: 0 (off) or 1..=1e6.
    pub start_descent_rpm_s: f64,
    /// Peak count of the PWM carrier, which counts up and down at the 50 MHz master
    /// clock: the PWM frequency is 25 MHz / this \[counts\]. Default 2000 (12.5 kHz, the
    /// chip's). The voltage command and the current PI's gains are in these counts, so at
    /// another top the same gains give another duty per ampere (scale `current_kp` and
    /// `current_ki` by top/2000 to keep it). Rule: 500..=4095 (a 12-bit counter, 6.1 kHz;
    /// at 50 kHz the 2 µs spike each PWM edge leaves fills a fifth of the period).
    pub carrier_top: u32,
}

impl Default for ControlParams {
    fn default() -> Self {
        ControlParams {
            speed_ref_rpm: 3000.0,
            speed_kp: 2.610e-4,
            speed_ki: 4.105e-6,
            current_kp: 0.0,
            current_ki: 203.3,
            current_limit_a: 0.25,
            start_current_a: 0.15,
            anti_windup: true,
            anti_windup_gain: 32.0,
            speed_anti_windup: true,
            speed_anti_windup_gain: 1.0,
            startup_duty: 0.2,
            align_current_a: 0.39,
            start_phase_current_a: 0.55,
            align_s: [0.7, 0.038, 0.015],
            handover_t60_s: 0.0119,
            startup_confirm_deg: 2,
            startup_conduction_deg: 150.0,
            step_miss_s: 0.05,
            max_restarts: 5,
            supervisor: true,
            supervisor_no_load_rpm: 15150.0,
            supervisor_emf_fraction: 0.5,
            supervisor_current_a: 0.01,
            supervisor_locked_rotor_a: 2.73,
            supervisor_locked_share: 0.03,
            supervisor_updates: 8,
            supervisor_coast_rise: 0.25,
            supervisor_blind_sectors: 12,
            speed_periods: 10,
            speed_counter_bits: 15,
            current_reads: 16,
            speed_window_s: 0.02,
            gain_schedule: true,
            schedule_min_duty: 0.03,
            stop_at_zero: true,
            speed_resume: true,
            start_descent_rpm_s: 562.0,
            carrier_top: 2000,
        }
    }
}

impl ControlParams {
    /// Checks every rule; the error names the first field that breaks one.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.check_loops()?;
        self.check_start_up()?;
        self.check_supervision()?;
        self.check_meters()?;
        Ok(())
    }

    /// The speed and current PIs: the command, gains, limits and anti-windup.
    fn check_loops(&self) -> Result<(), ParamError> {
        check_range(
            "control.speed_ref_rpm",
            self.speed_ref_rpm,
            0.0,
            SPEED_CMD_MAX_RPM,
            "must be in 0..=16383 rpm (14-bit speed register)",
        )?;
        // Gain bounds: 3 to 6 decades above the defaults, where one update's action on the
        // smallest error the loop can see already spans its whole output (10 A; 2000
        // carrier counts), so a larger gain only feeds non-finite arithmetic.
        check_range(
            "control.speed_kp",
            self.speed_kp,
            0.0,
            1.0,
            "must be in 0..=1 A/rpm (1 rpm of error commands 1 A)",
        )?;
        check_range(
            "control.speed_ki",
            self.speed_ki,
            0.0,
            1.0,
            "must be in 0..=1 A/(rpm·update)",
        )?;
        check_range(
            "control.current_kp",
            self.current_kp,
            0.0,
            1e6,
            "must be in 0..=1e6 counts/A (1 mA of error commands half the carrier)",
        )?;
        check_range(
            "control.current_ki",
            self.current_ki,
            0.0,
            1e6,
            "must be in 0..=1e6 counts/(A·update)",
        )?;
        if !(self.current_limit_a > 0.0 && self.current_limit_a <= 10.0) {
            return Err(ParamError::new(
                "control.current_limit_a",
                self.current_limit_a,
                "must be in (0, 10] A",
            ));
        }
        if !(self.start_current_a > 0.0 && self.start_current_a <= self.current_limit_a) {
            return Err(ParamError::new(
                "control.start_current_a",
                self.start_current_a,
                format!(
                    "must be in (0, control.current_limit_a] A, control.current_limit_a = {}",
                    self.current_limit_a
                ),
            ));
        }
        check_range(
            "control.anti_windup_gain",
            self.anti_windup_gain,
            0.0,
            1024.0,
            "must be in 0..=1024",
        )?;
        if !(self.speed_anti_windup_gain > 0.0 && self.speed_anti_windup_gain <= 2.0) {
            return Err(ParamError::new(
                "control.speed_anti_windup_gain",
                self.speed_anti_windup_gain,
                "must be in (0, 2] (above 2 each update over-corrects the integrator)",
            ));
        }
        Ok(())
    }

    /// The start-up: alignment, open-loop ramp and hand-over.
    fn check_start_up(&self) -> Result<(), ParamError> {
        if !(self.startup_duty > 0.0 && self.startup_duty <= 1.0) {
            return Err(ParamError::new(
                "control.startup_duty",
                self.startup_duty,
                "must be in (0, 1] (fraction of the carrier top)",
            ));
        }
        for (name, x) in [
            ("control.align_current_a", self.align_current_a),
            ("control.start_phase_current_a", self.start_phase_current_a),
        ] {
            if !(x == 0.0 || (0.01..=10.0).contains(&x)) {
                return Err(ParamError::new(
                    name,
                    x,
                    "must be 0 (off) or in 0.01..=10 A",
                ));
            }
        }
        for (k, &d) in self.align_s.iter().enumerate() {
            let field = [
                "control.align_s[0]",
                "control.align_s[1]",
                "control.align_s[2]",
            ][k];
            check_range(
                field,
                d,
                327.68e-6,
                10.0,
                "must be in 327.68e-6..=10 s (at least one align-clock period)",
            )?;
        }
        check_range(
            "control.handover_t60_s",
            self.handover_t60_s,
            1e-5,
            0.02,
            "must be in 1e-5..=0.02 s (the 15-bit 0.64 µs counter)",
        )?;
        if self.startup_confirm_deg > 15 {
            return Err(ParamError::new(
                "control.startup_confirm_deg",
                self.startup_confirm_deg,
                "must be 0..=15 electrical degrees",
            ));
        }
        if !(self.startup_conduction_deg.is_finite()
            && (120.0..180.0).contains(&self.startup_conduction_deg))
        {
            return Err(ParamError::new(
                "control.startup_conduction_deg",
                self.startup_conduction_deg,
                "must be in 120 <= x < 180 electrical degrees",
            ));
        }
        Ok(())
    }

    /// Restarts and the supervisor.
    fn check_supervision(&self) -> Result<(), ParamError> {
        check_range(
            "control.step_miss_s",
            self.step_miss_s,
            0.001,
            10.0,
            "must be in 0.001..=10 s",
        )?;
        if self.max_restarts > 1000 {
            return Err(ParamError::new(
                "control.max_restarts",
                self.max_restarts,
                "must be <= 1000",
            ));
        }
        check_range(
            "control.supervisor_no_load_rpm",
            self.supervisor_no_load_rpm,
            100.0,
            1e6,
            "must be in 100..=1e6 rpm",
        )?;
        if !(self.supervisor_emf_fraction > 0.0 && self.supervisor_emf_fraction <= 1.0) {
            return Err(ParamError::new(
                "control.supervisor_emf_fraction",
                self.supervisor_emf_fraction,
                "must be in (0, 1]",
            ));
        }
        if !(self.supervisor_current_a > 0.0 && self.supervisor_current_a <= 10.0) {
            return Err(ParamError::new(
                "control.supervisor_current_a",
                self.supervisor_current_a,
                "must be in (0, 10] A",
            ));
        }
        if !(self.supervisor_locked_rotor_a > 0.0 && self.supervisor_locked_rotor_a <= 1000.0) {
            return Err(ParamError::new(
                "control.supervisor_locked_rotor_a",
                self.supervisor_locked_rotor_a,
                "must be in (0, 1000] A",
            ));
        }
        check_range(
            "control.supervisor_locked_share",
            self.supervisor_locked_share,
            0.0,
            1.0,
            "must be in 0..=1",
        )?;
        check_range(
            "control.supervisor_updates",
            f64::from(self.supervisor_updates),
            2.0,
            32.0,
            "must be in 2..=32 PI updates",
        )?;
        check_range(
            "control.supervisor_coast_rise",
            self.supervisor_coast_rise,
            0.01,
            10.0,
            "must be in 0.01..=10",
        )?;
        check_range(
            "control.supervisor_blind_sectors",
            f64::from(self.supervisor_blind_sectors),
            2.0,
            1000.0,
            "must be in 2..=1000 crossings",
        )?;
        Ok(())
    }

    /// The current reads, the gain schedule, the speed meter and the carrier.
    fn check_meters(&self) -> Result<(), ParamError> {
        check_range(
            "control.current_reads",
            f64::from(self.current_reads),
            1.0,
            64.0,
            "must be in 1..=64 reads per PI update",
        )?;
        check_range(
            "control.schedule_min_duty",
            self.schedule_min_duty,
            1e-3,
            1.0,
            "must be in 1e-3..=1 (a fraction of full duty)",
        )?;
        if !(self.start_descent_rpm_s == 0.0 || (1.0..=1e6).contains(&self.start_descent_rpm_s)) {
            return Err(ParamError::new(
                "control.start_descent_rpm_s",
                self.start_descent_rpm_s,
                "must be 0 (off) or in 1..=1e6 rpm/s",
            ));
        }
        if !(self.speed_window_s == 0.0 || (1e-3..=1.0).contains(&self.speed_window_s)) {
            return Err(ParamError::new(
                "control.speed_window_s",
                self.speed_window_s,
                "must be 0 (off) or in 1e-3..=1 s",
            ));
        }
        check_range(
            "control.speed_periods",
            f64::from(self.speed_periods),
            1.0,
            100.0,
            "must be in 1..=100 FG periods",
        )?;
        check_range(
            "control.speed_counter_bits",
            f64::from(self.speed_counter_bits),
            8.0,
            32.0,
            "must be in 8..=32 bits",
        )?;
        check_range(
            "control.carrier_top",
            f64::from(self.carrier_top),
            500.0,
            4095.0,
            "must be in 500..=4095 counts (6.1 to 50 kHz PWM)",
        )?;
        Ok(())
    }
}

/// A built-in strategy name, as used by every front end (bench, FMU, config).
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum StrategyName {
    /// 120° six-step with the two-counter phase shifter (guard from `strategy.guard`).
    SixStep120,
    /// Twelve-step (150° by default) without a guard.
    TwelveStepRaw,
    /// Twelve-step with a fixed linear region.
    TwelveStepNd,
    /// Twelve-step with a speed-modulated linear region.
    TwelveStepLm,
    /// Twelve-step with the digital filter.
    TwelveStepDf,
}

impl StrategyName {
    /// Every built-in strategy, in the order front ends list them.
    pub const ALL: [StrategyName; 5] = [
        StrategyName::SixStep120,
        StrategyName::TwelveStepRaw,
        StrategyName::TwelveStepNd,
        StrategyName::TwelveStepLm,
        StrategyName::TwelveStepDf,
    ];

    /// The name used on the command line and in config files.
    pub fn as_str(self) -> &'static str {
        match self {
            StrategyName::SixStep120 => "six-step-120",
            StrategyName::TwelveStepRaw => "twelve-step-raw",
            StrategyName::TwelveStepNd => "twelve-step-nd",
            StrategyName::TwelveStepLm => "twelve-step-lm",
            StrategyName::TwelveStepDf => "twelve-step-df",
        }
    }

    /// The guard a twelve-step name fixes (`None` for six-step, which takes `strategy.guard`).
    pub fn fixed_guard(self) -> Option<GuardKind> {
        match self {
            StrategyName::SixStep120 => None,
            StrategyName::TwelveStepRaw => Some(GuardKind::Raw),
            StrategyName::TwelveStepNd => Some(GuardKind::Nd),
            StrategyName::TwelveStepLm => Some(GuardKind::Lm),
            StrategyName::TwelveStepDf => Some(GuardKind::Df),
        }
    }
}

impl fmt::Display for StrategyName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A strategy name that is not built in.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown strategy `{0}` (rule: one of six-step-120, twelve-step-raw, twelve-step-nd, twelve-step-lm, twelve-step-df)"
)]
pub struct UnknownStrategy(pub String);

impl FromStr for StrategyName {
    type Err = UnknownStrategy;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        StrategyName::ALL
            .into_iter()
            .find(|n| n.as_str() == s)
            .ok_or_else(|| UnknownStrategy(s.to_string()))
    }
}

impl Serialize for StrategyName {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for StrategyName {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// Which zero-crossing guard protects the floating-phase comparator from PWM edges.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GuardKind {
    /// No guard: the raw comparator output is trusted (shows the problem).
    Raw,
    /// Fixed linear region of `strategy.linear_region_deg` before each expected crossing.
    Nd,
    /// Linear region shrunk with the measured speed (docs/chip.md).
    Lm,
    /// Digital filter of `strategy.filter_samples` flip-flops and an RS latch.
    Df,
}

impl GuardKind {
    /// The short name used in strategy names and config.
    pub fn as_str(self) -> &'static str {
        match self {
            GuardKind::Raw => "raw",
            GuardKind::Nd => "nd",
            GuardKind::Lm => "lm",
            GuardKind::Df => "df",
        }
    }
}

/// Commutation strategy and its zero-crossing guard (`[strategy]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StrategyParams {
    /// Built-in strategy. Default `twelve-step-df`.
    pub name: StrategyName,
    /// Guard of `six-step-120`. Default `df`. Rule: only with six-step-120 (the
    /// twelve-step names fix their guard).
    pub guard: Option<GuardKind>,
    /// Conduction angle of the twelve-step strategies [electrical degrees]: each phase
    /// conducts this long per half cycle, from its own crossing on; the floating window
    /// before each crossing is 180° − angle. Default 150 (the chip). Rule: 120 ≤ x < 180
    /// (at 180° nothing floats, so nothing can be sensed); twelve-step names only.
    pub conduction_angle_deg: Option<f64>,
    /// Linear-region window θZC before each expected crossing [whole electrical degrees]
    /// (`nd`; the upper end of `lm`). Default 15. Rule: 1..=60.
    pub linear_region_deg: u32,
    /// ωM: speed from which `lm` uses the full window \[rpm\]. Default 13430: from
    /// `drive-bench calibrate-lm` on the built-in motor, where a 14° window keeps
    /// synchronism up to the top speed 12 V allows, so the full window is never needed
    /// below it and ωM is that top speed. Rule: > ωm (with the other defaults at least 552),
    /// ≤ 16383.
    pub lm_speed_max_rpm: u32,
    /// ωm: speed at and below which `lm` uses a 1° window \[rpm\]. Default 551: from
    /// `drive-bench calibrate-lm` on the built-in motor, the lowest speed a 1° window holds
    /// (below it the drive runs above the command, driven by the window's full-voltage
    /// time, which lasts until the detected crossing). Rule: < ωM (with the other defaults at
    /// most 13429).
    pub lm_speed_min_rpm: u32,
    /// Flip-flops of the digital filter (3 in the chip), clocked at 0.64 µs. Default 3.
    /// Rule: 1..=64.
    pub filter_samples: u32,
    /// `lm` only: the linear region ends θZC after it began even when the crossing has not
    /// been detected by then; PWM resumes and detection goes on under it. Default true (not
    /// the published chip, whose region lasts until the detected crossing: set false).
    /// Why: a crossing taken early under PWM (a PWM-edge glitch outside LM's narrow window)
    /// shortens t_60, so the next region opens that much early and, held to the crossing,
    /// lasts several times θZC; at 3000 rpm such full-voltage pulses reach 0.5 A against a
    /// 0.03 A running current, the current PI samples them and cuts the duty, and the speed
    /// loop hunts. Capped, the region adds the θZC/60 of full voltage the LM law sets.
    /// Rule: any.
    pub lm_window_capped: bool,
}

impl Default for StrategyParams {
    fn default() -> Self {
        StrategyParams {
            name: StrategyName::TwelveStepDf,
            guard: None,
            conduction_angle_deg: None,
            linear_region_deg: 15,
            lm_speed_max_rpm: 13430,
            lm_speed_min_rpm: 551,
            filter_samples: 3,
            lm_window_capped: true,
        }
    }
}

impl StrategyParams {
    /// Checks every rule; the error names the first field that breaks one.
    pub fn validate(&self) -> Result<(), ParamError> {
        if let Some(g) = self.guard
            && let Some(fixed) = self.name.fixed_guard()
            && g != fixed
        {
            return Err(ParamError::new(
                "strategy.guard",
                format!("\"{}\" with {}", g.as_str(), self.name),
                "applies to six-step-120 only; twelve-step names fix their guard (pick the name with the guard you want)",
            ));
        }
        if let Some(a) = self.conduction_angle_deg {
            if self.name == StrategyName::SixStep120 {
                return Err(ParamError::new(
                    "strategy.conduction_angle_deg",
                    a,
                    "applies to twelve-step strategies only (six-step-120 conducts 120°)",
                ));
            }
            if !(a.is_finite() && (120.0..180.0).contains(&a)) {
                return Err(ParamError::new(
                    "strategy.conduction_angle_deg",
                    a,
                    "must be in 120 <= x < 180 electrical degrees",
                ));
            }
        }
        check_range(
            "strategy.linear_region_deg",
            f64::from(self.linear_region_deg),
            1.0,
            60.0,
            "must be in 1..=60 electrical degrees",
        )?;
        if self.lm_speed_max_rpm as f64 > SPEED_CMD_MAX_RPM {
            return Err(ParamError::new(
                "strategy.lm_speed_max_rpm",
                self.lm_speed_max_rpm,
                "must be <= 16383 rpm",
            ));
        }
        if self.lm_speed_max_rpm <= self.lm_speed_min_rpm {
            return Err(ParamError::new(
                "strategy.lm_speed_max_rpm",
                self.lm_speed_max_rpm,
                format!(
                    "must be greater than strategy.lm_speed_min_rpm = {} (ωM > ωm)",
                    self.lm_speed_min_rpm
                ),
            ));
        }
        check_range(
            "strategy.filter_samples",
            f64::from(self.filter_samples),
            1.0,
            64.0,
            "must be in 1..=64 samples",
        )?;
        Ok(())
    }

    /// The guard in force: the one the name fixes, else `strategy.guard`, else `df`.
    pub fn guard_kind(&self) -> GuardKind {
        self.name
            .fixed_guard()
            .or(self.guard)
            .unwrap_or(GuardKind::Df)
    }

    /// Conduction angle in force [electrical degrees].
    pub fn conduction_deg(&self) -> f64 {
        match self.name {
            StrategyName::SixStep120 => 120.0,
            _ => self.conduction_angle_deg.unwrap_or(150.0),
        }
    }

    /// The commutation table these settings configure (the chip may start narrower).
    pub fn table(&self) -> crate::Table {
        match self.name {
            StrategyName::SixStep120 => crate::Table::SixStep,
            _ => crate::Table::TwelveStep {
                conduction_deg: self.conduction_deg(),
            },
        }
    }
}
