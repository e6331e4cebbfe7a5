//! The report's results chapter: the experiments the reproduced drive's designers ran, run
//! again on the simulated drive, each with a table, a figure and what the simulation finds.
//! Only runs judged `running` give figures; the others give their verdict.

use super::range::{Limit, Range, holds};
use super::svg::{Panel, Series, chart};
use super::{AntiWindup, Comparison, StepRun};
use crate::scenario::Summary;
use std::fmt::Write as _;

/// The file of the speed-range figure.
pub const RANGE_CHART: &str = "speed_range.svg";

/// Speeds of the grid taken as low and medium for the vibration comparison \[rpm\]: 2000,
/// not 1000, because started from standstill at 1000 rpm the speed loop has not settled
/// within the grid's 3 s (the floors, turned down, reach lower).
const LOW_RPM: f64 = 2000.0;
const MEDIUM_RPM: f64 = 3000.0;

fn ranges<'a>(c: &'a Comparison, meter: &'a str) -> impl Iterator<Item = &'a Range> + 'a {
    c.ranges.iter().filter(move |r| r.meter == meter)
}

fn grid_point<'a>(c: &'a Comparison, variant: &str, rpm: f64) -> Option<&'a Summary> {
    c.grid
        .iter()
        .find(|g| g.variant == variant && g.summary.speed_ref_rpm == rpm)
        .map(|g| &g.summary)
}

/// A figure of a running grid point, or its verdict.
fn figure(s: Option<&Summary>, f: impl Fn(&Summary) -> String) -> String {
    match s {
        Some(s) if holds(s) => f(s),
        Some(s) => format!("*{}*", s.verdict),
        None => "–".into(),
    }
}

fn limit(l: &Option<Limit>) -> String {
    l.as_ref().map_or("–".into(), |l| {
        format!("{:.0} rpm **{}**: {}", l.rpm, l.verdict, l.reason)
    })
}

fn rpm(x: Option<f64>) -> String {
    x.map_or("none".into(), |x| format!("{x:.0}"))
}

/// Floor to top of every strategy, one line per meter.
pub fn range_chart(c: &Comparison) -> String {
    let panels: Vec<Panel> = c
        .plan
        .range_meters
        .iter()
        .map(|m| Panel {
            y_label: format!("strategy #, meter {}", m.label),
            series: ranges(c, m.label)
                .enumerate()
                .filter_map(|(k, r)| {
                    let (lo, hi) = (r.min_rpm?, r.max_rpm?);
                    let y = (k + 1) as f64;
                    Some(Series {
                        name: format!("{} {}", k + 1, r.strategy),
                        points: vec![(lo, y), (hi, y)],
                        steps: false,
                        color: c.color_of(&r.strategy),
                        dash: None,
                    })
                })
                .collect(),
        })
        .collect();
    chart(
        "Speed range: floor (turned down) to top (turned up), judged from the true rotor",
        "speed [rpm]",
        &panels,
    )
}

/// The chapter, in Markdown.
pub fn section(c: &Comparison) -> String {
    let mut s = String::from(
        "\n## Results of the source's experiments\n\nEach experiment the drive's designers reported, run again here: what the simulation finds and what limits it.\n",
    );
    speed_range(c, &mut s);
    top_speed(c, &mut s);
    anti_windup(c, &mut s);
    currents(c, &mut s);
    vibration(c, &mut s);
    s
}

fn speed_range(c: &Comparison, s: &mut String) {
    let _ = writeln!(s, "\n### Speed range per guard and conduction angle\n");
    if c.ranges.is_empty() {
        let _ = writeln!(s, "Not searched in this run (`--quick`).");
        return;
    }
    let _ = writeln!(s, "![{RANGE_CHART}]({RANGE_CHART})\n");
    let _ = writeln!(
        s,
        "| strategy | meter | floor rpm | floor limited by | top rpm | top limited by |\n|---|---|---:|---|---:|---|"
    );
    for r in &c.ranges {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} |",
            r.strategy,
            r.meter,
            rpm(r.min_rpm),
            limit(&r.min_limit),
            rpm(r.max_rpm),
            limit(&r.max_limit)
        );
    }
    let wide = c.plan.meter.label;
    let lowest = ranges(c, wide)
        .filter_map(|r| Some((r.min_rpm?, r)))
        .min_by(|a, b| a.0.total_cmp(&b.0));
    let highest = ranges(c, wide)
        .filter_map(|r| Some((r.max_rpm?, r)))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    if let (Some((lo, a)), Some((hi, b))) = (lowest, highest) {
        let _ = writeln!(
            s,
            "\nFound (meter {wide}): the lowest floor is {}'s, {lo:.0} rpm; the highest top speed is {}'s, {hi:.0} rpm. Each limit is the failed run just beyond the bound; `off-speed` in synchronism means the guard held and the speed loop or the voltage did not, `lost-sync`, `stalled` or `not-started` that the rotor was lost.",
            a.strategy, b.strategy
        );
    }
    s.push_str(&super::floors::section(&c.floor_zooms));
}

fn top_speed(c: &Comparison, s: &mut String) {
    let wide = c.plan.meter.label;
    let top = |label: &str| {
        ranges(c, wide)
            .find(|r| r.strategy == label)
            .map(|r| (r.max_rpm, &r.max_limit))
    };
    let _ = writeln!(
        s,
        "\n### Top speed, 150° against 120° conduction\n\n| conduction | strategy | top rpm | limited by |\n|---|---|---:|---|"
    );
    let rows = [
        ("120°", "six-step-120"),
        ("135°", "twelve-step-df@135"),
        ("150°", "twelve-step-df"),
        ("165°", "twelve-step-df@165"),
    ];
    for (angle, label) in rows {
        if let Some((max, l)) = top(label) {
            let _ = writeln!(s, "| {angle} | {label} | {} | {} |", rpm(max), limit(l));
        }
    }
    if let (Some((Some(a), _)), Some((Some(b), _))) = (top("twelve-step-df"), top("six-step-120")) {
        let why = if a > b {
            "the 3-phase states put the third phase to work for 30° of every 60°, so the same supply drives the rotor further before the back-EMF catches up"
        } else {
            "the wider conduction does not pay off on this drive"
        };
        let _ = writeln!(
            s,
            "\nFound: 150° reaches {a:.0} rpm, 120° {b:.0} rpm ({:+.1} %): {why}.",
            100.0 * (a / b - 1.0)
        );
    } else {
        let _ = writeln!(s, "\nNo range was searched for one of the two in this run.");
    }
}

fn anti_windup(c: &Comparison, s: &mut String) {
    let _ = writeln!(
        s,
        "\n### Speed steps with and without anti-windup\n\n![speed_step.svg](speed_step.svg)\n\nThe peak beyond the command in the direction of the change (overshoot after a step up or a load's release, undershoot after a step down), in % of the step or, after a load's release, of the command, and the settling time [s], for anti-windup off / on the current PI (the chip's) / on both PIs; details in the anti-windup section below.\n\n| case | strategy | off | current PI | both PIs |\n|---|---|---|---|---|"
    );
    for (k, case) in c.plan.step.cases.iter().enumerate() {
        for v in &c.plan.step.variants {
            let cell = |aw: AntiWindup| {
                c.steps
                    .iter()
                    .find(|x| x.case == k && &x.variant == v && x.anti_windup == aw)
                    .map_or("–".into(), |x| {
                        if !x.verdict.is_running() {
                            return format!("*{}*", x.verdict);
                        }
                        format!(
                            "{:.1} % {}, {}",
                            case.peak_pct(x),
                            case.peak_pct_of(),
                            x.response
                                .settling_s
                                .map_or("not settled".into(), |t| format!("{t:.2} s"))
                        )
                    })
            };
            let _ = writeln!(
                s,
                "| {} | {v} | {} | {} | {} |",
                case.name,
                cell(AntiWindup::Off),
                cell(AntiWindup::Current),
                cell(AntiWindup::Both)
            );
        }
    }
    // Whether the chip's anti-windup (current PI) changed a case's response at all.
    for (k, case) in c.plan.step.cases.iter().enumerate() {
        let same = c.plan.step.variants.iter().all(|v| {
            let of = |aw| {
                c.steps
                    .iter()
                    .find(|x| x.case == k && &x.variant == v && x.anti_windup == aw)
                    .map(|x| (x.response.clone(), x.verdict))
            };
            of(AntiWindup::Off) == of(AntiWindup::Current)
        });
        let effect = if same {
            "changes nothing: that PI never saturates here".to_string()
        } else {
            // Per strategy: the settling without and with it, and which way it moved.
            let moved: Vec<String> = c
                .plan
                .step
                .variants
                .iter()
                .filter_map(|v| {
                    let of = |aw| {
                        c.steps
                            .iter()
                            .find(|x| x.case == k && &x.variant == v && x.anti_windup == aw)
                    };
                    let (off, on) = (of(AntiWindup::Off)?, of(AntiWindup::Current)?);
                    let settling = |x: &StepRun| {
                        x.verdict
                            .is_running()
                            .then_some(x.response.settling_s)
                            .flatten()
                    };
                    let says = |x: &StepRun| match settling(x) {
                        Some(t) => format!("{t:.2} s"),
                        None if x.verdict.is_running() => "not settled".into(),
                        None => x.verdict.to_string(),
                    };
                    let way = match (settling(off), settling(on)) {
                        (Some(a), Some(b)) if b < a => format!("won {:.2} s", a - b),
                        (Some(a), Some(b)) if b > a => format!("lost {:.2} s", b - a),
                        (Some(_), Some(_)) => "the same settling".into(),
                        (Some(_), None) => "settling lost within the run".into(),
                        (None, Some(_)) => "settling won within the run".into(),
                        (None, None) => "settled in neither".into(),
                    };
                    Some(format!(
                        "{v} settles in {} without it, {} with it ({way})",
                        says(off),
                        says(on)
                    ))
                })
                .collect();
            format!(
                "acts: with it the current PI's integrator stops growing while the duty sits at full voltage, so after the step the duty leaves the limit as soon as the error reverses instead of first unwinding (the full-duty time in the summary): {}",
                moved.join("; ")
            )
        };
        let _ = writeln!(
            s,
            "\nFound for {}: the chip's anti-windup (current PI) {effect} ({}).",
            case.name, case.saturates
        );
    }
}

fn currents(c: &Comparison, s: &mut String) {
    let at = c.plan.trace_rpm;
    let _ = writeln!(
        s,
        "\n### Current waveforms per guard\n\n![phase_current.svg](phase_current.svg)\n\nAt {at:.0} rpm, over the steady-state window:\n\n| strategy | I rms A | I peak A | commutation peak A |\n|---|---:|---:|---:|"
    );
    for v in &c.variants {
        let g = grid_point(c, &v.label, at);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            v.label,
            figure(g, |x| format!("{:.3}", x.current_rms_a)),
            figure(g, |x| format!("{:.3}", x.current_peak_a)),
            figure(g, |x| format!("{:.3}", x.commutation_peak_a)),
        );
    }
}

fn vibration(c: &Comparison, s: &mut String) {
    let _ = writeln!(
        s,
        "\n### Vibration per strategy at low and medium speed\n\n![ripple_vs_speed.svg](ripple_vs_speed.svg)\n\nThe vibration proxy is the low-frequency torque ripple (below {:.0} Hz), beside the full-band figure [mN·m]:\n\n| strategy | LF @ {LOW_RPM:.0} rpm | LF @ {MEDIUM_RPM:.0} rpm | full band @ {LOW_RPM:.0} | full band @ {MEDIUM_RPM:.0} |\n|---|---:|---:|---:|---:|",
        c.grid
            .first()
            .map_or(2000.0, |g| g.summary.torque_lowpass_hz)
    );
    let mn = |x: f64| format!("{:.4}", x * 1e3);
    for v in &c.variants {
        let (lo, mid) = (
            grid_point(c, &v.label, LOW_RPM),
            grid_point(c, &v.label, MEDIUM_RPM),
        );
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} |",
            v.label,
            figure(lo, |x| mn(x.torque_ripple_lf_nm)),
            figure(mid, |x| mn(x.torque_ripple_lf_nm)),
            figure(lo, |x| mn(x.torque_ripple_nm)),
            figure(mid, |x| mn(x.torque_ripple_nm)),
        );
    }
    for rpm in [LOW_RPM, MEDIUM_RPM] {
        let lf = |label: &str| {
            grid_point(c, label, rpm)
                .filter(|x| x.verdict.is_running())
                .map(|x| x.torque_ripple_lf_nm)
        };
        if let (Some(a), Some(b)) = (lf("twelve-step-df"), lf("six-step-120")) {
            let _ = writeln!(
                s,
                "\nFound at {rpm:.0} rpm: 150° (twelve-step-df) {} mN·m against 120° (six-step-120) {} mN·m of low-frequency ripple ({:+.0} %).",
                mn(a),
                mn(b),
                100.0 * (a / b - 1.0)
            );
        }
    }
}
