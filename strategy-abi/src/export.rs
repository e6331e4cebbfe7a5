//! The plugin side: a safe trait and the `extern "C"` functions generated from it, each of
//! which catches panics so that none unwinds into the host.

use crate::{
    CCommand, CSensed, CStatus, CTable, DriveInfo, ERROR, ErrorBuf, Inputs, Instance, OK, PANICKED,
    VTable,
};
use std::any::Any;
use std::ffi::{CStr, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};

/// A strategy as a plugin author writes it, in safe Rust.
pub trait Plugin: Clone + Send + Sized + 'static {
    /// Builds the strategy from the drive's TOML config and the drive facts.
    fn create(config_toml: &str, info: &DriveInfo) -> Result<Self, String>;
    /// Clock period [20 ns ticks].
    fn clock(&self) -> u64;
    /// The commutation table aimed for.
    fn table(&self) -> CTable;
    /// New chip inputs.
    fn set_inputs(&mut self, inputs: &Inputs);
    /// One clock edge: the command to apply and the status to show.
    fn step(&mut self, now: u64, sensed: &CSensed) -> Result<(CCommand, CStatus), String>;
    /// The dynamic state as bytes of the plugin's own format (ABI 1.1), for the host to
    /// store and hand back to [`Plugin::restore`] on an instance created from the same
    /// config.
    fn save(&self) -> Result<Vec<u8>, String> {
        Err(
            "this plugin cannot save its state (rule: implement Plugin::save and Plugin::restore)"
                .into(),
        )
    }
    /// Reads back what [`Plugin::save`] wrote, refusing bytes it does not accept.
    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        let _ = state;
        Err("this plugin cannot restore its state (rule: implement Plugin::save and Plugin::restore)".into())
    }
    /// The next instant \[ticks\] at which the strategy already knows it will command other
    /// legs, with those legs, if its inputs hold (ABI 1.2; a hint, see
    /// [`crate::VTable::planned_change`]). None by default.
    fn planned_change(&self) -> Option<(u64, [u8; 3])> {
        None
    }
}

/// An instance with its initial state (for reset) and a poison flag set by a panic.
struct Slot<T> {
    inner: T,
    initial: T,
    poisoned: bool,
}

fn panic_text(p: Box<dyn Any + Send>) -> String {
    let what = p
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into());
    format!("plugin panicked: {what}")
}

/// # Safety
/// `err` is null or a valid [`ErrorBuf`].
unsafe fn report(err: *mut ErrorBuf, msg: &str) {
    // SAFETY: per the function contract.
    if let Some(e) = unsafe { err.as_mut() }
        && !e.ptr.is_null()
    {
        // SAFETY: the host's buffer is valid for `cap` bytes (ABI contract).
        unsafe { e.write(msg) };
    }
}

/// Runs `f` on the instance behind `inst`, turning errors, panics and bad pointers into
/// status codes.
///
/// # Safety
/// `inst` is null or an instance created by `create::<T>`; `err` as in [`report`].
unsafe fn with<T: Plugin>(
    inst: Instance,
    err: *mut ErrorBuf,
    f: impl FnOnce(&mut T) -> Result<(), String>,
) -> i32 {
    // SAFETY: per the function contract.
    let Some(slot) = (unsafe { inst.cast::<Slot<T>>().as_mut() }) else {
        unsafe { report(err, "null instance") };
        return ERROR;
    };
    if slot.poisoned {
        unsafe { report(err, "instance unusable: it panicked in an earlier call") };
        return PANICKED;
    }
    match catch_unwind(AssertUnwindSafe(|| f(&mut slot.inner))) {
        Ok(Ok(())) => OK,
        Ok(Err(m)) => {
            unsafe { report(err, &m) };
            ERROR
        }
        Err(p) => {
            slot.poisoned = true;
            unsafe { report(err, &panic_text(p)) };
            PANICKED
        }
    }
}

unsafe extern "C" fn create<T: Plugin>(
    config_toml: *const c_char,
    info: *const DriveInfo,
    err: *mut ErrorBuf,
) -> Instance {
    let r = catch_unwind(|| {
        if config_toml.is_null() || info.is_null() {
            return Err("create: null config or drive info".to_string());
        }
        // SAFETY: non-null, NUL-terminated per the ABI.
        let text = unsafe { CStr::from_ptr(config_toml) }
            .to_str()
            .map_err(|e| format!("create: config is not UTF-8: {e}"))?;
        // SAFETY: non-null, points to a DriveInfo per the ABI.
        let t = T::create(text, unsafe { &*info })?;
        let slot = Slot {
            initial: t.clone(),
            inner: t,
            poisoned: false,
        };
        Ok(Box::into_raw(Box::new(slot)).cast())
    });
    match r {
        Ok(Ok(p)) => p,
        Ok(Err(m)) => {
            unsafe { report(err, &m) };
            std::ptr::null_mut()
        }
        Err(p) => {
            unsafe { report(err, &panic_text(p)) };
            std::ptr::null_mut()
        }
    }
}

unsafe extern "C" fn clone<T: Plugin>(inst: Instance, err: *mut ErrorBuf) -> Instance {
    let mut out: Option<Slot<T>> = None;
    let code = unsafe {
        with::<T>(inst, err, |_| Ok(())) // poison and null checks
    };
    if code != OK {
        return std::ptr::null_mut();
    }
    // SAFETY: checked non-null and healthy above.
    let slot = unsafe { &*inst.cast::<Slot<T>>() };
    match catch_unwind(AssertUnwindSafe(|| {
        out = Some(Slot {
            inner: slot.inner.clone(),
            initial: slot.initial.clone(),
            poisoned: false,
        })
    })) {
        Ok(()) => out.map_or(std::ptr::null_mut(), |s| Box::into_raw(Box::new(s)).cast()),
        Err(p) => {
            unsafe { report(err, &panic_text(p)) };
            std::ptr::null_mut()
        }
    }
}

unsafe extern "C" fn destroy<T: Plugin>(inst: Instance) {
    if !inst.is_null() {
        // A panicking Drop must not unwind into the host; the memory is then leaked.
        let _ = catch_unwind(|| {
            // SAFETY: created by Box::into_raw in create/clone, destroyed once (ABI).
            drop(unsafe { Box::from_raw(inst.cast::<Slot<T>>()) });
        });
    }
}

unsafe extern "C" fn reset<T: Plugin>(inst: Instance, err: *mut ErrorBuf) -> i32 {
    // SAFETY: pointer contract forwarded.
    let Some(slot) = (unsafe { inst.cast::<Slot<T>>().as_mut() }) else {
        unsafe { report(err, "null instance") };
        return ERROR;
    };
    match catch_unwind(AssertUnwindSafe(|| slot.initial.clone())) {
        Ok(t) => {
            slot.inner = t;
            slot.poisoned = false;
            OK
        }
        Err(p) => {
            unsafe { report(err, &panic_text(p)) };
            PANICKED
        }
    }
}

unsafe extern "C" fn clock<T: Plugin>(inst: Instance, out: *mut u64, err: *mut ErrorBuf) -> i32 {
    if out.is_null() {
        unsafe { report(err, "clock: null output") };
        return ERROR;
    }
    unsafe {
        with::<T>(inst, err, |t| {
            *out = t.clock();
            Ok(())
        })
    }
}

unsafe extern "C" fn table<T: Plugin>(inst: Instance, out: *mut CTable, err: *mut ErrorBuf) -> i32 {
    if out.is_null() {
        unsafe { report(err, "table: null output") };
        return ERROR;
    }
    unsafe {
        with::<T>(inst, err, |t| {
            *out = t.table();
            Ok(())
        })
    }
}

unsafe extern "C" fn set_inputs<T: Plugin>(
    inst: Instance,
    inputs: *const Inputs,
    err: *mut ErrorBuf,
) -> i32 {
    // SAFETY: null or a valid Inputs per the ABI.
    let Some(inputs) = (unsafe { inputs.as_ref() }) else {
        unsafe { report(err, "set_inputs: null inputs") };
        return ERROR;
    };
    unsafe {
        with::<T>(inst, err, |t| {
            t.set_inputs(inputs);
            Ok(())
        })
    }
}

unsafe extern "C" fn step<T: Plugin>(
    inst: Instance,
    now: u64,
    sensed: *const CSensed,
    command: *mut CCommand,
    status: *mut CStatus,
    err: *mut ErrorBuf,
) -> i32 {
    if sensed.is_null() || command.is_null() || status.is_null() {
        unsafe { report(err, "step: null argument") };
        return ERROR;
    }
    unsafe {
        with::<T>(inst, err, |t| {
            let (c, s) = t.step(now, &*sensed)?;
            *command = c;
            *status = s;
            Ok(())
        })
    }
}

unsafe extern "C" fn save<T: Plugin>(
    inst: Instance,
    buf: *mut u8,
    cap: usize,
    len: *mut usize,
    err: *mut ErrorBuf,
) -> i32 {
    if len.is_null() {
        unsafe { report(err, "save: null length") };
        return ERROR;
    }
    unsafe {
        with::<T>(inst, err, |t| {
            let bytes = t.save()?;
            *len = bytes.len();
            if buf.is_null() {
                return Ok(());
            }
            if bytes.len() > cap {
                return Err(format!(
                    "save: {} bytes do not fit in {cap} (rule: ask for the length first)",
                    bytes.len()
                ));
            }
            // SAFETY: the host's buffer holds `cap` bytes (ABI contract).
            std::ptr::copy_nonoverlapping(bytes.as_ptr(), buf, bytes.len());
            Ok(())
        })
    }
}

unsafe extern "C" fn restore<T: Plugin>(
    inst: Instance,
    buf: *const u8,
    len: usize,
    err: *mut ErrorBuf,
) -> i32 {
    if buf.is_null() && len > 0 {
        unsafe { report(err, "restore: null state") };
        return ERROR;
    }
    let state: &[u8] = if len == 0 {
        &[]
    } else {
        // SAFETY: the host's buffer holds `len` bytes (ABI contract).
        unsafe { std::slice::from_raw_parts(buf, len) }
    };
    unsafe { with::<T>(inst, err, |t| t.restore(state)) }
}

unsafe extern "C" fn planned_change<T: Plugin>(
    inst: Instance,
    at: *mut u64,
    legs: *mut [u8; 3],
    err: *mut ErrorBuf,
) -> i32 {
    if at.is_null() || legs.is_null() {
        unsafe { report(err, "planned_change: null argument") };
        return ERROR;
    }
    unsafe {
        with::<T>(inst, err, |t| {
            (*at, *legs) = t.planned_change().unwrap_or((u64::MAX, [0; 3]));
            Ok(())
        })
    }
}

/// The vtable of `T`: every function wraps `T`'s method with panic and null checks.
pub const fn vtable_of<T: Plugin>() -> VTable {
    VTable {
        create: create::<T>,
        clone: clone::<T>,
        destroy: destroy::<T>,
        reset: reset::<T>,
        clock: clock::<T>,
        table: table::<T>,
        set_inputs: set_inputs::<T>,
        step: step::<T>,
        save: Some(save::<T>),
        restore: Some(restore::<T>),
        planned_change: Some(planned_change::<T>),
    }
}

/// Exports `$t` (a [`Plugin`]) as a strategy plugin named `$name` with description
/// `$description` (string literals): defines the entry symbol and its static header.
#[macro_export]
macro_rules! export_strategy {
    ($t:ty, $name:literal, $description:literal) => {
        /// The plugin's entry point (see the strategy-abi crate).
        #[unsafe(no_mangle)]
        pub extern "C" fn bldc_strategy_entry() -> *const $crate::Header {
            static HEADER: $crate::Header = $crate::Header {
                magic: $crate::MAGIC,
                abi_major: $crate::ABI_MAJOR,
                abi_minor: $crate::ABI_MINOR,
                name: concat!($name, "\0").as_ptr().cast(),
                description: concat!($description, "\0").as_ptr().cast(),
                vtable_size: ::core::mem::size_of::<$crate::VTable>() as u32,
                vtable: $crate::vtable_of::<$t>(),
            };
            &HEADER
        }
    };
}
