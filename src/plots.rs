//! Plots of one scenario, as a drive engineer reads them (`drive-bench run --plot DIR`).
//!
//! - `overview.svg`, the whole run: true and estimated speed with the command overlaid, the
//!   duty, the torque and a phase current, sampled every 1/4000 of the run (at least
//!   every 10 µs). Samples of PWM-rate signals at that spacing show their envelope, not
//!   their shape: the zoom is for that.
//! - `zoom.svg`, the last three electrical turns at the final command (1–20 ms) sampled
//!   every microsecond: phase currents, terminal and neutral voltages, the commutation
//!   state as labelled steps, and the zero-crossing signal raw and after the guard.
//!
//! Each figure comes from its own run of the scenario with a trace over its window; runs
//! are deterministic, so both show the same drive as the summary.

use crate::bench::svg::{Panel, Series, chart};
use crate::scenario::{RunError, Scenario, TraceRow, TraceSpec, run};

/// Samples in the overview.
const OVERVIEW_POINTS: f64 = 4000.0;
/// The zoom's sampling period \[s\].
const ZOOM_EVERY_S: f64 = 1e-6;

/// The figures of `sc`: (file name, SVG).
pub fn scenario_plots(sc: &Scenario) -> Result<Vec<(String, String)>, RunError> {
    let title = format!(
        "{} — {}",
        match &sc.plugin {
            Some(p) => p.name().to_string(),
            None => sc.config.strategy.name.to_string(),
        },
        describe(sc)
    );
    let every = (sc.duration_s / OVERVIEW_POINTS).max(10e-6);
    let rows = traced(sc, 0.0, sc.duration_s, every)?;
    let overview = chart(
        &format!("{title}: the whole run"),
        "time [s]",
        &overview_panels(sc, &rows),
    );
    let (from, to) = zoom_window(sc);
    let rows = traced(sc, from, to, ZOOM_EVERY_S)?;
    let zoom = chart(
        &format!(
            "{title}: the last electrical turns, {:.1} ms",
            (to - from) * 1e3
        ),
        "time [ms]",
        &zoom_panels(&rows),
    );
    Ok(vec![
        ("overview.svg".into(), overview),
        ("zoom.svg".into(), zoom),
    ])
}

fn describe(sc: &Scenario) -> String {
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

/// Three electrical turns at the final command, 1–20 ms, ending with the run.
fn zoom_window(sc: &Scenario) -> (f64, f64) {
    let rpm = sc.speed_rpm.value_at(sc.duration_s).max(1.0);
    let turn = 60.0 / (rpm * f64::from(sc.config.motor.poles / 2));
    let span = (3.0 * turn).clamp(1e-3, 20e-3).min(sc.duration_s);
    (sc.duration_s - span, sc.duration_s)
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

fn overview_panels(sc: &Scenario, rows: &[TraceRow]) -> Vec<Panel> {
    let of = |f: fn(&TraceRow) -> f64| rows.iter().map(|r| (r.t_s, f(r))).collect();
    // The command at the same instants, with its steps drawn as steps.
    let command = rows
        .iter()
        .map(|r| (r.t_s, sc.speed_rpm.value_at(r.t_s)))
        .collect();
    vec![
        Panel {
            y_label: "speed [rpm]".into(),
            series: vec![
                steps("command", command),
                line("true", of(|r| r.speed_rpm)),
                steps("chip's estimate (FG)", of(|r| r.speed_est_rpm)),
            ],
        },
        Panel {
            y_label: "duty [fraction of the carrier]".into(),
            series: vec![steps("duty", of(|r| r.duty))],
        },
        Panel {
            y_label: "torque [mN·m]".into(),
            series: vec![line("Te, sampled", of(|r| r.torque_nm * 1e3))],
        },
        Panel {
            y_label: "phase current [A]".into(),
            series: vec![line("i_u, sampled", of(|r| r.i_u))],
        },
    ]
}

fn zoom_panels(rows: &[TraceRow]) -> Vec<Panel> {
    let ms = |r: &TraceRow| r.t_s * 1e3;
    let of = |f: fn(&TraceRow) -> f64| rows.iter().map(|r| (ms(r), f(r))).collect();
    vec![
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
        let figs = scenario_plots(&sc).unwrap();
        assert_eq!(figs.len(), 2);
        for (name, svg) in &figs {
            assert!(
                svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
                "{name}"
            );
            // Every series drew a line through many points.
            let lines = svg.matches("<path d=\"M").count();
            assert!(lines >= 6, "{name}: {lines}");
            let longest = svg
                .split("<path d=\"")
                .skip(1)
                .map(|p| p.matches(" L").count())
                .max();
            assert!(longest.unwrap_or(0) > 1000, "{name}");
            assert!(!svg.contains("NaN"), "{name}");
        }
        // 3000 rpm, 6 pole pairs: a turn is 3.33 ms, the zoom 10 ms.
        let (a, b) = zoom_window(&sc);
        assert!((b - a - 10e-3).abs() < 1e-12);
    }
}
