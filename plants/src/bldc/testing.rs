//! Plants set up for the unit tests of the plant's parts, and the reference solution they
//! are held to.

use super::{BldcPlant, State, dynamic};
use crate::params::PlantParams;
use drive_core::{Abc, Gates, Phase, Plant, PlantStop, Ticks, Watch};

/// RK4 with `n` sub-steps, each from its own exact angle: the reference solution.
pub(super) fn fine(pl: &BldcPlant, x: &State, h: f64, n: usize) -> State {
    let mut x = *x;
    for _ in 0..n {
        let b = BldcPlant::base(&x);
        x = pl.rk4_from(&x, h / n as f64, b, &pl.deriv(&dynamic(&x), b));
    }
    x
}

/// A plant at `rpm` with u switched high, v low and w off, the currents `i`.
pub(super) fn driven(i: [f64; 3], rpm: f64, lock: bool) -> BldcPlant {
    driven_with(PlantParams::default(), i, rpm, lock)
}

pub(super) fn driven_with(params: PlantParams, i: [f64; 3], rpm: f64, lock: bool) -> BldcPlant {
    let mut pl = BldcPlant::new(params).expect("valid parameters");
    pl.set_rotor(0.3, rpm, lock);
    pl.gates = Gates {
        high: Abc::from_fn(|p| p == Phase::U),
        low: Abc::from_fn(|p| p == Phase::V),
    };
    for (k, v) in i.into_iter().enumerate() {
        pl.x[k] = v;
    }
    pl.refresh_start();
    pl
}

/// A plant with the bridge off and the rotor at `rpm` from θe = 0.3, locked to that
/// speed, stepped `n` plant steps of the longest length; `each` sees it after each.
pub(super) fn crawl(
    params: PlantParams,
    rpm: f64,
    n: u64,
    mut each: impl FnMut(&BldcPlant),
) -> BldcPlant {
    let mut pl = BldcPlant::new(params).expect("valid parameters");
    pl.set_rotor(0.3, rpm, true);
    let watch = Watch {
        channels: Abc::splat(false),
        reads: Abc::splat(Ticks::ZERO),
        clock: Ticks(32),
        horizon: Ticks::ZERO,
    };
    let step = Ticks::from_seconds(pl.h_max).expect("a step in ticks").0;
    for k in 1..=n {
        while pl.advance(Ticks(k * step), &watch) != PlantStop::Reached {}
        each(&pl);
    }
    pl
}

/// The plant restored from its own bytes, into one built from the same parameters.
pub(super) fn restored(pl: &BldcPlant) -> Result<BldcPlant, String> {
    use drive_core::state::Persist;
    let mut copy = BldcPlant::new(pl.params.clone()).expect("valid parameters");
    copy.restore_from(&pl.to_bytes()?)?;
    Ok(copy)
}
