//! The C SDK's plugins, compiled by the system C compiler in this crate's build script
//! (`build.rs`): `libc_six_step.so` (the example, strategy `c-six-step`) and
//! `libc_misbehaving.so` (a fixture breaking the ABI's rules as `BLDC_TEST_MISBEHAVE`
//! says), both written beside the Rust plugins in `target/<profile>/`; and the layout of
//! the ABI's structs as C sees them through `strategy-abi/include/bldc_strategy.h`, which
//! `tests/layout.rs` compares with Rust's.

use std::ffi::{CStr, c_char};

#[repr(C)]
struct Entry {
    name: *const c_char,
    value: u64,
}

// The C side of the layout table (src/layout.c, linked by the build script).
#[allow(unsafe_code)]
unsafe extern "C" {
    fn bldc_layout_table(count: *mut usize) -> *const Entry;
    fn bldc_layout_magic() -> *const u8;
    fn bldc_layout_entry_symbol() -> *const c_char;
}

/// Every size, alignment and field offset \[bytes\] and every constant of the header, as
/// the C compiler computed them: (`Struct.field`, `Struct.size`, `Struct.align` or the
/// constant's Rust name, value).
#[allow(unsafe_code)]
pub fn c_layout() -> Vec<(String, u64)> {
    let mut n = 0usize;
    // SAFETY: the C function writes the count and returns its static table of `n` entries,
    // each name a static NUL-terminated string.
    unsafe {
        let t = bldc_layout_table(&mut n);
        std::slice::from_raw_parts(t, n)
            .iter()
            .map(|e| {
                (
                    CStr::from_ptr(e.name).to_string_lossy().into_owned(),
                    e.value,
                )
            })
            .collect()
    }
}

/// `BLDC_MAGIC_INIT` and `BLDC_STRATEGY_ENTRY_SYMBOL` as C sees them.
#[allow(unsafe_code)]
pub fn c_magic_and_symbol() -> ([u8; 8], String) {
    // SAFETY: static 8-byte array and static NUL-terminated string of src/layout.c.
    unsafe {
        let m = std::slice::from_raw_parts(bldc_layout_magic(), 8);
        let s = CStr::from_ptr(bldc_layout_entry_symbol());
        (m.try_into().unwrap(), s.to_string_lossy().into_owned())
    }
}

/// The C plugin `lib<stem>.so` as this crate's build script compiled it (`c_six_step` or
/// `c_misbehaving`); the same file is copied to `target/<profile>/`.
pub fn built(stem: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("OUT_DIR")).join(format!("lib{stem}.so"))
}
