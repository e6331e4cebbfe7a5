//! Tornado charts of the sensitivity study ([`super::sensitivity`]): per strategy and
//! measure, a horizontal segment per factor from its low level's value to its high
//! level's, the widest on top, the baseline a vertical line; a level whose run failed is
//! named as failed, never drawn as a number.

use super::sensitivity::{Factor, Point, Side};
use super::svg::{COLORS, escape, fmt_tick, tick_step};
use std::fmt::Write as _;

/// What a tornado shows.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Measure {
    /// The floor \[rpm\].
    Floor,
    /// The low-band ripple at the study's low speed [% of the mean torque].
    Ripple,
}

impl Measure {
    /// Both, in report order.
    pub const ALL: [Measure; 2] = [Measure::Floor, Measure::Ripple];

    /// The value of `p`, or why there is none.
    pub fn of(self, p: &Point) -> Result<f64, String> {
        match self {
            Measure::Floor => p.floor_rpm.ok_or_else(|| {
                let l = p.floor_limit.as_ref();
                format!(
                    "seed fails ({})",
                    l.map_or("no verdict".into(), |l| l.verdict.to_string())
                )
            }),
            Measure::Ripple => p.ripple_pct.ok_or_else(|| {
                let v = p.ripple_verdict.split(':').next().unwrap_or("");
                format!("fails ({v})")
            }),
        }
    }

    /// A value as tables show it.
    pub fn format(self, x: f64) -> String {
        match self {
            Measure::Floor => format!("{x:.0}"),
            Measure::Ripple => format!("{x:.1}"),
        }
    }

    /// Its short name ("floor", "ripple"), as file names and sentences use it.
    pub fn file_part(self) -> &'static str {
        match self {
            Measure::Floor => "floor",
            Measure::Ripple => "ripple",
        }
    }

    fn axis(self) -> String {
        match self {
            Measure::Floor => "floor [rpm] (24-bit meter)".into(),
            Measure::Ripple => format!(
                "low-band torque ripple at {:.0} rpm [% of the mean torque]",
                super::sensitivity::RIPPLE_RPM
            ),
        }
    }
}

/// One factor's row: its levels' labels and values.
#[derive(Clone, Debug, PartialEq)]
pub struct Bar {
    /// The factor.
    pub factor: Factor,
    /// Low level: label and value (Err: why none).
    pub low: (String, Result<f64, String>),
    /// High level: label and value.
    pub high: (String, Result<f64, String>),
}

impl Bar {
    /// |high − low| when both are known.
    pub fn span(&self) -> Option<f64> {
        match (&self.low.1, &self.high.1) {
            (Ok(a), Ok(b)) => Some((b - a).abs()),
            _ => None,
        }
    }
}

/// The baseline and the rows of `strategy`'s tornado for `m`: a level that failed is
/// the widest effect there is (it breaks the drive), so its rows come first, then the
/// rest by span, widest first.
pub fn bars(
    points: &[Point],
    strategy: &str,
    m: Measure,
) -> (Option<Result<f64, String>>, Vec<Bar>) {
    let of = |level: Option<(Factor, Side)>| {
        points
            .iter()
            .find(|p| p.strategy == strategy && p.level == level)
            .map(|p| (p.label.clone(), m.of(p)))
    };
    let base = of(None).map(|b| b.1);
    let mut rows: Vec<Bar> = Factor::ALL
        .into_iter()
        .filter_map(|f| {
            Some(Bar {
                factor: f,
                low: of(Some((f, Side::Low)))?,
                high: of(Some((f, Side::High)))?,
            })
        })
        .collect();
    // Stable: equal spans keep the table's order.
    rows.sort_by(|a, b| match (a.span(), b.span()) {
        (None, None) => std::cmp::Ordering::Equal,
        (None, Some(_)) => std::cmp::Ordering::Less,
        (Some(_), None) => std::cmp::Ordering::Greater,
        (Some(x), Some(y)) => y.total_cmp(&x),
    });
    (base, rows)
}

/// The chart's file.
pub fn file_of(strategy: &str, m: Measure) -> String {
    super::svg::file_name(&format!("tornado_{}", m.file_part()), strategy)
}

const W: f64 = 1000.0;
const LEFT: f64 = 250.0;
const RIGHT: f64 = 230.0;
const TOP: f64 = 60.0;
const ROW: f64 = 34.0;
const LABEL_PX: f64 = 80.0;

/// The tornado of `strategy` for `m`, in `color` (a palette index).
pub fn chart(points: &[Point], strategy: &str, m: Measure, color: usize) -> String {
    let (base, rows) = bars(points, strategy, m);
    let known = rows
        .iter()
        .flat_map(|r| [&r.low.1, &r.high.1])
        .chain(base.iter())
        .filter_map(|v| v.as_ref().ok().copied());
    let (mut x0, mut x1) = known.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !x0.is_finite() {
        (x0, x1) = (0.0, 1.0);
    }
    // Room for an end's level label (≈ 80 px) on either side of the values.
    let pw = W - LEFT - RIGHT;
    let pad = (x1 - x0).max(1e-9 * x1.abs().max(1.0)) * LABEL_PX / (pw - 2.0 * LABEL_PX);
    let (x0, x1) = (x0 - pad, x1 + pad);
    let px = |x: f64| LEFT + (x - x0) / (x1 - x0) * pw;
    let h = TOP + ROW * rows.len().max(1) as f64 + 50.0;
    let bottom = TOP + ROW * rows.len().max(1) as f64;
    let col = COLORS[color % COLORS.len()];
    let mut s = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{h}" viewBox="0 0 {W} {h}" font-family="sans-serif" font-size="12">
<rect width="100%" height="100%" fill="white"/>
<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>
<text x="{}" y="40" text-anchor="middle" fill="#555">○ low level, ● high level; widest effect on top; a failed level is named at the right</text>
"##,
        W / 2.0,
        escape(&format!("{strategy}: what moves the {}", m.file_part())),
        W / 2.0,
    );
    let dx = tick_step(x1 - x0);
    let mut x = (x0 / dx).ceil() * dx;
    while x <= x1 {
        let _ = writeln!(
            s,
            r##"<line x1="{0:.1}" x2="{0:.1}" y1="{TOP}" y2="{bottom}" stroke="#eee"/><text x="{0:.1}" y="{1}" text-anchor="middle">{2}</text>"##,
            px(x),
            bottom + 14.0,
            fmt_tick(x, dx)
        );
        x += dx;
    }
    let _ = writeln!(
        s,
        r##"<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{}" fill="none" stroke="#888"/>"##,
        bottom - TOP
    );
    for (k, r) in rows.iter().enumerate() {
        row(&mut s, r, TOP + ROW * (k as f64 + 0.5), &px, col);
    }
    if let Some(Ok(b)) = base {
        let _ = writeln!(
            s,
            r##"<line x1="{0:.1}" x2="{0:.1}" y1="{1}" y2="{bottom}" stroke="#333" stroke-dasharray="4 3"/><text x="{0:.1}" y="{2}" text-anchor="middle" font-size="11">baseline {3}</text>"##,
            px(b),
            TOP - 2.0,
            TOP - 6.0,
            m.format(b)
        );
    }
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        LEFT + pw / 2.0,
        h - 12.0,
        escape(&m.axis())
    );
    s.push_str("</svg>\n");
    s
}

/// One row at height `y`: the factor's name, the segment, each end's level, a failed
/// level named at the right.
fn row(s: &mut String, r: &Bar, y: f64, px: &impl Fn(f64) -> f64, col: &str) {
    let _ = writeln!(
        s,
        r#"<text x="{}" y="{:.1}" text-anchor="end">{}</text>"#,
        LEFT - 10.0,
        y + 4.0,
        escape(r.factor.name())
    );
    if let (Ok(a), Ok(b)) = (&r.low.1, &r.high.1) {
        let _ = writeln!(
            s,
            r#"<line x1="{:.1}" x2="{:.1}" y1="{y:.1}" y2="{y:.1}" stroke="{col}" stroke-width="8" stroke-opacity="0.45"/>"#,
            px(*a),
            px(*b)
        );
    }
    // The end further left gets its label on its left, the other on its right: labels
    // never overlap, however short the segment.
    let left_is_low = match (&r.low.1, &r.high.1) {
        (Ok(a), Ok(b)) => a <= b,
        _ => true,
    };
    let mut failed = Vec::new();
    for (side, (label, v)) in [(Side::Low, &r.low), (Side::High, &r.high)] {
        let filled = if side == Side::Low { "white" } else { col };
        match v {
            Ok(x) => {
                let on_left = (side == Side::Low) == left_is_low;
                let (tx, anchor) = if on_left {
                    (px(*x) - 9.0, "end")
                } else {
                    (px(*x) + 9.0, "start")
                };
                let _ = writeln!(
                    s,
                    r#"<circle cx="{:.1}" cy="{y:.1}" r="5" fill="{filled}" stroke="{col}" stroke-width="2"/><text x="{tx:.1}" y="{:.1}" text-anchor="{anchor}" font-size="11">{}</text>"#,
                    px(*x),
                    y + 4.0,
                    escape(label)
                );
            }
            Err(why) => failed.push(format!(
                "{} {label}: {why}",
                if side == Side::Low { "○" } else { "●" }
            )),
        }
    }
    if !failed.is_empty() {
        let _ = writeln!(
            s,
            r##"<text x="{}" y="{:.1}" font-size="11" fill="#b00">{}</text>"##,
            W - RIGHT + 10.0,
            y + 4.0,
            escape(&failed.join("; "))
        );
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn point(
        level: Option<(Factor, Side)>,
        label: &str,
        floor: Option<f64>,
        ripple: Option<f64>,
    ) -> Point {
        Point {
            strategy: "s".into(),
            level,
            label: label.into(),
            floor_rpm: floor,
            floor_limit: None,
            ripple_pct: ripple,
            ripple_verdict: if ripple.is_some() {
                "running: fine".into()
            } else {
                "stalled: lost".into()
            },
            runs: 1,
            sim_s: 1.0,
            wall_s: 0.1,
        }
    }

    pub(crate) fn study() -> Vec<Point> {
        use Factor::*;
        use Side::*;
        vec![
            point(None, "baseline", Some(500.0), Some(20.0)),
            // Span 100, low above high: the segment still runs from one to the other.
            point(Some((Hysteresis, Low)), "5 mV", Some(550.0), Some(21.0)),
            point(Some((Hysteresis, High)), "20 mV", Some(450.0), Some(19.0)),
            // Span 600.
            point(Some((FilterMismatch, Low)), "0 %", Some(200.0), Some(15.0)),
            point(
                Some((FilterMismatch, High)),
                "10 %",
                Some(800.0),
                Some(30.0),
            ),
            // A failed level: on top, whatever the other level's value.
            point(Some((Friction, Low)), "0.1 mN·m", Some(510.0), None),
            point(Some((Friction, High)), "0.5 mN·m", Some(520.0), Some(9.0)),
            // Only one level run: no row.
            point(Some((MeterPeriods, Low)), "5", Some(500.0), Some(20.0)),
        ]
    }

    #[test]
    fn rows_are_sorted_failed_first_then_by_span_with_their_levels_values() {
        let (base, floor) = bars(&study(), "s", Measure::Floor);
        assert_eq!(base, Some(Ok(500.0)));
        let order: Vec<Factor> = floor.iter().map(|b| b.factor).collect();
        // Spans 600, 100, 10: the friction's narrow one last.
        assert_eq!(
            order,
            [Factor::FilterMismatch, Factor::Hysteresis, Factor::Friction]
        );
        assert_eq!(floor[0].low, ("0 %".to_string(), Ok(200.0)));
        assert_eq!(floor[0].high, ("10 %".to_string(), Ok(800.0)));
        assert_eq!(floor[1].span(), Some(100.0));
        let (_, ripple) = bars(&study(), "s", Measure::Ripple);
        // The friction's low level failed: first, with no span and its verdict named.
        assert_eq!(ripple[0].factor, Factor::Friction);
        assert_eq!(ripple[0].span(), None);
        assert_eq!(ripple[0].low.1, Err("fails (stalled)".to_string()));
        assert_eq!(ripple[1].factor, Factor::FilterMismatch);
        assert_eq!(bars(&study(), "other", Measure::Floor).1, Vec::new());
    }

    #[test]
    fn the_chart_places_segments_and_names_a_failed_level_without_a_number() {
        let svg = chart(&study(), "s", Measure::Ripple, 2);
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"));
        // x from 9 to 30 % with 80 px of room either side: 0 % → 10 % is the segment from
        // 15 to 30.
        let pad = 21.0 * LABEL_PX / (W - LEFT - RIGHT - 2.0 * LABEL_PX);
        let (x0, x1) = (9.0 - pad, 30.0 + pad);
        let px = |x: f64| LEFT + (x - x0) / (x1 - x0) * (W - LEFT - RIGHT);
        let y = TOP + ROW * 1.5; // the second row
        assert!(
            svg.contains(&format!(
                r#"<line x1="{:.1}" x2="{:.1}" y1="{y:.1}" y2="{y:.1}""#,
                px(15.0),
                px(30.0)
            )),
            "{svg}"
        );
        // The failed friction level is named, its row has one circle and no segment.
        assert!(svg.contains("○ 0.1 mN·m: fails (stalled)"));
        let first = TOP + ROW * 0.5;
        assert!(!svg.contains(&format!(
            r#"y1="{first:.1}" y2="{first:.1}" stroke="{}""#,
            COLORS[2]
        )));
        assert_eq!(svg.matches(&format!(r#"cy="{first:.1}""#)).count(), 1);
        // The baseline is marked.
        assert!(svg.contains(&format!(r#"x1="{:.1}" x2="{:.1}""#, px(20.0), px(20.0))));
        assert!(svg.contains("baseline 20.0"));
    }
}
