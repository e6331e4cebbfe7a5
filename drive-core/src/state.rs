//! The dynamic state of a running drive, saved and restored by value (FMU states).
//!
//! A component writes the values that change while it runs ([`Persist::save`]) and reads
//! them back into a component built from the same parameters ([`Persist::restore`]).
//! Parameters and what is derived from them are never read back: bytes made on purpose
//! cannot set, say, a step size. Every value read is checked (floats finite, codes in
//! range, counts bounded by the bytes left), and a refusal names the field and the rule.
//! The encoding is little-endian and of a size fixed by the parameters (see the
//! `VecDeque` impl), so a state's size does not grow with the steps taken.

use crate::abc::{Abc, Phase};
use crate::bridge::{GateMask, Gates, LegState};
use crate::control::Command;
use crate::time::Ticks;
use std::cell::Cell;
use std::collections::VecDeque;

/// Collects the bytes of a state; the first value that cannot be saved is kept as the
/// error [`Writer::finish`] returns.
#[derive(Default)]
pub struct Writer {
    buf: Vec<u8>,
    err: Option<String>,
}

impl Writer {
    /// An empty state.
    pub fn new() -> Self {
        Writer::default()
    }
    /// Appends one byte.
    pub fn u8(&mut self, x: u8) {
        self.buf.push(x);
    }
    /// Appends a u64.
    pub fn u64(&mut self, x: u64) {
        self.buf.extend_from_slice(&x.to_le_bytes());
    }
    /// Appends a length and the bytes.
    pub fn bytes(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        self.buf.extend_from_slice(b);
    }
    /// Records why the state cannot be saved (the first reason is kept).
    pub fn fail(&mut self, why: impl Into<String>) {
        self.err.get_or_insert_with(|| why.into());
    }
    /// The bytes, or why they could not be written.
    pub fn finish(self) -> Result<Vec<u8>, String> {
        match self.err {
            Some(e) => Err(e),
            None => Ok(self.buf),
        }
    }
}

/// Reads a state's bytes; every read checks the length.
pub struct Reader<'a> {
    b: &'a [u8],
}

impl<'a> Reader<'a> {
    /// Reads `b` from its start.
    pub fn new(b: &'a [u8]) -> Self {
        Reader { b }
    }
    /// The bytes not read yet.
    pub fn rest(&self) -> &'a [u8] {
        self.b
    }
    /// The next `n` bytes.
    pub fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if n > self.b.len() {
            return Err("ends early (rule: the state is complete)".into());
        }
        let (h, t) = self.b.split_at(n);
        self.b = t;
        Ok(h)
    }
    /// One byte.
    pub fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    /// A u64.
    pub fn u64(&mut self) -> Result<u64, String> {
        let mut a = [0u8; 8];
        a.copy_from_slice(self.take(8)?);
        Ok(u64::from_le_bytes(a))
    }
    /// A count of items of at least `each` bytes: never more than the bytes left, which
    /// bounds every allocation by the input's size.
    pub fn len(&mut self, each: usize) -> Result<usize, String> {
        let n = self.u64()?;
        usize::try_from(n)
            .ok()
            .filter(|&n| n.saturating_mul(each.max(1)) <= self.b.len())
            .ok_or_else(|| format!("= {n} items (rule: no more than the bytes left hold)"))
    }
    /// Bytes written by [`Writer::bytes`].
    pub fn bytes(&mut self) -> Result<&'a [u8], String> {
        let n = self.len(1)?;
        self.take(n)
    }
    /// Restores `x` as the field `name`: a refusal names the path to the value.
    pub fn field<T: Persist + ?Sized>(&mut self, name: &str, x: &mut T) -> Result<(), String> {
        x.restore(self).map_err(|e| named(name, &e))
    }
}

/// `name` prefixed to a refusal: "a.b = 3 (rule: …)"; a refusal of the whole rather than
/// a field ("12 bytes left over …": field paths never start with a digit) as "a: …".
pub fn named(name: &str, e: &str) -> String {
    if e.starts_with('=') || e.starts_with(' ') {
        format!("{name} {e}")
    } else if e.starts_with(|c: char| c.is_ascii_digit()) {
        format!("{name}: {e}")
    } else {
        format!("{name}.{e}")
    }
}

/// A component whose dynamic state can be saved and restored by value.
pub trait Persist {
    /// Writes the dynamic state.
    fn save(&self, w: &mut Writer);
    /// Reads it back into a component built from the same parameters, checking every
    /// value; on `Err` the component is in an unspecified state and must be dropped.
    fn restore(&mut self, r: &mut Reader) -> Result<(), String>;

    /// The dynamic state as bytes, or why it cannot be saved.
    fn to_bytes(&self) -> Result<Vec<u8>, String> {
        let mut w = Writer::new();
        self.save(&mut w);
        w.finish()
    }

    /// Restores from `bytes`, all of them: bytes left over were not saved by a component
    /// built like this one.
    fn restore_from(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut r = Reader::new(bytes);
        self.restore(&mut r)?;
        check(r.rest().is_empty(), || {
            format!(
                "{} bytes left over (rule: the state of a component built from the same values)",
                r.rest().len()
            )
        })
    }
}

/// The check of a struct whose restored fields need none together.
pub fn unchecked<T: ?Sized>(_: &T) -> Result<(), String> {
    Ok(())
}

/// Implements [`Persist`] for a struct by the listed fields, in order; with
/// `then check`, `check(&self) -> Result<(), String>` judges the restored values together.
#[macro_export]
macro_rules! persist_fields {
    ($ty:ty { $($f:ident),* $(,)? } then $check:path) => {
        impl $crate::state::Persist for $ty {
            fn save(&self, w: &mut $crate::state::Writer) {
                $( $crate::state::Persist::save(&self.$f, w); )*
            }
            fn restore(
                &mut self,
                r: &mut $crate::state::Reader,
            ) -> ::std::result::Result<(), ::std::string::String> {
                $( r.field(stringify!($f), &mut self.$f)?; )*
                $check(self)
            }
        }
    };
    ($ty:ty { $($f:ident),* $(,)? }) => {
        $crate::persist_fields!($ty { $($f),* } then $crate::state::unchecked);
    };
}

/// Implements [`Persist`] for a field-less enum as the variant's index.
#[macro_export]
macro_rules! persist_enum {
    ($ty:ident { $($v:ident),* $(,)? }) => {
        impl $crate::state::Persist for $ty {
            fn save(&self, w: &mut $crate::state::Writer) {
                const ALL: &[$ty] = &[$($ty::$v),*];
                let k = ALL.iter().position(|v| v == self).unwrap_or(0);
                w.u8(k as u8);
            }
            fn restore(
                &mut self,
                r: &mut $crate::state::Reader,
            ) -> ::std::result::Result<(), ::std::string::String> {
                const ALL: &[$ty] = &[$($ty::$v),*];
                let k = r.u8()?;
                *self = *ALL.get(usize::from(k)).ok_or_else(|| format!(
                    "= {k} (rule: a {} code 0..={})", stringify!($ty), ALL.len() - 1
                ))?;
                Ok(())
            }
        }
    };
}

impl Persist for f64 {
    fn save(&self, w: &mut Writer) {
        if !self.is_finite() {
            w.fail(format!(
                "the drive holds a non-finite value {self} (rule: only a drive whose state is finite can be serialized)"
            ));
        }
        w.u64(self.to_bits());
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        let x = f64::from_bits(r.u64()?);
        if !x.is_finite() {
            return Err(format!("= {x} (rule: finite)"));
        }
        *self = x;
        Ok(())
    }
}

macro_rules! persist_uint {
    ($($t:ty),*) => {$(
        impl Persist for $t {
            fn save(&self, w: &mut Writer) {
                w.u64(*self as u64);
            }
            fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
                let x = r.u64()?;
                *self = <$t>::try_from(x).map_err(|_| {
                    format!("= {x} (rule: at most {})", <$t>::MAX)
                })?;
                Ok(())
            }
        }
    )*};
}
persist_uint!(u64, u32, u16, u8, usize);

impl Persist for bool {
    fn save(&self, w: &mut Writer) {
        w.u8(u8::from(*self));
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        *self = match r.u8()? {
            0 => false,
            1 => true,
            b => return Err(format!("= {b} (rule: a Boolean 0 or 1)")),
        };
        Ok(())
    }
}

impl Persist for Ticks {
    fn save(&self, w: &mut Writer) {
        w.u64(self.0);
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        self.0 = r.u64()?;
        Ok(())
    }
}

impl<T: Persist> Persist for [T] {
    fn save(&self, w: &mut Writer) {
        self.iter().for_each(|x| x.save(w));
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        for (k, x) in self.iter_mut().enumerate() {
            r.field(&format!("[{k}]"), x)?;
        }
        Ok(())
    }
}

impl<T: Persist, const N: usize> Persist for [T; N] {
    fn save(&self, w: &mut Writer) {
        self.as_slice().save(w);
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        self.as_mut_slice().restore(r)
    }
}

/// A tag, then the value, or a default one in its place: the size does not depend on
/// whether there is a value. The place of none holds the default's bytes, as saved.
impl<T: Persist + Default> Persist for Option<T> {
    fn save(&self, w: &mut Writer) {
        match self {
            None => {
                w.u8(0);
                T::default().save(w);
            }
            Some(x) => {
                w.u8(1);
                x.save(w);
            }
        }
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        match r.u8()? {
            0 => {
                restore_default::<T>(r).map_err(|e| format!("= none{e}"))?;
                *self = None;
            }
            1 => self.get_or_insert_with(T::default).restore(r)?,
            b => return Err(format!("= tag {b} (rule: 0 for none, 1 for a value)")),
        }
        Ok(())
    }
}

/// Reads a place saved as `T`'s default (a none's, a deque's or pipeline's padding):
/// refused unless it holds the default's bytes, as saved, naming the first byte that
/// differs.
pub fn restore_default<T: Persist + Default>(r: &mut Reader) -> Result<(), String> {
    let mut w = Writer::new();
    T::default().save(&mut w);
    let held = r.take(w.buf.len())?;
    match w.buf.iter().zip(held).position(|(a, b)| a != b) {
        None => Ok(()),
        Some(k) => Err(format!(
            " with byte {k} of its place {} (rule: a place saved empty holds the default's bytes, here {})",
            held[k], w.buf[k]
        )),
    }
}

impl<T: Persist + Copy + Default> Persist for Cell<T> {
    fn save(&self, w: &mut Writer) {
        self.get().save(w);
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        self.get_mut().restore(r)
    }
}

macro_rules! persist_tuple {
    ($($n:tt $t:ident),*) => {
        impl<$($t: Persist),*> Persist for ($($t,)*) {
            fn save(&self, w: &mut Writer) {
                $( self.$n.save(w); )*
            }
            fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
                $( r.field(concat!(".", stringify!($n)), &mut self.$n)?; )*
                Ok(())
            }
        }
    };
}
persist_tuple!(0 A, 1 B);
persist_tuple!(0 A, 1 B, 2 C);

/// Deques are written padded to this many items, so that their encoding (and a state's
/// size) does not change with how full they are; a fuller one takes more.
pub const DEQUE_SLOTS: usize = 64;

impl<T: Persist + Default> Persist for VecDeque<T> {
    fn save(&self, w: &mut Writer) {
        w.u64(self.len() as u64);
        self.iter().for_each(|x| x.save(w));
        for _ in self.len()..DEQUE_SLOTS {
            T::default().save(w);
        }
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        let n = r.len(1)?;
        self.clear();
        for k in 0..n.max(DEQUE_SLOTS) {
            if k < n {
                let mut x = T::default();
                r.field(&format!("[{k}]"), &mut x)?;
                self.push_back(x);
            } else {
                restore_default::<T>(r).map_err(|e| format!("[{k}] = padding{e}"))?;
            }
        }
        Ok(())
    }
}

impl<T: Persist> Persist for Abc<T> {
    fn save(&self, w: &mut Writer) {
        self.u.save(w);
        self.v.save(w);
        self.w.save(w);
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        r.field("u", &mut self.u)?;
        r.field("v", &mut self.v)?;
        r.field("w", &mut self.w)
    }
}

persist_enum!(Phase { U, V, W });
persist_enum!(LegState { High, Low, Float });
persist_fields!(Gates { high, low });

/// As the [`Gates`] it packs: the layout does not depend on the working form.
impl Persist for GateMask {
    fn save(&self, w: &mut Writer) {
        Gates::from(*self).save(w);
    }
    fn restore(&mut self, r: &mut Reader) -> Result<(), String> {
        let mut g = Gates::OFF;
        g.restore(r)?;
        *self = g.into();
        Ok(())
    }
}
persist_fields!(Command {
    pattern,
    duty,
    watch,
    reads,
    wake_at
});

/// The most a count that only grows (steps, toggles, work done) holds in a restored
/// state: a run within the plant's time rule (1e9 s, 5e16 ticks) counts far fewer at a
/// few a tick, and one may count on 2^62 times from there without overflowing.
pub const COUNT_MAX: u64 = 1 << 62;

/// A count that only grows, restored: at most [`COUNT_MAX`].
pub fn check_count(name: &str, n: u64) -> Result<(), String> {
    check(n <= COUNT_MAX, || {
        format!("{name} = {n} (rule: a count a run reaches, at most 2^62)")
    })
}

/// A check of a restored value against the others: `Err` names it and the rule.
pub fn check(ok: bool, what: impl FnOnce() -> String) -> Result<(), String> {
    if ok { Ok(()) } else { Err(what()) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Default, Debug, PartialEq)]
    struct Demo {
        a: f64,
        b: Option<(u32, bool)>,
        c: VecDeque<Ticks>,
        d: Abc<LegState>,
    }
    persist_fields!(Demo { a, b, c, d });

    fn bytes(x: &Demo) -> Vec<u8> {
        x.to_bytes().unwrap()
    }

    #[test]
    fn values_round_trip_at_a_fixed_size() {
        let mut x = Demo {
            a: 1.5,
            b: Some((7, true)),
            c: [Ticks(3), Ticks(9)].into(),
            d: Abc::splat(LegState::Low),
        };
        let b = bytes(&x);
        let mut y = Demo::default();
        y.restore_from(&b).unwrap();
        assert_eq!(x, y);
        // All the bytes or none: one more is not this component's state.
        let mut longer = b.clone();
        longer.push(0);
        let e = Demo::default().restore_from(&longer).unwrap_err();
        assert!(e.starts_with("1 bytes left over (rule:"), "{e}");
        assert!(named("demo", &e).starts_with("demo: 1 bytes left over"));
        x.c.pop_back();
        assert_eq!(
            bytes(&x).len(),
            b.len(),
            "a deque takes its slots however full"
        );
    }

    #[test]
    fn bad_values_are_refused_naming_the_field() {
        let x = Demo::default();
        let b = bytes(&x);
        let refuse = |edit: &dyn Fn(&mut Vec<u8>)| {
            let mut b = b.clone();
            edit(&mut b);
            Demo::default().restore(&mut Reader::new(&b)).unwrap_err()
        };
        let e = refuse(&|b| b[..8].copy_from_slice(&f64::NAN.to_bits().to_le_bytes()));
        assert!(e.starts_with("a = NaN") && e.contains("rule"), "{e}");
        let e = refuse(&|b| b[8] = 2);
        assert!(e.starts_with("b = tag 2"), "{e}");
        // None holds the default's bytes in its place (the u32's low byte here).
        let e = refuse(&|b| b[9] = 5);
        assert!(
            e.starts_with("b = none with byte 0 of its place 5 (rule: a place saved empty"),
            "{e}"
        );
        // So does a deque's padding.
        let e = refuse(&|b| b[26] = 1);
        assert!(e.starts_with("c.[0] = padding with byte 0"), "{e}");
        let e = refuse(&|b| b[18..26].copy_from_slice(&u64::MAX.to_le_bytes()));
        assert!(e.starts_with("c = "), "{e}");
        let n = b.len();
        let e = refuse(&|b| b[n - 1] = 3);
        assert!(e.starts_with("d.w = 3") && e.contains("LegState"), "{e}");
        let e = refuse(&|b| b.truncate(n - 1));
        assert!(e.contains("ends early"), "{e}");
    }
}
