//! Test fixture for the host's plugin checks. The environment variable
//! `BLDC_TEST_MISBEHAVE` chooses the fault, read when the entry symbol is called (header
//! faults) or when an instance is created (call faults):
//! `magic` (wrong magic), `major` (ABI major + 1), `null-header`, `panic` (step panics),
//! `shoot-through` (step commands both switches of leg u on), `create-error`,
//! `save-panic` and `restore-panic` (those calls panic), `save-huge` (save asks for more
//! than the host accepts), `minor-0` (an ABI 1.0 plugin: no save or restore),
//! `plan-panic` (planned_change panics), `plan-garbage` (it plans legs no bridge takes, at
//! the end of time), `plan-past` (it plans a change at tick 0, long past),
//! `vtable-mid-pointer` (a table size that ends inside a function pointer); anything
//! else: a well-behaved strategy that keeps the bridge off and saves its state.

use strategy_abi::{
    ABI_MAJOR, ABI_MINOR, CCommand, CSensed, CStatus, CTable, DriveInfo, Header, Inputs, LEG_HIGH,
    LEG_LOW, MAGIC, Plugin, VTABLE_1_0, VTable, vtable_of,
};

fn mode() -> String {
    std::env::var("BLDC_TEST_MISBEHAVE").unwrap_or_default()
}

/// The text every panic this fixture means to raise begins with.
const DELIBERATE: &str = "deliberate panic";

/// Keeps the fixture's deliberate panics off stderr (the host reports each as an error,
/// and the tests check that), handing every other panic to the hook it replaces. The
/// hook is this cdylib's own std's: the host's panics, and those of any other test, are
/// not affected.
fn quiet_deliberate_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let p = info.payload();
            let text = p
                .downcast_ref::<&str>()
                .copied()
                .or_else(|| p.downcast_ref::<String>().map(String::as_str));
            if !text.is_some_and(|t| t.starts_with(DELIBERATE)) {
                previous(info);
            }
        }));
    });
}

#[derive(Clone)]
struct Misbehaving {
    mode: String,
}

impl Plugin for Misbehaving {
    fn create(_config: &str, _info: &DriveInfo) -> Result<Self, String> {
        quiet_deliberate_panics();
        let mode = mode();
        if mode == "create-error" {
            return Err("create-error requested by BLDC_TEST_MISBEHAVE".into());
        }
        Ok(Misbehaving { mode })
    }
    fn clock(&self) -> u64 {
        32
    }
    fn table(&self) -> CTable {
        CTable {
            kind: 1,
            conduction_deg: 150.0,
        }
    }
    fn set_inputs(&mut self, _inputs: &Inputs) {}
    fn step(&mut self, now: u64, _sensed: &CSensed) -> Result<(CCommand, CStatus), String> {
        let mut c = CCommand {
            wake_at: now + 32_000,
            ..CCommand::default()
        };
        if now >= 64_000 {
            match self.mode.as_str() {
                "panic" => panic!("{DELIBERATE} at tick {now}"),
                "shoot-through" => c.legs = [LEG_HIGH | LEG_LOW, LEG_LOW, 0],
                _ => {}
            }
        }
        Ok((c, CStatus::default()))
    }
    fn save(&self) -> Result<Vec<u8>, String> {
        match self.mode.as_str() {
            "save-panic" => panic!("{DELIBERATE} in save"),
            "save-huge" => Ok(vec![0; strategy_abi::MAX_STATE_BYTES + 1]),
            _ => Ok(b"ok".to_vec()),
        }
    }
    fn planned_change(&self) -> Option<(u64, [u8; 3])> {
        match self.mode.as_str() {
            "plan-panic" => panic!("{DELIBERATE} in planned_change"),
            "plan-garbage" => Some((u64::MAX - 1, [LEG_HIGH | LEG_LOW, 7, 0])),
            "plan-past" => Some((0, [LEG_HIGH, LEG_LOW, 0])),
            _ => None,
        }
    }
    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        match self.mode.as_str() {
            "restore-panic" => panic!("{DELIBERATE} in restore"),
            _ if state == b"ok" => Ok(()),
            _ => Err(format!(
                "{} bytes that are not a state of this plugin",
                state.len()
            )),
        }
    }
}

struct Headers {
    good: Header,
    magic: Header,
    major: Header,
    minor_0: Header,
    mid_pointer: Header,
}

const fn header(magic: [u8; 8], major: u32) -> Header {
    Header {
        magic,
        abi_major: major,
        abi_minor: ABI_MINOR,
        name: c"misbehaving".as_ptr(),
        description: c"test fixture".as_ptr(),
        vtable_size: size_of::<VTable>() as u32,
        vtable: vtable_of::<Misbehaving>(),
    }
}

/// As a plugin built against ABI 1.0 states itself: its table ends before `save`.
const fn header_1_0() -> Header {
    let mut h = header(MAGIC, ABI_MAJOR);
    h.abi_minor = 0;
    h.vtable_size = VTABLE_1_0 as u32;
    h
}

/// A table size that ends inside a function pointer (`save`'s first half).
const fn header_mid_pointer() -> Header {
    let mut h = header(MAGIC, ABI_MAJOR);
    h.vtable_size = (VTABLE_1_0 + 4) as u32;
    h
}

static HEADERS: Headers = Headers {
    good: header(MAGIC, ABI_MAJOR),
    magic: header(*b"NOTBLDC!", ABI_MAJOR),
    major: header(MAGIC, ABI_MAJOR + 1),
    minor_0: header_1_0(),
    mid_pointer: header_mid_pointer(),
};

/// The entry symbol, answering according to `BLDC_TEST_MISBEHAVE`.
#[unsafe(no_mangle)]
pub extern "C" fn bldc_strategy_entry() -> *const Header {
    match mode().as_str() {
        "magic" => &HEADERS.magic,
        "major" => &HEADERS.major,
        "null-header" => std::ptr::null(),
        "minor-0" => &HEADERS.minor_0,
        "vtable-mid-pointer" => &HEADERS.mid_pointer,
        _ => &HEADERS.good,
    }
}
