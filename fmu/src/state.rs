//! Serialized FMU states: the variable values (numbers and strings) the drive was built
//! from, every input change and communication point since, and the phase and clocks. Deserializing rebuilds the
//! drive and replays the record, which reproduces it bit for bit because the simulation is
//! deterministic; the cost is the simulated time since initialization.

use crate::drive::{Drive, Event};
use crate::model::{Model, Phase};
use crate::xml::guid;
use std::path::Path;

// 2: String values (strategy.plugin) follow the numbers.
const MAGIC: &[u8; 8] = b"BLDCFMU2";

/// An FMU state as handed to the master (`fmi2FMUstate` points to one).
pub struct Snapshot {
    /// The instance as it was.
    pub model: Model,
}

/// The bytes of a state.
pub fn serialize(m: &Model) -> Vec<u8> {
    let mut w = Vec::new();
    w.extend_from_slice(MAGIC);
    put_bytes(&mut w, guid().as_bytes());
    w.push(phase_code(m.phase));
    put_f64(&mut w, m.start_time);
    put_f64(&mut w, m.stop_time.unwrap_or(f64::NAN));
    put_f64(&mut w, m.time);
    put_f64s(&mut w, &m.values);
    put_texts(&mut w, &m.texts);
    match &m.drive {
        None => w.push(0),
        Some(d) => {
            w.push(1);
            put_f64s(&mut w, &d.built_from);
            put_texts(&mut w, &d.built_from_texts);
            put_u64(&mut w, d.events.len() as u64);
            for e in &d.events {
                match *e {
                    Event::RunTo(t) => {
                        w.push(0);
                        put_u64(&mut w, t);
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
    w
}

/// The instance a state's bytes describe, or what is wrong with them. A plugin is loaded
/// again, a relative path inside `resources` (the deserializing instance's folder).
pub fn deserialize(bytes: &[u8], resources: Option<&Path>) -> Result<Model, String> {
    let mut r = Reader { b: bytes };
    let magic = r.take(8)?;
    if magic != MAGIC {
        return Err(format!(
            "bad magic {:?} (rule: a state serialized by this FMU version starts with {:?})",
            String::from_utf8_lossy(magic),
            String::from_utf8_lossy(MAGIC)
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
            let mut d = Drive::new(&built_from, &built_texts, resources)?;
            let n = r.u64()?;
            for _ in 0..n {
                let e = match r.u8()? {
                    0 => Event::RunTo(r.u64()?),
                    1 => {
                        let vr = u32::try_from(r.u64()?).map_err(|e| e.to_string())?;
                        Event::Set(vr, r.f64()?)
                    }
                    t => return Err(format!("unknown event tag {t}")),
                };
                d.replay(e)?;
            }
            let now = r.u64()?;
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
    fn len(&mut self) -> Result<usize, String> {
        let n = self.u64()?;
        // A length can never exceed the bytes left; this also bounds allocations.
        usize::try_from(n)
            .ok()
            .filter(|&n| n <= self.b.len())
            .ok_or_else(|| "truncated state".to_string())
    }
    fn f64s(&mut self) -> Result<Vec<f64>, String> {
        let n = self.len()?;
        (0..n).map(|_| self.f64()).collect()
    }
    fn bytes(&mut self) -> Result<&'a [u8], String> {
        let n = self.len()?;
        self.take(n)
    }
    fn texts(&mut self) -> Result<Vec<String>, String> {
        let n = self.len()?;
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
        let bytes = serialize(&m);
        let mut copy = deserialize(&bytes, None).unwrap();
        assert_eq!(serialize(&copy), bytes);
        run(&mut m, 1.0, 1e-3);
        run(&mut copy, 1.0, 1e-3);
        assert_eq!(outputs(&mut m), outputs(&mut copy));
        assert_ne!(outputs(&mut m)[5], 0.0);
    }

    #[test]
    fn damaged_bytes_are_refused() {
        let m = Model::new();
        let bytes = serialize(&m);
        assert!(deserialize(&bytes, None).is_ok());
        assert!(deserialize(&bytes[..bytes.len() - 1], None).is_err());
        assert!(deserialize(b"nonsense", None).is_err());
        let mut other = bytes.clone();
        other[20] ^= 1; // inside the GUID
        assert!(deserialize(&other, None).is_err());
        let mut old = bytes.clone();
        old[7] = b'1'; // a state of the previous format, without String values
        let Err(e) = deserialize(&old, None) else {
            panic!("an old-format state was accepted")
        };
        assert!(e.contains("bad magic") && e.contains("BLDCFMU2"), "{e}");
    }
}
