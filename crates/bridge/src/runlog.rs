//! The run log: every exchanged sample and every event, in a framed file that survives a
//! crash of the process writing it.
//!
//! Each record goes to the kernel in one `write(2)` as soon as it exists (no user-space
//! buffer), so a crash loses nothing already logged; a record cut short by the crash
//! itself is recognised on reading (its length or CRC does not check) and reported as a
//! truncated tail. Layout, little-endian:
//!
//! ```text
//! file   = "IWLOG" 0x00 version=1 0x00, record*
//! record = len:u16  kind:u8  payload[len]  crc32(len, kind, payload):u32
//! ```
//!
//! A run that finishes in order writes an [`Record::End`] last, so a reader can tell a
//! log that stops at a record boundary because the writer was killed from a finished one.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use inchworm_hil_protocol::crc32;

pub const MAGIC: &[u8; 8] = b"IWLOG\0\x01\0";

/// One tick of the controller side: the encoder count it used, the reference, and the DAC
/// codes it sent for the interval that starts at this tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerSample {
    pub tick: u32,
    pub time: f64,
    pub reference: f64,
    pub counts: i32,
    pub codes: [u16; 3],
    /// Status bits of the board's last encoder frame.
    pub status: u16,
    pub seq: u16,
}

/// One period of the board side: the codes it applied (after the watchdog) and the count
/// at the end of the interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardSample {
    pub tick: u32,
    pub codes: [u16; 3],
    pub counts: i32,
    pub status: u16,
    pub dac_seq: u16,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Record {
    /// `key=value` lines: role, FMU, parameters, protocol settings.
    Meta(String),
    Controller(ControllerSample),
    Board(BoardSample),
    /// Something that happened at `tick`: arm, fault, safe state, overrun, re-arm.
    Event {
        tick: u32,
        text: String,
    },
    /// The last record of a run that finished in order (completed, or ended in a fault it
    /// reported): a log without one is from a run that was killed or crashed.
    End {
        tick: u32,
        text: String,
    },
}

const KIND_META: u8 = 1;
const KIND_CONTROLLER: u8 = 2;
const KIND_BOARD: u8 = 3;
const KIND_EVENT: u8 = 4;
const KIND_END: u8 = 5;

impl Record {
    fn encode(&self, out: &mut Vec<u8>) {
        out.clear();
        out.extend_from_slice(&[0, 0, 0]);
        let kind = match self {
            Record::Meta(text) => {
                out.extend_from_slice(text.as_bytes());
                KIND_META
            }
            Record::Controller(s) => {
                out.extend_from_slice(&s.tick.to_le_bytes());
                out.extend_from_slice(&s.time.to_le_bytes());
                out.extend_from_slice(&s.reference.to_le_bytes());
                out.extend_from_slice(&s.counts.to_le_bytes());
                for c in s.codes {
                    out.extend_from_slice(&c.to_le_bytes());
                }
                out.extend_from_slice(&s.status.to_le_bytes());
                out.extend_from_slice(&s.seq.to_le_bytes());
                KIND_CONTROLLER
            }
            Record::Board(s) => {
                out.extend_from_slice(&s.tick.to_le_bytes());
                for c in s.codes {
                    out.extend_from_slice(&c.to_le_bytes());
                }
                out.extend_from_slice(&s.counts.to_le_bytes());
                out.extend_from_slice(&s.status.to_le_bytes());
                out.extend_from_slice(&s.dac_seq.to_le_bytes());
                KIND_BOARD
            }
            Record::Event { tick, text } => {
                out.extend_from_slice(&tick.to_le_bytes());
                out.extend_from_slice(text.as_bytes());
                KIND_EVENT
            }
            Record::End { tick, text } => {
                out.extend_from_slice(&tick.to_le_bytes());
                out.extend_from_slice(text.as_bytes());
                KIND_END
            }
        };
        // Texts are short; a longer one is cut rather than making the record unreadable.
        let len = (out.len() - 3).min(u16::MAX as usize);
        out.truncate(3 + len);
        out[..2].copy_from_slice(&(len as u16).to_le_bytes());
        out[2] = kind;
        let crc = crc32(out);
        out.extend_from_slice(&crc.to_le_bytes());
    }

    fn decode(kind: u8, p: &[u8]) -> Result<Record, RecordError> {
        let u16_at = |i: usize| u16::from_le_bytes([p[i], p[i + 1]]);
        let u32_at = |i: usize| u32::from_le_bytes(p[i..i + 4].try_into().unwrap());
        let f64_at = |i: usize| f64::from_le_bytes(p[i..i + 8].try_into().unwrap());
        let need = |n: usize| {
            if p.len() == n {
                Ok(())
            } else {
                Err(RecordError::Length { kind, len: p.len(), expected: n })
            }
        };
        match kind {
            KIND_META => Ok(Record::Meta(String::from_utf8_lossy(p).into_owned())),
            KIND_CONTROLLER => {
                need(34)?;
                Ok(Record::Controller(ControllerSample {
                    tick: u32_at(0),
                    time: f64_at(4),
                    reference: f64_at(12),
                    counts: u32_at(20) as i32,
                    codes: [u16_at(24), u16_at(26), u16_at(28)],
                    status: u16_at(30),
                    seq: u16_at(32),
                }))
            }
            KIND_BOARD => {
                need(18)?;
                Ok(Record::Board(BoardSample {
                    tick: u32_at(0),
                    codes: [u16_at(4), u16_at(6), u16_at(8)],
                    counts: u32_at(10) as i32,
                    status: u16_at(14),
                    dac_seq: u16_at(16),
                }))
            }
            KIND_EVENT | KIND_END => {
                if p.len() < 4 {
                    return Err(RecordError::NoTick { end: kind == KIND_END, len: p.len() });
                }
                let (tick, text) = (u32_at(0), String::from_utf8_lossy(&p[4..]).into_owned());
                Ok(if kind == KIND_END {
                    Record::End { tick, text }
                } else {
                    Record::Event { tick, text }
                })
            }
            other => Err(RecordError::UnknownKind(other)),
        }
    }
}

pub struct LogWriter {
    file: File,
    buf: Vec<u8>,
    records: u64,
}

impl LogWriter {
    pub fn create(path: &Path) -> io::Result<LogWriter> {
        let mut file = File::create(path)
            .map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
        file.write_all(MAGIC)?;
        Ok(LogWriter { file, buf: Vec::with_capacity(64), records: 0 })
    }

    /// One record, handed to the kernel before this returns.
    pub fn write(&mut self, record: &Record) -> io::Result<()> {
        record.encode(&mut self.buf);
        self.file.write_all(&self.buf)?;
        self.records += 1;
        Ok(())
    }

    pub fn records(&self) -> u64 {
        self.records
    }

    /// Forces the records to the disk (survives a machine crash too); the bridge calls it
    /// at the end of a run and after a fault, not every tick.
    pub fn sync(&mut self) -> io::Result<()> {
        self.file.sync_data()
    }
}

/// A log as read back.
#[derive(Clone, Debug, Default)]
pub struct LogContents {
    pub records: Vec<Record>,
    /// Set when the file ends inside a record (the writer died mid-write): the byte offset
    /// where the incomplete record starts. Everything before it is intact.
    pub truncated_at: Option<u64>,
}

impl LogContents {
    /// The run's end record, if the run got to write one.
    pub fn end(&self) -> Option<(u32, &str)> {
        self.records.iter().rev().find_map(|r| match r {
            Record::End { tick, text } => Some((*tick, text.as_str())),
            _ => None,
        })
    }

    /// Whole, and closed by an end record: the run finished in order.
    pub fn complete(&self) -> bool {
        self.truncated_at.is_none() && self.end().is_some()
    }
}

/// A log that could not be read ([`read_log`]): the file, or what is in it.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    #[error("{}: {source}", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    #[error("{}: {source}", path.display())]
    Parse {
        path: PathBuf,
        #[source]
        source: ParseError,
    },
}

/// Bytes that are not a whole log ([`parse_log`]), up to the truncated tail it tolerates.
#[derive(Debug, thiserror::Error)]
pub enum ParseError {
    #[error("not an inchworm bridge log (no IWLOG header)")]
    NotALog,
    #[error("log format version {found} (this build reads {reads})")]
    Version { found: u8, reads: u8 },
    #[error(
        "record at byte {at}: CRC mismatch (stored {stored:#010x}, computed {computed:#010x})"
    )]
    Crc { at: usize, stored: u32, computed: u32 },
    #[error("record at byte {at}: {source}")]
    Record {
        at: usize,
        #[source]
        source: RecordError,
    },
}

/// A record whose CRC holds but whose contents do not.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("record kind {kind} has {len} bytes, expected {expected}")]
    Length { kind: u8, len: usize, expected: usize },
    #[error("{} record of {len} bytes is shorter than its tick", if *.end { "end" } else { "event" })]
    NoTick { end: bool, len: usize },
    #[error("unknown record kind {0}")]
    UnknownKind(u8),
}

/// Reads and checks a whole log. A damaged record in the middle is an error naming its
/// offset (the log cannot be trusted past it); a short last record is a truncated tail.
pub fn read_log(path: &Path) -> Result<LogContents, LogError> {
    let bytes = std::fs::read(path)
        .map_err(|source| LogError::Read { path: path.to_path_buf(), source })?;
    parse_log(&bytes).map_err(|source| LogError::Parse { path: path.to_path_buf(), source })
}

pub fn parse_log(bytes: &[u8]) -> Result<LogContents, ParseError> {
    if bytes.len() < MAGIC.len() || &bytes[..5] != b"IWLOG" {
        return Err(ParseError::NotALog);
    }
    if bytes[6] != MAGIC[6] {
        return Err(ParseError::Version { found: bytes[6], reads: MAGIC[6] });
    }
    let mut out = LogContents::default();
    let mut at = MAGIC.len();
    while at < bytes.len() {
        let rest = &bytes[at..];
        if rest.len() < 3 {
            out.truncated_at = Some(at as u64);
            break;
        }
        let len = u16::from_le_bytes([rest[0], rest[1]]) as usize;
        let total = 3 + len + 4;
        if rest.len() < total {
            out.truncated_at = Some(at as u64);
            break;
        }
        let stored = u32::from_le_bytes(rest[3 + len..total].try_into().unwrap());
        let computed = crc32(&rest[..3 + len]);
        if stored != computed {
            if at + total == bytes.len() {
                // The last record, damaged: the crash hit while it was written.
                out.truncated_at = Some(at as u64);
                break;
            }
            return Err(ParseError::Crc { at, stored, computed });
        }
        out.records.push(
            Record::decode(rest[2], &rest[3..3 + len])
                .map_err(|source| ParseError::Record { at, source })?,
        );
        at += total;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_records() -> Vec<Record> {
        vec![
            Record::Meta("role=controller\nperiod_us=2000".into()),
            Record::Controller(ControllerSample {
                tick: 7,
                time: 0.014,
                reference: 1e-4,
                counts: -12,
                codes: [1, 65535, 300],
                status: 1,
                seq: 65535,
            }),
            Record::Board(BoardSample {
                tick: u32::MAX,
                codes: [0, 0, 0],
                counts: i32::MIN,
                status: 3,
                dac_seq: 4,
            }),
            Record::Event { tick: 9, text: "safe state: silence for 3 periods".into() },
            Record::End { tick: 10, text: "completed: 3 ticks".into() },
        ]
    }

    fn write_all(path: &Path) {
        let mut w = LogWriter::create(path).unwrap();
        for r in sample_records() {
            w.write(&r).unwrap();
        }
    }

    #[test]
    fn round_trip_and_truncated_tail() {
        let dir = std::env::temp_dir().join(format!("iwlog-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.log");
        write_all(&path);
        let log = read_log(&path).unwrap();
        assert_eq!(log.records, sample_records());
        assert_eq!(log.truncated_at, None);
        assert_eq!((log.complete(), log.end()), (true, Some((10, "completed: 3 ticks"))));

        // A crash mid-record: every cut point keeps all whole records before it.
        let bytes = std::fs::read(&path).unwrap();
        let mut boundaries = vec![MAGIC.len()];
        let mut buf = Vec::new();
        for r in sample_records() {
            r.encode(&mut buf);
            boundaries.push(boundaries.last().unwrap() + buf.len());
        }
        assert_eq!(*boundaries.last().unwrap(), bytes.len());
        for cut in MAGIC.len()..bytes.len() {
            let log = parse_log(&bytes[..cut]).unwrap();
            let whole = boundaries.iter().filter(|&&b| b <= cut).count() - 1;
            assert_eq!(log.records, sample_records()[..whole].to_vec(), "cut at {cut}");
            assert_eq!(
                log.truncated_at,
                (cut != boundaries[whole]).then_some(boundaries[whole] as u64),
                "cut at {cut}"
            );
            // Cut anywhere, at a record boundary too, the log is not the whole run.
            assert!(!log.complete(), "cut at {cut}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn damage_in_the_middle_is_an_error_with_its_offset() {
        let mut buf = Vec::new();
        let mut bytes = MAGIC.to_vec();
        for r in sample_records() {
            r.encode(&mut buf);
            bytes.extend_from_slice(&buf);
        }
        let mut bad = bytes.clone();
        bad[MAGIC.len() + 10] ^= 0x40;
        let e = parse_log(&bad).unwrap_err();
        assert!(matches!(e, ParseError::Crc { at: 8, .. }), "{e:?}");
        assert!(e.to_string().starts_with("record at byte 8: CRC mismatch"), "{e}");
        let e = parse_log(b"hello world").unwrap_err();
        assert!(matches!(e, ParseError::NotALog) && e.to_string().contains("IWLOG"), "{e}");
    }
}
