//! A copied drive continues exactly like the original (FMU state saving relies on it).

use bldc_drive::DriveConfig;
use bldc_drive::drive::{build, run_to, try_clone};

#[test]
fn a_copy_continues_bit_identically_and_independently() {
    let mut a = build(&DriveConfig::default()).unwrap();
    run_to(&mut a, 0.8, |_, _| {}).unwrap();
    let mut b = try_clone(&a).unwrap();
    run_to(&mut a, 0.85, |_, _| {}).unwrap();
    run_to(&mut b, 0.85, |_, _| {}).unwrap();
    let (oa, ob) = (a.plant.observe(), b.plant.observe());
    assert_eq!(format!("{oa:?}"), format!("{ob:?}"));
    assert_eq!(a.controller.status(), b.controller.status());
    // Independent: a different load on the copy changes only the copy.
    b.plant.set_load_torque(5e-4);
    run_to(&mut a, 0.9, |_, _| {}).unwrap();
    run_to(&mut b, 0.9, |_, _| {}).unwrap();
    assert!(b.plant.observe().speed_rpm < a.plant.observe().speed_rpm - 1.0);
}
