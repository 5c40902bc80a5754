//! One module per command of the `inchworm` binary, and what they share: writing a file
//! and saying so, and `--param NAME=VALUE` lists.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use inchworm_cosim::InputTable;

pub mod bridge;
pub mod delay_line;
pub mod gait;
pub mod replay;
pub mod run;
pub mod scenario;
pub mod signals;
pub mod spread;
pub mod sweep;

/// Creates the folder `path` goes in, if it has one and it is missing.
pub fn create_parent(path: &Path) -> Result<(), String> {
    match path.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(dir) => std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display())),
        None => Ok(()),
    }
}

/// Creates `path` (and its folder), writes it through `write`, flushes it and prints
/// `wrote <path>`: a file is reported only once all of it is on disk, and every error
/// names the file.
pub fn write_file(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), String> {
    create_parent(path)?;
    let f = File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut w = BufWriter::new(f);
    write(&mut w).and_then(|_| w.flush()).map_err(|e| format!("{}: {e}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Creates `path` (and its folder) for a writer that fills it over time, as `inchworm run`
/// streams its rows; the caller flushes it and says `wrote`.
pub fn create_file(path: &Path) -> Result<BufWriter<File>, String> {
    create_parent(path)?;
    let f = File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(BufWriter::new(f))
}

/// [`write_file`] for a plot: plotters creates and writes the PNG itself, so this only
/// makes the folder, draws and reports.
pub fn write_png(
    path: &Path,
    draw: impl FnOnce(&Path) -> Result<(), Box<dyn std::error::Error + Send + Sync>>,
) -> Result<(), String> {
    create_parent(path)?;
    draw(path).map_err(|e| format!("{}: cannot draw the plot: {e}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

/// `--param NAME=VALUE` arguments as (name, value text) pairs.
pub fn parse_params(params: &[String]) -> Result<Vec<(String, String)>, String> {
    params
        .iter()
        .map(|p| {
            p.split_once('=')
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .ok_or_else(|| format!("--param {p}: expected NAME=VALUE"))
        })
        .collect()
}

/// The largest input CSV read, bytes, unless `INCHWORM_MAX_INPUT_BYTES` says otherwise: the
/// table is held in memory (a few times its text), and a file from outside may be any size.
const MAX_INPUT_BYTES: u64 = 256 << 20;

/// A CSV of inputs (`time,<name>,…`) read from `path`; errors name the file.
pub fn read_input(path: &Path) -> Result<InputTable, String> {
    let here = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let limit = match std::env::var("INCHWORM_MAX_INPUT_BYTES") {
        Err(_) => MAX_INPUT_BYTES,
        Ok(v) => v.trim().parse::<u64>().ok().filter(|&n| n > 0).ok_or_else(|| {
            here(&format!("INCHWORM_MAX_INPUT_BYTES=`{v}` is not a positive whole number"))
        })?,
    };
    let file = File::open(path).map_err(|e| here(&e))?;
    let mut text = String::new();
    // Counted while reading, so a growing file or a pipe is bounded too.
    std::io::Read::read_to_string(&mut std::io::Read::take(file, limit + 1), &mut text)
        .map_err(|e| here(&e))?;
    if text.len() as u64 > limit {
        return Err(here(&format!(
            "the input CSV is larger than {limit} bytes (raise the limit with INCHWORM_MAX_INPUT_BYTES): refused"
        )));
    }
    InputTable::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Makes the output folder before a run, so a bad path fails before the work, not after.
pub fn create_dir(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("{}: cannot create the output directory: {e}", dir.display()))
}

/// The binary reports every error as one line of text, `error: <message>`.
pub trait Text<T> {
    fn text(self) -> Result<T, String>;
}

impl<T, E: std::fmt::Display> Text<T> for Result<T, E> {
    fn text(self) -> Result<T, String> {
        self.map_err(|e| e.to_string())
    }
}
