//! strategy-abi: the contract between the drive (host) and a commutation strategy compiled
//! as a separate shared library (plugin).
//!
//! A plugin exports one symbol, [`ENTRY_SYMBOL`], an `extern "C" fn() -> *const Header`.
//! The [`Header`] starts with a magic, the ABI major and minor version, the strategy's
//! name and description, then the [`VTable`]. Every function takes and returns C-layout
//! values only; the strategy's configuration is passed as a TOML string the plugin parses.
//!
//! # Versioning rules
//! - The first three fields of [`Header`] (`magic`, `abi_major`, `abi_minor`) never move,
//!   in any version, so a host can always read them before trusting anything else.
//! - A host loads a plugin only if the majors are equal. A different major may change
//!   anything after those three fields.
//! - Within a major, a minor version may only *append*: new functions at the end of
//!   [`VTable`] (the plugin states the size of its table in `vtable_size`, so a newer host
//!   knows which functions an older plugin lacks) and new trailing fields in the structs
//!   that carry a size. Existing fields, their types, meanings and the calling
//!   conventions never change within a major. A host accepts any minor of its major; it
//!   must not call a function beyond the plugin's `vtable_size`.
//! - Instances must be movable between threads (the host may create an instance on one
//!   thread and step it on another, never on two at once).
//!
//! Plugin authors implement [`Plugin`] in safe Rust and call [`export_strategy!`]: the
//! generated functions catch every panic (a panic never unwinds into the host; the
//! instance then refuses further calls) and convert errors into messages.
//!
//! Plugin authors in C (or any language that can export a C function) include
//! `strategy-abi/include/bldc_strategy.h`, the same ABI as one C99 header (also valid
//! C++11); `plugins/c-example/tests/layout.rs` checks that every struct's size, alignment
//! and field offsets and every constant there equal the definitions here. A guide:
//! docs/plugins-c.md.
#![warn(missing_docs)]

mod export;

pub use export::{Plugin, vtable_of};

use std::ffi::c_char;
use std::ffi::c_void;

/// The first eight bytes of every header.
pub const MAGIC: [u8; 8] = *b"BLDCSTRT";
/// ABI major version of this crate.
pub const ABI_MAJOR: u32 = 1;
/// ABI minor version of this crate. 1: `save` and `restore` appended to [`VTable`];
/// 2: `planned_change`.
pub const ABI_MINOR: u32 = 2;
/// Name of the entry symbol (NUL-terminated for `dlsym`).
pub const ENTRY_SYMBOL: &[u8] = b"bldc_strategy_entry\0";

/// Status codes of vtable calls.
pub const OK: i32 = 0;
/// The call failed; the message is in the [`ErrorBuf`].
pub const ERROR: i32 = 1;
/// The plugin panicked (now or in an earlier call); the instance is unusable.
pub const PANICKED: i32 = 2;

/// Leg bits in [`CCommand::legs`]: high-side switch on.
pub const LEG_HIGH: u8 = 1;
/// Leg bits: low-side switch on. Both bits set would short the supply: the host refuses it.
pub const LEG_LOW: u8 = 2;

/// The entry function's type.
pub type EntryFn = unsafe extern "C" fn() -> *const Header;

/// What the entry symbol returns (static for the library's lifetime).
#[repr(C)]
pub struct Header {
    /// [`MAGIC`].
    pub magic: [u8; 8],
    /// ABI major the plugin was built against.
    pub abi_major: u32,
    /// ABI minor the plugin was built against.
    pub abi_minor: u32,
    /// Strategy name, NUL-terminated UTF-8 (e.g. `example-twelve-step-df`).
    pub name: *const c_char,
    /// One-line description, NUL-terminated UTF-8.
    pub description: *const c_char,
    /// Size of the plugin's [`VTable`] in bytes: a whole number of function pointers
    /// (every entry is one), at least [`VTABLE_1_0`].
    pub vtable_size: u32,
    /// The functions.
    pub vtable: VTable,
}

// The header is immutable static data.
unsafe impl Sync for Header {}

/// Facts about the drive a strategy needs at creation.
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DriveInfo {
    /// Motor pole pairs.
    pub pole_pairs: u32,
    /// Current-sense scale [A per ADC code].
    pub amps_per_code: f64,
    /// PWM carrier top \[counts\] (duty = cv / top).
    pub carrier_top: u32,
}

/// Inputs of the chip, set by the host between steps.
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Inputs {
    /// Instant of the change [20 ns ticks].
    pub now: u64,
    /// Start input (1 = high).
    pub start: u8,
    /// Reset input (1 = high).
    pub reset: u8,
    /// Speed command \[rpm\].
    pub speed_ref_rpm: f64,
}

/// What the strategy sees at a clock edge.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct CSensed {
    /// Comparator outputs u, v, w (1 = terminal above neutral).
    pub zc: [u8; 3],
    /// Latest shunt-current ADC code.
    pub current_code: u16,
}

/// What the strategy returns at a clock edge.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct CCommand {
    /// Per leg u, v, w: [`LEG_HIGH`], [`LEG_LOW`] or 0 (floating). The high side chops
    /// according to the host's PWM scheme.
    pub legs: [u8; 3],
    /// Voltage command [carrier counts], 0..=carrier_top.
    pub duty: u32,
    /// Comparator channels whose changes must wake the strategy (1 = watch).
    pub watch: [u8; 3],
    /// Next instant the strategy must run even without a watched change \[ticks\];
    /// `u64::MAX` for none.
    pub wake_at: u64,
}

/// What the strategy shows (for traces and the benchmark).
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct CStatus {
    /// 0 off, 1 aligning, 2 running, 3 gave up.
    pub mode: u8,
    /// Commutation state (1..12 or 1..6), 0 when off or starting.
    pub state: u8,
    /// Raw Z_d (0/1).
    pub zd: u8,
    /// Guarded Z_d (0/1).
    pub zdf: u8,
    /// Inside a linear region (0/1).
    pub linear: u8,
    /// Voltage command [carrier counts].
    pub duty: u32,
    /// Speed measurement \[rpm\].
    pub speed_est_rpm: u32,
    /// Current command \[A\].
    pub current_ref_a: f64,
    /// Current-PI integrator [carrier counts] (0 if the strategy has none).
    pub current_integrator: f64,
    /// Restarts so far.
    pub restarts: u32,
    /// Accepted zero crossings.
    pub crossings: u64,
    /// Crossings taken by a timeout.
    pub forced_crossings: u64,
}

/// The commutation table a strategy aims for (the host measures commutation angles
/// against its boundaries).
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct CTable {
    /// 0: 120° six-step, 1: twelve-step.
    pub kind: u8,
    /// Conduction angle of a twelve-step table [electrical degrees].
    pub conduction_deg: f64,
}

/// A buffer the plugin writes an error message into (UTF-8, truncated to `cap`).
#[repr(C)]
pub struct ErrorBuf {
    /// Start of the host's buffer.
    pub ptr: *mut u8,
    /// Its capacity \[bytes\].
    pub cap: usize,
    /// Bytes written.
    pub len: usize,
}

impl ErrorBuf {
    /// Writes `msg`, truncated at a character boundary.
    ///
    /// # Safety
    /// `ptr` must be valid for writes of `cap` bytes.
    pub unsafe fn write(&mut self, msg: &str) {
        let mut n = msg.len().min(self.cap);
        while !msg.is_char_boundary(n) {
            n -= 1;
        }
        // SAFETY: the caller guarantees ptr..ptr+cap is writable; n <= cap.
        unsafe { std::ptr::copy_nonoverlapping(msg.as_ptr(), self.ptr, n) };
        self.len = n;
    }
}

/// The size of a plugin state the host accepts from `save` \[bytes\]: a state is the
/// strategy's registers and counters, far smaller.
pub const MAX_STATE_BYTES: usize = 1 << 20;

/// Opaque instance pointer.
pub type Instance = *mut c_void;

/// The plugin's functions. Every one returns or reports errors; none may unwind.
#[repr(C)]
#[derive(Copy, Clone)]
pub struct VTable {
    /// Creates an instance from the drive's TOML config (NUL-terminated) and the drive
    /// facts; null on error (message in `err`).
    pub create: unsafe extern "C" fn(
        config_toml: *const c_char,
        info: *const DriveInfo,
        err: *mut ErrorBuf,
    ) -> Instance,
    /// An independent copy of an instance in the same state; null on error.
    pub clone: unsafe extern "C" fn(inst: Instance, err: *mut ErrorBuf) -> Instance,
    /// Frees an instance (null is ignored).
    pub destroy: unsafe extern "C" fn(inst: Instance),
    /// Back to the state right after `create`.
    pub reset: unsafe extern "C" fn(inst: Instance, err: *mut ErrorBuf) -> i32,
    /// The strategy's clock period [20 ns ticks] (written to `out`).
    pub clock: unsafe extern "C" fn(inst: Instance, out: *mut u64, err: *mut ErrorBuf) -> i32,
    /// Its commutation table (written to `out`).
    pub table: unsafe extern "C" fn(inst: Instance, out: *mut CTable, err: *mut ErrorBuf) -> i32,
    /// Sets the chip inputs.
    pub set_inputs:
        unsafe extern "C" fn(inst: Instance, inputs: *const Inputs, err: *mut ErrorBuf) -> i32,
    /// Runs the strategy at clock edge `now`; writes the command and the status.
    pub step: unsafe extern "C" fn(
        inst: Instance,
        now: u64,
        sensed: *const CSensed,
        command: *mut CCommand,
        status: *mut CStatus,
        err: *mut ErrorBuf,
    ) -> i32,
    /// ABI 1.1: writes the instance's dynamic state (bytes of the plugin's own format)
    /// into `buf` and its length to `len`. With `buf` null, only writes the length needed
    /// and returns OK; with `cap` too small, writes the length needed and returns ERROR.
    /// A plugin that cannot save its state returns ERROR with the reason. `None` (a null
    /// pointer) is the same as a plugin that cannot.
    pub save: Option<
        unsafe extern "C" fn(
            inst: Instance,
            buf: *mut u8,
            cap: usize,
            len: *mut usize,
            err: *mut ErrorBuf,
        ) -> i32,
    >,
    /// ABI 1.1: reads a state `save` wrote (`len` bytes at `buf`) into an instance
    /// created from the same config; refuses (ERROR) bytes it does not accept; the host
    /// then drops the instance.
    pub restore: Option<
        unsafe extern "C" fn(inst: Instance, buf: *const u8, len: usize, err: *mut ErrorBuf) -> i32,
    >,
    /// ABI 1.2: the next instant \[ticks\] at which the strategy already knows it will
    /// command other legs (e.g. a commutation timed by a counter), with those legs (as in
    /// [`CCommand::legs`]), if its inputs hold; `u64::MAX` in `at` for none. A hint the host
    /// reads after each `step` and `restore`: it ends the plant's integration step there.
    /// `None` (a null pointer), an error, legs that are not a valid `legs` value, legs equal
    /// to those in force, or an instant not after the present are the same as none; a panic
    /// is reported as the plugin's fault. The answer must be a function of the state `save`
    /// writes, as of the last `step` or `restore` (`set_inputs` must not change it): the
    /// host keeps it until the next step, and asks again after a restore, so anything else
    /// makes a restored run differ from an uninterrupted one.
    pub planned_change: Option<
        unsafe extern "C" fn(
            inst: Instance,
            at: *mut u64,
            legs: *mut [u8; 3],
            err: *mut ErrorBuf,
        ) -> i32,
    >,
}

/// The size of a 1.0 [`VTable`] \[bytes\]: the functions every plugin of this major has.
pub const VTABLE_1_0: usize = std::mem::offset_of!(VTable, save);
