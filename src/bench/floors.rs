//! Where each floor fails: the failed run just below a strategy's floor (24-bit meter)
//! run again with a microsecond trace over the turns where its commutation lost the
//! rotor, so that the report shows the mechanism (a missed or false crossing, the
//! comparator's edge spikes taken for one, the meter's delay) beside the verdict.

use super::range::{self, Meter, Range};
use crate::config::DriveConfig;
use crate::plots;
use crate::scenario::{RunError, TraceRow, run, settled};
use crate::verdict::Verdict;
use serde::Serialize;
use strategies::PluginLibrary;

/// The failed run below one strategy's floor, traced where it lost the rotor.
#[derive(Clone, Debug, Serialize)]
pub struct FloorZoom {
    /// Strategy label.
    pub variant: String,
    /// The floor \[rpm\] and the command below it that failed \[rpm\].
    pub floor_rpm: f64,
    /// See `floor_rpm`.
    pub failed_rpm: f64,
    /// The failed run's verdict and reason.
    pub verdict: Verdict,
    /// See `verdict`.
    pub reason: String,
    /// Where its commutation first lost the rotor: (t \[s\], true rpm).
    pub lost: Option<(f64, f64)>,
    /// The trace (not in the JSON; plotted).
    #[serde(skip)]
    pub rows: Vec<TraceRow>,
}

/// The zoom below `range`'s floor when the search found one with the wide meter;
/// `config` is the strategy's (its meter is set here).
pub fn zoom(
    config: &DriveConfig,
    plugin: Option<&PluginLibrary>,
    range: &Range,
) -> Result<Option<FloorZoom>, RunError> {
    let (Some(floor), Some(limit)) = (range.min_rpm, &range.min_limit) else {
        return Ok(None);
    };
    if range.meter != Meter::WIDE.label {
        return Ok(None);
    }
    // The search's seed: the first speed that held (the floor's runs come after it).
    let Some(&(seed, _)) = range.tried.iter().find(|t| t.1) else {
        return Ok(None);
    };
    let mut sc = range::turned(
        &Meter::WIDE.apply(config),
        seed,
        limit.rpm,
        range::TURN_DOWN_S,
    );
    sc.plugin = plugin.cloned();
    // The run as the search judged it (lengthened the same way).
    let (sc, out) = settled(&sc, |s| run(s, |_| {}))?;
    let s = out.summary;
    let lost = plots::lost_at(&s);
    Ok(Some(FloorZoom {
        variant: range.strategy.clone(),
        floor_rpm: floor,
        failed_rpm: limit.rpm,
        verdict: s.verdict,
        reason: limit.reason.clone(),
        lost,
        rows: plots::zoom_rows(&sc, lost)?,
    }))
}

/// The figure's file name for `variant`.
pub fn file_name(variant: &str) -> String {
    super::svg::file_name("floor", variant)
}

/// Each zoom's figure: (file name, SVG).
pub fn charts(zooms: &[FloorZoom]) -> Vec<(String, String)> {
    zooms
        .iter()
        .map(|z| {
            let title = format!(
                "{} below its floor ({:.0} rpm): turned down to {:.0} rpm, {}",
                z.variant, z.floor_rpm, z.failed_rpm, z.verdict
            );
            (
                file_name(&z.variant),
                plots::zoom_chart(&title, &z.rows, z.lost),
            )
        })
        .collect()
}

/// The report's paragraphs: per strategy, the failed run's reason and its figure.
pub fn section(zooms: &[FloorZoom]) -> String {
    if zooms.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\n#### Where each floor fails\n\nThe run just below each floor (24-bit meter), traced every microsecond over the electrical turns around the first commutation out of synchronism (marked), or over its last turns when it stayed in synchronism: the true speed beside the chip's estimate, the phase currents, the terminal voltages, the state and the comparator before and after the guard.\n",
    );
    for z in zooms {
        let name = file_name(&z.variant);
        s.push_str(&format!(
            "\n**{}**, turned down to {:.0} rpm: {}.\n\n![{name}]({name})\n",
            z.variant, z.failed_rpm, z.reason
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_zoom_is_a_figure_named_in_the_section_with_its_loss_marked() {
        let rows: Vec<TraceRow> = (0..200)
            .map(|k| TraceRow {
                t_s: 4.0 + f64::from(k) * 1e-5,
                speed_rpm: 300.0,
                ..TraceRow::default()
            })
            .collect();
        let z = FloorZoom {
            variant: "twelve-step-df@165".into(),
            floor_rpm: 240.0,
            failed_rpm: 120.0,
            verdict: Verdict::LostSync,
            reason: "first out of synchronism at 4.00 s, 300 rpm (true); then …".into(),
            lost: Some((4.001, 300.0)),
            rows,
        };
        let figs = charts(std::slice::from_ref(&z));
        assert_eq!(figs.len(), 1);
        let (name, svg) = &figs[0];
        assert_eq!(name, "floor_twelve-step-df_165.svg");
        // The loss is marked on every panel (six), at 4001 ms.
        assert_eq!(svg.matches("rotor lost").count(), 6 + 1, "{svg}");
        let md = section(&[z]);
        assert_eq!(md.matches(&format!("]({name})")).count(), 1);
        assert!(md.contains("turned down to 120 rpm: first out of synchronism"));
        assert!(section(&[]).is_empty());
    }
}
