//! Runs independent jobs on every core, with an optional progress bar on stderr.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;

/// Runs `f` on every item, on up to `threads` threads, returning results in item order.
/// A progress bar is drawn on stderr when `progress` is set and stderr is a terminal. A
/// panic in `f` reaches the caller, as it would in a loop.
pub fn map<T: Sync, R: Send>(
    items: &[T],
    threads: usize,
    progress: Option<&str>,
    f: impl Fn(&T) -> R + Sync,
) -> Vec<R> {
    let bar = match progress {
        Some(label) => bar(label, items.len() as u64, "runs"),
        None => ProgressBar::hidden(),
    };
    let job = |item: &T| {
        let r = f(item);
        bar.inc(1);
        r
    };
    // Its own pool, so `threads` holds whatever the global pool is doing.
    let out = match rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
    {
        Ok(pool) => pool.install(|| items.par_iter().map(job).collect()),
        // No threads to be had: the same work, here.
        Err(_) => items.iter().map(job).collect(),
    };
    bar.finish_and_clear();
    out
}

/// A bar of `len` `unit` with its ETA on stderr, drawn only when stderr is a terminal (a
/// log or a pipe gets nothing).
pub fn bar(label: &str, len: u64, unit: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    let template =
        format!("{{prefix}} [{{bar:30}}] {{pos}}/{{len}} {unit}, {{elapsed}} elapsed, ETA {{eta}}");
    if let Ok(style) = ProgressStyle::with_template(&template) {
        bar.set_style(style.progress_chars("#>."));
    }
    bar.set_prefix(label.to_string());
    bar
}

/// Threads to use: the machine's parallelism.
pub fn default_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

#[cfg(test)]
mod tests {
    #[test]
    fn results_come_back_in_item_order() {
        let items: Vec<u64> = (0..50).collect();
        let out = super::map(&items, 4, None, |&x| x * x);
        assert_eq!(out, items.iter().map(|x| x * x).collect::<Vec<_>>());
    }
}
