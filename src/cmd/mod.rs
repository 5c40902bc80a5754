//! One module per command of the `inchworm` binary, and what they share: writing a file
//! and saying so, and `--param NAME=VALUE` lists.

use std::fs::File;
use std::io::Write;
use std::path::Path;

use inchworm_cosim::output::{self, Pending};
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

/// Checks every output of a command before any work (README, "Reliability"): distinct
/// from each other and from every input, each a file in a folder that is made where
/// missing ([`inchworm_cosim::output::check`]).
pub fn check_outputs(outputs: &[(&str, &Path)], inputs: &[&Path]) -> Result<(), String> {
    output::check(outputs, inputs).map_err(|e| e.to_string())
}

/// Writes `path` through `write` into a temporary beside it, renamed over it once all of
/// it is on disk, and prints `wrote <path>`; on an error the file is as it was, no
/// temporary is left, and the error names the file.
pub fn write_file(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), String> {
    let mut p = create_file(path)?;
    write(&mut p).map_err(|e| format!("{}: {e}", path.display()))?;
    commit(p)?;
    println!("wrote {}", path.display());
    Ok(())
}

/// A temporary beside `path` (its folder made where missing) for a writer that fills it
/// over time, as `inchworm run` streams its rows; [`commit`] puts it in place, dropping
/// it leaves `path` as it was.
pub fn create_file(path: &Path) -> Result<Pending, String> {
    create_parent(path)?;
    Pending::new(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Renames a complete temporary over its target.
pub fn commit(p: Pending) -> Result<(), String> {
    let path = p.target().to_path_buf();
    p.commit().map_err(|e| format!("{}: {e}", path.display()))
}

/// [`write_file`] for a plot: plotters writes the PNG itself, into the temporary.
pub fn write_png(
    path: &Path,
    draw: impl FnOnce(&Path) -> Result<(), Box<dyn std::error::Error + Send + Sync>>,
) -> Result<(), String> {
    let p = create_file(path)?;
    draw(p.path()).map_err(|e| format!("{}: cannot draw the plot: {e}", path.display()))?;
    commit(p)?;
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
