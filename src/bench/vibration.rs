//! The report's vibration section: each strategy's torque spectrum at low and medium speed
//! on the quiet loops, in orders of the electrical frequency with each line named, the
//! low-band ripple and the commutation surge beside it, and which orderings hold.

use super::spectrum::{self, Spectrum};
use super::svg::{Mark, Panel, Series, chart_marked};
use super::{Comparison, SpectrumRun};
use drive_core::time::clocks;
use std::fmt::Write as _;

/// The spectrum figure of a variant.
pub fn file_of(variant: &str) -> String {
    super::svg::file_name("spectrum", variant)
}

fn runs<'a>(c: &'a Comparison, variant: &'a str) -> impl Iterator<Item = &'a SpectrumRun> {
    c.spectra
        .iter()
        .filter(move |r| r.variant == variant && !r.contrast)
}

/// Steps per electrical turn of a variant's strategy, as its spectra were named.
fn steps_of(c: &Comparison, variant: &str) -> u32 {
    c.variants
        .iter()
        .find(|v| v.label == variant)
        .map_or(12, |v| match v.plugin {
            Some(_) => 12,
            None => v.strategy.table().states_per_turn(),
        })
}

/// The known frequencies marked on a spectrum: the commutation's order, its half and (for
/// twelve-step) its quarter, the PI update, and the low band's edge.
fn marks(sp: &Spectrum, steps: u32, band_hz: f64) -> Vec<Mark> {
    let mut m = vec![
        Mark {
            x: f64::from(steps),
            label: format!("commutation ({steps})"),
        },
        Mark {
            x: f64::from(steps / 2),
            label: "every 2 steps".into(),
        },
        Mark {
            x: band_hz / sp.fe_hz,
            label: format!("LF band edge {band_hz:.0} Hz"),
        },
    ];
    if steps == 12 {
        m.push(Mark {
            x: 3.0,
            label: "every 4 steps".into(),
        });
    }
    m.push(Mark {
        x: 1.0 / clocks::PI_UPDATE.seconds() / sp.fe_hz,
        label: "PI update".into(),
    });
    m
}

/// One figure per variant with a spectrum: a panel per speed (and per scheme for the
/// chopping experiment).
pub fn charts(c: &Comparison) -> Vec<(String, String)> {
    let band_hz = band(c);
    c.variants
        .iter()
        .filter_map(|v| {
            let steps = steps_of(c, &v.label);
            let (panels, marks): (Vec<Panel>, Vec<Vec<Mark>>) = c
                .spectra
                .iter()
                .filter(|r| r.variant == v.label)
                .filter_map(|r| {
                    let sp = r.spectrum.as_ref()?;
                    let panel = Panel {
                        y_label: format!("{:.0} rpm, {} [% of mean torque]", r.rpm, r.pwm_scheme),
                        series: vec![Series {
                            name: format!("{:.0} rpm, {}", r.rpm, r.pwm_scheme),
                            points: sp.binned.clone(),
                            color: c.color_of(&v.label),
                            ..Series::default()
                        }],
                    };
                    Some((panel, marks(sp, steps, band_hz)))
                })
                .unzip();
            (!panels.is_empty()).then(|| {
                let svg = chart_marked(
                    &format!(
                        "{}: torque spectrum (largest amplitude per {} order)",
                        v.label,
                        spectrum::BIN_ORDERS
                    ),
                    "order of the electrical frequency (f / f_e)",
                    &panels,
                    &marks,
                );
                (file_of(&v.label), svg)
            })
        })
        .collect()
}

/// The low band's edge \[Hz\] (the summaries' `torque_lowpass_hz`).
fn band(c: &Comparison) -> f64 {
    c.spectra
        .first()
        .map_or(2000.0, |r| r.summary.torque_lowpass_hz)
}

fn pct(x: f64, of: f64) -> f64 {
    100.0 * x / of.abs().max(f64::MIN_POSITIVE)
}

/// Low-band ripple of a running spectrum run, % of its mean torque.
fn lf_pct(r: &SpectrumRun) -> Option<f64> {
    r.summary
        .verdict
        .is_running()
        .then(|| pct(r.summary.torque_ripple_lf_nm, r.summary.torque_mean_nm))
}

fn lines_cell(sp: &Spectrum, band_hz: f64) -> String {
    let inside: Vec<String> = sp
        .lines
        .iter()
        .filter(|l| l.hz < band_hz)
        .take(4)
        .map(|l| format!("{:.2} ({}) {:.1} %", l.order, l.source.describe(), l.pct))
        .collect();
    if inside.is_empty() {
        format!("none ≥ {} %", spectrum::LISTED_PCT)
    } else {
        inside.join("; ")
    }
}

/// The section, in Markdown.
pub fn section(c: &Comparison) -> String {
    let band_hz = band(c);
    let mut s = format!(
        "\n## Vibration on quiet loops: torque spectra in electrical orders\n\nEach strategy started at {:.0} rpm and was turned down (or held) to each speed as the range's floors are, then its torque traced every {:.0} µs over the judged window (whole electrical turns, Hann window). A line's amplitude is in % of the mean torque; its order is f / f_e with f_e measured, so the commutation's lines sit at whole orders and the loops' at fixed hertz move with the speed. Lines are named by where they sit: a whole order k repeats every S / gcd(k, S) commutation steps (S = 6 for six-step, 12 for twelve-step): every step is the commutation itself, every 2 steps alternate steps that differ (six-step: high- against low-side commutations; twelve-step at 150°: two- against three-phase conduction), every 4 steps (twelve-step) the two kinds of three-phase step; off the orders, multiples of the PI update (190.7 Hz) and, below the electrical frequency, the speed loop. The resolution is 1/turns of an order. A listed line's amplitude is from its main lobe's energy (exact wherever the line falls between bins); the figures plot each bin's amplitude, which reads a line between bins up to 15 % low. The low-band ripple is the vibration proxy (the torque's means over blocks of 1/{band_hz:.0} Hz: lines above {band_hz:.0} Hz drop out); the commutation surge is the mean over the states of each state's largest phase current.\n\n| strategy | rpm | verdict | LF ripple % of mean torque | full band % | commutation surge A | I rms A | largest lines below {band_hz:.0} Hz: order (source) % |\n|---|---:|---|---:|---:|---:|---:|---|\n",
        c.plan.trace_rpm,
        spectrum::TRACE_EVERY_S * 1e6
    );
    for v in &c.variants {
        for r in runs(c, &v.label) {
            let x = &r.summary;
            let row = match (&r.spectrum, lf_pct(r)) {
                (Some(sp), Some(lf)) => format!(
                    "{} | {lf:.1} | {:.1} | {:.4} | {:.4} | {}",
                    x.verdict,
                    pct(x.torque_ripple_nm, x.torque_mean_nm),
                    x.commutation_peak_a,
                    x.current_rms_a,
                    lines_cell(sp, band_hz)
                ),
                _ => format!("*{}* | – | – | – | – | {}", x.verdict, x.verdict_reason),
            };
            let _ = writeln!(s, "| {} | {:.0} | {row} |", v.label, r.rpm);
        }
    }
    orderings(c, &mut s);
    chopping(c, band_hz, &mut s);
    for v in &c.variants {
        if c.spectra
            .iter()
            .any(|r| r.variant == v.label && r.spectrum.is_some())
        {
            let f = file_of(&v.label);
            let _ = writeln!(s, "\n![{f}]({f})");
        }
    }
    s
}

/// Which orderings of the low-band ripple hold at each speed: between the guards at
/// 150°, between 150° and 120°, and between the conduction angles.
fn orderings(c: &Comparison, s: &mut String) {
    let _ = writeln!(
        s,
        "\n### Which orderings hold\n\nLow-band ripple, % of the mean torque, lowest first (runs that were not `running` are left out and named):\n"
    );
    let groups: [(&str, &[&str]); 3] = [
        (
            "guards at 150°",
            &[
                "twelve-step-raw",
                "twelve-step-nd",
                "twelve-step-lm",
                "twelve-step-df",
            ],
        ),
        ("150° against 120°", &["twelve-step-df", "six-step-120"]),
        (
            "conduction angle (digital filter)",
            &["twelve-step-df@135", "twelve-step-df", "twelve-step-df@165"],
        ),
    ];
    for rpm in &c.plan.spectrum_rpm {
        for (name, labels) in groups {
            let mut ok: Vec<(String, f64, f64)> = Vec::new();
            let mut failed = Vec::new();
            for l in labels {
                let Some(r) = runs(c, l).find(|r| r.rpm == *rpm) else {
                    continue;
                };
                match lf_pct(r) {
                    Some(lf) => ok.push((l.to_string(), lf, r.summary.commutation_error_deg_mean)),
                    None => failed.push(format!("{l} *{}*", r.summary.verdict)),
                }
            }
            ok.sort_by(|a, b| a.1.total_cmp(&b.1));
            let listed: Vec<String> = ok
                .iter()
                .map(|(l, lf, err)| format!("{l} {lf:.1} % (commutation error {err:+.1}°)"))
                .collect();
            let mut line = format!("- {rpm:.0} rpm, {name}: {}", listed.join(" < "));
            if !failed.is_empty() {
                let _ = write!(line, "; not running: {}", failed.join(", "));
            }
            let _ = writeln!(s, "{line}");
        }
    }
    // Electrical turns per mechanical turn, from any spectrum (f_e against the true speed).
    let Some(pp) = c.spectra.iter().find_map(|r| {
        let sp = r.spectrum.as_ref()?;
        Some((sp.fe_hz * 60.0 / r.summary.speed_mean_rpm).round())
    }) else {
        return;
    };
    let below = |order: f64| band(c) / order * 60.0 / pp;
    let _ = writeln!(
        s,
        "\nWhy, from the lines above: a guard changes when the chip commutates (the mean commutation error beside each figure), not which lines the commutation makes, so strategies of one conduction angle share their largest orders and differ in their size. Between 150° and 120° the orders differ: six-step's commutation line is its 6th order, inside the low band below {:.0} rpm, twelve-step's its 12th, inside below {:.0} rpm; at 150° the alternation of two- and three-phase conduction adds an order 6 of its own (every 2 steps), inside below {:.0} rpm.",
        below(6.0),
        below(12.0),
        below(6.0)
    );
}

/// The chopping experiment: the same strategy with the other chopping.
fn chopping(c: &Comparison, band_hz: f64, s: &mut String) {
    let Some(label) = &c.plan.spectrum_chopping else {
        return;
    };
    let line3 = |r: &SpectrumRun| {
        r.spectrum.as_ref().and_then(|sp| {
            sp.lines
                .iter()
                .filter(|l| (l.order - 3.0).abs() < 0.05 && l.hz < band_hz)
                .map(|l| l.pct)
                .reduce(f64::max)
        })
    };
    let config_scheme = runs(c, label).next().map_or("–", |r| r.pwm_scheme.as_str());
    let _ = writeln!(
        s,
        "\n### The 3rd-order lines: the chopping\n\nThe published chip chops the high-side switch only: in a PWM off-time the chopped phase's current freewheels through a diode, which stops conducting when that current reaches zero, and a three-phase step with two high-side switches on is not the mirror image of one with two low-side switches on. Alternate three-phase steps then differ, a pattern of 4 steps (order 3) in twelve-step. Lone-switch chopping (`power_stage.pwm_scheme = \"lone-switch-chop\"`, the shipped default) chops the low switch in a state with two legs high and the high switch otherwise, so every state mirrors its opposite; the two-phase states, where the crossings are sensed, are chopped as the chip chops them (docs/chip.md, \"Chopping\"). Six-step has no three-phase state and is chopped alike by both. {label} with each (the config's scheme, `{}`, gives every other figure of this report):\n\n| rpm | scheme | verdict | LF ripple % | order-3 line % |\n|---:|---|---|---:|---:|",
        config_scheme
    );
    for rpm in &c.plan.spectrum_rpm {
        for r in c
            .spectra
            .iter()
            .filter(|r| &r.variant == label && r.rpm == *rpm)
        {
            let _ = writeln!(
                s,
                "| {rpm:.0} | {} | {} | {} | {} |",
                r.pwm_scheme,
                r.summary.verdict,
                lf_pct(r).map_or("–".into(), |x| format!("{x:.1}")),
                line3(r).map_or("–".into(), |x| format!("{x:.1}")),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_figure_per_variant_is_named_without_at_signs() {
        assert_eq!(
            file_of("twelve-step-df@135"),
            "spectrum_twelve-step-df_135.svg"
        );
    }

    #[test]
    fn the_commutation_and_pi_update_are_marked_at_their_orders() {
        let sp = Spectrum {
            fe_hz: 200.0,
            mean_nm: 1.0,
            turns: 200,
            binned: Vec::new(),
            lines: Vec::new(),
        };
        let m = marks(&sp, 12, 2000.0);
        let at = |label: &str| m.iter().find(|k| k.label.starts_with(label)).unwrap().x;
        assert_eq!(at("commutation"), 12.0);
        assert_eq!(at("every 2"), 6.0);
        assert_eq!(at("LF band"), 10.0);
        assert_eq!(at("every 4"), 3.0);
        assert!((at("PI update") - 190.7348 / 200.0).abs() < 1e-4);
    }
}
