//! The C header and the Rust definitions of the plugin ABI agree: every struct's size,
//! alignment and field offsets, and every constant, as the C compiler computed them
//! through `strategy-abi/include/bldc_strategy.h` (src/layout.c), equal Rust's.

use std::mem::{align_of, offset_of, size_of};
use strategy_abi as abi;

macro_rules! layout {
    ($out:ident, $t:ty, $name:literal: $($f:ident),* $(,)?) => {
        $out.push((concat!($name, ".size").to_string(), size_of::<$t>() as u64));
        $out.push((concat!($name, ".align").to_string(), align_of::<$t>() as u64));
        $($out.push((concat!($name, ".", stringify!($f)).to_string(), offset_of!($t, $f) as u64));)*
    };
}

fn rust_layout() -> Vec<(String, u64)> {
    let mut v = Vec::new();
    layout!(v, abi::DriveInfo, "DriveInfo": pole_pairs, amps_per_code, carrier_top);
    layout!(v, abi::Inputs, "Inputs": now, start, reset, speed_ref_rpm);
    layout!(v, abi::CSensed, "CSensed": zc, current_code);
    layout!(v, abi::CCommand, "CCommand": legs, duty, watch, wake_at);
    layout!(v, abi::CStatus, "CStatus": mode, state, zd, zdf, linear, duty, speed_est_rpm,
        current_ref_a, current_integrator, restarts, crossings, forced_crossings);
    layout!(v, abi::CTable, "CTable": kind, conduction_deg);
    layout!(v, abi::ErrorBuf, "ErrorBuf": ptr, cap, len);
    layout!(v, abi::VTable, "VTable": create, clone, destroy, reset, clock, table, set_inputs,
        step, save, restore, planned_change);
    layout!(v, abi::Header, "Header": magic, abi_major, abi_minor, name, description,
        vtable_size, vtable);
    for (name, value) in [
        ("ABI_MAJOR", u64::from(abi::ABI_MAJOR)),
        ("ABI_MINOR", u64::from(abi::ABI_MINOR)),
        ("OK", abi::OK as u64),
        ("ERROR", abi::ERROR as u64),
        ("PANICKED", abi::PANICKED as u64),
        ("LEG_HIGH", u64::from(abi::LEG_HIGH)),
        ("LEG_LOW", u64::from(abi::LEG_LOW)),
        ("MAX_STATE_BYTES", abi::MAX_STATE_BYTES as u64),
        ("VTABLE_1_0", abi::VTABLE_1_0 as u64),
        ("NEVER", u64::MAX),
        ("sizeof(bldc_instance)", size_of::<abi::Instance>() as u64),
    ] {
        v.push((name.to_string(), value));
    }
    v
}

#[test]
fn every_struct_field_and_constant_is_laid_out_as_in_rust() {
    let c = c_example_plugin::c_layout();
    let rust = rust_layout();
    // Entry by entry, in one order: a field missing on either side is a mismatch too.
    let names = |v: &[(String, u64)]| v.iter().map(|e| e.0.clone()).collect::<Vec<_>>();
    assert_eq!(names(&c), names(&rust), "the same entries on both sides");
    let wrong: Vec<String> = c
        .iter()
        .zip(&rust)
        .filter(|(a, b)| a.1 != b.1)
        .map(|(a, b)| format!("{}: C {} vs Rust {}", a.0, a.1, b.1))
        .collect();
    assert!(
        wrong.is_empty(),
        "C and Rust disagree:\n{}",
        wrong.join("\n")
    );
    // 9 structs (size, alignment: 18), their 48 fields and 11 constants: nothing dropped.
    assert_eq!(c.len(), 77, "{c:?}");
}

#[test]
fn the_magic_and_the_entry_symbol_are_spelled_alike() {
    let (magic, symbol) = c_example_plugin::c_magic_and_symbol();
    assert_eq!(magic, abi::MAGIC);
    assert_eq!(format!("{symbol}\0").as_bytes(), abi::ENTRY_SYMBOL);
}
