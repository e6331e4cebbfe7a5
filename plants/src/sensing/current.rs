//! Shunt-current channel: shunt → ×gain amplifier (clipped to its swing) → first-order
//! low-pass → sample-and-hold ADC converting back to back.
//!
//! Sample k is taken at k·T_conv and becomes readable at (k+1)·T_conv; the reading is
//! `code = floor(v / full_scale · 2^bits)` clipped to 0..2^bits − 1. Negative shunt current
//! (regeneration, diode freewheeling into the supply) clips to code 0, as on a single-supply
//! amplifier.

use super::foh::Foh;
use crate::params::CurrentSenseParams;
use drive_core::{TICK_S, Ticks};

/// The current-sense chain and its ADC pipeline.
#[derive(Copy, Clone, Debug)]
pub struct CurrentSense {
    volts_per_amp: f64,
    max_v: f64,
    tau: f64,
    codes: f64,
    max_code: u16,
    full_scale: f64,
    conv: u64,
    y: f64,
    /// The latest conversions as (readable from tick, code), newest last.
    results: [(u64, u16); 4],
    next_sample: u64,
}

impl CurrentSense {
    /// A settled chain at zero current with `shunt_ohm` in the power path.
    pub fn new(p: &CurrentSenseParams, shunt_ohm: f64) -> Self {
        let conv = p.conversion().0;
        CurrentSense {
            volts_per_amp: shunt_ohm * p.amplifier_gain,
            max_v: p.amplifier_max_v,
            tau: 1.0 / (std::f64::consts::TAU * p.filter_cutoff_hz),
            codes: (1u32 << p.adc_bits) as f64,
            max_code: ((1u32 << p.adc_bits) - 1) as u16,
            full_scale: p.adc_full_scale_v,
            conv,
            y: 0.0,
            results: [(0, 0); 4],
            next_sample: conv,
        }
    }

    /// Amplifier output for a shunt current [V].
    pub fn amplifier_v(&self, i_shunt: f64) -> f64 {
        (i_shunt * self.volts_per_amp).clamp(0.0, self.max_v)
    }

    fn quantise(&self, v: f64) -> u16 {
        ((v / self.full_scale * self.codes).floor().max(0.0) as u64).min(self.max_code as u64)
            as u16
    }

    /// Advances over [t0, t1] with the shunt current going linearly from `i0` to `i1`,
    /// taking every ADC sample that falls in (t0, t1].
    pub fn update(&mut self, t0: f64, t1: f64, i0: f64, i1: f64) {
        let h = t1 - t0;
        if h <= 0.0 {
            return;
        }
        let seg = Foh::new(
            self.y,
            self.amplifier_v(i0),
            self.amplifier_v(i1),
            h,
            self.tau,
        );
        let k_end = (t1 / TICK_S + 1e-6).floor() as u64;
        while self.next_sample <= k_end {
            let code = self.quantise(seg.at(self.next_sample as f64 * TICK_S - t0));
            self.results.rotate_left(1);
            self.results[3] = (self.next_sample + self.conv, code);
            self.next_sample += self.conv;
        }
        self.y = seg.at(h);
    }

    /// The latest conversion readable at `at` (which may lie a few conversions back).
    pub fn code_at(&self, at: Ticks) -> u16 {
        self.results
            .iter()
            .rev()
            .find(|r| r.0 <= at.0)
            .map_or(0, |r| r.1)
    }

    /// Amperes per ADC code (for converting readings back).
    pub fn amps_per_code(&self) -> f64 {
        self.full_scale / self.codes / self.volts_per_amp
    }

    /// Filter output [V].
    pub fn filtered_v(&self) -> f64 {
        self.y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_scaling_half_amp_is_full_scale() {
        let c = CurrentSense::new(&CurrentSenseParams::default(), 0.25);
        assert!((c.amplifier_v(0.5) - 10.0).abs() < 1e-12);
        assert_eq!(c.amplifier_v(-0.1), 0.0);
        assert!((c.amps_per_code() - 0.5 / 4096.0).abs() < 1e-15);
    }

    #[test]
    fn dc_current_settles_and_reads_with_one_conversion_latency() {
        let p = CurrentSenseParams::default();
        let mut c = CurrentSense::new(&p, 0.25);
        let i = 0.2; // → 4 V → code floor(4/10·4096) = 1638
        let dt = 1e-6;
        for k in 0..1000 {
            c.update(k as f64 * dt, (k + 1) as f64 * dt, i, i);
        }
        assert_eq!(c.code_at(Ticks(50_000)), 1638);
        // Filter time constant 6.37 µs: one conversion after a step the reading is still 0.
        let mut c = CurrentSense::new(&p, 0.25);
        c.update(0.0, 20e-6, i, i);
        assert_eq!(c.code_at(Ticks(999)), 0);
        let v = 4.0 * (1.0 - (-20e-6 / c.tau).exp());
        c.update(20e-6, 40e-6, i, i);
        assert_eq!(c.code_at(Ticks(2000)), (v / 10.0 * 4096.0).floor() as u16);
    }
}
