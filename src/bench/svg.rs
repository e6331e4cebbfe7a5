//! Minimal SVG line charts: stacked panels sharing one x axis, no dependencies.
//!
//! Why not plotters: its SVG backend lays text out with a font library (the default `ttf`
//! feature loads system fonts through font-kit, which a CI image or a user's machine may
//! not have), and what these charts need beyond lines and axes would still be ours:
//! decimation of long traces to the pixels ([`super::decimate`]), step drawing of logic signals, colours fixed per strategy
//! across charts, and labels that wrap. The SVG is inlined in report.html as it is written.

use super::decimate::min_max_per_column;
use std::fmt::Write;

/// One line.
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Points (x, y).
    pub points: Vec<(f64, f64)>,
    /// Draw as steps (sample-and-hold logic signals) instead of straight segments.
    pub steps: bool,
    /// Palette index; `None`: the series' position in its panel. Charts that compare
    /// strategies give each strategy its index in the comparison, so a strategy keeps its
    /// colour from chart to chart.
    pub color: Option<usize>,
    /// SVG dash pattern (e.g. "6 3"); `None`: solid.
    pub dash: Option<&'static str>,
}

/// One panel: its y label and lines.
pub struct Panel {
    /// Y-axis label (with unit).
    pub y_label: String,
    /// Lines.
    pub series: Vec<Series>,
}

pub(crate) const COLORS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
];
const W: f64 = 1000.0;
const PANEL_H: f64 = 220.0;
const LEFT: f64 = 80.0;
const RIGHT: f64 = 290.0;
const TOP: f64 = 40.0;
const GAP: f64 = 30.0;

/// Characters of a y label that fit along a panel's height (≈ 7.5 px each at the default
/// font size).
const LABEL_CHARS: usize = 28;

/// `text` in lines of at most `max` characters, broken between words (a longer word
/// keeps its own line).
fn wrap(text: &str, max: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in text.split(' ') {
        match lines.last_mut() {
            Some(l) if l.chars().count() + 1 + word.chars().count() <= max => {
                l.push(' ');
                l.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// Round tick spacing covering `span` with about five ticks.
pub(crate) fn tick_step(span: f64) -> f64 {
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let n = raw / mag;
    mag * if n < 1.5 {
        1.0
    } else if n < 3.5 {
        2.0
    } else if n < 7.5 {
        5.0
    } else {
        10.0
    }
}

fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 * lo.abs().max(1.0) {
        return (lo - 0.5, hi + 0.5);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

pub(crate) fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// A figure's file name: `{prefix}_{label}.svg`, the variant's label with `@` (the
/// conduction angle's mark) as `_`, one rule for every per-variant figure.
pub fn file_name(prefix: &str, label: &str) -> String {
    format!("{prefix}_{}.svg", label.replace('@', "_"))
}

/// A labelled vertical line across a panel (a known frequency on a spectrum).
#[derive(Clone, Debug)]
pub struct Mark {
    /// Where \[x units\].
    pub x: f64,
    /// Label, written up the line.
    pub label: String,
}

/// Renders `panels` stacked, under `title`, with the shared `x_label`.
pub fn chart(title: &str, x_label: &str, panels: &[Panel]) -> String {
    chart_marked(title, x_label, panels, &[])
}

/// [`chart`] with `marks[k]` drawn on panel k (panels past the end of `marks` get none).
pub fn chart_marked(title: &str, x_label: &str, panels: &[Panel], marks: &[Vec<Mark>]) -> String {
    let h = TOP + panels.len() as f64 * (PANEL_H + GAP) + 30.0;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{h}" viewBox="0 0 {W} {h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
        W / 2.0,
        escape(title)
    );
    let x = bounds(
        panels
            .iter()
            .flat_map(|p| p.series.iter().flat_map(|s| s.points.iter().map(|q| q.0))),
    );
    let pw = W - LEFT - RIGHT;
    for (k, panel) in panels.iter().enumerate() {
        let top = TOP + k as f64 * (PANEL_H + GAP);
        let y = bounds(
            panel
                .series
                .iter()
                .flat_map(|s| s.points.iter().map(|q| q.1)),
        );
        let f = Frame { top, x, y, pw };
        grid(&mut s, &f);
        for m in marks.get(k).into_iter().flatten() {
            mark(&mut s, &f, m);
        }
        y_label(&mut s, top, &panel.y_label);
        for (j, series) in panel.series.iter().enumerate() {
            series_path(&mut s, &f, series, j);
        }
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        LEFT + pw / 2.0,
        h - 8.0,
        escape(x_label)
    );
    s.push_str("</svg>\n");
    s
}

/// A panel's place: its top \[px\], the x and y ranges it shows, the plot's width \[px\].
#[derive(Copy, Clone)]
struct Frame {
    top: f64,
    x: (f64, f64),
    y: (f64, f64),
    pw: f64,
}

impl Frame {
    fn px(&self, x: f64) -> f64 {
        LEFT + (x - self.x.0) / (self.x.1 - self.x.0) * self.pw
    }

    fn py(&self, y: f64) -> f64 {
        self.top + PANEL_H - (y - self.y.0) / (self.y.1 - self.y.0) * PANEL_H
    }
}

/// A panel's frame, grid lines and tick labels.
fn grid(s: &mut String, f: &Frame) {
    let Frame {
        top,
        x: (x0, x1),
        y: (y0, y1),
        pw,
    } = *f;
    let _ = writeln!(
        s,
        r##"<rect x="{LEFT}" y="{top}" width="{pw}" height="{PANEL_H}" fill="none" stroke="#888"/>"##
    );
    let dy = tick_step(y1 - y0);
    let mut y = (y0 / dy).ceil() * dy;
    while y <= y1 {
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" x2="{0}" y1="{1:.1}" y2="{1:.1}" stroke="#eee"/><text x="{2}" y="{3:.1}" text-anchor="end">{4}</text>"##,
            LEFT + pw,
            f.py(y),
            LEFT - 5.0,
            f.py(y) + 4.0,
            fmt_tick(y, dy)
        );
        y += dy;
    }
    let dx = tick_step(x1 - x0);
    let mut x = (x0 / dx).ceil() * dx;
    while x <= x1 {
        let _ = writeln!(
            s,
            r##"<line x1="{0:.1}" x2="{0:.1}" y1="{1}" y2="{2}" stroke="#eee"/><text x="{0:.1}" y="{3}" text-anchor="middle">{4}</text>"##,
            f.px(x),
            top,
            top + PANEL_H,
            top + PANEL_H + 14.0,
            fmt_tick(x, dx)
        );
        x += dx;
    }
}

/// A mark on a panel: a dashed line at its x, labelled up the line (none outside the
/// panel's x range).
fn mark(s: &mut String, f: &Frame, m: &Mark) {
    let (top, (x0, x1)) = (f.top, f.x);
    if !(x0..=x1).contains(&m.x) {
        return;
    }
    let _ = writeln!(
        s,
        r##"<line x1="{0:.1}" x2="{0:.1}" y1="{1}" y2="{2}" stroke="#999" stroke-dasharray="3 3"/><text transform="translate({3:.1},{4}) rotate(-90)" text-anchor="end" font-size="10" fill="#555">{5}</text>"##,
        f.px(m.x),
        top,
        top + PANEL_H,
        f.px(m.x) - 3.0,
        top + 4.0,
        escape(&m.label)
    );
}

/// A panel's y label, up its left side.
fn y_label(s: &mut String, top: f64, y_label: &str) {
    // A label longer than the panel is tall goes on two or more lines (a case name
    // with its unit would otherwise run into the next panel's label).
    let lines = wrap(y_label, LABEL_CHARS);
    let _ = write!(
        s,
        r#"<text transform="translate({:.1},{}) rotate(-90)" text-anchor="middle">"#,
        15.0 - 3.0 * (lines.len() - 1) as f64,
        top + PANEL_H / 2.0,
    );
    for (j, line) in lines.iter().enumerate() {
        let dy = if j == 0 { "0" } else { "1.2em" };
        let _ = write!(s, r#"<tspan x="0" dy="{dy}">{}</tspan>"#, escape(line));
    }
    let _ = writeln!(s, "</text>");
}

/// A series on a panel, its `j`th: the path (a dot for a lone point) and its legend.
fn series_path(s: &mut String, f: &Frame, series: &Series, j: usize) {
    let (top, (x0, x1), pw) = (f.top, f.x, f.pw);
    let color = COLORS[series.color.unwrap_or(j) % COLORS.len()];
    let dash = series
        .dash
        .map_or(String::new(), |d| format!(r#" stroke-dasharray="{d}""#));
    // One column a pixel of the plot's width: the file's weight is what the eye sees.
    let points = min_max_per_column(&series.points, x0, x1, pw as usize);
    let mut drawn = Vec::new();
    for &(x, y) in &points {
        // A step holds the previous level up to the new point's x.
        if series.steps
            && let Some(&(_, y0)) = drawn.last()
        {
            drawn.push((f.px(x), y0));
        }
        drawn.push((f.px(x), f.py(y)));
    }
    let d = path_data(&drawn);
    let _ = writeln!(
        s,
        r#"<path d="{d}" fill="none" stroke="{color}" stroke-width="1.3"{dash}/>"#
    );
    // A lone point draws no line: mark it (a one-speed grid, a single run).
    if let [(cx, cy)] = drawn[..] {
        let _ = writeln!(
            s,
            r#"<circle cx="{cx:.1}" cy="{cy:.1}" r="4" fill="{color}"/>"#
        );
    }
    let ly = top + 14.0 + 16.0 * j as f64;
    let _ = writeln!(
        s,
        r#"<line x1="{0}" x2="{1}" y1="{2}" y2="{2}" stroke="{color}" stroke-width="2"{dash}/><text x="{3}" y="{4}">{5}</text>"#,
        LEFT + pw + 10.0,
        LEFT + pw + 30.0,
        ly - 4.0,
        LEFT + pw + 35.0,
        ly,
        escape(&series.name)
    );
}

/// SVG path data through `points` (pixels): the first absolute, the others relative to
/// the one before, to 0.1 px, without leading zeros: "M80.0,40.0 l.5,-1.2 1,3". The
/// offsets come from the rounded positions, so rounding does not accumulate.
fn path_data(points: &[(f64, f64)]) -> String {
    let tenths = |v: f64| (v * 10.0).round() as i64;
    let mut d = String::new();
    let mut prev: Option<(i64, i64)> = None;
    for (k, &(x, y)) in points.iter().enumerate() {
        let p = (tenths(x), tenths(y));
        match prev {
            None => {
                let _ = write!(d, "M{:.1},{:.1}", p.0 as f64 / 10.0, p.1 as f64 / 10.0);
            }
            // One `l` for them all: SVG repeats the last command for further pairs.
            Some(q) => {
                let l = if k == 1 { "l" } else { "" };
                let _ = write!(d, " {l}{},{}", short(p.0 - q.0), short(p.1 - q.1));
            }
        }
        prev = Some(p);
    }
    d
}

/// `tenths` / 10 in the fewest characters: "3", "-1.2", ".5", "-.5".
fn short(tenths: i64) -> String {
    let (sign, a) = if tenths < 0 {
        ("-", -tenths)
    } else {
        ("", tenths)
    };
    match (a / 10, a % 10) {
        (i, 0) => format!("{sign}{i}"),
        (0, f) => format!("{sign}.{f}"),
        (i, f) => format!("{sign}{i}.{f}"),
    }
}

pub(crate) fn fmt_tick(v: f64, step: f64) -> String {
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let v = if v.abs() < step * 1e-6 { 0.0 } else { v }; // no "-0"
    format!("{v:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative offsets from rounded positions: the path ends where the points end, to
    /// 0.1 px, however many there are.
    #[test]
    fn path_data_is_relative_short_and_does_not_drift() {
        assert_eq!(
            path_data(&[(80.0, 40.0), (80.5, 38.8), (81.5, 41.8), (81.54, 41.8)]),
            "M80.0,40.0 l.5,-1.2 1,3 0,0"
        );
        assert_eq!(short(-5), "-.5");
        assert_eq!(short(-12), "-1.2");
        let pts: Vec<(f64, f64)> = (0..=1000)
            .map(|k| (k as f64 * 0.33, 100.0 + k as f64 * 0.07))
            .collect();
        let d = path_data(&pts);
        let sum = |i: usize| -> f64 {
            d.split(' ')
                .skip(1)
                .map(|p| {
                    p.trim_start_matches('l')
                        .split(',')
                        .nth(i)
                        .unwrap()
                        .parse::<f64>()
                        .unwrap()
                })
                .sum()
        };
        assert!((0.0 + sum(0) - 330.0).abs() < 0.051, "{}", sum(0));
        assert!((100.0 + sum(1) - 170.0).abs() < 0.051, "{}", sum(1));
    }

    #[test]
    fn ticks_are_round_numbers() {
        assert_eq!(tick_step(10.0), 2.0);
        assert_eq!(tick_step(0.003), 0.0005);
        assert_eq!(tick_step(7000.0), 1000.0);
    }

    #[test]
    fn long_labels_wrap_between_words() {
        let label = "step 16000 (beyond reach) → 8000 rpm [rpm]";
        let lines = wrap(label, LABEL_CHARS);
        assert_eq!(lines, ["step 16000 (beyond reach) →", "8000 rpm [rpm]"]);
        assert_eq!(lines.join(" "), label);
        assert_eq!(wrap("speed [rpm]", LABEL_CHARS), ["speed [rpm]"]);
    }

    #[test]
    fn a_chart_is_well_formed_and_places_points_inside_its_panel() {
        let svg = chart(
            "t <1>",
            "x",
            &[Panel {
                y_label: "y".into(),
                series: vec![Series {
                    name: "a&b".into(),
                    points: vec![(0.0, 0.0), (1.0, 1.0)],
                    steps: false,
                    ..Series::default()
                }],
            }],
        );
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"));
        assert!(svg.contains("t &lt;1&gt;") && svg.contains("a&amp;b"));
        // x range padded by 5 %: x = 0 sits 1/22 of the plot width right of the left edge.
        let x0 = LEFT + (W - LEFT - RIGHT) / 22.0;
        assert!(svg.contains(&format!("M{x0:.1},")), "{svg}");
    }

    #[test]
    fn a_lone_point_is_marked_and_a_non_finite_first_point_does_not_break_the_path() {
        let svg = chart(
            "t",
            "x",
            &[Panel {
                y_label: "y".into(),
                series: vec![
                    Series {
                        name: "one".into(),
                        points: vec![(3000.0, 1.0)],
                        steps: false,
                        ..Series::default()
                    },
                    Series {
                        name: "nan first".into(),
                        points: vec![(0.0, f64::NAN), (1.0, 1.0), (2.0, 2.0)],
                        steps: false,
                        ..Series::default()
                    },
                ],
            }],
        );
        assert_eq!(svg.matches("<circle").count(), 1);
        assert!(!svg.contains("d=\" L") && !svg.contains("d=\"L"), "{svg}");
    }

    #[test]
    fn marks_are_drawn_on_their_panel_inside_the_x_range_only() {
        let panel = || Panel {
            y_label: "y".into(),
            series: vec![Series {
                name: "a".into(),
                points: vec![(0.0, 0.0), (10.0, 1.0)],
                ..Series::default()
            }],
        };
        let marks = vec![
            Vec::new(),
            vec![
                Mark {
                    x: 5.0,
                    label: "PI <update>".into(),
                },
                Mark {
                    x: 50.0,
                    label: "outside".into(),
                },
            ],
        ];
        let svg = chart_marked("t", "x", &[panel(), panel()], &marks);
        assert_eq!(svg.matches("stroke-dasharray=\"3 3\"").count(), 1);
        assert!(svg.contains("PI &lt;update&gt;") && !svg.contains("outside"));
        // x = 5 is the middle of the padded range: the plot's centre.
        let mid = LEFT + (W - LEFT - RIGHT) / 2.0;
        assert!(
            svg.contains(&format!("x1=\"{mid:.1}\" x2=\"{mid:.1}\"")),
            "{svg}"
        );
        // On the second panel, below the first.
        assert!(svg.contains(&format!("y1=\"{}\"", TOP + PANEL_H + GAP)));
    }

    #[test]
    fn a_series_colour_follows_its_index_not_its_position() {
        let one = |color| Series {
            name: "a".into(),
            points: vec![(0.0, 0.0), (1.0, 1.0)],
            color,
            dash: Some("6 3"),
            ..Series::default()
        };
        let svg = chart(
            "t",
            "x",
            &[Panel {
                y_label: "y".into(),
                series: vec![one(Some(3))],
            }],
        );
        assert!(svg.contains(&format!("stroke=\"{}\"", COLORS[3])));
        assert!(!svg.contains(&format!("stroke=\"{}\"", COLORS[0])));
        assert!(svg.contains("stroke-dasharray=\"6 3\""));
    }
}
