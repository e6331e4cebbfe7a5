//! The host side of strategy plugins: loads a shared library, checks its header before
//! touching anything else, and wraps its instances as [`Strategy`]s.
//!
//! The library stays loaded as long as any instance made from it (each holds an `Arc`).
//! Every plugin failure becomes a [`PluginError`] naming the file; a failure during a
//! step (an error, a panic caught on the plugin side, or a command the host refuses such
//! as both switches of a leg on) becomes a controller fault that stops the engine.

use crate::chip::{ChipStatus, Mode};
use crate::strategy::Strategy;
use crate::table::{OFF_FLAG, Table, flag_of};
use drive_core::{
    Abc, Command, Controller, LegState, Pattern, Persist, Reader, Sensed, Ticks, Writer,
};
use std::ffi::{CStr, CString, c_char};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use strategy_abi as abi;

pub use abi::DriveInfo;

const SYMBOL: &str = "bldc_strategy_entry";

/// Why a plugin cannot be used.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PluginError {
    /// The file could not be opened as a shared library.
    #[error("plugin {path}: not a loadable shared library: {reason}")]
    NotALibrary {
        /// File.
        path: PathBuf,
        /// The loader's message.
        reason: String,
    },
    /// The entry symbol is missing.
    #[error(
        "plugin {path}: symbol `{SYMBOL}` not found (rule: a strategy plugin exports it, see the strategy-abi crate; host ABI {host_major}.{host_minor}): {reason}"
    )]
    NoEntry {
        /// File.
        path: PathBuf,
        /// Host ABI major.
        host_major: u32,
        /// Host ABI minor.
        host_minor: u32,
        /// The loader's message.
        reason: String,
    },
    /// The header is missing or malformed.
    #[error("plugin {path}: symbol `{SYMBOL}`: {problem}")]
    BadHeader {
        /// File.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// The ABI versions are incompatible.
    #[error(
        "plugin {path}: symbol `{SYMBOL}`: ABI {plugin_major}.{plugin_minor} (plugin) vs {host_major}.{host_minor} (host) (rule: majors must be equal)"
    )]
    Version {
        /// File.
        path: PathBuf,
        /// Plugin ABI major.
        plugin_major: u32,
        /// Plugin ABI minor.
        plugin_minor: u32,
        /// Host ABI major.
        host_major: u32,
        /// Host ABI minor.
        host_minor: u32,
    },
    /// A call into the plugin failed.
    #[error("plugin `{name}` ({path}): {call}: {message}")]
    Call {
        /// File.
        path: PathBuf,
        /// Strategy name.
        name: String,
        /// The vtable function.
        call: &'static str,
        /// The plugin's message.
        message: String,
    },
}

/// The functions of [`abi::VTable`], in its order (for errors naming an entry).
const VTABLE_NAMES: [&str; 11] = [
    "create",
    "clone",
    "destroy",
    "reset",
    "clock",
    "table",
    "set_inputs",
    "step",
    "save",
    "restore",
    "planned_change",
];
const VTABLE_ENTRIES: usize = VTABLE_NAMES.len();
const _: () =
    assert!(std::mem::size_of::<abi::VTable>() == VTABLE_ENTRIES * std::mem::size_of::<usize>());

struct Loaded {
    path: PathBuf,
    name: String,
    description: String,
    vtable: abi::VTable,
    /// The ABI minor the plugin was built against.
    minor: u32,
    // Last: the vtable points into it.
    _lib: libloading::Library,
}

/// A loaded strategy plugin.
#[derive(Clone)]
pub struct PluginLibrary {
    inner: Arc<Loaded>,
}

impl std::fmt::Debug for PluginLibrary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "PluginLibrary({} from {})",
            self.inner.name,
            self.inner.path.display()
        )
    }
}

fn text(p: *const c_char, what: &str, path: &Path) -> Result<String, PluginError> {
    if p.is_null() {
        return Err(PluginError::BadHeader {
            path: path.into(),
            problem: format!("{what} is a null pointer"),
        });
    }
    // SAFETY: non-null, NUL-terminated static string per the ABI (magic already checked).
    unsafe { CStr::from_ptr(p) }
        .to_str()
        .map(str::to_string)
        .map_err(|e| PluginError::BadHeader {
            path: path.into(),
            problem: format!("{what} is not UTF-8: {e}"),
        })
}

/// The plugin's vtable, checked: a whole number of pointers, at least ABI 1.0's, none of
/// those eight null. What a plugin of an older minor lacks is `None`.
///
/// # Safety
/// `header` points to a header of this ABI major whose vtable holds `size` bytes.
unsafe fn vtable_of(header: *const abi::Header, size: usize) -> Result<abi::VTable, String> {
    if size < abi::VTABLE_1_0 {
        return Err(format!(
            "vtable of {size} bytes, ABI {}.0 requires {}",
            abi::ABI_MAJOR,
            abi::VTABLE_1_0
        ));
    }
    let ptr = std::mem::size_of::<usize>();
    if size % ptr != 0 {
        return Err(format!(
            "vtable of {size} bytes (rule: a whole number of {ptr}-byte function pointers)"
        ));
    }
    // The table as raw pointers first: a C plugin can leave an entry NULL, which the
    // 1.0 functions' Rust types (never null) must not hold.
    let mut raw = [std::ptr::null::<std::ffi::c_void>(); VTABLE_ENTRIES];
    // SAFETY: the plugin's table holds `size` bytes (at least the 1.0 functions), a
    // whole number of pointers; what it lacks stays null (None).
    unsafe {
        let src = std::ptr::addr_of!((*header).vtable).cast::<u8>();
        let n = size.min(std::mem::size_of_val(&raw));
        std::ptr::copy_nonoverlapping(src, raw.as_mut_ptr().cast::<u8>(), n);
    }
    if let Some(k) = raw[..abi::VTABLE_1_0 / ptr]
        .iter()
        .position(|f| f.is_null())
    {
        return Err(format!(
            "vtable entry `{}` is a null pointer (rule: the eight ABI {}.0 functions, create to step, are all given)",
            VTABLE_NAMES[k],
            abi::ABI_MAJOR
        ));
    }
    // SAFETY: same size and layout (asserted at compile time beside VTABLE_NAMES); those
    // that are not Options were checked non-null above.
    Ok(unsafe {
        std::mem::transmute::<[*const std::ffi::c_void; VTABLE_ENTRIES], abi::VTable>(raw)
    })
}

impl PluginLibrary {
    /// Loads `path` and checks its header: magic, then ABI version, then the rest.
    pub fn load(path: &Path) -> Result<Self, PluginError> {
        let p = || path.to_path_buf();
        // SAFETY: loading runs the library's initialisers; that is the contract of a
        // plugin file the user chose to load.
        let lib =
            unsafe { libloading::Library::new(path) }.map_err(|e| PluginError::NotALibrary {
                path: p(),
                reason: e.to_string(),
            })?;
        // SAFETY: the symbol's type is fixed by the ABI; it is only called below.
        let entry: abi::EntryFn =
            *unsafe { lib.get::<abi::EntryFn>(abi::ENTRY_SYMBOL) }.map_err(|e| {
                PluginError::NoEntry {
                    path: p(),
                    host_major: abi::ABI_MAJOR,
                    host_minor: abi::ABI_MINOR,
                    reason: e.to_string(),
                }
            })?;
        // SAFETY: calling the entry function is the ABI's first step; it takes nothing.
        let header = unsafe { entry() };
        let bad = |problem: String| PluginError::BadHeader { path: p(), problem };
        if header.is_null() {
            return Err(bad("returned a null header".into()));
        }
        // Only the fixed prefix is read before the checks (see the versioning rules).
        // SAFETY: non-null; magic and versions are at fixed offsets in every version.
        let (magic, major, minor) = unsafe {
            (
                std::ptr::addr_of!((*header).magic).read_unaligned(),
                std::ptr::addr_of!((*header).abi_major).read_unaligned(),
                std::ptr::addr_of!((*header).abi_minor).read_unaligned(),
            )
        };
        if magic != abi::MAGIC {
            return Err(bad(format!(
                "bad magic {magic:02x?} (expected {:02x?}): not a strategy plugin",
                abi::MAGIC
            )));
        }
        if major != abi::ABI_MAJOR {
            return Err(PluginError::Version {
                path: p(),
                plugin_major: major,
                plugin_minor: minor,
                host_major: abi::ABI_MAJOR,
                host_minor: abi::ABI_MINOR,
            });
        }
        // Magic and major match, so the header has this layout up to the plugin's vtable
        // size; functions of a later minor are read only if that size holds them.
        // SAFETY: fields before the vtable are in every header of this major.
        let (name_p, description_p, size) = unsafe {
            (
                std::ptr::addr_of!((*header).name).read_unaligned(),
                std::ptr::addr_of!((*header).description).read_unaligned(),
                std::ptr::addr_of!((*header).vtable_size).read_unaligned() as usize,
            )
        };
        // SAFETY: non-null, magic and major checked: the header has this major's layout.
        let vtable = unsafe { vtable_of(header, size) }.map_err(bad)?;
        let name = text(name_p, "name", path)?;
        if name.is_empty() {
            return Err(bad("empty name".into()));
        }
        let description = text(description_p, "description", path)?;
        Ok(PluginLibrary {
            inner: Arc::new(Loaded {
                path: p(),
                name,
                description,
                vtable,
                minor,
                _lib: lib,
            }),
        })
    }

    /// The strategy's name.
    pub fn name(&self) -> &str {
        &self.inner.name
    }

    /// Its description.
    pub fn description(&self) -> &str {
        &self.inner.description
    }

    /// The file it was loaded from.
    pub fn path(&self) -> &Path {
        &self.inner.path
    }

    /// Creates an instance from the drive's TOML config and facts, with the start input
    /// high and the speed command `speed_ref_rpm` (as the built-in chip starts).
    pub fn instantiate(
        &self,
        config_toml: &str,
        info: abi::DriveInfo,
        speed_ref_rpm: f64,
    ) -> Result<PluginStrategy, PluginError> {
        let call_err = |call, message| PluginError::Call {
            path: self.inner.path.clone(),
            name: self.inner.name.clone(),
            call,
            message,
        };
        let cfg = CString::new(config_toml)
            .map_err(|_| call_err("create", "config contains a NUL byte".into()))?;
        let mut buf = ErrBuf::new();
        // SAFETY: valid pointers for the duration of the call.
        let inst = unsafe { (self.inner.vtable.create)(cfg.as_ptr(), &info, buf.raw()) };
        if inst.is_null() {
            return Err(call_err("create", buf.message()));
        }
        let mut s = PluginStrategy {
            lib: self.inner.clone(),
            inst,
            clock: Ticks(1),
            table: Table::SixStep,
            status: idle_status(),
            fault: None,
            inputs: abi::Inputs {
                now: 0,
                start: 1,
                reset: 0,
                speed_ref_rpm,
            },
            top: info.carrier_top,
            plan: None,
            err: ErrBuf::new(),
        };
        let mut clock = 0u64;
        // SAFETY: live instance, valid out pointers.
        s.check(
            unsafe { (s.lib.vtable.clock)(s.inst, &mut clock, buf.raw()) },
            &buf,
        )
        .map_err(|m| call_err("clock", m))?;
        if clock == 0 {
            return Err(call_err(
                "clock",
                "clock period of 0 ticks (rule: >= 1)".into(),
            ));
        }
        s.clock = Ticks(clock);
        s.push_inputs();
        if let Some(m) = s.fault.take() {
            return Err(call_err("set_inputs", m));
        }
        let mut t = abi::CTable {
            kind: 0,
            conduction_deg: 0.0,
        };
        // SAFETY: as above.
        s.check(
            unsafe { (s.lib.vtable.table)(s.inst, &mut t, buf.raw()) },
            &buf,
        )
        .map_err(|m| call_err("table", m))?;
        s.table = match t.kind {
            0 => Table::SixStep,
            1 if (120.0..180.0).contains(&t.conduction_deg) => Table::TwelveStep {
                conduction_deg: t.conduction_deg,
            },
            k => {
                return Err(call_err(
                    "table",
                    format!(
                        "kind {k}, conduction {}° (rule: 0 six-step, or 1 twelve-step with 120 <= angle < 180)",
                        t.conduction_deg
                    ),
                ));
            }
        };
        Ok(s)
    }
}

/// A host-owned error buffer, lent to one call at a time. Its pointer is set at each
/// lending, so the buffer may move between calls (an instance keeps one for its ticks).
struct ErrBuf {
    bytes: [u8; 512],
    raw: abi::ErrorBuf,
}

impl ErrBuf {
    fn new() -> Self {
        ErrBuf {
            bytes: [0; 512],
            raw: abi::ErrorBuf {
                ptr: std::ptr::null_mut(),
                cap: 512,
                len: 0,
            },
        }
    }
    fn raw(&mut self) -> *mut abi::ErrorBuf {
        self.raw.ptr = self.bytes.as_mut_ptr();
        self.raw.len = 0;
        &mut self.raw
    }
    /// The plugin's message: `len` bytes, never more than the buffer (a plugin written in
    /// C may claim more, or write no NUL: neither is read past the buffer), lossy UTF-8.
    fn message(&self) -> String {
        let n = self.raw.len.min(self.bytes.len());
        let m = String::from_utf8_lossy(&self.bytes[..n]).into_owned();
        let m = if m.is_empty() {
            "(no message; rule: a failed call writes its reason into the error buffer)".into()
        } else {
            m
        };
        if self.raw.len > self.bytes.len() {
            format!(
                "{m} [message cut: the plugin set len = {} for a buffer of {} bytes (rule: len <= cap)]",
                self.raw.len,
                self.bytes.len()
            )
        } else {
            m
        }
    }
}

fn idle_status() -> ChipStatus {
    ChipStatus {
        mode: Mode::Off,
        state: 0,
        flag: OFF_FLAG,
        zd: false,
        zdf: false,
        linear: false,
        duty: 0,
        speed_est_rpm: 0,
        current_ref_a: 0.0,
        current_integrator: 0.0,
        restarts: 0,
        crossings: 0,
        forced_crossings: 0,
    }
}

/// An instance of a plugin strategy.
pub struct PluginStrategy {
    lib: Arc<Loaded>,
    inst: abi::Instance,
    clock: Ticks,
    table: Table,
    status: ChipStatus,
    fault: Option<String>,
    inputs: abi::Inputs,
    top: u32,
    /// The plugin's planned change (ABI 1.2), as of its last step or restore.
    plan: Option<(Ticks, Pattern)>,
    /// The error buffer of the calls made at every tick (no allocation per call).
    err: ErrBuf,
}

// SAFETY: the ABI requires instances to be movable between threads, and the host never
// uses one from two threads at once (it is owned, `&mut` for every call).
unsafe impl Send for PluginStrategy {}

impl Drop for PluginStrategy {
    fn drop(&mut self) {
        // SAFETY: the instance came from create/clone of this library and is freed once.
        unsafe { (self.lib.vtable.destroy)(self.inst) };
    }
}

impl PluginStrategy {
    fn check(&self, code: i32, buf: &ErrBuf) -> Result<(), String> {
        match code {
            abi::OK => Ok(()),
            abi::PANICKED => Err(buf.message()),
            abi::ERROR => Err(buf.message()),
            c => Err(format!("unknown status code {c}: {}", buf.message())),
        }
    }

    /// Why this plugin's state cannot be saved or restored: it predates ABI 1.1.
    fn cannot(&self, call: &str) -> String {
        format!(
            "plugin `{}` ({}): {call}: built against strategy-abi {}.{}, which has no {call} (rule: a plugin strategy's state is serialized only by a plugin of ABI 1.1 or later, through its save and restore functions)",
            self.lib.name,
            self.lib.path.display(),
            abi::ABI_MAJOR,
            self.lib.minor
        )
    }

    /// The plugin's own state bytes (ABI 1.1 `save`: length first, then the bytes), or
    /// why there are none.
    fn plugin_state(&self) -> Result<Vec<u8>, String> {
        let named = |m: String| {
            let rule = if m.contains("(rule:") {
                ""
            } else {
                " (rule: a plugin strategy's save succeeds for its drive to be serialized)"
            };
            format!(
                "plugin `{}` ({}): save: {m}{rule}",
                self.lib.name,
                self.lib.path.display()
            )
        };
        if let Some(f) = &self.fault {
            return Err(format!(
                "{f} (rule: a failed strategy has no state to save)"
            ));
        }
        let save = self.lib.vtable.save.filter(|_| self.lib.minor >= 1);
        let Some(save) = save else {
            return Err(self.cannot("save"));
        };
        let mut buf = ErrBuf::new();
        let mut len = 0usize;
        // SAFETY: live instance; a null buffer asks for the length only.
        let code = unsafe { save(self.inst, std::ptr::null_mut(), 0, &mut len, buf.raw()) };
        self.check(code, &buf).map_err(named)?;
        if len > abi::MAX_STATE_BYTES {
            return Err(named(format!(
                "{len} bytes (rule: at most {} bytes)",
                abi::MAX_STATE_BYTES
            )));
        }
        let mut bytes = vec![0u8; len];
        let mut wrote = 0usize;
        // SAFETY: live instance; the buffer holds `len` bytes.
        let code = unsafe { save(self.inst, bytes.as_mut_ptr(), len, &mut wrote, buf.raw()) };
        self.check(code, &buf).map_err(named)?;
        if wrote != len {
            return Err(named(format!(
                "wrote {wrote} bytes after asking for {len} (rule: the same length both times)"
            )));
        }
        Ok(bytes)
    }

    fn fail(&mut self, call: &str, message: String) {
        if self.fault.is_none() {
            self.fault = Some(format!(
                "plugin `{}` ({}): {call}: {message}",
                self.lib.name,
                self.lib.path.display()
            ));
        }
    }

    /// Asks the plugin for its planned change (ABI 1.2). Only a hint: without the function,
    /// on an error or with legs the bridge cannot take, there is none; a panic is the
    /// plugin's fault, returned and kept (the next step reports it).
    fn refresh_plan(&mut self) -> Result<(), String> {
        self.plan = None;
        let Some(f) = self
            .lib
            .vtable
            .planned_change
            .filter(|_| self.lib.minor >= 2)
        else {
            return Ok(());
        };
        let (mut at, mut legs) = (u64::MAX, [0u8; 3]);
        // SAFETY: live instance, valid out pointers.
        match unsafe { f(self.inst, &mut at, &mut legs, self.err.raw()) } {
            abi::OK if at != u64::MAX => {}
            abi::PANICKED => {
                let m = self.err.message();
                self.fail("planned_change", m);
                return Err(self.fault.clone().unwrap_or_default());
            }
            _ => return Ok(()),
        }
        // Legs a command could not carry are no plan.
        self.plan = pattern_of(&legs).ok().map(|p| (Ticks(at), p));
        Ok(())
    }

    fn push_inputs(&mut self) {
        // SAFETY: live instance, valid pointers.
        let code = unsafe { (self.lib.vtable.set_inputs)(self.inst, &self.inputs, self.err.raw()) };
        if let Err(m) = self.check(code, &self.err) {
            self.fail("set_inputs", m);
        }
    }

    /// Converts the plugin's command, refusing anything the bridge must never see.
    fn command(&self, now: Ticks, c: &abi::CCommand) -> Result<Command, String> {
        let pattern = pattern_of(&c.legs)?;
        if c.duty > self.top {
            return Err(format!("duty {} counts (rule: 0..={})", c.duty, self.top));
        }
        if c.wake_at <= now.0 {
            return Err(format!(
                "wake_at = {} ticks at the step of tick {} (rule: a wake-up after the step's instant, or u64::MAX for none)",
                c.wake_at, now.0
            ));
        }
        Ok(Command {
            pattern,
            duty: c.duty,
            watch: Abc {
                u: c.watch[0] != 0,
                v: c.watch[1] != 0,
                w: c.watch[2] != 0,
            },
            // The ABI passes every comparator output to the plugin.
            reads: Command::READS_ALL,
            wake_at: if c.wake_at == u64::MAX {
                Ticks::NEVER
            } else {
                Ticks(c.wake_at)
            },
        })
    }
}

/// The legs of a plugin's command or plan (`CCommand::legs` bits), refusing anything the
/// bridge must never see.
fn pattern_of(legs: &[u8; 3]) -> Result<Pattern, String> {
    let mut out = [LegState::Float; 3];
    for (k, &bits) in legs.iter().enumerate() {
        out[k] = match bits {
            0 => LegState::Float,
            abi::LEG_HIGH => LegState::High,
            abi::LEG_LOW => LegState::Low,
            b if b == abi::LEG_HIGH | abi::LEG_LOW => {
                return Err(format!(
                    "both switches of leg {} on: shoot-through refused (rule: at most one switch per leg)",
                    ["u", "v", "w"][k]
                ));
            }
            b => {
                return Err(format!(
                    "leg {} bits {b:#04b} (rule: 0, 1 high or 2 low)",
                    ["u", "v", "w"][k]
                ));
            }
        };
    }
    Ok(Abc {
        u: out[0],
        v: out[1],
        w: out[2],
    })
}

impl Controller for PluginStrategy {
    fn clock(&self) -> Ticks {
        self.clock
    }

    fn tick(&mut self, now: Ticks, sensed: &Sensed) -> Command {
        if self.fault.is_some() {
            return Command::OFF;
        }
        let s = abi::CSensed {
            zc: sensed.zc_all().to_array().map(u8::from),
            current_code: sensed.current_code,
        };
        let mut c = abi::CCommand::default();
        let mut st = abi::CStatus::default();
        // SAFETY: live instance, valid pointers for the call.
        let code = unsafe {
            (self.lib.vtable.step)(self.inst, now.0, &s, &mut c, &mut st, self.err.raw())
        };
        if let Err(m) = self.check(code, &self.err) {
            self.fail("step", m);
            return Command::OFF;
        }
        match self.command(now, &c) {
            Ok(cmd) => {
                self.status = ChipStatus {
                    mode: match st.mode {
                        1 => Mode::Aligning {
                            step: 0,
                            until: Ticks::NEVER,
                        },
                        2 => Mode::Running,
                        3 => Mode::GaveUp,
                        _ => Mode::Off,
                    },
                    state: st.state,
                    flag: flag_of(&cmd.pattern).unwrap_or(OFF_FLAG),
                    zd: st.zd != 0,
                    zdf: st.zdf != 0,
                    linear: st.linear != 0,
                    duty: st.duty,
                    speed_est_rpm: st.speed_est_rpm,
                    current_ref_a: st.current_ref_a,
                    current_integrator: st.current_integrator,
                    restarts: st.restarts,
                    crossings: st.crossings,
                    forced_crossings: st.forced_crossings,
                };
                // A panic there is kept as the fault, which the engine reports after this tick.
                let _ = self.refresh_plan();
                cmd
            }
            Err(m) => {
                self.fail("step", m);
                Command::OFF
            }
        }
    }

    fn fault(&self) -> Option<&str> {
        self.fault.as_deref()
    }

    fn planned_change(&self) -> Option<(Ticks, Pattern)> {
        self.plan.filter(|_| self.fault.is_none())
    }
}

impl Strategy for PluginStrategy {
    fn name(&self) -> &str {
        &self.lib.name
    }
    fn status(&self) -> ChipStatus {
        self.status
    }
    fn table(&self) -> Table {
        self.table
    }
    fn set_start(&mut self, now: Ticks, level: bool) {
        self.inputs.now = now.0;
        self.inputs.start = level.into();
        self.push_inputs();
    }
    fn set_reset(&mut self, level: bool) {
        self.inputs.reset = level.into();
        self.push_inputs();
    }
    fn set_speed_ref(&mut self, rpm: f64) {
        if rpm.is_finite() {
            self.inputs.speed_ref_rpm = rpm;
            self.push_inputs();
        }
    }
    fn speed_ref_rpm(&self) -> f64 {
        self.inputs.speed_ref_rpm
    }
    fn save_state(&self, w: &mut Writer) {
        match self.plugin_state() {
            Ok(bytes) => {
                self.status.save(w);
                self.inputs.now.save(w);
                self.inputs.start.save(w);
                self.inputs.reset.save(w);
                self.inputs.speed_ref_rpm.save(w);
                w.bytes(&bytes);
            }
            Err(e) => w.fail(e),
        }
    }
    fn restore_state(&mut self, r: &mut Reader) -> Result<(), String> {
        // No plan survives a failed restore; a good one asks the plugin again.
        self.plan = None;
        r.field("status", &mut self.status)?;
        r.field("inputs.now", &mut self.inputs.now)?;
        r.field("inputs.start", &mut self.inputs.start)?;
        r.field("inputs.reset", &mut self.inputs.reset)?;
        r.field("inputs.speed_ref_rpm", &mut self.inputs.speed_ref_rpm)?;
        let bytes = r.bytes()?;
        let restore = self.lib.vtable.restore.filter(|_| self.lib.minor >= 1);
        let Some(restore) = restore else {
            return Err(self.cannot("restore"));
        };
        let mut buf = ErrBuf::new();
        // SAFETY: live instance; the slice is valid for its length during the call.
        let code = unsafe { restore(self.inst, bytes.as_ptr(), bytes.len(), buf.raw()) };
        self.check(code, &buf).map_err(|m| {
            format!(
                "plugin `{}` ({}): restore: {m}",
                self.lib.name,
                self.lib.path.display()
            )
        })?;
        self.refresh_plan()
    }
    fn try_clone(&self) -> Result<Box<dyn Strategy>, String> {
        let mut buf = ErrBuf::new();
        // SAFETY: live instance, valid buffer.
        let inst = unsafe { (self.lib.vtable.clone)(self.inst, buf.raw()) };
        if inst.is_null() {
            return Err(format!(
                "plugin `{}`: clone: {}",
                self.lib.name,
                buf.message()
            ));
        }
        Ok(Box::new(PluginStrategy {
            lib: self.lib.clone(),
            inst,
            clock: self.clock,
            table: self.table,
            status: self.status,
            fault: self.fault.clone(),
            inputs: self.inputs,
            top: self.top,
            plan: self.plan,
            err: ErrBuf::new(),
        }))
    }
}
