//! Unpacking an SSP archive and keeping what it names inside it. An SSP comes from outside:
//! it is unpacked within the same caps as an FMU (`inchworm_fmi_import::archive::Limits`,
//! raised by the `INCHWORM_MAX_*` variables), into a folder of an unpredictable name
//! created exclusively, and every path its SSD gives must stay inside that folder.

use std::path::{Path, PathBuf};

use inchworm_fmi_import::archive::{self as fmu_archive, Limits};

use crate::Error;

/// An unpacked archive's folder, removed when dropped, also on an error's way out.
#[derive(Debug)]
pub struct Unpacked {
    dir: tempfile::TempDir,
}

impl Unpacked {
    /// Takes ownership of a folder already made (tests build archives by hand).
    pub fn new(dir: tempfile::TempDir) -> Unpacked {
        Unpacked { dir }
    }

    pub fn dir(&self) -> &Path {
        self.dir.path()
    }
}

/// Unpacks the SSP at `path` into a new temporary folder.
pub fn unpack_ssp(path: &Path) -> Result<Unpacked, Error> {
    let path_buf = || path.to_path_buf();
    let archive = |unpacking| move |source| Error::Archive { path: path_buf(), unpacking, source };
    let file =
        std::fs::File::open(path).map_err(|source| Error::Io { path: path_buf(), source })?;
    let mut zip = zip::ZipArchive::new(std::io::BufReader::new(file))
        .map_err(|source| Error::NotZip { path: path_buf(), source })?;
    let limits = Limits::from_env().map_err(archive(false))?;
    let dir = fmu_archive::temp_dir("inchworm-ssp-").map_err(archive(false))?;
    fmu_archive::extract(&mut zip, dir.path(), &limits).map_err(archive(true))?;
    Ok(Unpacked { dir })
}

/// Bytes in the files under `dir` (an unpacked archive: within the entry cap, so the walk
/// is bounded).
fn dir_bytes(dir: &Path) -> u64 {
    let mut total = 0u64;
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            match e.file_type() {
                Ok(t) if t.is_dir() => todo.push(e.path()),
                Ok(t) if t.is_file() => {
                    total = total.saturating_add(e.metadata().map_or(0, |m| m.len()))
                }
                _ => {}
            }
        }
    }
    total
}

/// Bytes the FMU at `path` unpacks to (the entries a run needs,
/// [`fmu_archive::is_run_entry`]), counted by inflating them (the sizes an archive declares
/// are not to be trusted) and stopping past `budget`: `None` once more. A file that is not
/// a zip counts 0: its loader refuses it with its own message.
fn inflated_size(path: &Path, budget: u64) -> Result<Option<u64>, Error> {
    let Ok(file) = std::fs::File::open(path) else { return Ok(Some(0)) };
    let Ok(mut zip) = zip::ZipArchive::new(std::io::BufReader::new(file)) else {
        return Ok(Some(0));
    };
    let mut total = 0u64;
    for i in 0..zip.len() {
        let needed = zip.name_for_index(i).and_then(fmu_archive::safe_relative);
        if !needed.is_some_and(|rel| fmu_archive::is_run_entry(&rel)) {
            continue;
        }
        let Ok(entry) = zip.by_index(i) else { return Ok(Some(total)) };
        let left = budget - total;
        let n = std::io::copy(&mut std::io::Read::take(entry, left + 1), &mut std::io::sink())
            .map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        if n > left {
            return Ok(None);
        }
        total += n;
    }
    Ok(Some(total))
}

/// One unpacking budget for a whole system: the SSP unpacked in `dir` and every FMU its
/// components reference together within the total cap ([`Limits::total_bytes`],
/// `INCHWORM_MAX_UNPACKED_BYTES`). An FMU that several components reference counts once,
/// as the master unpacks it once (see `System::load`), and one the cache of unpacked FMUs
/// holds already ([`fmu_archive::cache`]) not at all, as nothing of it is written; one that must be unpacked apart
/// for every instance (`canBeInstantiatedOnlyOncePerProcess`) is counted again by
/// [`check_another_copy`] before each further copy. Each archive alone is held to the cap
/// as it is unpacked; without this, an SSP that references one FMU many times would
/// unpack that many times the cap. Returns the bytes counted so far.
pub fn check_system_budget(dir: &Path, components: &[(&str, &Path)]) -> Result<u64, Error> {
    let limits = Limits::from_env().map_err(|e| Error::Ssp(e.to_string()))?;
    let cap = limits.total_bytes;
    let ssp = dir_bytes(dir);
    let mut used = ssp;
    let over = |what: String| {
        Error::Ssp(format!(
            "the system unpacks to more than {cap} bytes in all ({what}): refused (raise the cap with {})",
            fmu_archive::ENV_TOTAL
        ))
    };
    let cache = fmu_archive::cache::root();
    for (i, (name, source)) in components.iter().enumerate() {
        if components[..i].iter().any(|(_, earlier)| earlier == source) {
            continue;
        }
        // An FMU the cache holds is taken from it: nothing of it is written.
        if cache.as_deref().is_some_and(|root| fmu_archive::cache::holds(root, source)) {
            continue;
        }
        let left = cap.saturating_sub(used);
        match inflated_size(source, left)? {
            Some(n) => used += n,
            None => {
                return Err(over(format!(
                    "the SSP {ssp} bytes, then {} component FMUs; component {} ({}) passes it",
                    i + 1,
                    cut(name, 200),
                    source
                        .file_name()
                        .map_or_else(String::new, |f| f.to_string_lossy().into_owned())
                )))
            }
        }
    }
    Ok(used)
}

/// Counts one more copy of the FMU `source` (component `name`) into `used`, the bytes
/// [`check_system_budget`] counted, or refuses it past the total cap.
pub fn check_another_copy(used: &mut u64, name: &str, source: &Path) -> Result<(), Error> {
    let limits = Limits::from_env().map_err(|e| Error::Ssp(e.to_string()))?;
    let cap = limits.total_bytes;
    match inflated_size(source, cap.saturating_sub(*used))? {
        Some(n) => {
            *used += n;
            Ok(())
        }
        None => Err(Error::Ssp(format!(
            "the system unpacks to more than {cap} bytes in all (component {} needs a copy of its FMU of its own, as it declares canBeInstantiatedOnlyOncePerProcess): refused (raise the cap with {})",
            cut(name, 200),
            fmu_archive::ENV_TOTAL
        ))),
    }
}

/// The file an SSD `source` names, inside the unpacked archive `dir`. A source that is
/// absolute, climbs out with `..`, or is a URI with a scheme (`file:`, `http:`) would load
/// something the archive does not hold, so it is refused.
pub fn source_path(dir: &Path, component: &str, source: &str) -> Result<PathBuf, Error> {
    let shown = cut(source, 200);
    let refuse = |why: &str| {
        Error::Ssp(format!("component {component}: source \"{shown}\" {why}: refused (it must be a relative path inside the SSP, e.g. resources/Model.fmu)"))
    };
    if source.contains(':') {
        return Err(refuse("is a URI or a drive path"));
    }
    let rel = fmu_archive::safe_relative(source)
        .ok_or_else(|| refuse("is absolute or climbs out of the SSP with `..`"))?;
    if rel.as_os_str().is_empty() {
        return Err(refuse("names no file"));
    }
    Ok(dir.join(rel))
}

/// `s` cut to its first `n` characters (marked `…` when cut), to echo untrusted text.
pub fn cut(s: &str, n: usize) -> String {
    match s.char_indices().nth(n) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_stay_inside_the_archive() {
        let d = Path::new("/x");
        assert_eq!(source_path(d, "a", "resources/A.fmu").unwrap(), d.join("resources/A.fmu"));
        assert_eq!(source_path(d, "a", "./A.fmu").unwrap(), d.join("A.fmu"));
        for bad in ["/tmp/A.fmu", "../A.fmu", "resources/../../A.fmu", "file:///tmp/A.fmu", "."] {
            let e = source_path(d, "a", bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("component a: source \"{bad}\" ")), "{e}");
            assert!(e.contains(": refused"), "{e}");
        }
    }

    #[test]
    fn cut_marks_what_it_drops() {
        assert_eq!(cut("abc", 3), "abc");
        assert_eq!(cut("abcd", 3), "abc…");
        assert_eq!(cut("ééé", 2), "éé…");
    }
}
