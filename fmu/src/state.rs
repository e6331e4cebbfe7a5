//! Serialized FMU states: the phase and clocks, the variable values (numbers and strings),
//! and, once the drive is built, the values it was built from and its dynamic state by
//! value (see [`bldc_drive::drive_core::state`]). Deserializing builds the drive from
//! those values, as initialization does, and overwrites only its dynamic state: no
//! parameter or derived value is read from the bytes, nothing is replayed, and the cost
//! and the size do not depend on the steps taken. The continuation is bit-identical.
//!
//! Layout: magic (format version) | payload length (u64) | FNV-1a 64 of the payload (u64) |
//! payload. Damaged bytes are refused by the length and the hash before anything in the
//! payload is believed, in time linear in their length. The hash finds damage, it is not a
//! signature: bytes made on purpose with a matching hash are checked value by value.

use crate::drive::{Drive, portable_texts};
use crate::model::{Model, Phase, check_held};
use crate::variables::{Role, table};
use crate::xml::guid;
use bldc_drive::drive_core::state::{Persist, Reader, Writer, named};
use std::path::Path;

// 2: String values (strategy.plugin) follow the numbers.
// 3: length and hash header; communication points run-length encoded.
// 4: the drive's dynamic state by value instead of a record to replay.
// 5: the plant's start solution may hold its losses unmade (copper −0.0); the comparator
//    records hold the ringing envelope at the step's first tick, not at its start.
// 6: the comparator records keep their filters' responses without the time constants
//    (the parameters') and a floating leg's bend as its cubic and transient alone.
// 7: the current sense's pipeline at its size fixed by the parameters (not padded to
//    64 and grown past it); values held are checked as when set (a speed command is
//    held clamped).
const MAGIC: &[u8; 8] = b"BLDCFMU7";
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
    w.extend_from_slice(&(p.len() as u64).to_le_bytes());
    w.extend_from_slice(&fnv1a64(&p).to_le_bytes());
    w.extend_from_slice(&p);
    Ok(w)
}

fn payload(m: &Model) -> Result<Vec<u8>, String> {
    let resources = m.resources.as_deref();
    let mut w = Writer::new();
    w.bytes(guid().as_bytes());
    w.u8(phase_code(m.phase));
    put_f64(&mut w, m.start_time);
    put_f64(&mut w, m.stop_time.unwrap_or(f64::NAN));
    put_f64(&mut w, m.time);
    put_f64s(&mut w, &m.values);
    put_texts(&mut w, &portable_texts(&m.texts, resources)?);
    match &m.drive {
        None => w.u8(0),
        Some(d) => {
            w.u8(1);
            put_f64s(&mut w, &d.built_from);
            put_texts(&mut w, &portable_texts(&d.built_from_texts, resources)?);
            w.bytes(&d.to_bytes()?);
        }
    }
    w.finish()
}

/// The instance a state's bytes describe, or what is wrong with them. A plugin is loaded
/// again, a relative path inside `resources` (the deserializing instance's folder).
pub fn deserialize(bytes: &[u8], resources: Option<&Path>) -> Result<Model, String> {
    let mut r = Reader::new(bytes);
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
    if len != r.rest().len() as u64 {
        return Err(format!(
            "payload length {len} in the header, {} bytes given (rule: they agree)",
            r.rest().len()
        ));
    }
    if fnv1a64(r.rest()) != sum {
        return Err(format!(
            "checksum mismatch: header {sum:#018x}, payload {:#018x} (rule: the FNV-1a 64 of the payload; the state is damaged)",
            fnv1a64(r.rest())
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
    let start_time = f64_of(&mut r)?;
    let stop = f64_of(&mut r)?;
    let time = f64_of(&mut r)?;
    let values = f64s_of(&mut r)?;
    let texts = texts_of(&mut r)?;
    let n = crate::variables::table().len();
    if values.len() != n || texts.len() != n {
        return Err("state has the wrong number of variables".into());
    }
    check_values("values", &values, &texts)?;
    check_times(start_time, stop, time)?;
    let drive = match r.u8()? {
        0 => None,
        1 => {
            let built_from = f64s_of(&mut r)?;
            let built_texts = texts_of(&mut r)?;
            if built_from.len() != n || built_texts.len() != n {
                return Err("state has the wrong number of variables".into());
            }
            check_values("built_from", &built_from, &built_texts)?;
            check_built_from(&values, &texts, &built_from, &built_texts)?;
            let dynamic = r.bytes()?;
            let mut d = Drive::new(&built_from, &built_texts, resources)?;
            d.restore_from(dynamic)
                .map_err(|e| format!("drive state: {}", named("drive", &e)))?;
            check_applied(&values, &d)?;
            // The outputs are not stored: they are computed from the restored dynamic
            // state, by the rule a step's end is held to (every output finite).
            if let Some((name, x)) = d.non_finite_output() {
                return Err(format!(
                    "the restored drive gives output `{name}` = {x} (rule: every output finite, as at the end of a step)"
                ));
            }
            // After a failed step the engine stopped somewhere past the last good point.
            if phase != Phase::Error {
                check_clock(start_time, time, d.engine.now().0)?;
            }
            Some(d)
        }
        t => return Err(format!("unknown drive tag {t}")),
    };
    if drive.is_none() {
        check_unbuilt(phase, start_time, time)?;
    } else if matches!(phase, Phase::Instantiated | Phase::InitializationMode) && time != start_time
    {
        // A drive built early (to answer output queries) has taken no step either.
        return Err(format!(
            "time = {time} in phase {phase:?} (rule: no step is taken before initialization ends: the start time {start_time})"
        ));
    }
    if !r.rest().is_empty() {
        return Err(format!("{} trailing bytes", r.rest().len()));
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

/// Every value held passes the rule it passed when it was set ([`check_held`]); String
/// slots of variables that are not Strings are empty.
fn check_values(what: &str, values: &[f64], texts: &[String]) -> Result<(), String> {
    for ((v, &x), t) in table().iter().zip(values).zip(texts) {
        check_held(v, x).map_err(|e| format!("{what}: {e}"))?;
        if !matches!(v.role, Role::Text(_)) && !t.is_empty() {
            return Err(format!(
                "{what}: `{}` holds the text `{t}` (rule: only a String variable holds one)",
                v.name
            ));
        }
    }
    Ok(())
}

/// The start, stop and present times: finite, the stop (NaN for none) not before the
/// start, the present not before the start.
fn check_times(start: f64, stop: f64, time: f64) -> Result<(), String> {
    if !start.is_finite() {
        return Err(format!("start time = {start} (rule: must be finite)"));
    }
    if !(stop.is_nan() || (stop.is_finite() && stop >= start)) {
        return Err(format!(
            "stop time = {stop} (rule: none, or finite and >= the start time {start})"
        ));
    }
    // No step ends past the stop time (fmi2DoStep's rule, with its half-tick tolerance).
    let tol = 0.5 * bldc_drive::drive_core::TICK_S;
    if !(time.is_finite() && time >= start && (stop.is_nan() || time <= stop + tol)) {
        return Err(format!(
            "time = {time} (rule: finite, from the start time {start} to the stop time {stop})"
        ));
    }
    Ok(())
}

/// Without a drive no step has been taken: the phase is one before initialization ends
/// (or the error state), and the time is the start time.
fn check_unbuilt(phase: Phase, start: f64, time: f64) -> Result<(), String> {
    if matches!(phase, Phase::StepComplete | Phase::Terminated) {
        return Err(format!(
            "phase {phase:?} without a drive (rule: the drive is built at fmi2ExitInitializationMode)"
        ));
    }
    if time != start {
        return Err(format!(
            "time = {time} without a drive (rule: no step taken, the start time {start})"
        ));
    }
    Ok(())
}

/// The drive was built from the parameters the variables hold: they are fixed once it is
/// (setting one before initialization ends drops the drive), and so are the Strings.
fn check_built_from(
    values: &[f64],
    texts: &[String],
    built_from: &[f64],
    built_texts: &[String],
) -> Result<(), String> {
    for (k, v) in table().iter().enumerate() {
        let same = match v.role {
            Role::Parameter { .. } => values[k] == built_from[k],
            Role::Text(_) => texts[k] == built_texts[k],
            _ => true,
        };
        if !same {
            return Err(format!(
                "built_from: `{}` = {}, but the variable holds {} (rule: the drive is built from the parameters held, fixed once it is)",
                v.name, built_from[k], values[k]
            ));
        }
    }
    Ok(())
}

/// The inputs in force in the drive are the values the variables hold (each set is
/// applied at once after initialization, and drops the drive before).
fn check_applied(values: &[f64], d: &Drive) -> Result<(), String> {
    for (k, v) in table().iter().enumerate() {
        if let Role::Input(i) = v.role
            && d.applied(i) != values[k]
        {
            return Err(format!(
                "drive.applied `{}` = {}, but the variable holds {} (rule: the input in force is the value set)",
                v.name,
                d.applied(i),
                values[k]
            ));
        }
    }
    Ok(())
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

/// Any f64, NaN too (an absent stop time): unlike [`Persist`]'s, which refuses one.
fn put_f64(w: &mut Writer, x: f64) {
    w.u64(x.to_bits());
}

fn put_f64s(w: &mut Writer, xs: &[f64]) {
    w.u64(xs.len() as u64);
    xs.iter().for_each(|&x| put_f64(w, x));
}

fn put_texts(w: &mut Writer, ts: &[String]) {
    w.u64(ts.len() as u64);
    ts.iter().for_each(|t| w.bytes(t.as_bytes()));
}

fn f64_of(r: &mut Reader) -> Result<f64, String> {
    Ok(f64::from_bits(r.u64()?))
}

fn f64s_of(r: &mut Reader) -> Result<Vec<f64>, String> {
    let n = r.len(8)?;
    (0..n).map(|_| f64_of(r)).collect()
}

fn texts_of(r: &mut Reader) -> Result<Vec<String>, String> {
    let n = r.len(8)?;
    (0..n)
        .map(|_| {
            let b = r.bytes()?;
            String::from_utf8(b.to_vec()).map_err(|e| format!("a String value: {e}"))
        })
        .collect()
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
        old[7] = b'6'; // a state of the previous format (BLDCFMU6)
        let Err(e) = deserialize(&old, None) else {
            panic!("an old-format state was accepted")
        };
        assert!(e.contains("bad magic") && e.contains("BLDCFMU7"), "{e}");
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
    fn every_bit_flip_and_truncation_is_refused_by_the_header() {
        let m = running(0.3);
        let bytes = serialize(&m).unwrap();
        deserialize(&bytes, None).unwrap();
        // Every refusal must name the header's check. Were the values read before the hash
        // is checked, a flip that makes one invalid (a NaN, a code out of range) would name
        // that value's rule instead: this pins that nothing is read or built first. (Not
        // timed: a ratio of two timings fails on a loaded machine.)
        for bit in 0..bytes.len() * 8 {
            let mut b = bytes.clone();
            b[bit / 8] ^= 1 << (bit % 8);
            let Err(e) = deserialize(&b, None) else {
                panic!("bit {bit} flipped was accepted")
            };
            assert!(
                e.contains("checksum") || e.contains("magic") || e.contains("length"),
                "bit {bit}: {e}"
            );
        }
        for n in 0..bytes.len() {
            let Err(e) = deserialize(&bytes[..n], None) else {
                panic!("{n} bytes of {} were accepted", bytes.len())
            };
            assert!(
                e.contains("header") || e.contains("magic") || e.contains("length"),
                "{n} bytes: {e}"
            );
        }
    }

    /// `m` run on by `n` steps cycling through sizes off the 1 ms grid.
    fn steps(m: &mut Model, n: usize) {
        for k in 0..n {
            let t = m.time;
            m.do_step(t, [1e-4, 0.7e-4, 1.3e-4, 0.25e-4][k % 4])
                .unwrap();
        }
    }

    #[test]
    fn the_size_and_the_restore_time_do_not_grow_with_the_steps_taken() {
        let mut m = running(0.0);
        steps(&mut m, 10);
        let short = serialize(&m).unwrap();
        let long = {
            let mut m = running(0.0);
            m.set(Access::Real, vr_of("speed_ref_rpm").unwrap(), 2000.0)
                .unwrap();
            steps(&mut m, 10_000);
            m.set(Access::Real, vr_of("load_torque_nm").unwrap(), 1e-4)
                .unwrap();
            steps(&mut m, 10);
            assert!(m.time > 0.8, "past the start-up");
            serialize(&m).unwrap()
        };
        assert_eq!(short.len(), long.len(), "10 steps and 10 020");
        // Restoring either builds the drive and reads the same number of values.
        let time = |b: &[u8]| {
            (0..5)
                .map(|_| {
                    let t = std::time::Instant::now();
                    deserialize(b, None).unwrap();
                    t.elapsed()
                })
                .min()
                .unwrap()
        };
        let (a, b) = (time(&short), time(&long));
        assert!(b < a * 5 && a < b * 5, "short run {a:?}, long run {b:?}");
    }

    #[test]
    fn resealed_states_with_bad_dynamic_values_are_refused_naming_them() {
        let m = running(0.9);
        let bytes = serialize(&m).unwrap();
        // The drive's dynamic state ends the payload: its engine clock first, then (after
        // the engine's own fields) the plant's state vector (16 floats) and time.
        let d = m.drive.as_ref().unwrap();
        let base = bytes.len() - d.to_bytes().unwrap().len();
        let first = |pat: [u8; 8], from: usize| {
            (from..bytes.len() - 8)
                .find(|&i| bytes[i..i + 8] == pat)
                .unwrap()
        };
        let now = d.engine.now();
        let now_at = first(now.0.to_le_bytes(), base);
        let t_at = first(now.seconds().to_bits().to_le_bytes(), now_at);
        let speed_at = t_at - 16 * 8 + 3 * 8;
        let edit = |at: usize, x: &[u8]| {
            let mut b = bytes.clone();
            b[at..at + x.len()].copy_from_slice(x);
            reseal(&mut b);
            b
        };
        for (what, b, says) in [
            (
                "a speed that is not a number",
                edit(speed_at, &f64::NAN.to_bits().to_le_bytes()),
                "plant.x.[3] = NaN",
            ),
            (
                "an infinite speed",
                edit(speed_at, &f64::INFINITY.to_bits().to_le_bytes()),
                "plant.x.[3] = inf",
            ),
            (
                "an engine far ahead of the master",
                edit(now_at, &(now.0 * 2).to_le_bytes()),
                "rule",
            ),
            (
                "a master time far from the engine's",
                {
                    // time: after the GUID, the phase byte, start and stop.
                    let at = HEADER + 8 + guid().len() + 1 + 16;
                    edit(at, &1e6f64.to_bits().to_le_bytes())
                },
                "rule: they agree",
            ),
        ] {
            let t = std::time::Instant::now();
            let Err(e) = deserialize(&b, None) else {
                panic!("{what} was accepted")
            };
            assert!(e.contains(says) && e.contains("rule"), "{what}: {e}");
            assert!(
                t.elapsed().as_secs_f64() < 0.05,
                "{what}: {:?}",
                t.elapsed()
            );
        }
    }

    #[test]
    fn the_hash_is_fnv1a_64() {
        // Published test vectors of FNV-1a 64.
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }
}
