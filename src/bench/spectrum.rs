//! Torque spectra in orders of the electrical frequency, with each line named by its
//! source: the commutation, the chopping, the loops.
//!
//! The torque Te(t) of a steady run is traced every [`TRACE_EVERY_S`] over whole electrical
//! turns (delimited by the true θe wrapping through 0). Its mean is removed and the rest
//! transformed with a Hann window. The plotted spectrum is 2·|X(f)|/Σw (the window's
//! coherent gain divided out), which reads a line of amplitude A (Te = T̄ + A·cos(2πft + φ))
//! as A on a bin and down to 0.85·A between bins; a listed line's amplitude comes from its
//! main lobe's energy instead, exact wherever it falls. The frequency axis is shown
//! in orders k = f / f_e, with f_e the measured electrical frequency (turns / time), so
//! the commutation's lines sit at whole orders whatever the speed, and the loops' at
//! fixed hertz move along the axis as the speed changes.
//!
//! The trace samples the torque every 20 µs: 4 samples per 80 µs PWM carrier period on
//! the same 20 ns time base, so the carrier's harmonics fold onto 0, 12.5 and 25 kHz, none
//! of them into the orders shown (up to [`MAX_ORDER`], 3 kHz at 6000 rpm).

use crate::scenario::TraceRow;
use drive_core::time::clocks;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex;
use serde::Serialize;

/// Trace period of a spectrum run \[s\].
pub const TRACE_EVERY_S: f64 = 20e-6;
/// Highest order shown.
pub const MAX_ORDER: f64 = 30.0;
/// Width of the bins the plotted spectrum keeps the largest amplitude of (orders): fine
/// enough to separate the loops' lines from whole orders, coarse enough to plot.
pub const BIN_ORDERS: f64 = 0.05;
/// A line is listed when it reaches this share of the mean torque \[%\].
pub const LISTED_PCT: f64 = 1.0;
/// Lines listed per run, largest first.
pub const LISTED: usize = 8;

/// What makes a line.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// A whole order k: a pattern that repeats every `period_steps` commutation steps
    /// (S / gcd(k, S) for S steps per electrical turn). 1: the commutation itself; 2:
    /// alternate steps differ (six-step: the high-side against the low-side commutations;
    /// twelve-step at 150°: two- against three-phase conduction); 4 (twelve-step): the two
    /// kinds of three-phase step (two switches on the high side or on the low side), which
    /// single-switch chopping treats differently; S: once per electrical turn.
    Steps {
        /// Steps per repetition.
        period_steps: u32,
    },
    /// At a multiple of the PI update rate (190.7 Hz), not at a whole order.
    PiUpdate,
    /// Below the electrical frequency and not at a whole order: the speed loop.
    SpeedLoop,
    /// Anything else.
    Other,
}

impl Source {
    /// Name in the report.
    pub fn describe(self) -> String {
        match self {
            Source::Steps { period_steps: 1 } => "commutation".into(),
            Source::Steps { period_steps: p } => format!("every {p} steps"),
            Source::PiUpdate => "PI update".into(),
            Source::SpeedLoop => "speed loop".into(),
            Source::Other => "other".into(),
        }
    }
}

fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// One line of a spectrum.
#[derive(Clone, Debug, Serialize)]
pub struct Line {
    /// Order (f / f_e).
    pub order: f64,
    /// Frequency \[Hz\].
    pub hz: f64,
    /// Amplitude, % of the mean torque.
    pub pct: f64,
    /// What makes it.
    pub source: Source,
}

/// The torque spectrum of one steady run.
#[derive(Clone, Debug, Serialize)]
pub struct Spectrum {
    /// Measured electrical frequency \[Hz\].
    pub fe_hz: f64,
    /// Mean torque over the whole turns \[N·m\].
    pub mean_nm: f64,
    /// Whole electrical turns transformed.
    pub turns: usize,
    /// The largest amplitude in each bin of [`BIN_ORDERS`] up to [`MAX_ORDER`]:
    /// (order at the bin's centre, % of the mean torque).
    pub binned: Vec<(f64, f64)>,
    /// The largest lines, each a local maximum over ±0.1 order, largest first.
    pub lines: Vec<Line>,
}

/// Names the source of a line at `order` of `fe_hz` for a strategy of `steps`
/// commutations per electrical turn, measured over `turns` turns (bins of fe/turns).
pub fn source(order: f64, fe_hz: f64, steps: u32, turns: usize) -> Source {
    // A Hann-windowed line's peak lies within 1.5 bins of its frequency; the speed's own
    // ripple (a few rpm in a thousand) smears a whole order by up to a few hundredths.
    let tol = (1.5 / turns as f64).max(0.03); // in orders
    let k = order.round();
    if k >= 1.0 && (order - k).abs() <= tol {
        let k = k as u32;
        return Source::Steps {
            period_steps: steps / gcd(k, steps),
        };
    }
    let (hz, pi_hz) = (order * fe_hz, 1.0 / clocks::PI_UPDATE.seconds());
    let m = (hz / pi_hz).round();
    if m >= 1.0 && (hz - m * pi_hz).abs() <= tol * fe_hz {
        return Source::PiUpdate;
    }
    if order < 1.0 {
        Source::SpeedLoop
    } else {
        Source::Other
    }
}

/// The spectrum of the torque in `samples` (t \[s\], θe \[°\], Te [N·m], every
/// [`TRACE_EVERY_S`]), for a strategy of `steps` commutations per electrical turn; `None`
/// with fewer than 10 whole turns.
pub fn torque_spectrum(samples: &[(f64, f64, f64)], steps: u32) -> Option<Spectrum> {
    let wraps: Vec<usize> = samples
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[1].1 < w[0].1 - 180.0)
        .map(|(i, _)| i + 1)
        .collect();
    let (&a, &b) = (wraps.first()?, wraps.last()?);
    let turns = wraps.len() - 1;
    if turns < 10 {
        return None;
    }
    let fe_hz = turns as f64 / (samples[b].0 - samples[a].0);
    let te: Vec<f64> = samples[a..b].iter().map(|s| s.2).collect();
    let n = te.len();
    let mean_nm = te.iter().sum::<f64>() / n as f64;
    let hann = |i: usize| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos();
    let gain: f64 = (0..n).map(hann).sum();
    let mut buf: Vec<Complex<f64>> = te
        .iter()
        .enumerate()
        .map(|(i, &x)| Complex::new((x - mean_nm) * hann(i), 0.0))
        .collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    let df = 1.0 / (n as f64 * TRACE_EVERY_S);
    let energy: f64 = (0..n).map(|i| hann(i) * hann(i)).sum();
    // A line's amplitude from the energy of its main lobe (±2 bins, taken ±3): by Parseval,
    // A²/2·Σw² = 2/N·Σ|X|² over the lobe, whatever the line's offset from a bin (the
    // peak bin alone loses up to 15 % between bins: Hann's scalloping).
    let lobe_pct = |i: usize| {
        let sum: f64 = buf[i.saturating_sub(3)..=(i + 3).min(n / 2)]
            .iter()
            .map(|c| c.norm_sqr())
            .sum();
        100.0 * (4.0 * sum / (n as f64 * energy)).sqrt() / mean_nm.abs().max(f64::MIN_POSITIVE)
    };
    let top = ((MAX_ORDER * fe_hz / df) as usize).min(n / 2);
    let pct: Vec<f64> = buf[..=top]
        .iter()
        .map(|c| 100.0 * 2.0 * c.norm() / gain / mean_nm.abs().max(f64::MIN_POSITIVE))
        .collect();
    let order_of = |i: usize| i as f64 * df / fe_hz;
    let nbins = (MAX_ORDER / BIN_ORDERS).round() as usize;
    let mut binned: Vec<(f64, f64)> = (0..nbins)
        .map(|j| ((j as f64 + 0.5) * BIN_ORDERS, 0.0))
        .collect();
    for (i, &p) in pct.iter().enumerate().skip(1) {
        let j = (order_of(i) / BIN_ORDERS) as usize;
        if let Some(bin) = binned.get_mut(j) {
            bin.1 = bin.1.max(p);
        }
    }
    // Lines: local maxima over ±0.1 order (the loops' lines sit that close to the orders
    // at low speed), above the listing threshold.
    let half = ((0.1 * fe_hz / df).round() as usize).max(2);
    let mut lines: Vec<Line> = (1..pct.len())
        .filter(|&i| pct[i] >= LISTED_PCT)
        .filter(|&i| {
            let lo = i.saturating_sub(half).max(1);
            let hi = (i + half).min(pct.len() - 1);
            (lo..=hi).all(|j| pct[j] <= pct[i])
        })
        .map(|i| {
            let (order, hz) = (order_of(i), i as f64 * df);
            Line {
                order,
                hz,
                pct: lobe_pct(i),
                source: source(order, fe_hz, steps, turns),
            }
        })
        .collect();
    lines.sort_by(|x, y| y.pct.total_cmp(&x.pct));
    lines.truncate(LISTED);
    Some(Spectrum {
        fe_hz,
        mean_nm,
        turns,
        binned,
        lines,
    })
}

/// The samples a spectrum needs from a trace row.
pub fn sample(r: &TraceRow) -> (f64, f64, f64) {
    (r.t_s, r.theta_e_deg, r.torque_nm)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A torque of known lines at a steady 200 Hz electrical: each is found at its order
    /// with its amplitude, and named by its source.
    #[test]
    fn known_lines_come_back_at_their_orders_and_amplitudes() {
        let fe = 200.0;
        let mean = 0.5e-3;
        // 3rd and 6th orders at 10 % and 12 % of the mean, a 190.73 Hz PI-update line at
        // 3 % (order 0.954), a 7.5 Hz loop line at 2 %.
        let pi_hz = 1.0 / clocks::PI_UPDATE.seconds();
        let parts = [
            (3.0 * fe, 0.10),
            (6.0 * fe, 0.12),
            (pi_hz, 0.03),
            (7.5, 0.02),
        ];
        let samples: Vec<(f64, f64, f64)> = (0..100_000)
            .map(|i| {
                let t = i as f64 * TRACE_EVERY_S;
                let theta = (360.0 * fe * t + 10.0) % 360.0;
                let te = mean
                    + parts
                        .iter()
                        .map(|&(f, a)| a * mean * (2.0 * std::f64::consts::PI * f * t + 0.3).cos())
                        .sum::<f64>();
                (t, theta, te)
            })
            .collect();
        let s = torque_spectrum(&samples, 12).expect("enough turns");
        assert!((s.fe_hz - fe).abs() < 1e-6 * fe, "{}", s.fe_hz);
        assert!((s.mean_nm - mean).abs() < 1e-3 * mean);
        let find = |order: f64| {
            s.lines
                .iter()
                .find(|l| (l.order - order).abs() < 0.02)
                .unwrap_or_else(|| panic!("no line at order {order}: {:?}", s.lines))
        };
        for (order, pct, source) in [
            (3.0, 10.0, Source::Steps { period_steps: 4 }),
            (6.0, 12.0, Source::Steps { period_steps: 2 }),
            (pi_hz / fe, 3.0, Source::PiUpdate),
            (7.5 / fe, 2.0, Source::SpeedLoop),
        ] {
            let l = find(order);
            // From the lobe's energy: the PI-update line falls between bins, where the peak
            // bin alone would read it up to 15 % low.
            assert!((l.pct - pct).abs() < 0.01 * pct, "{l:?} against {pct} %");
            assert_eq!(l.source, source, "{l:?}");
        }
        // The commutation's own order, and six-step's 3rd (every other step).
        let steps = |p| Source::Steps { period_steps: p };
        assert_eq!(source(12.0, fe, 12, 400), steps(1));
        assert_eq!(source(6.0, fe, 6, 400), steps(1));
        assert_eq!(source(3.0, fe, 6, 400), steps(2));
        assert_eq!(source(1.0, fe, 6, 400), steps(6));
        assert_eq!(source(2.5, fe, 6, 400), Source::Other);
        assert_eq!(source(5.98, fe, 12, 400), steps(2));
        assert_eq!(source(5.9, fe, 12, 400), Source::Other);
        // The bins keep each line's peak.
        let bin = s.binned[(3.0 / BIN_ORDERS) as usize];
        assert!((bin.1 - 10.0).abs() < 0.2, "{bin:?}");
    }

    #[test]
    fn too_few_turns_give_no_spectrum() {
        let samples: Vec<(f64, f64, f64)> = (0..1000)
            .map(|i| (i as f64 * TRACE_EVERY_S, (i as f64 * 3.6) % 360.0, 1.0))
            .collect();
        assert!(torque_spectrum(&samples, 6).is_none());
    }
}
