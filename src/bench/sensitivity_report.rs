//! The sensitivity study's report: its section (factors and levels, a table and two
//! tornado charts per strategy, what the study finds and what limits it) and, for
//! `drive-bench sensitivity`, a folder of its own.

use super::sensitivity::{Factor, Point, Side};
use super::tornado::{Bar, Measure, bars, chart, file_of};
use std::fmt::Write as _;

fn cell(m: Measure, p: Option<&Point>) -> String {
    match p.map(|p| m.of(p)) {
        Some(Ok(x)) => m.format(x),
        Some(Err(why)) => format!("*{why}*"),
        None => "–".into(),
    }
}

/// The section, in Markdown, for `strategies` (labels, in order) and `seed` (the noise
/// seed of every run).
pub fn section(points: &[Point], strategies: &[String], seed: u64) -> String {
    use super::sensitivity::{RESOLUTION, RIPPLE_RPM, SEED_RPM};
    if points.is_empty() {
        return String::new();
    }
    let (runs, sim_s, thread_s) = points.iter().fold((0, 0.0, 0.0), |a, p| {
        (a.0 + p.runs, a.1 + p.sim_s, a.2 + p.wall_s)
    });
    let mut s = format!(
        "\n## What moves the floor and the vibration\n\nWhat a chip designer controls and what the hardware varies, one factor at a time at a low and a high level, every other setting at the baseline (the config with the 24-bit meter, which does not bind), for {}. Per level: the **floor**, the range's bisection turned down from {SEED_RPM:.0} rpm after {SEED_RPM:.0} rpm held from standstill, to {:.0} % (or {:.0} rpm), judged by the verdict; and the **low-band ripple** at {RIPPLE_RPM:.0} rpm (% of the mean torque), turned down from {SEED_RPM:.0} rpm as the vibration section's runs are. {runs} runs, {sim_s:.0} s simulated ({thread_s:.0} s of wall time summed over the jobs' threads).\n\nWhat limits each figure: a floor is the lowest speed that held with one {:.0} % lower failing, so two floors closer than about {:.0} % are not told apart; every run starts at the {SEED_RPM:.0} rpm seed, so a level that cannot hold it from standstill has no floor here (shown as failed); every run uses the one noise seed {seed} (the comparator's noise is one realisation: a drive at the edge of synchronism can move by a bisection step with another); a ripple figure is one run's window of at least 1 s, and a share of the mean torque, which without a load is the friction's: the friction's row moves the ratio's denominator as much as the ripple.\n\n| factor | low | high | basis |\n|---|---|---|---|\n",
        strategies.join(", "),
        RESOLUTION * 100.0,
        super::range::FLOOR_RESOLUTION_RPM,
        RESOLUTION * 100.0,
        2.0 * RESOLUTION * 100.0,
    );
    for f in Factor::ALL {
        let label = |side| {
            points
                .iter()
                .find(|p| p.level == Some((f, side)))
                .map_or("–".to_string(), |p| p.label.clone())
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            f.name(),
            label(Side::Low),
            label(Side::High),
            f.basis()
        );
    }
    for st in strategies {
        strategy_part(&mut s, points, st);
    }
    s
}

fn strategy_part(s: &mut String, points: &[Point], st: &str) {
    let at = |level| points.iter().find(|p| p.strategy == st && p.level == level);
    let base = at(None);
    let _ = writeln!(
        s,
        "\n### {st}\n\n![{0}]({0})\n\n![{1}]({1})\n\n| factor | low level | floor rpm | ripple % | high level | floor rpm | ripple % |\n|---|---|---:|---:|---|---:|---:|\n| baseline | – | {2} | {3} | – | – | – |",
        file_of(st, Measure::Floor),
        file_of(st, Measure::Ripple),
        cell(Measure::Floor, base),
        cell(Measure::Ripple, base),
    );
    for f in Factor::ALL {
        let (lo, hi) = (at(Some((f, Side::Low))), at(Some((f, Side::High))));
        let (Some(lo), Some(hi)) = (lo, hi) else {
            continue;
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            f.name(),
            lo.label,
            cell(Measure::Floor, Some(lo)),
            cell(Measure::Ripple, Some(lo)),
            hi.label,
            cell(Measure::Floor, Some(hi)),
            cell(Measure::Ripple, Some(hi)),
        );
    }
    let mut found = Vec::new();
    for m in Measure::ALL {
        let (_, rows) = bars(points, st, m);
        let unit = if m == Measure::Floor { " rpm" } else { " %" };
        let fmt = |v: &Result<f64, String>| match v {
            Ok(x) if m == Measure::Floor => format!("{x:.0}{unit}"),
            Ok(x) => format!("{x:.1}{unit}"),
            Err(why) => why.clone(),
        };
        // A floor's span inside two bisection steps is not an effect the study resolves.
        let resolved = |r: &&Bar| match (m, &r.low.1, &r.high.1) {
            (Measure::Floor, Ok(a), Ok(b)) => {
                (a - b).abs() > 2.0 * super::sensitivity::RESOLUTION * a.max(*b)
            }
            _ => true,
        };
        let named: Vec<String> = rows
            .iter()
            .filter(resolved)
            .take(3)
            .map(|r| {
                format!(
                    "{} ({} → {}: {} → {})",
                    r.factor.name(),
                    r.low.0,
                    r.high.0,
                    fmt(&r.low.1),
                    fmt(&r.high.1)
                )
            })
            .collect();
        found.push(if named.is_empty() {
            format!(
                "no factor moves the {} beyond the resolution",
                m.file_part()
            )
        } else {
            format!(
                "the {} moves most with {}",
                m.file_part(),
                named.join(", then ")
            )
        });
    }
    let _ = writeln!(s, "\nFound: {}.", found.join("; "));
}

/// Writes the study alone into `dir`: `report.md`, `report.html`, `sensitivity.json` and
/// the tornado charts; returns the files written.
pub fn write_folder(
    points: &[Point],
    strategies: &[String],
    config: &crate::config::DriveConfig,
    dir: &std::path::Path,
) -> std::io::Result<Vec<std::path::PathBuf>> {
    let mut files = Vec::new();
    let mut put = |name: &str, text: &str| -> std::io::Result<()> {
        let p = dir.join(name);
        std::fs::write(&p, text)?;
        files.push(p);
        Ok(())
    };
    let figures: Vec<(String, String)> = strategies
        .iter()
        .enumerate()
        .flat_map(|(k, st)| {
            // The comparison's colour: the strategy's place among the built-in ones.
            let color = strategies::StrategyName::ALL
                .iter()
                .position(|n| n.as_str() == st)
                .unwrap_or(k);
            Measure::ALL.map(|m| (file_of(st, m), chart(points, st, m, color)))
        })
        .collect();
    for (name, svg) in &figures {
        put(name, svg)?;
    }
    let json = serde_json::json!({
        "tool": format!("drive-bench {}", env!("CARGO_PKG_VERSION")),
        "config": config,
        "points": points,
    });
    put(
        "sensitivity.json",
        &serde_json::to_string_pretty(&json).map_err(std::io::Error::other)?,
    )?;
    let md = format!(
        "# drive-bench sensitivity study\n{}",
        section(points, strategies, config.sensing.seed)
    );
    put(
        "report.html",
        &super::html::page("drive-bench sensitivity study", &md, &figures),
    )?;
    put("report.md", &md)?;
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::tornado::tests::study;

    #[test]
    fn the_table_shows_a_failed_run_as_its_verdict() {
        let md = section(&study(), &["s".to_string()], 1);
        assert!(
            md.contains("| comparator filter mismatch | 0 % | 200 | 15.0 | 10 % | 800 | 30.0 |"),
            "{md}"
        );
        assert!(
            md.contains(
                "| Coulomb friction | 0.1 mN·m | 510 | *fails (stalled)* | 0.5 mN·m | 520 | 9.0 |"
            ),
            "{md}"
        );
        assert!(md.contains("| baseline | – | 500 | 20.0 |"));
    }
}
