//! Unpacking an FMU (a zip archive) into a fresh directory, removed again on drop.

use std::fs;
use std::io::{self, Read};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

use crate::ImportError;

/// An unpacked FMU: the directory and the text of its `modelDescription.xml`. Dropping it
/// deletes the directory.
#[derive(Debug)]
pub struct Unpacked {
    dir: PathBuf,
    pub(crate) model_description: String,
}

impl Unpacked {
    /// The directory the archive was unpacked into.
    pub fn dir(&self) -> &Path {
        &self.dir
    }
}

impl Drop for Unpacked {
    fn drop(&mut self) {
        if let Err(e) = fs::remove_dir_all(&self.dir) {
            if e.kind() != io::ErrorKind::NotFound {
                log::warn!("cannot remove the unpacked FMU {}: {e}", self.dir.display());
            }
        }
    }
}

/// A new, empty directory under the system temp dir, unique within and across processes.
fn unique_dir() -> Result<PathBuf, ImportError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let base = std::env::temp_dir();
    let base = if base.is_absolute() {
        base
    } else {
        std::env::current_dir().map(|d| d.join(&base)).unwrap_or(base)
    };
    for _ in 0..100 {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let nanos = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
        let dir = base.join(format!("inchworm-fmu-{}-{n}-{nanos}", std::process::id()));
        match fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
            Err(source) => {
                return Err(ImportError::Io {
                    what: format!("cannot create the directory {}", dir.display()),
                    source,
                })
            }
        }
    }
    Err(ImportError::Io {
        what: format!("cannot create a unique directory under {}", base.display()),
        source: io::Error::from(io::ErrorKind::AlreadyExists),
    })
}

/// The relative path an archive entry may be written to, or `None` for a dangerous one.
fn safe_relative(name: &str) -> Option<PathBuf> {
    // Zip names use '/', but some Windows tools write '\'.
    let name = name.replace('\\', "/");
    if name.starts_with('/') || name.contains(':') && cfg!(windows) {
        return None;
    }
    let mut out = PathBuf::new();
    for c in Path::new(&name).components() {
        match c {
            Component::Normal(p) => out.push(p),
            Component::CurDir => {}
            Component::ParentDir | Component::RootDir | Component::Prefix(_) => return None,
        }
    }
    Some(out)
}

/// Unpacks the FMU at `path`; fails if it is not a zip, has an entry pointing outside
/// the directory, or lacks `modelDescription.xml`.
pub fn unpack(path: &Path) -> Result<Unpacked, ImportError> {
    let file = fs::File::open(path)
        .map_err(|source| ImportError::Io { what: "cannot open the file".into(), source })?;
    let mut zip = zip::ZipArchive::new(io::BufReader::new(file)).map_err(ImportError::NotZip)?;
    // Check every name before writing anything.
    let mut has_md = false;
    for i in 0..zip.len() {
        let name = zip.name_for_index(i).unwrap_or_default().to_owned();
        let rel = safe_relative(&name).ok_or_else(|| ImportError::UnsafePath(name.clone()))?;
        has_md |= rel == Path::new("modelDescription.xml");
    }
    if !has_md {
        return Err(ImportError::NoModelDescription);
    }
    let mut unpacked = Unpacked { dir: unique_dir()?, model_description: String::new() };
    let mut md = None;
    for i in 0..zip.len() {
        let mut entry = zip.by_index(i).map_err(ImportError::NotZip)?;
        let name = entry.name().to_owned();
        let rel = safe_relative(&name).ok_or_else(|| ImportError::UnsafePath(name.clone()))?;
        if rel.as_os_str().is_empty() {
            continue;
        }
        let target = unpacked.dir.join(&rel);
        let io_err =
            |source: io::Error| ImportError::Io { what: format!("cannot unpack `{name}`"), source };
        if entry.is_dir() {
            fs::create_dir_all(&target).map_err(io_err)?;
            continue;
        }
        if let Some(parent) = target.parent() {
            fs::create_dir_all(parent).map_err(io_err)?;
        }
        let mut bytes = Vec::with_capacity(entry.size().min(1 << 28) as usize);
        entry.read_to_end(&mut bytes).map_err(io_err)?;
        if rel == Path::new("modelDescription.xml") {
            md = Some(bytes.clone());
        }
        fs::write(&target, &bytes).map_err(io_err)?;
    }
    let md = md.ok_or(ImportError::NoModelDescription)?;
    let md = md.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&md);
    let text = String::from_utf8(md.to_vec()).map_err(|e| {
        let (line, column) = crate::description::line_column(
            &String::from_utf8_lossy(md),
            e.utf8_error().valid_up_to(),
        );
        ImportError::Description { line, column, message: "the file is not valid UTF-8".into() }
    })?;
    unpacked.model_description = text;
    Ok(unpacked)
}

#[cfg(test)]
mod tests {
    use super::safe_relative;
    use std::path::Path;

    #[test]
    fn zip_slip_names_are_refused() {
        assert_eq!(
            safe_relative("binaries/linux64/a.so").as_deref(),
            Some(Path::new("binaries/linux64/a.so"))
        );
        assert_eq!(
            safe_relative("./modelDescription.xml").as_deref(),
            Some(Path::new("modelDescription.xml"))
        );
        assert!(safe_relative("../evil.so").is_none());
        assert!(safe_relative("resources/../../evil").is_none());
        assert!(safe_relative("/etc/passwd").is_none());
        assert!(safe_relative("..\\evil").is_none());
    }
}
