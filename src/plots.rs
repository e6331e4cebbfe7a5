//! Plots of one scenario, as a drive engineer reads them (`drive-bench run --plot DIR`).
//!
//! - `overview.svg`, the whole run, with the experiment's inputs beside the response: the
//!   speed command with the true speed and the chip's estimate; the current command (the
//!   speed PI's output) with the shunt current; the duty; the torque with the load's;
//!   the supply. Each point is the mean over 1/4000 of the run of a trace taken every
//!   10 µs (at most), so PWM-rate signals show their average, as the loops see them.
//! - `zoom.svg`, three electrical turns sampled every microsecond: phase currents,
//!   terminal and neutral voltages, the commutation state as labelled steps, and the
//!   zero-crossing signal raw and after the guard. For a drive that lost its rotor, the
//!   turns around the first commutation out of synchronism (marked on both figures);
//!   otherwise the last turns of the run.
//!
//! Titles carry the scenario's description. Each figure comes from its own run of the
//! scenario with a trace over its window; runs are deterministic, so both show the same
//! drive as the summary.

use crate::bench::svg::{Mark, Panel, Series, chart_marked};
use crate::scenario::{RunError, Scenario, Summary, TraceRow, TraceSpec, run};

/// Points in the overview.
const OVERVIEW_POINTS: f64 = 4000.0;
/// The overview's trace period, averaged into each point \[s\].
const OVERVIEW_EVERY_S: f64 = 10e-6;
/// The zoom's sampling period \[s\].
const ZOOM_EVERY_S: f64 = 1e-6;

/// The figures of `sc`, whose run gave `summary`: (file name, SVG).
pub fn scenario_plots(sc: &Scenario, summary: &Summary) -> Result<Vec<(String, String)>, RunError> {
    let title = format!(
        "{} — {}",
        match &sc.plugin {
            Some(p) => p.name().to_string(),
            None => sc.config.strategy.name.to_string(),
        },
        describe(sc)
    );
    let lost = lost_at(summary);
    let bin = (sc.duration_s / OVERVIEW_POINTS).max(OVERVIEW_EVERY_S);
    let rows = binned(sc, bin)?;
    let mark = |x: f64| Mark {
        x,
        label: "rotor lost".into(),
    };
    let overview_panels = overview_panels(&rows);
    let overview = chart_marked(
        &format!("{title}: the whole run ({})", summary.verdict),
        "time [s]",
        &overview_panels,
        &vec![lost.map(|(t, _)| mark(t)).into_iter().collect::<Vec<_>>(); overview_panels.len()],
    );
    let rows = zoom_rows(sc, lost)?;
    let zoom = zoom_chart(&title, &rows, lost);
    Ok(vec![
        ("overview.svg".into(), overview),
        ("zoom.svg".into(), zoom),
    ])
}

/// The zoom's rows of `sc`: three electrical turns every microsecond (see
/// [`zoom_chart`]), around `lost` (t \[s\], rpm) when given.
pub fn zoom_rows(sc: &Scenario, lost: Option<(f64, f64)>) -> Result<Vec<TraceRow>, RunError> {
    let (from, to) = zoom_window(sc, lost);
    traced(sc, from, to, ZOOM_EVERY_S)
}

/// The zoom of `rows` under `title`: the speed (true and the chip's estimate), phase
/// currents, terminal and neutral voltages, the state and the comparator before and
/// after the guard, with the loss of the rotor `lost` (t \[s\], rpm) marked.
pub fn zoom_chart(title: &str, rows: &[TraceRow], lost: Option<(f64, f64)>) -> String {
    let span = rows.last().map_or(0.0, |r| r.t_s) - rows.first().map_or(0.0, |r| r.t_s);
    let what = match lost {
        Some((t, rpm)) => format!("rotor lost at {t:.4} s, {rpm:.0} rpm"),
        None => "the last electrical turns".to_string(),
    };
    let panels = zoom_panels(rows);
    let mark = lost.map(|(t, _)| Mark {
        x: t * 1e3,
        label: "rotor lost".into(),
    });
    chart_marked(
        &format!("{title}: {what}, {:.1} ms", span * 1e3),
        "time [ms]",
        &panels,
        &vec![mark.into_iter().collect::<Vec<_>>(); panels.len()],
    )
}

/// Where a drive that failed, or was stopped, lost its rotor: (t \[s\], true speed \[rpm\]).
pub fn lost_at(summary: &Summary) -> Option<(f64, f64)> {
    use crate::verdict::Verdict;
    // A stop is a success that passes through the loss on its way down: shown too.
    summary
        .sync_lost_at
        .filter(|_| !matches!(summary.verdict, Verdict::Running | Verdict::Unsettled))
}

fn describe(sc: &Scenario) -> String {
    if !sc.description.is_empty() {
        return sc.description.clone();
    }
    let p = sc.speed_rpm.points();
    if p.len() == 1 {
        format!("{:.0} rpm for {} s", p[0].1, sc.duration_s)
    } else {
        format!("speed profile over {} s", sc.duration_s)
    }
}

fn traced(sc: &Scenario, from_s: f64, to_s: f64, every_s: f64) -> Result<Vec<TraceRow>, RunError> {
    let mut sc = sc.clone();
    sc.trace = Some(TraceSpec {
        every_s,
        from_s,
        to_s,
    });
    let mut rows = Vec::new();
    run(&sc, |r| rows.push(*r))?;
    Ok(rows)
}

/// The run traced every [`OVERVIEW_EVERY_S`] (at most `bin`), each bin of `bin` seconds
/// one row: the mean of every signal, timed at the bin's middle.
fn binned(sc: &Scenario, bin: f64) -> Result<Vec<TraceRow>, RunError> {
    let mut sc = sc.clone();
    let every = OVERVIEW_EVERY_S.min(bin);
    sc.trace = Some(TraceSpec {
        every_s: every,
        from_s: 0.0,
        to_s: sc.duration_s,
    });
    let mut out = Vec::new();
    let (mut sum, mut n, mut k) = (TraceRow::default(), 0u32, 0u64);
    // A bin cut short by the run's end would be a mean of a few PWM periods: dropped.
    let full = (bin / every * 0.5).max(1.0) as u32;
    let close = |sum: &mut TraceRow, n: &mut u32, k: u64, out: &mut Vec<TraceRow>| {
        if *n >= full {
            let f = 1.0 / f64::from(*n);
            let mut r = *sum;
            for x in [
                &mut r.speed_rpm,
                &mut r.speed_est_rpm,
                &mut r.duty,
                &mut r.torque_nm,
                &mut r.speed_ref_rpm,
                &mut r.current_ref_a,
                &mut r.load_nm,
                &mut r.supply_v,
                &mut r.i_shunt_a,
            ] {
                *x *= f;
            }
            r.t_s = (k as f64 + 0.5) * bin;
            out.push(r);
        }
        (*sum, *n) = (TraceRow::default(), 0);
    };
    run(&sc, |r| {
        let kr = (r.t_s / bin).floor() as u64;
        if kr != k {
            close(&mut sum, &mut n, k, &mut out);
            k = kr;
        }
        sum.speed_rpm += r.speed_rpm;
        sum.speed_est_rpm += r.speed_est_rpm;
        sum.duty += r.duty;
        sum.torque_nm += r.torque_nm;
        sum.speed_ref_rpm += r.speed_ref_rpm;
        sum.current_ref_a += r.current_ref_a;
        sum.load_nm += r.load_nm;
        sum.supply_v += r.supply_v;
        sum.i_shunt_a += r.i_shunt_a;
        n += 1;
    })?;
    close(&mut sum, &mut n, k, &mut out);
    Ok(out)
}

/// Three electrical turns, 1–20 ms: around `lost` (t, rpm), two turns before it and one
/// after, at that speed; otherwise at the final command, ending with the run.
fn zoom_window(sc: &Scenario, lost: Option<(f64, f64)>) -> (f64, f64) {
    let turn_at = |rpm: f64| 60.0 / (rpm.abs().max(1.0) * f64::from(sc.config.motor.poles / 2));
    match lost {
        Some((t, rpm)) => {
            let span = (3.0 * turn_at(rpm)).clamp(1e-3, 20e-3).min(sc.duration_s);
            let from = (t - span * 2.0 / 3.0).clamp(0.0, sc.duration_s - span);
            (from, from + span)
        }
        None => {
            let rpm = sc.speed_rpm.value_at(sc.duration_s);
            let span = (3.0 * turn_at(rpm)).clamp(1e-3, 20e-3).min(sc.duration_s);
            (sc.duration_s - span, sc.duration_s)
        }
    }
}

fn line(name: &str, points: Vec<(f64, f64)>) -> Series {
    Series {
        name: name.into(),
        points,
        ..Series::default()
    }
}

/// A sample-and-hold signal (the command, logic levels, the state).
fn steps(name: &str, points: Vec<(f64, f64)>) -> Series {
    Series {
        steps: true,
        ..line(name, points)
    }
}

fn overview_panels(rows: &[TraceRow]) -> Vec<Panel> {
    let of = |f: fn(&TraceRow) -> f64| rows.iter().map(|r| (r.t_s, f(r))).collect();
    vec![
        Panel {
            y_label: "speed [rpm]".into(),
            series: vec![
                line("command", of(|r| r.speed_ref_rpm)),
                line("true", of(|r| r.speed_rpm)),
                line("chip's estimate (FG)", of(|r| r.speed_est_rpm)),
            ],
        },
        Panel {
            y_label: "current [A]".into(),
            series: vec![
                line("command (speed PI)", of(|r| r.current_ref_a)),
                line("shunt, mean", of(|r| r.i_shunt_a)),
            ],
        },
        Panel {
            y_label: "duty [fraction of the carrier]".into(),
            series: vec![line("duty", of(|r| r.duty))],
        },
        Panel {
            y_label: "torque [mN·m]".into(),
            series: vec![
                line("Te, mean", of(|r| r.torque_nm * 1e3)),
                line("load T_L", of(|r| r.load_nm * 1e3)),
            ],
        },
        Panel {
            y_label: "supply [V]".into(),
            series: vec![line("V_DD", of(|r| r.supply_v))],
        },
    ]
}

fn zoom_panels(rows: &[TraceRow]) -> Vec<Panel> {
    let ms = |r: &TraceRow| r.t_s * 1e3;
    let of = |f: fn(&TraceRow) -> f64| rows.iter().map(|r| (ms(r), f(r))).collect();
    vec![
        Panel {
            y_label: "speed [rpm]".into(),
            series: vec![
                line("true", of(|r| r.speed_rpm)),
                steps("chip's estimate (FG)", of(|r| r.speed_est_rpm)),
            ],
        },
        Panel {
            y_label: "phase currents [A]".into(),
            series: vec![
                line("i_u", of(|r| r.i_u)),
                line("i_v", of(|r| r.i_v)),
                line("i_w", of(|r| r.i_w)),
            ],
        },
        Panel {
            y_label: "terminal voltages [V]".into(),
            series: vec![
                line("v_u", of(|r| r.v_u)),
                line("v_v", of(|r| r.v_v)),
                line("v_w", of(|r| r.v_w)),
                line("neutral v_n", of(|r| r.v_n)),
            ],
        },
        Panel {
            y_label: "commutation state (0: off)".into(),
            series: vec![steps("state", of(|r| f64::from(r.state)))],
        },
        Panel {
            y_label: "zero-crossing signal Z_d raw (0/1)".into(),
            series: vec![steps("raw", of(|r| f64::from(r.zd)))],
        },
        Panel {
            y_label: "Z_d after the guard (0/1)".into(),
            series: vec![
                steps("guarded", of(|r| f64::from(r.zdf))),
                steps("linear region", of(|r| f64::from(r.linear))),
            ],
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::DriveConfig;

    #[test]
    fn both_figures_have_every_panel_and_data() {
        let sc = Scenario::hold(DriveConfig::default(), 3000.0, 1.5);
        let summary = run(&sc, |_| {}).unwrap().summary;
        let figs = scenario_plots(&sc, &summary).unwrap();
        assert_eq!(figs.len(), 2);
        for (name, svg) in &figs {
            assert!(
                svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
                "{name}"
            );
            // Every series drew a line through many points.
            let lines = svg.matches("<path d=\"M").count();
            assert!(lines >= 6, "{name}: {lines}");
            // Points of the longest path (relative moves, space-separated): thinned to at
            // most two per pixel column of the 630 px plot, at least one per column.
            let longest = svg
                .split("<path d=\"")
                .skip(1)
                .map(|p| p.split('"').next().unwrap_or("").split(' ').count())
                .max();
            assert!(longest.unwrap_or(0) > 600, "{name}: {longest:?}");
            assert!(!svg.contains("NaN"), "{name}");
        }
        // 3000 rpm, 6 pole pairs: a turn is 3.33 ms, the zoom 10 ms.
        let (a, b) = zoom_window(&sc, None);
        assert!((b - a - 10e-3).abs() < 1e-12);
    }
}
