//! The comparison as a terminal table and a report folder (JSON, CSV, Markdown, SVG).

use super::range::holds;
use super::report_sections as sections;
use super::svg::{Panel, Series, chart};
use super::{AntiWindup, Comparison, CrossingTrace, StepRun};
use crate::config::DriveConfig;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One sentence per metric, shown in the report (and the definitions the code uses).
pub const METRIC_DEFINITIONS: &[(&str, &str)] = &[
    (
        "speed_mean_rpm",
        "time-weighted mean of the true rotor speed over the steady-state window (the last third of the run), sampled at every engine instant and held in between",
    ),
    (
        "speed_ripple_rpm",
        "standard deviation of the true rotor speed over the same window",
    ),
    (
        "torque_mean_nm / torque_ripple_nm",
        "exact time mean and standard deviation of the electromagnetic torque over the window, from the plant's integrals of Te and Te²; the ripple includes commutation and PWM ripple",
    ),
    (
        "torque_ripple_lf_nm (LF ripple)",
        "the vibration proxy: standard deviation of the torque's exact means over consecutive blocks of 1/f_c (f_c = 2 kHz by default: `Scenario::torque_lowpass_hz`) in the window; a boxcar of that length passes what a spindle's structure feels and has its first null at f_c, so the PWM ripple drops out, and with 12 poles and 2 kHz so does the commutation ripple above ≈ 1670 rpm for twelve-step (12 × the electrical frequency) and 3330 rpm for six-step (6 ×)",
    ),
    (
        "current_peak_a / commutation_peak_a",
        "largest phase-current magnitude in the window, and the commutation surge: the mean over the window's states of the largest phase-current magnitude during each state",
    ),
    (
        "current_rms_a",
        "RMS phase current over the window, √(mean(i_u² + i_v² + i_w²)/3), exact: from the copper loss the plant integrates",
    ),
    (
        "commutation error",
        "true electrical angle at each commutation minus the table boundary of the state entered, in electrical degrees (positive: late); mean is signed, max is the largest magnitude",
    ),
    (
        "restarts",
        "restarts during the run (a step miss or a supervisor trip), after each of which the chip re-aligned and started again",
    ),
    (
        "forced crossings",
        "zero crossings the phase shifter took from its demagnetisation timeout because the comparator did not show one in time",
    ),
    (
        "min / max rpm",
        "floor: the lowest command the drive holds (verdict `running`, no restart) after being turned down from a running speed; top: the highest it holds after being turned up from a running speed; found by bisection to 3 % (floor also to 5 rpm), each with the verdict of the failed run beyond it",
    ),
    (
        "anti-windup: overshoot / undershoot / settling",
        "for each anti-windup case, from its event (a speed step, or the release of a load): the largest excursion of the true speed beyond the command in the direction of the change (above it after a step up or a release, below it after a step down), in rpm and in % of the change, and the time after the event from which the speed stays within ±2 % of the command",
    ),
    (
        "load dip / recovery",
        "for the load step: largest drop of the true speed below the command, and the time after the step from which it stays within ±2 % of the command",
    ),
    (
        "sensitivity: floor / ripple per level",
        "for each factor of the sensitivity study at its low and its high level (every other setting at the baseline, the 24-bit meter): the floor as above (also to 3 % or 5 rpm), seeded at 3000 rpm once that holds from standstill (none when it does not), and the LF ripple in % of the mean torque at 1000 rpm turned down from 3000 rpm; a tornado's segment runs from the low level's value to the high level's",
    ),
];

pub(super) fn opt(v: Option<f64>, scale: f64, decimals: usize) -> String {
    v.map_or("–".to_string(), |x| format!("{:.decimals$}", x * scale))
}

/// The summary's columns: (name, unit or second header line).
const SUMMARY_COLUMNS: [(&str, &str); 10] = [
    ("strategy", ""),
    ("min", "rpm"),
    ("max", "rpm"),
    ("grid", "ok"),
    ("err@{trace} °", "mean / max"),
    ("ripple", "rpm"),
    ("T ripple", "mN·m"),
    ("I rms", "A"),
    ("full duty ms", "AW on / off"),
    ("load dip rpm", "/ recovery s"),
];

/// The summary's header (name, unit), its rows and the note under it.
type SummaryTable = (Vec<(String, &'static str)>, Vec<[String; 10]>, String);

/// The summary's header, its rows (one per variant) and the note under it: one source for
/// the terminal's fixed-width table and the report's Markdown table.
fn summary(c: &Comparison) -> SummaryTable {
    let trace_rpm = c.plan.trace_rpm;
    let head = SUMMARY_COLUMNS
        .iter()
        .map(|&(n, u)| (n.replace("{trace}", &format!("{trace_rpm:.0}")), u))
        .collect();
    let rows = c
        .variants
        .iter()
        .map(|v| summary_row(c, &v.label))
        .collect();
    let note = format!(
        "grid ok: speeds of {:?} rpm held within 2 % without restart; err/ripple/I at {trace_rpm:.0} rpm; full duty ms: how long the voltage command stays at >= 95 % of the carrier after the step down from beyond reach, anti-windup on the current PI / off; load dip: the deepest speed drop and the time back within 2 % after a {:.1} mN·m load at {:.0} rpm",
        c.plan.grid_rpm,
        c.plan.load.1 * 1e3,
        c.plan.load.0
    );
    (head, rows, note)
}

fn summary_row(c: &Comparison, label: &str) -> [String; 10] {
    let trace_rpm = c.plan.trace_rpm;
    let range = c
        .ranges
        .iter()
        .find(|r| r.strategy == label && r.meter == c.plan.meter.label);
    let grid: Vec<_> = c.grid.iter().filter(|g| g.variant == label).collect();
    let ok = grid.iter().filter(|g| holds(&g.summary)).count();
    let at_any = grid.iter().find(|g| g.summary.speed_ref_rpm == trace_rpm);
    // A failed run's figures are not a measurement: its verdict stands in their place.
    let at = at_any.filter(|g| holds(&g.summary));
    let failed = at_any
        .filter(|g| !holds(&g.summary))
        .map(|g| g.summary.verdict.as_str().to_string());
    // The release of a saturated voltage command: the first case stepping down.
    let release = c.plan.step.cases.iter().position(|k| k.is_step_down());
    let step = |aw: AntiWindup| {
        c.steps
            .iter()
            .find(|x| x.variant == label && Some(x.case) == release && x.anti_windup == aw)
            .map_or("–".into(), |x| {
                format!("{:.0}", x.full_duty_after_s * 1e3)
            })
    };
    let load = c.loads.iter().find(|l| l.variant == label);
    [
        label.to_string(),
        opt(range.and_then(|r| r.min_rpm), 1.0, 0),
        opt(range.and_then(|r| r.max_rpm), 1.0, 0),
        format!("{ok}/{}", grid.len()),
        at.map_or(failed.unwrap_or("–".into()), |g| {
            format!(
                "{:+.1} / {:.1}",
                g.summary.commutation_error_deg_mean, g.summary.commutation_error_deg_max
            )
        }),
        at.map_or("–".into(), |g| {
            format!("{:.1}", g.summary.speed_ripple_rpm)
        }),
        at.map_or("–".into(), |g| {
            format!("{:.3}", g.summary.torque_ripple_nm * 1e3)
        }),
        at.map_or("–".into(), |g| format!("{:.3}", g.summary.current_rms_a)),
        format!("{} / {}", step(AntiWindup::Current), step(AntiWindup::Off)),
        // A drive that failed the load run has no dip to show: its verdict instead.
        load.map_or("–".into(), |l| {
            if l.verdict.is_running() {
                format!(
                    "{:.0} / {}",
                    l.response.dip,
                    opt(l.response.recovery_s, 1.0, 2)
                )
            } else {
                l.verdict.as_str().to_string()
            }
        }),
    ]
}

/// The compact table printed to the terminal.
pub fn terminal_table(c: &Comparison) -> String {
    const WIDTHS: [usize; 10] = [22, 7, 7, 5, 13, 9, 9, 7, 13, 13];
    let (head, rows, note) = summary(c);
    let mut s = String::new();
    let mut line = |cells: &mut dyn Iterator<Item = &str>| {
        let mut l = String::new();
        for (k, (cell, w)) in cells.zip(WIDTHS).enumerate() {
            let _ = match k {
                0 => write!(l, "{cell:<w$}"),
                _ => write!(l, " {cell:>w$}"),
            };
        }
        let _ = writeln!(s, "{}", l.trim_end());
    };
    line(&mut head.iter().map(|h| h.0.as_str()));
    line(&mut head.iter().map(|h| h.1));
    for r in &rows {
        line(&mut r.iter().map(String::as_str));
    }
    let _ = writeln!(s, "{note}");
    let _ = writeln!(s, "wall time {:.1} s on {} threads", c.wall_s, c.threads);
    s
}

/// The summary as a Markdown table, its note under it.
fn summary_markdown(c: &Comparison) -> String {
    let (head, rows, note) = summary(c);
    let mut s = String::from("|");
    for (name, unit) in &head {
        let _ = match *unit {
            "" => write!(s, " {name} |"),
            u => write!(s, " {name} {u} |"),
        };
    }
    s.push_str("\n|---|");
    s.push_str(&"---:|".repeat(head.len() - 1));
    s.push('\n');
    for r in &rows {
        let _ = writeln!(s, "| {} |", r.join(" | "));
    }
    let _ = writeln!(s, "\n{note}.");
    s
}

/// Writes `results.json`, `results.csv`, `report.md`, `report.html` (the same report in
/// one self-contained page) and the SVG plots into `dir`,
/// returning the files written.
pub fn write_folder(
    c: &Comparison,
    config: &DriveConfig,
    dir: &Path,
) -> std::io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let mut files = Vec::new();
    let mut put = |name: &str, text: String| -> std::io::Result<()> {
        let p = dir.join(name);
        std::fs::write(&p, text)?;
        files.push(p);
        Ok(())
    };
    let record = ResultsRecord {
        schema_version: 1,
        tool: format!("drive-bench {}", env!("CARGO_PKG_VERSION")),
        config,
        seed: config.sensing.seed,
        columns: "report.md, section \"results.csv columns\"",
        comparison: c,
    };
    let json = serde_json::to_string_pretty(&record).map_err(std::io::Error::other)?;
    put("results.json", json)?;
    put("results.csv", grid_csv(c))?;
    let mut figures = vec![
        ("speed_step.svg".to_string(), speed_step_chart(c, config)),
        ("load_step.svg".to_string(), load_step_chart(c)),
        ("ripple_vs_speed.svg".to_string(), ripple_chart(c)),
        ("phase_current.svg".to_string(), current_chart(c)),
    ];
    // No range searched (`--quick`): no empty figure.
    if !c.ranges.is_empty() {
        figures.push((
            super::results::RANGE_CHART.to_string(),
            super::results::range_chart(c),
        ));
    }
    figures.extend(super::vibration::charts(c));
    if !c.drifts.is_empty() {
        figures.push((super::drift::CHART.to_string(), super::drift::chart(c)));
    }
    figures.extend(super::floors::charts(&c.floor_zooms));
    figures.extend(tornado_charts(c));
    let mut crossing_files = Vec::new();
    for t in &c.crossings {
        let name = super::svg::file_name("crossing", &t.variant);
        figures.push((name.clone(), crossing_chart(t)));
        crossing_files.push(name);
    }
    for (name, svg) in &figures {
        put(name, svg.clone())?;
    }
    let md = markdown(c, config, &crossing_files);
    put(
        "report.html",
        super::html::page("drive-bench report", &md, &figures),
    )?;
    put("report.md", md)?;
    Ok(files)
}

/// The labels of the variants the sensitivity study ran, in the comparison's order.
fn studied(c: &Comparison) -> Vec<String> {
    c.variants
        .iter()
        .map(|v| v.label.clone())
        .filter(|l| c.sensitivity.iter().any(|p| &p.strategy == l))
        .collect()
}

/// The sensitivity study's tornado charts: per studied strategy, the floor's and the
/// ripple's.
fn tornado_charts(c: &Comparison) -> Vec<(String, String)> {
    use super::tornado::{Measure, chart, file_of};
    studied(c)
        .iter()
        .flat_map(|l| {
            Measure::ALL.map(|m| {
                let color = c.color_of(l).unwrap_or(0);
                (file_of(l, m), chart(&c.sensitivity, l, m, color))
            })
        })
        .collect()
}

/// `results.csv`'s columns, in order: (name, unit, definition). The header and the
/// report's column reference are both written from this one table. "Window" is the grid
/// run's steady-state window: its last third.
pub const GRID_COLUMNS: [(&str, &str, &str); 21] = [
    (
        "strategy",
        "",
        "strategy (and guard or conduction angle) of the run",
    ),
    (
        "speed_ref_rpm",
        "rpm",
        "speed command, held from standstill",
    ),
    (
        "verdict",
        "",
        "running, off-speed, lost-sync, stalled, not-started, gave-up or non-finite, judged from the true rotor; the figures after it are a valid measurement only when it is running",
    ),
    ("verdict_reason", "", "why, in one line"),
    (
        "speed_mean_rpm",
        "rpm",
        "time-weighted mean of the true speed over the window",
    ),
    (
        "speed_ripple_rpm",
        "rpm",
        "standard deviation of the true speed over the window",
    ),
    (
        "torque_mean_nm",
        "N·m",
        "mean electromagnetic torque over the window, exact (from ∫Te dt)",
    ),
    (
        "torque_ripple_nm",
        "N·m",
        "standard deviation of the torque over the window, full band, exact (from ∫Te dt and ∫Te² dt)",
    ),
    (
        "torque_ripple_lf_nm",
        "N·m",
        "low-frequency torque ripple, the vibration proxy: standard deviation of the torque's means over blocks of 1/f_c (f_c = 2 kHz) in the window",
    ),
    (
        "current_rms_a",
        "A",
        "phase-current RMS over the window, √(mean(i_u² + i_v² + i_w²)/3), exact (from the copper loss)",
    ),
    (
        "current_peak_a",
        "A",
        "largest phase-current magnitude at the engine's whole-tick stops in the window",
    ),
    (
        "commutation_peak_a",
        "A",
        "commutation surge: mean over the states in the window of each state's largest phase-current magnitude",
    ),
    (
        "restarts",
        "",
        "restarts (step-miss or supervisor) during the whole run",
    ),
    (
        "chip_running",
        "",
        "whether the controller believes it ended in closed loop (the verdict says whether the rotor agrees)",
    ),
    ("commutations", "", "commutations in the window"),
    (
        "commutation_error_deg_mean",
        "° (electrical)",
        "signed mean of the commutation-angle error at the true θe (positive: late)",
    ),
    (
        "commutation_error_deg_max",
        "° (electrical)",
        "largest |commutation-angle error| in the window",
    ),
    (
        "forced_crossings",
        "",
        "zero crossings taken by the demagnetisation timeout instead of the comparator, since the last hand-over",
    ),
    ("sim_s", "s", "simulated time"),
    ("wall_s", "s", "wall-clock time of the run"),
    ("realtime_factor", "", "sim_s / wall_s"),
];

/// The metric definitions and the `results.csv` column reference, as Markdown sections:
/// the report's, and the project's `docs/outputs.md` (a test keeps it current).
pub fn metrics_reference(grid_duration_s: f64) -> String {
    let mut s = String::from("\n## Metrics\n\n");
    for (name, def) in METRIC_DEFINITIONS {
        let _ = writeln!(s, "- **{name}**: {def}.");
    }
    let _ = writeln!(
        s,
        "\n## results.csv columns\n\nOne row per grid run (every strategy at every grid speed, {grid_duration_s} s from standstill; the window is the last third). `results.json` holds the same runs and every other experiment, with the tool's version, the complete config and the seeds.\n\n| column | unit | definition |\n|---|---|---|",
    );
    for (name, unit, def) in GRID_COLUMNS {
        let _ = writeln!(s, "| `{name}` | {unit} | {def} |");
    }
    s
}

/// `results.json`: what produced the comparison, then the comparison itself.
#[derive(Serialize)]
struct ResultsRecord<'a> {
    /// Version of this layout; it changes when a key changes meaning or goes away.
    schema_version: u32,
    /// The program and its version.
    tool: String,
    /// The base config every variant ran on, complete (each variant sets its strategy).
    config: &'a DriveConfig,
    /// The comparator-noise seed of every run but the start-up Monte-Carlo's, whose
    /// seed is `plan.startup`'s second element.
    seed: u64,
    /// Where `results.csv`'s columns are defined.
    columns: &'static str,
    #[serde(flatten)]
    comparison: &'a Comparison,
}

fn grid_csv(c: &Comparison) -> String {
    // Writing to memory cannot fail; every record has the header's length.
    let mut w = csv::Writer::from_writer(Vec::new());
    let _ = w.write_record(GRID_COLUMNS.iter().map(|c| c.0));
    for g in &c.grid {
        let m = &g.summary;
        let _ = w.write_record([
            g.variant.to_string(),
            m.speed_ref_rpm.to_string(),
            m.verdict.to_string(),
            m.verdict_reason.clone(),
            format!("{:.3}", m.speed_mean_rpm),
            format!("{:.3}", m.speed_ripple_rpm),
            format!("{:.6e}", m.torque_mean_nm),
            format!("{:.6e}", m.torque_ripple_nm),
            format!("{:.6e}", m.torque_ripple_lf_nm),
            format!("{:.5}", m.current_rms_a),
            format!("{:.5}", m.current_peak_a),
            format!("{:.5}", m.commutation_peak_a),
            m.restarts.to_string(),
            m.chip_running.to_string(),
            m.commutations.to_string(),
            format!("{:.3}", m.commutation_error_deg_mean),
            format!("{:.3}", m.commutation_error_deg_max),
            m.forced_crossings.to_string(),
            format!("{:.3}", m.sim_s),
            format!("{:.3}", m.wall_s),
            format!("{:.2}", m.realtime_factor),
        ]);
    }
    String::from_utf8(w.into_inner().unwrap_or_default()).unwrap_or_default()
}

/// The anti-windup cases of one strategy (the last of the plan's, the chip's default):
/// per case the command and the true speed, the speed PI's output (the current command)
/// with its limit, and the current PI's (the duty) with full voltage, each with anti-windup
/// off, on the current PI and on both, so that a PI sitting at its limit is seen.
fn speed_step_chart(c: &Comparison, config: &DriveConfig) -> String {
    let Some(strategy) = c.plan.step.variants.last() else {
        return chart("Anti-windup: no case run", "time [s]", &[]);
    };
    let limit = config.control.current_limit_a;
    let mut panels = Vec::new();
    for (k, case) in c.plan.step.cases.iter().enumerate() {
        let from = case
            .load_nm
            .points()
            .iter()
            .find(|l| l.1 != 0.0)
            .map_or(case.at_s, |l| l.0.min(case.at_s))
            - 0.5;
        let runs: Vec<&StepRun> = c
            .steps
            .iter()
            .filter(|s| s.case == k && &s.variant == strategy)
            .collect();
        let to = runs
            .iter()
            .filter_map(|s| s.speed.last().map(|p| p.0))
            .fold(from, f64::max);
        let after = |v: &[(f64, f64)]| v.iter().copied().filter(|p| p.0 >= from).collect();
        // Anti-windup off, current PI, both: colours 0, 1, 2.
        let per = |f: &dyn Fn(&StepRun) -> Vec<(f64, f64)>| -> Vec<Series> {
            runs.iter()
                .map(|s| Series {
                    name: format!("anti-windup {}", s.anti_windup.as_str()),
                    points: f(s),
                    color: Some(s.anti_windup as usize),
                    ..Series::default()
                })
                .collect()
        };
        let level = |name: &str, y: f64| Series {
            name: name.into(),
            points: vec![(from, y), (to, y)],
            color: Some(7),
            dash: Some("4 3"),
            ..Series::default()
        };
        let command = Series {
            name: "command".into(),
            points: (0..=400)
                .map(|i| from + (to - from) * f64::from(i) / 400.0)
                .map(|t| (t, case.speed_rpm.value_at(t)))
                .collect(),
            steps: true,
            color: Some(7),
            ..Series::default()
        };
        let mut speed = vec![command];
        speed.extend(per(&|s| after(&s.speed)));
        panels.push(Panel {
            y_label: format!("{}: speed [rpm]", case.name),
            series: speed,
        });
        let mut current = per(&|s| after(&s.current_ref));
        current.push(level("current limit", limit));
        panels.push(Panel {
            y_label: "current command (speed PI) [A]".into(),
            series: current,
        });
        let mut duty = per(&|s| after(&s.duty));
        duty.push(level("full voltage", 1.0));
        panels.push(Panel {
            y_label: "duty (current PI)".into(),
            series: duty,
        });
    }
    chart(
        &format!("Anti-windup, {strategy}: speed and both PIs' outputs against their limits"),
        "time [s]",
        &panels,
    )
}

fn load_step_chart(c: &Comparison) -> String {
    let series = c
        .loads
        .iter()
        .map(|l| Series {
            name: l.variant.clone(),
            points: l
                .speed
                .iter()
                .copied()
                .filter(|p| p.0 > c.plan.load.2 - 0.5)
                .collect(),
            steps: false,
            color: c.color_of(&l.variant),
            dash: None,
        })
        .collect();
    chart(
        &format!(
            "Load step {:.2} mN·m at t = {} s, {:.0} rpm",
            c.plan.load.1 * 1e3,
            c.plan.load.2,
            c.plan.load.0
        ),
        "time [s]",
        &[Panel {
            y_label: "speed [rpm]".into(),
            series,
        }],
    )
}

fn ripple_chart(c: &Comparison) -> String {
    let per = |f: &dyn Fn(&crate::scenario::Summary) -> f64| -> Vec<Series> {
        c.variants
            .iter()
            .map(|v| Series {
                name: v.label.clone(),
                points: c
                    .grid
                    .iter()
                    .filter(|g| g.variant == v.label && g.summary.verdict.is_running())
                    .map(|g| (g.summary.speed_ref_rpm, f(&g.summary)))
                    .collect(),
                steps: false,
                color: c.color_of(&v.label),
                dash: None,
            })
            .collect()
    };
    chart(
        "Steady state vs speed (points where the drive was running)",
        "speed command [rpm]",
        &[
            Panel {
                y_label: "torque ripple (std) [mN·m]".into(),
                series: per(&|s| s.torque_ripple_nm * 1e3),
            },
            Panel {
                y_label: "LF torque ripple < 2 kHz [mN·m]".into(),
                series: per(&|s| s.torque_ripple_lf_nm * 1e3),
            },
            Panel {
                y_label: "max |commutation error| [°]".into(),
                series: per(&|s| s.commutation_error_deg_max),
            },
        ],
    )
}

fn current_chart(c: &Comparison) -> String {
    let panels: Vec<Panel> = c
        .crossings
        .iter()
        .map(|t| {
            let t0 = t.rows.first().map_or(0.0, |r| r.t_s);
            let line = |name: &str, f: fn(&crate::scenario::TraceRow) -> f64| Series {
                name: name.into(),
                points: t.rows.iter().map(|r| ((r.t_s - t0) * 1e3, f(r))).collect(),
                ..Series::default()
            };
            // A failed run's currents are not the strategy's: the panel says so.
            let failed = c
                .grid
                .iter()
                .find(|g| g.variant == t.variant && g.summary.speed_ref_rpm == c.plan.trace_rpm)
                .filter(|g| !holds(&g.summary));
            Panel {
                y_label: match failed {
                    Some(g) => format!(
                        "{}: {}, not a measurement [A]",
                        t.variant, g.summary.verdict
                    ),
                    None => format!("{} [A]", t.variant),
                },
                series: vec![
                    line("i_u", |r| r.i_u),
                    line("i_v", |r| r.i_v),
                    line("i_w", |r| r.i_w),
                ],
            }
        })
        .collect();
    chart(
        &format!(
            "Phase currents over one electrical turn at {:.0} rpm",
            c.plan.trace_rpm
        ),
        "time from window start [ms]",
        &panels,
    )
}

/// Phase u against the neutral, with Z_d before and after the guard and the linear
/// flag, over ±60° electrical around the first rising crossing of e_u (θe through 0°).
fn crossing_chart(t: &CrossingTrace) -> String {
    let rows = &t.rows;
    let k = rows
        .windows(2)
        .position(|w| w[0].theta_e_deg > 300.0 && w[1].theta_e_deg < 60.0)
        .unwrap_or(rows.len() / 2);
    let t_cross = rows.get(k).map_or(0.0, |r| r.t_s);
    // 60° electrical in time, from the angle advance across the trace.
    let span = rows
        .windows(2)
        .map(|w| (w[1].theta_e_deg - w[0].theta_e_deg).rem_euclid(360.0))
        .sum::<f64>();
    let dur = rows.last().map_or(0.0, |r| r.t_s) - rows.first().map_or(0.0, |r| r.t_s);
    let w60 = if span > 0.0 {
        60.0 * dur / span
    } else {
        dur / 2.0
    };
    let win: Vec<_> = rows
        .iter()
        .filter(|r| (r.t_s - t_cross).abs() <= w60)
        .collect();
    let x = |r: &crate::scenario::TraceRow| (r.t_s - t_cross) * 1e6;
    let line = |name: &str, steps: bool, f: &dyn Fn(&crate::scenario::TraceRow) -> f64| Series {
        name: name.into(),
        points: win.iter().map(|r| (x(r), f(r))).collect(),
        steps,
        ..Series::default()
    };
    chart(
        &format!("{}: around a rising crossing of e_u (θe = 0)", t.variant),
        "time from θe = 0 [µs]",
        &[
            Panel {
                y_label: "voltage [V]".into(),
                series: vec![
                    line("v_u − v_n", false, &|r| r.v_u - r.v_n),
                    line("v_u", false, &|r| r.v_u),
                    line("v_n", false, &|r| r.v_n),
                ],
            },
            Panel {
                y_label: "Z_d raw (0/1)".into(),
                series: vec![line("raw", true, &|r| f64::from(r.zd))],
            },
            Panel {
                y_label: "Z_d after the guard (0/1)".into(),
                series: vec![
                    line("guarded", true, &|r| f64::from(r.zdf)),
                    line("linear region", true, &|r| f64::from(r.linear)),
                ],
            },
            Panel {
                y_label: "commutation state".into(),
                series: vec![line("state", true, &|r| f64::from(r.state))],
            },
        ],
    )
}

fn markdown(c: &Comparison, config: &DriveConfig, crossings: &[String]) -> String {
    let mut s = String::new();
    sections::intro(&mut s, c, config);
    let _ = writeln!(s, "## Summary\n\n{}", summary_markdown(c));
    s.push_str(&super::results::section(c));
    s.push_str(&metrics_reference(c.plan.grid_duration_s));
    sections::ranges(&mut s, c);
    sections::steady_state(&mut s, c);
    sections::anti_windup(&mut s, c);
    sections::load_step(&mut s, c);
    sections::startup(&mut s, c);
    s.push_str(&super::drift::section(c, config));
    s.push_str(&super::vibration::section(c));
    s.push_str(&super::sensitivity_report::section(
        &c.sensitivity,
        &studied(c),
        config.sensing.seed,
    ));
    sections::plots(&mut s, crossings);
    s
}
