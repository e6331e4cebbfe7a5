//! Serialized FMU states: the variable values (numbers and strings) the drive was built
//! from, every input change and communication point since (run-length encoded), and the
//! phase and clocks. Deserializing rebuilds the drive and replays the record, which
//! reproduces it bit for bit because the simulation is deterministic; the cost is the
//! simulated time since initialization.
//!
//! Layout: magic (format version) | payload length (u64) | FNV-1a 64 of the payload (u64) |
//! payload. Damaged bytes are refused by the length and the hash before anything in the
//! payload is believed, so no replay starts from them. The hash finds damage, it is not a
//! signature: bytes made on purpose with a matching hash are only checked for consistency.

use crate::drive::{Drive, Event, check_record, portable_texts};
use crate::model::{Model, Phase};
use crate::xml::guid;
use std::path::Path;

// 2: String values (strategy.plugin) follow the numbers.
// 3: length and hash header; communication points run-length encoded.
const MAGIC: &[u8; 8] = b"BLDCFMU3";
const HEADER: usize = 8 + 8 + 8;

/// FNV-1a, 64 bit (offset basis 0xcbf29ce484222325, prime 0x100000001b3). Each byte
/// step is a bijection of the hash, so any change confined to one byte always changes the
/// result; other damage goes unseen with probability about 2^-64.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// An FMU state as handed to the master (`fmi2FMUstate` points to one).
pub struct Snapshot {
    /// The instance as it was.
    pub model: Model,
}

/// The bytes of a state; refused when `strategy.plugin` is an absolute path outside the
/// resources folder (a state never holds an absolute path: [`portable_texts`]).
pub fn serialize(m: &Model) -> Result<Vec<u8>, String> {
    let p = payload(m)?;
    let mut w = Vec::with_capacity(HEADER + p.len());
    w.extend_from_slice(MAGIC);
    put_u64(&mut w, p.len() as u64);
    put_u64(&mut w, fnv1a64(&p));
    w.extend_from_slice(&p);
    Ok(w)
}

fn payload(m: &Model) -> Result<Vec<u8>, String> {
    let resources = m.resources.as_deref();
    let mut w = Vec::new();
    put_bytes(&mut w, guid().as_bytes());
    w.push(phase_code(m.phase));
    put_f64(&mut w, m.start_time);
    put_f64(&mut w, m.stop_time.unwrap_or(f64::NAN));
    put_f64(&mut w, m.time);
    put_f64s(&mut w, &m.values);
    put_texts(&mut w, &portable_texts(&m.texts, resources)?);
    match &m.drive {
        None => w.push(0),
        Some(d) => {
            w.push(1);
            put_f64s(&mut w, &d.built_from);
            put_texts(&mut w, &portable_texts(&d.built_from_texts, resources)?);
            put_u64(&mut w, d.events.len() as u64);
            for e in &d.events {
                match *e {
                    Event::Run {
                        first,
                        stride,
                        count,
                    } => {
                        w.push(0);
                        put_u64(&mut w, first);
                        put_u64(&mut w, stride);
                        put_u64(&mut w, count);
                    }
                    Event::Set(vr, x) => {
                        w.push(1);
                        put_u64(&mut w, u64::from(vr));
                        put_f64(&mut w, x);
                    }
                }
            }
            put_u64(&mut w, d.engine.now().0);
        }
    }
    Ok(w)
}

/// The instance a state's bytes describe, or what is wrong with them. A plugin is loaded
/// again, a relative path inside `resources` (the deserializing instance's folder).
pub fn deserialize(bytes: &[u8], resources: Option<&Path>) -> Result<Model, String> {
    let mut r = Reader { b: bytes };
    let magic = r.take(8).map_err(|_| {
        format!(
            "{} bytes (rule: at least the {HEADER}-byte header)",
            bytes.len()
        )
    })?;
    if magic != MAGIC {
        return Err(format!(
            "bad magic {:?} (rule: a state serialized by this FMU version starts with {:?})",
            String::from_utf8_lossy(magic),
            String::from_utf8_lossy(MAGIC)
        ));
    }
    let len = r.u64().map_err(|_| "truncated header".to_string())?;
    let sum = r.u64().map_err(|_| "truncated header".to_string())?;
    if len != r.b.len() as u64 {
        return Err(format!(
            "payload length {len} in the header, {} bytes given (rule: they agree)",
            r.b.len()
        ));
    }
    if fnv1a64(r.b) != sum {
        return Err(format!(
            "checksum mismatch: header {sum:#018x}, payload {:#018x} (rule: the FNV-1a 64 of the payload; the state is damaged)",
            fnv1a64(r.b)
        ));
    }
    let g = r.bytes()?;
    if g != guid().as_bytes() {
        return Err(format!(
            "state of a different model: GUID {} (rule: must be {})",
            String::from_utf8_lossy(g),
            guid()
        ));
    }
    let phase = phase_of(r.u8()?)?;
    let start_time = r.f64()?;
    let stop = r.f64()?;
    let time = r.f64()?;
    let values = r.f64s()?;
    let texts = r.texts()?;
    let n = crate::variables::table().len();
    if values.len() != n || texts.len() != n {
        return Err("state has the wrong number of variables".into());
    }
    let drive = match r.u8()? {
        0 => None,
        1 => {
            let built_from = r.f64s()?;
            let built_texts = r.texts()?;
            if built_from.len() != n || built_texts.len() != n {
                return Err("state has the wrong number of variables".into());
            }
            // Each event takes at least 13 bytes: the count cannot outgrow the input.
            let n = r.len(13)?;
            let mut events = Vec::with_capacity(n);
            for _ in 0..n {
                events.push(match r.u8()? {
                    0 => Event::Run {
                        first: r.u64()?,
                        stride: r.u64()?,
                        count: r.u64()?,
                    },
                    1 => {
                        let vr = u32::try_from(r.u64()?).map_err(|e| e.to_string())?;
                        Event::Set(vr, r.f64()?)
                    }
                    t => return Err(format!("unknown event tag {t}")),
                });
            }
            let now = r.u64()?;
            check_record(&events, now)?;
            // After a failed step the engine stopped somewhere past the last good point.
            if phase != Phase::Error {
                check_clock(start_time, time, now)?;
            }
            let mut d = Drive::new(&built_from, &built_texts, resources)?;
            d.replay(events, phase == Phase::Error)?;
            if d.engine.now().0 != now {
                return Err(format!(
                    "replay ended at tick {} instead of {now}",
                    d.engine.now().0
                ));
            }
            Some(d)
        }
        t => return Err(format!("unknown drive tag {t}")),
    };
    if !r.b.is_empty() {
        return Err(format!("{} trailing bytes", r.b.len()));
    }
    Ok(Model {
        phase,
        values,
        texts,
        resources: resources.map(Path::to_path_buf),
        start_time,
        stop_time: (!stop.is_nan()).then_some(stop),
        time,
        drive,
    })
}

/// The master's time and the engine's clock must describe the same instant (the engine
/// rounds to whole ticks).
fn check_clock(start: f64, time: f64, now: u64) -> Result<(), String> {
    let engine = bldc_drive::drive_core::Ticks(now).seconds();
    let tol = 0.5 * bldc_drive::drive_core::TICK_S + 1e-12 * time.abs().max(1.0);
    if start.is_finite() && time.is_finite() && (time - start - engine).abs() <= tol {
        Ok(())
    } else {
        Err(format!(
            "time {time} s from start {start} s, but the engine is at {engine} s (rule: they agree within half a tick)"
        ))
    }
}

fn phase_code(p: Phase) -> u8 {
    match p {
        Phase::Instantiated => 0,
        Phase::InitializationMode => 1,
        Phase::StepComplete => 2,
        Phase::Terminated => 3,
        Phase::Error => 4,
    }
}

fn phase_of(c: u8) -> Result<Phase, String> {
    Ok(match c {
        0 => Phase::Instantiated,
        1 => Phase::InitializationMode,
        2 => Phase::StepComplete,
        3 => Phase::Terminated,
        4 => Phase::Error,
        _ => return Err(format!("unknown phase {c}")),
    })
}

fn put_u64(w: &mut Vec<u8>, x: u64) {
    w.extend_from_slice(&x.to_le_bytes());
}

fn put_f64(w: &mut Vec<u8>, x: f64) {
    put_u64(w, x.to_bits());
}

fn put_f64s(w: &mut Vec<u8>, xs: &[f64]) {
    put_u64(w, xs.len() as u64);
    xs.iter().for_each(|&x| put_f64(w, x));
}

fn put_bytes(w: &mut Vec<u8>, b: &[u8]) {
    put_u64(w, b.len() as u64);
    w.extend_from_slice(b);
}

fn put_texts(w: &mut Vec<u8>, ts: &[String]) {
    put_u64(w, ts.len() as u64);
    ts.iter().for_each(|t| put_bytes(w, t.as_bytes()));
}

/// Reads little-endian fields; every read checks the length.
struct Reader<'a> {
    b: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if n > self.b.len() {
            return Err("truncated state".into());
        }
        let (h, t) = self.b.split_at(n);
        self.b = t;
        Ok(h)
    }
    fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    fn u64(&mut self) -> Result<u64, String> {
        let mut a = [0u8; 8];
        a.copy_from_slice(self.take(8)?);
        Ok(u64::from_le_bytes(a))
    }
    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_bits(self.u64()?))
    }
    /// A count of items of at least `each` bytes: it can never exceed the bytes left, which
    /// bounds every allocation by the input's size.
    fn len(&mut self, each: usize) -> Result<usize, String> {
        let n = self.u64()?;
        usize::try_from(n)
            .ok()
            .filter(|&n| n.saturating_mul(each) <= self.b.len())
            .ok_or_else(|| "truncated state".to_string())
    }
    fn f64s(&mut self) -> Result<Vec<f64>, String> {
        let n = self.len(8)?;
        (0..n).map(|_| self.f64()).collect()
    }
    fn bytes(&mut self) -> Result<&'a [u8], String> {
        let n = self.len(1)?;
        self.take(n)
    }
    fn texts(&mut self) -> Result<Vec<String>, String> {
        let n = self.len(8)?;
        (0..n)
            .map(|_| {
                let b = self.bytes()?;
                String::from_utf8(b.to_vec()).map_err(|e| format!("a String value: {e}"))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Access;
    use crate::variables::vr_of;

    fn run(m: &mut Model, to: f64, h: f64) {
        while m.time < to - 1e-12 {
            let t = m.time;
            m.do_step(t, h).unwrap();
        }
    }

    fn outputs(m: &mut Model) -> Vec<f64> {
        let vrs: Vec<u32> = [
            "speed_rpm",
            "theta_e_deg",
            "i_u",
            "i_v",
            "torque_nm",
            "duty",
        ]
        .iter()
        .map(|n| vr_of(n).unwrap())
        .collect();
        let mut o = vec![0.0; vrs.len()];
        m.get(Access::Real, &vrs, &mut o).unwrap();
        o
    }

    #[test]
    fn a_serialized_state_names_its_plugin_relative_to_the_resources() {
        let p = vr_of("strategy.plugin").unwrap();
        let mut m = Model::new();
        m.resources = Some(std::path::PathBuf::from("/unpacked/here/resources"));
        m.enter_initialization().unwrap();
        m.set_text(p, "/unpacked/here/resources/sub/p.so").unwrap();
        let bytes = serialize(&m).unwrap();
        let has = |needle: &[u8]| bytes.windows(needle.len()).any(|w| w == needle);
        assert!(!has(b"/unpacked"), "no absolute path in the bytes");
        assert!(has(b"sub/p.so"));
        // Restored elsewhere, the name resolves in that instance's resources.
        let copy = deserialize(&bytes, Some(Path::new("/elsewhere/resources"))).unwrap();
        assert_eq!(copy.texts[p as usize], "sub/p.so");
        // A relative name is kept as set.
        m.set_text(p, "p.so").unwrap();
        let copy = deserialize(&serialize(&m).unwrap(), None).unwrap();
        assert_eq!(copy.texts[p as usize], "p.so");
        // An absolute path outside the resources cannot be written relatively: refused.
        for (outside, resources) in [("/opt/p.so", m.resources.clone()), ("/opt/p.so", None)] {
            m.resources = resources;
            m.set_text(p, outside).unwrap();
            let e = serialize(&m).unwrap_err();
            assert!(e.contains("`/opt/p.so`") && e.contains("rule"), "{e}");
        }
    }

    #[test]
    fn a_deserialized_state_continues_bit_identically() {
        let mut m = Model::new();
        m.enter_initialization().unwrap();
        m.exit_initialization().unwrap();
        run(&mut m, 0.02, 1e-3);
        m.set(Access::Real, vr_of("load_torque_nm").unwrap(), 1e-4)
            .unwrap();
        m.set(Access::Real, vr_of("speed_ref_rpm").unwrap(), 2500.0)
            .unwrap();
        // Past the alignment (it ends at 0.75 s): the state is taken while the drive
        // commutates closed loop, with a communication step off the 1 ms grid.
        run(&mut m, 0.9, 0.7e-3);
        assert!(outputs(&mut m)[0] > 1000.0, "running at the save point");
        let bytes = serialize(&m).unwrap();
        let mut copy = deserialize(&bytes, None).unwrap();
        assert_eq!(serialize(&copy).unwrap(), bytes);
        run(&mut m, 1.0, 1e-3);
        run(&mut copy, 1.0, 1e-3);
        assert_eq!(outputs(&mut m), outputs(&mut copy));
        assert_ne!(outputs(&mut m)[5], 0.0);
    }

    #[test]
    fn damaged_bytes_are_refused() {
        let m = Model::new();
        let bytes = serialize(&m).unwrap();
        assert!(deserialize(&bytes, None).is_ok());
        assert!(deserialize(&bytes[..bytes.len() - 1], None).is_err());
        assert!(deserialize(b"nonsense", None).is_err());
        assert!(deserialize(b"", None).is_err());
        let mut old = bytes.clone();
        old[7] = b'2'; // a state of the previous format, without length and hash
        let Err(e) = deserialize(&old, None) else {
            panic!("an old-format state was accepted")
        };
        assert!(e.contains("bad magic") && e.contains("BLDCFMU3"), "{e}");
    }

    /// The header's hash recomputed after the payload was edited, as bytes made on purpose
    /// would be.
    fn reseal(bytes: &mut [u8]) {
        let sum = fnv1a64(&bytes[HEADER..]);
        bytes[16..24].copy_from_slice(&sum.to_le_bytes());
    }

    fn running(to: f64) -> Model {
        let mut m = Model::new();
        m.enter_initialization().unwrap();
        m.exit_initialization().unwrap();
        run(&mut m, to, 1e-3);
        m
    }

    #[test]
    fn every_bit_flip_is_refused_by_the_header_before_any_replay() {
        // A state 0.3 s into a run: replaying it takes far longer than checking a hash, so
        // a thousand refusals in well under the time of a few replays show none started.
        let m = running(0.3);
        let bytes = serialize(&m).unwrap();
        let t = std::time::Instant::now();
        deserialize(&bytes, None).unwrap();
        let one_replay = t.elapsed();
        let t = std::time::Instant::now();
        let mut flips = 0u32;
        for bit in (0..bytes.len() * 8).step_by(7) {
            let mut b = bytes.clone();
            b[bit / 8] ^= 1 << (bit % 8);
            let Err(e) = deserialize(&b, None) else {
                panic!("bit {bit} flipped was accepted")
            };
            assert!(
                e.contains("checksum") || e.contains("magic") || e.contains("length"),
                "bit {bit}: {e}"
            );
            flips += 1;
        }
        assert!(flips > 1000, "{flips}");
        // Checking a hash over a few kilobytes against rebuilding and running the drive.
        let each = t.elapsed() / flips;
        assert!(
            each * 20 < one_replay,
            "a refusal took {each:?} on average, one replay {one_replay:?}"
        );
    }

    #[test]
    fn the_size_does_not_grow_with_the_steps_taken() {
        let mut m = running(0.01);
        let early = serialize(&m).unwrap().len();
        run(&mut m, 0.2, 1e-3);
        assert_eq!(
            serialize(&m).unwrap().len(),
            early,
            "190 more steps of the same size"
        );
        // An input change and a different step size add one record each, not one per step.
        m.set(Access::Real, vr_of("speed_ref_rpm").unwrap(), 2000.0)
            .unwrap();
        run(&mut m, 0.25, 0.5e-3);
        let later = serialize(&m).unwrap().len();
        run(&mut m, 0.4, 0.5e-3);
        assert_eq!(serialize(&m).unwrap().len(), later);
        assert!(later - early < 100, "{early} -> {later}");
        let copy = deserialize(&serialize(&m).unwrap(), None).unwrap();
        assert_eq!(serialize(&copy).unwrap(), serialize(&m).unwrap());
    }

    #[test]
    fn a_resealed_record_that_disagrees_with_itself_is_refused_before_replay() {
        let m = running(0.05);
        let bytes = serialize(&m).unwrap();
        let n = bytes.len();
        // The payload ends with: the last run (first, stride, count) and the engine's tick.
        let field = |k: usize| n - 8 * k..n - 8 * (k - 1);
        let get = |k: usize| u64::from_le_bytes(bytes[field(k)].try_into().unwrap());
        let edit = |k: usize, x: u64| {
            let mut b = bytes.clone();
            b[field(k)].copy_from_slice(&x.to_le_bytes());
            reseal(&mut b);
            b
        };
        let (stride, count, now) = (get(3), get(2), get(1));
        assert!(
            stride > 0 && count > 1 && now > 0,
            "one run of {count} steps"
        );
        for (what, b) in [
            ("a run past the engine's tick", edit(2, count + 1)),
            ("a run of zero communication points", edit(2, 0)),
            ("a run overflowing the tick counter", edit(3, u64::MAX)),
            ("an engine tick beyond the record", edit(1, now + 1)),
            ("an engine tick far from the record", edit(1, u64::MAX)),
            ("a master time far from the engine's", {
                // time: after the GUID, the phase byte, start and stop.
                let at = HEADER + 8 + guid().len() + 1 + 16;
                let mut b = bytes.clone();
                b[at..at + 8].copy_from_slice(&1e6f64.to_bits().to_le_bytes());
                reseal(&mut b);
                b
            }),
        ] {
            let t = std::time::Instant::now();
            let Err(e) = deserialize(&b, None) else {
                panic!("{what} was accepted")
            };
            assert!(e.contains("rule"), "{what}: {e}");
            assert!(
                t.elapsed().as_secs_f64() < 0.05,
                "{what}: {:?}",
                t.elapsed()
            );
        }
    }

    #[test]
    fn a_long_run_of_zero_stride_replays_in_one_call() {
        // Steps shorter than half a tick leave the engine where it is; however many are
        // recorded, replaying them is one call.
        let mut m = running(0.0);
        let mut d = m.drive.take().unwrap();
        d.events = vec![Event::Run {
            first: 0,
            stride: 0,
            count: u64::MAX,
        }];
        d.replay(d.events.clone(), false).unwrap();
        m.drive = Some(d);
        let bytes = serialize(&m).unwrap();
        let t = std::time::Instant::now();
        let copy = deserialize(&bytes, None).unwrap();
        assert!(t.elapsed().as_secs_f64() < 0.05, "{:?}", t.elapsed());
        assert_eq!(serialize(&copy).unwrap(), bytes);
    }

    #[test]
    fn the_hash_is_fnv1a_64() {
        // Published test vectors of FNV-1a 64.
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }
}
