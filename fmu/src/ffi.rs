//! The C side of an instance: FMI 2.0 types (`fmi2TypesPlatform.h`, `fmi2FunctionTypes.h`),
//! the copied callbacks, the logger, and the registry that tells live handles from stale
//! or foreign pointers.

use crate::model::{Fault, Model};
use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;
use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::panic::{self, AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::sync::{Mutex, Once};

/// `fmi2Status`.
pub type Status = c_int;
/// `fmi2OK`.
pub const OK: Status = 0;
/// `fmi2Warning`.
pub const WARNING: Status = 1;
/// `fmi2Error`.
pub const ERROR: Status = 3;
/// `fmi2Fatal`.
pub const FATAL: Status = 4;

/// `fmi2CallbackLogger`: printf-style, variadic.
pub type Logger =
    unsafe extern "C" fn(*mut c_void, *const c_char, Status, *const c_char, *const c_char, ...);

/// `fmi2CallbackFunctions` (field order and C layout as in the header).
#[repr(C)]
#[derive(Copy, Clone)]
pub struct CallbackFunctions {
    /// Logger; may be NULL (then nothing is logged).
    pub logger: Option<Logger>,
    /// Not used: the FMU declares `canNotUseMemoryManagementFunctions`.
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    /// Not used.
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    /// Not used (no asynchronous steps).
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, Status)>,
    /// Passed back to the logger.
    pub component_environment: *mut c_void,
}

/// Log categories, in the order of [`crate::xml::LOG_CATEGORIES`].
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Category {
    /// `logStatusError`.
    Error = 0,
    /// `logStatusWarning`.
    Warning = 1,
    /// `logEvents`.
    Events = 2,
}

const CATEGORY_C: [&CStr; 3] = [c"logStatusError", c"logStatusWarning", c"logEvents"];

/// One FMU instance behind an `fmi2Component`.
pub struct Instance {
    /// The instance name, for the logger.
    pub name: CString,
    logger: Option<Logger>,
    env: *mut c_void,
    /// Which categories are logged.
    pub enabled: [bool; 3],
    /// The safe core.
    pub model: Model,
    /// What the last `fmi2GetString` returned: kept so its pointers stay valid.
    pub strings_out: Vec<CString>,
}

impl Instance {
    /// A new instance; errors and warnings are logged unless switched off, events only with
    /// `logging_on`.
    pub fn new(name: CString, callbacks: &CallbackFunctions, logging_on: bool) -> Instance {
        Instance {
            name,
            logger: callbacks.logger,
            env: callbacks.component_environment,
            enabled: [true, true, logging_on],
            model: Model::new(),
            strings_out: Vec::new(),
        }
    }

    /// Sends `msg` to the master's logger under `cat`, if that category is on.
    pub fn log(&self, status: Status, cat: Category, msg: &str) {
        if self.enabled[cat as usize] {
            log_raw(self.logger, self.env, &self.name, status, cat, msg);
        }
    }

    /// Logs a fault of `call` and turns it into a status.
    pub fn report(&self, call: &str, r: Result<(), Fault>) -> Status {
        match r {
            Ok(()) => OK,
            Err(Fault::Warning(m)) => {
                self.log(WARNING, Category::Warning, &format!("{call}: {m}"));
                WARNING
            }
            Err(Fault::Error(m)) => {
                self.log(ERROR, Category::Error, &format!("{call}: {m}"));
                ERROR
            }
        }
    }
}

/// The folder an `fmuResourceLocation` URI names: `file:///abs`, `file:/abs` or
/// `file://localhost/abs`, percent-decoded. None for anything else (a relative
/// `strategy.plugin` then cannot be resolved, which is reported when it is used).
pub fn resources_of_uri(uri: &str) -> Option<PathBuf> {
    let rest = uri.strip_prefix("file:")?;
    let path = match rest.strip_prefix("//") {
        Some(r) => r.strip_prefix("localhost").unwrap_or(r),
        None => rest,
    };
    if !path.starts_with('/') {
        return None;
    }
    let b = path.as_bytes();
    let hex = |i: usize| b.get(i).and_then(|&c| (c as char).to_digit(16));
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            out.push((hex(i + 1)? * 16 + hex(i + 2)?) as u8);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok().map(PathBuf::from)
}

/// Calls a C logger with `"%s"` and the message, so the text is never a format string.
pub(crate) fn log_raw(
    logger: Option<Logger>,
    env: *mut c_void,
    name: &CStr,
    status: Status,
    cat: Category,
    msg: &str,
) {
    let Some(logger) = logger else { return };
    let text = CString::new(msg.replace('\0', " ")).unwrap_or_default();
    // SAFETY: the logger comes from the master's callback struct and takes
    // (env, instanceName, status, category, format, ...); every string is NUL-terminated
    // and outlives the call, and "%s" consumes exactly the one vararg passed.
    unsafe {
        logger(
            env,
            name.as_ptr(),
            status,
            CATEGORY_C[cat as usize].as_ptr(),
            c"%s".as_ptr(),
            text.as_ptr(),
        );
    }
}

/// Addresses of live instances and live FMU states, each state with the instance that made
/// it: a pointer not in here is refused instead of dereferenced, and freeing an instance
/// frees the states it still owns. This is the only process-wide data; it holds no model
/// state.
static LIVE: Mutex<BTreeMap<(u8, usize), usize>> = Mutex::new(BTreeMap::new());

/// Kind of a registered pointer.
#[derive(Copy, Clone)]
pub enum Handle {
    /// An `fmi2Component`.
    Instance = 0,
    /// An `fmi2FMUstate`.
    State = 1,
}

fn live() -> std::sync::MutexGuard<'static, BTreeMap<(u8, usize), usize>> {
    LIVE.lock().unwrap_or_else(|p| p.into_inner())
}

/// Records `p` as live, owned by instance `owner` (NULL for an instance).
pub fn register(kind: Handle, p: *mut c_void, owner: *mut c_void) {
    live().insert((kind as u8, p as usize), owner as usize);
}

/// Forgets `p`; false if it was not live.
pub fn unregister(kind: Handle, p: *mut c_void) -> bool {
    live().remove(&(kind as u8, p as usize)).is_some()
}

/// Whether `p` is live.
pub fn is_live(kind: Handle, p: *mut c_void) -> bool {
    !p.is_null() && live().contains_key(&(kind as u8, p as usize))
}

/// Whether `p` is a live state made by instance `owner`.
pub fn is_state_of(p: *mut c_void, owner: *mut c_void) -> bool {
    !p.is_null() && live().get(&(Handle::State as u8, p as usize)) == Some(&(owner as usize))
}

/// Unregisters and returns every state `owner` made and nobody freed.
pub fn take_states_of(owner: *mut c_void) -> Vec<*mut c_void> {
    let mut live = live();
    let mine: Vec<(u8, usize)> = live
        .iter()
        .filter(|&(&(k, _), &o)| k == Handle::State as u8 && o == owner as usize)
        .map(|(&key, _)| key)
        .collect();
    mine.iter()
        .map(|key| {
            live.remove(key);
            key.1 as *mut c_void
        })
        .collect()
}

/// Panics caught inside FMU calls so far, in this process (for tests and fuzzing: each is
/// a bug, even though the importer only sees `fmi2Error`).
pub fn caught_panics() -> usize {
    CAUGHT.load(std::sync::atomic::Ordering::Relaxed)
}

static CAUGHT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// How many FMU states are live, over all instances (for leak tests).
pub fn live_states() -> usize {
    live()
        .keys()
        .filter(|(k, _)| *k == Handle::State as u8)
        .count()
}

thread_local! {
    /// Depth of FMU calls on this thread: a panic inside one is not printed.
    static IN_CALL: Cell<u32> = const { Cell::new(0) };
    /// The message and place of the last panic inside an FMU call, for the logger.
    static LAST_PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Installs, once, a panic hook that keeps panics inside FMU calls off stderr (they reach
/// the master's logger instead) and hands every other panic to the hook it replaced. The
/// hook is process-wide, but in the packaged FMU that is the cdylib's own copy of std, so
/// an importer's panics (a Rust importer has its own std) are not affected.
fn install_quiet_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if IN_CALL.with(Cell::get) > 0 {
                let at = info
                    .location()
                    .map(|l| format!(" at {}:{}", l.file(), l.line()))
                    .unwrap_or_default();
                let text = format!("{}{at}", payload_text(info.payload()));
                LAST_PANIC.with(|p| *p.borrow_mut() = Some(text));
            } else {
                previous(info);
            }
        }));
    });
}

fn payload_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_default()
}

/// Leaves an FMU call even when it unwinds.
struct InCall;

impl InCall {
    fn enter() -> InCall {
        IN_CALL.with(|c| c.set(c.get() + 1));
        InCall
    }
}

impl Drop for InCall {
    fn drop(&mut self) {
        IN_CALL.with(|c| c.set(c.get().saturating_sub(1)));
    }
}

/// Runs `body` with no panic escaping and none printed: a panic becomes `on_panic`.
pub fn guarded<T>(on_panic: T, body: impl FnOnce() -> T) -> T {
    install_quiet_hook();
    let _in = InCall::enter();
    catch_unwind(AssertUnwindSafe(body)).unwrap_or(on_panic)
}

/// Runs `body` on the instance behind `c`: refuses a stale or foreign pointer, and turns a
/// panic into `fmi2Error` with the instance put in the error phase and the panic's message
/// sent to the logger.
pub fn with_instance(
    c: *mut c_void,
    call: &str,
    body: impl FnOnce(&mut Instance) -> Status,
) -> Status {
    if !is_live(Handle::Instance, c) {
        return ERROR; // nothing to log with: the logger lives in the instance
    }
    let p = c.cast::<Instance>();
    install_quiet_hook();
    let _in = InCall::enter();
    let r = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: `c` is live, so it is a `Box<Instance>` from fmi2Instantiate not yet freed;
        // FMI forbids concurrent calls on one instance, so this is the only reference.
        body(unsafe { &mut *p })
    }));
    r.unwrap_or_else(|payload| {
        CAUGHT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let what = LAST_PANIC
            .with(|l| l.borrow_mut().take())
            .unwrap_or_else(|| payload_text(payload.as_ref()));
        guarded(FATAL, || {
            // SAFETY: as above; the panicking borrow has ended.
            let inst = unsafe { &mut *p };
            inst.model.fail();
            inst.log(
                ERROR,
                Category::Error,
                &format!("{call}: internal error ({what}); the instance is now in the error state: reset it or restore an FMU state"),
            );
            ERROR
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resource_uris_become_folders() {
        let f = |u: &str| resources_of_uri(u).map(|p| p.to_string_lossy().into_owned());
        assert_eq!(
            f("file:///tmp/x/resources").as_deref(),
            Some("/tmp/x/resources")
        );
        assert_eq!(f("file:/tmp/x").as_deref(), Some("/tmp/x"));
        assert_eq!(f("file://localhost/tmp/x").as_deref(), Some("/tmp/x"));
        assert_eq!(
            f("file:///tmp/a%20b/r%C3%A9s").as_deref(),
            Some("/tmp/a b/rés")
        );
        assert_eq!(f("http://host/x"), None);
        assert_eq!(f("file://host/x"), None);
        assert_eq!(f("file:///bad%2"), None);
        assert_eq!(f("file:///bad%zz"), None);
        assert_eq!(f("/tmp/x"), None);
    }
}
