//! A polyline thinned to what a plot's pixels can show: per pixel column, its lowest and
//! its highest point, in their order. Drawn as a line, the thinned series covers the same
//! vertical span in every column as the full one, so a peak one sample wide is kept where
//! taking every n-th sample would skip it.

/// `points` (x ascending) thinned to at most two per column, `columns` columns spanning
/// `x0..x1`, and the series' first and last points. Non-finite points are dropped (the
/// chart draws none); a series with no more than two points per column on average is
/// returned as it is.
pub fn min_max_per_column(
    points: &[(f64, f64)],
    x0: f64,
    x1: f64,
    columns: usize,
) -> Vec<(f64, f64)> {
    let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
    if points.len() <= 2 * columns || x1.partial_cmp(&x0) != Some(std::cmp::Ordering::Greater) {
        return points.iter().filter(finite).copied().collect();
    }
    let column = |x: f64| ((x - x0) / (x1 - x0) * columns as f64).floor() as i64;
    let mut out = Vec::with_capacity(2 * columns + 2);
    let mut bucket: Vec<(f64, f64)> = Vec::new();
    let mut flush = |bucket: &mut Vec<(f64, f64)>| {
        if bucket.is_empty() {
            return;
        }
        let at = |pick: fn(&(f64, f64), &(f64, f64)) -> bool| {
            (0..bucket.len()).fold(0, |k, j| if pick(&bucket[j], &bucket[k]) { j } else { k })
        };
        let (lo, hi) = (at(|a, b| a.1 < b.1), at(|a, b| a.1 > b.1));
        out.push(bucket[lo.min(hi)]);
        if lo != hi {
            out.push(bucket[lo.max(hi)]);
        }
        bucket.clear();
    };
    let mut current = None;
    for p in points.iter().filter(finite) {
        let c = column(p.0);
        if current != Some(c) {
            flush(&mut bucket);
            current = Some(c);
        }
        bucket.push(*p);
    }
    flush(&mut bucket);
    // The ends, where a column's extremes are not its first or last point.
    let ends = (points.iter().find(finite), points.iter().rev().find(finite));
    if let (Some(&first), Some(&last)) = ends {
        if out.first() != Some(&first) {
            out.insert(0, first);
        }
        if out.last() != Some(&last) {
            out.push(last);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A ripple of 100 000 samples with two spikes a single sample wide: thinned to 500
    /// columns it keeps both spikes and the ends, and at most 2 points a column.
    #[test]
    fn a_one_sample_peak_is_kept_and_the_count_is_bounded() {
        let n: usize = 100_000;
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let x = k as f64 / n as f64;
                (x, (2.0 * std::f64::consts::PI * 37.0 * x).sin())
            })
            .collect();
        pts[54_321].1 = 7.5;
        pts[12_345].1 = -3.25;
        let thin = min_max_per_column(&pts, 0.0, 1.0, 500);
        assert!(thin.len() <= 2 * 500 + 2, "{}", thin.len());
        assert!(thin.len() >= 500, "every column drawn: {}", thin.len());
        assert!(thin.contains(&pts[54_321]) && thin.contains(&pts[12_345]));
        // Every n-th sample, at the same count, misses the spike.
        let stride = n.div_ceil(thin.len());
        assert!(!pts.iter().step_by(stride).any(|p| p.1 == 7.5));
        // The ends and the order are kept.
        assert_eq!(thin.first(), pts.first());
        assert_eq!(thin.last(), pts.last());
        assert!(thin.windows(2).all(|w| w[0].0 < w[1].0));
    }

    #[test]
    fn short_series_are_kept_whole_and_non_finite_points_dropped() {
        let pts = [(0.0, 1.0), (1.0, f64::NAN), (2.0, 3.0)];
        assert_eq!(
            min_max_per_column(&pts, 0.0, 2.0, 100),
            [(0.0, 1.0), (2.0, 3.0)]
        );
        let many: Vec<_> = (0..1000).map(|k| (k as f64, f64::NAN)).collect();
        assert!(min_max_per_column(&many, 0.0, 999.0, 10).is_empty());
    }
}
