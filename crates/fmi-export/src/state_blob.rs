//! The serialized FMU state: a frame around the model's bytes that makes a corrupt,
//! truncated or foreign blob recognisable before any of it is trusted.
//!
//! Layout, little-endian: magic `IWFS` (4) | format version u16 | FMI major version u16 |
//! GUID length u16 + GUID bytes | model identifier length u16 + bytes | FMI state u16 |
//! time f64 | start time f64 | stop time f64 (NaN = none) | payload length u64 | payload |
//! CRC-32 of all before (u32).
//!
//! The payload is the model's: every parameter in table order as an f64 (see
//! [`save_model`]), then what [`Model::save_state`] appends. A state says which build
//! wrote it (standard, model, description digest) so that a state is restored only into
//! the build that wrote it: the FMI 2.0 and FMI 3.0 builds of a model share its GUID and
//! payload, but not the states and rules around them.

use inchworm_state_bytes::{Reader, Writer};

use crate::access::{Row, Value};
use crate::instance::State;
use crate::table::{Admission, Causality, Kind};
use crate::Model;

const MAGIC: &[u8; 4] = b"IWFS";
/// 1: no standard and no model identifier (the field of the standard was reserved).
pub const FORMAT_VERSION: u16 = 2;

#[derive(Debug)]
pub struct Header {
    pub state: State,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
}

/// Which build wrote a state: the FMI major version, the model identifier and the GUID
/// (the digest of the model description).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Build<'a> {
    pub major: u16,
    pub model: &'a str,
    pub guid: &'a str,
}

impl Build<'_> {
    /// Refuses a state another build wrote, naming both.
    pub fn check(&self, wrote: &Build) -> Result<(), String> {
        if wrote.model != self.model {
            return Err(format!(
                "serialized state belongs to another FMU ({}, this FMU is {})",
                wrote.model, self.model
            ));
        }
        if wrote.major != self.major {
            return Err(format!(
                "serialized state was saved by the FMI {}.0 build of {}, this is its FMI {}.0 build: a state does not cross standards",
                wrote.major, self.model, self.major
            ));
        }
        if wrote.guid != self.guid {
            return Err(format!(
                "serialized state belongs to another version of {} (GUID {}, this FMU is {})",
                self.model, wrote.guid, self.guid
            ));
        }
        Ok(())
    }
}

pub fn encode(build: &Build, h: &Header, payload: &[u8]) -> Vec<u8> {
    let (guid, model) = (build.guid.as_bytes(), build.model.as_bytes());
    let mut out = Vec::with_capacity(64 + guid.len() + model.len() + payload.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&build.major.to_le_bytes());
    for text in [guid, model] {
        out.extend_from_slice(&(text.len() as u16).to_le_bytes());
        out.extend_from_slice(text);
    }
    out.extend_from_slice(&(h.state as u16).to_le_bytes());
    out.extend_from_slice(&h.time.to_le_bytes());
    out.extend_from_slice(&h.start_time.to_le_bytes());
    out.extend_from_slice(&h.stop_time.unwrap_or(f64::NAN).to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(payload);
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

/// The frame of `blob`, checked as bytes (magic, checksum, lengths, format version, a
/// known FMI state, finite times); which build wrote it is the caller's to check
/// ([`Build::check`]).
pub fn decode(blob: &[u8]) -> Result<(Build<'_>, Header, &[u8]), String> {
    if blob.len() < 4 + 2 + 2 + 2 + 4 || &blob[..4] != MAGIC {
        return Err("not a serialized state of this FMU (no IWFS header)".into());
    }
    let (body, crc) = blob.split_at(blob.len() - 4);
    let crc = u32::from_le_bytes(crc.try_into().expect("4 bytes"));
    if crc32fast::hash(body) != crc {
        return Err("serialized state is corrupt (CRC-32 mismatch)".into());
    }
    let mut pos: usize = 4;
    let mut take = |n: usize| -> Result<&[u8], String> {
        // A length field may say anything: its end is checked, never overflowed.
        let end = pos.checked_add(n).ok_or("serialized state is truncated")?;
        let s = body.get(pos..end).ok_or("serialized state is truncated")?;
        pos += n;
        Ok(s)
    };
    let u16_at = |b: &[u8]| u16::from_le_bytes([b[0], b[1]]);
    let f64_at = |b: &[u8]| f64::from_le_bytes(b.try_into().expect("8 bytes"));
    let version = u16_at(take(2)?);
    if version != FORMAT_VERSION {
        return Err(format!("serialized state has format version {version}, this FMU reads version {FORMAT_VERSION}"));
    }
    let major = u16_at(take(2)?);
    let mut text = || -> Result<&str, String> {
        let n = u16_at(take(2)?) as usize;
        std::str::from_utf8(take(n)?)
            .map_err(|_| "serialized state has a name that is not UTF-8".into())
    };
    let (guid, model) = (text()?, text()?);
    let state = match u16_at(take(2)?) {
        s if s == State::Instantiated as u16 => State::Instantiated,
        s if s == State::InitializationMode as u16 => State::InitializationMode,
        s if s == State::StepComplete as u16 => State::StepComplete,
        s if s == State::StepFailed as u16 => State::StepFailed,
        s if s == State::StepCanceled as u16 => State::StepCanceled,
        s if s == State::Terminated as u16 => State::Terminated,
        s if s == State::EventMode as u16 => State::EventMode,
        s if s == State::ContinuousTimeMode as u16 => State::ContinuousTimeMode,
        s => return Err(format!("serialized state has an invalid FMI state {s}")),
    };
    let time = f64_at(take(8)?);
    let start_time = f64_at(take(8)?);
    let stop = f64_at(take(8)?);
    let len = u64::from_le_bytes(take(8)?.try_into().expect("8 bytes")) as usize;
    let payload = take(len)?;
    if pos != body.len() {
        return Err("serialized state has trailing bytes".into());
    }
    if !time.is_finite() || !start_time.is_finite() {
        return Err("serialized state has a non-finite time".into());
    }
    let header = Header { state, time, start_time, stop_time: (!stop.is_nan()).then_some(stop) };
    Ok((Build { major, model, guid }, header, payload))
}

fn parameters<M: Model>() -> impl Iterator<Item = &'static Row<M>> {
    M::table().iter().filter(|r| r.var.causality == Causality::Parameter)
}

/// The model's payload: its parameters, walked from the table so that no model writes
/// them by hand, then its own state. Each parameter is an f64: a Real as is, a Boolean
/// as 0 or 1, an Integer as its 32-bit pattern read unsigned (lossless, and the bytes
/// format 1 has always had for Integer parameters).
pub fn save_model<M: Model>(model: &M) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut w = Writer(&mut out);
    for r in parameters::<M>() {
        w.f64(match r.get(model) {
            Value::Real(x) => x,
            Value::Integer(i) => f64::from(i as u32),
            Value::Boolean(b) => f64::from(u8::from(b)),
        });
    }
    model.save_state(&mut w);
    Ok(out)
}

/// A fresh model with what [`save_model`] wrote, each parameter admitted as a master's
/// value would be.
pub fn load_model<M: Model>(payload: &[u8]) -> Result<M, String> {
    let n = parameters::<M>().count();
    let (params, rest) = payload
        .split_at_checked(8 * n)
        .ok_or_else(|| format!("model state truncated in its {n} parameters"))?;
    let mut r = Reader::new(params, "model parameters");
    let mut model = M::new();
    for row in parameters::<M>() {
        let (v, x) = (&row.var, r.f64()?);
        let bad = || format!("parameter {} has the invalid {:?} value {x}", v.name, v.kind);
        let value = match v.kind {
            Kind::Real => match v.admit_real(x, f64::NAN) {
                Ok((y, None)) => Value::Real(y),
                _ => return Err(bad()),
            },
            Kind::Integer if x.fract() == 0.0 && (0.0..=f64::from(u32::MAX)).contains(&x) => {
                Value::Integer(x as u32 as i32)
            }
            Kind::Boolean if x == 0.0 || x == 1.0 => Value::Boolean(x == 1.0),
            _ => return Err(bad()),
        };
        row.set(&mut model, value)?;
    }
    r.finish()?;
    model.load_state(rest)?;
    check_restored(&model)?;
    Ok(model)
}

/// A restored model is held to what a master could have set: a checksum proves the bytes
/// arrived as written, not that a writer wrote sense. Every Real must be finite (a NaN
/// there would poison every later step), and every input inside its declared range.
fn check_restored<M: Model>(model: &M) -> Result<(), String> {
    for row in M::table() {
        let (v, Some(x)) = (&row.var, row.real(model)) else { continue };
        let ok = match v.admit(x) {
            Admission::Accept(_) => true,
            Admission::Limit(_) | Admission::Clamp(_) | Admission::NonFinite => false,
        };
        if !ok {
            let what = if v.causality == Causality::Input {
                "must be finite and inside its declared range"
            } else {
                "must be finite"
            };
            return Err(format!("{} restored as {x}: {what}", v.name));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_every_kind_of_damage_is_refused() {
        let h = Header { state: State::StepComplete, time: 1.5, start_time: 0.0, stop_time: None };
        let a = Build { major: 2, model: "Toy", guid: "{guid-a}" };
        let blob = encode(&a, &h, b"payload bytes");
        let (wrote, back, payload) = decode(&blob).unwrap();
        assert_eq!(wrote, a);
        assert_eq!(
            (back.state, back.time, back.stop_time, payload),
            (State::StepComplete, 1.5, None, &b"payload bytes"[..])
        );
        assert_eq!(a.check(&wrote), Ok(()));
        let other = |major, model, guid| Build { major, model, guid }.check(&wrote).unwrap_err();
        assert_eq!(
            other(3, "Toy", "{guid-a}"),
            "serialized state was saved by the FMI 2.0 build of Toy, this is its FMI 3.0 build: a state does not cross standards"
        );
        assert!(other(2, "Plant", "{guid-a}").contains("another FMU (Toy, this FMU is Plant)"));
        assert!(other(2, "Toy", "{guid-b}").contains("another version of Toy"));
        for i in 0..blob.len() {
            let mut bad = blob.clone();
            bad[i] ^= 0x40;
            assert!(decode(&bad).is_err(), "flipped byte {i} accepted");
        }
        for n in 0..blob.len() {
            assert!(decode(&blob[..n]).is_err(), "truncation to {n} bytes accepted");
        }
    }
}
