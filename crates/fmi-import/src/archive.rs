//! Unpacking an FMU (a zip archive) into a fresh directory, removed again on drop, or into
//! the [`cache`] of unpacked FMUs when a program turns it on; and the bounded, confined
//! unpacking both FMUs and the master's SSP archives go through.

pub mod cache;

use std::fs;
use std::io::{self, Read, Seek};
use std::path::{Component, Path, PathBuf};

use crate::description::text::{cut, line_column};
use crate::ImportError;

/// Caps on what an archive may unpack to. An archive comes from outside: a few MB of zip
/// can inflate to any size, so every figure is checked against the bytes actually
/// inflated, not the sizes the archive declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// All entries together, bytes.
    pub total_bytes: u64,
    /// One entry, bytes.
    pub entry_bytes: u64,
    /// Entries (files and folders).
    pub entries: u64,
}

/// The variables that raise the caps, for users with large FMUs.
pub const ENV_TOTAL: &str = "INCHWORM_MAX_UNPACKED_BYTES";
pub const ENV_ENTRY: &str = "INCHWORM_MAX_ENTRY_BYTES";
pub const ENV_ENTRIES: &str = "INCHWORM_MAX_ENTRIES";

/// The largest `modelDescription.xml` read, bytes (raise it with [`ENV_DESCRIPTION`]). Far
/// above large vendor FMUs (a few MB for tens of thousands of variables), it bounds the
/// time and memory a hostile description can cost before anything of it is used.
pub const MAX_DESCRIPTION_BYTES: u64 = 64 << 20;
/// The variable that raises [`MAX_DESCRIPTION_BYTES`].
pub const ENV_DESCRIPTION: &str = "INCHWORM_MAX_DESCRIPTION_BYTES";

impl Limits {
    /// 1 GiB in all, 512 MiB an entry, 10 000 entries: far above the project's FMUs
    /// (under 1 MB) and large vendor FMUs, far below what would fill a disk.
    pub const DEFAULT: Limits =
        Limits { total_bytes: 1 << 30, entry_bytes: 512 << 20, entries: 10_000 };

    /// [`Limits::DEFAULT`], each figure replaced by its environment variable if set.
    pub fn from_env() -> Result<Limits, ImportError> {
        Ok(Limits {
            total_bytes: env_cap(ENV_TOTAL, Limits::DEFAULT.total_bytes)?,
            entry_bytes: env_cap(ENV_ENTRY, Limits::DEFAULT.entry_bytes)?,
            entries: env_cap(ENV_ENTRIES, Limits::DEFAULT.entries)?,
        })
    }
}

/// The cap in the environment variable `name`, or `default` if it is not set; a value
/// that is not a positive whole number is refused (not ignored).
pub fn env_cap(name: &'static str, default: u64) -> Result<u64, ImportError> {
    match std::env::var(name) {
        Err(_) => Ok(default),
        Ok(v) => v.trim().parse::<u64>().ok().filter(|&n| n > 0).ok_or_else(|| {
            let v = cut(&v, 40);
            ImportError::Limit(format!("{name}=`{v}` is not a positive whole number"))
        }),
    }
}

/// An unpacked FMU: the directory and the text of its `modelDescription.xml`. Dropping it
/// deletes a temporary directory, and releases a cache entry for another load.
#[derive(Debug)]
pub struct Unpacked {
    dir: Dir,
    pub(crate) model_description: String,
}

/// Where an FMU was unpacked.
#[derive(Debug)]
enum Dir {
    /// A fresh temporary directory of its own.
    Temp(tempfile::TempDir),
    /// An entry of the [`cache`].
    Cached(cache::InUse),
}

impl Unpacked {
    /// The directory the archive was unpacked into.
    pub fn dir(&self) -> &Path {
        match &self.dir {
            Dir::Temp(d) => d.path(),
            Dir::Cached(entry) => entry.dir(),
        }
    }

    /// Whether the directory is an entry of the [`cache`] (kept after the run).
    pub fn is_cached(&self) -> bool {
        matches!(self.dir, Dir::Cached(_))
    }
}

/// A new, empty directory under the system temp dir: a random name, created exclusively
/// and readable by its owner only, so no other local user can pre-create or swap it.
pub fn temp_dir(prefix: &str) -> Result<tempfile::TempDir, ImportError> {
    tempfile::Builder::new().prefix(prefix).tempdir().map_err(|source| ImportError::Io {
        what: format!("cannot create a directory under {}", std::env::temp_dir().display()),
        source,
    })
}

/// The relative path an archive entry may be written to, or `None` for a dangerous one.
pub fn safe_relative(name: &str) -> Option<PathBuf> {
    // Zip names use '/', but some Windows tools write '\'.
    let name = name.replace('\\', "/");
    if name.starts_with('/') || name.contains(':') && cfg!(windows) || name.contains('\0') {
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

fn too_big(what: String, env: &str, limit: u64) -> ImportError {
    ImportError::Limit(format!("{what} (limit {limit} bytes; raise it with {env})"))
}

/// Whether an FMU's entry (its path inside the archive, made safe by [`safe_relative`]) is
/// one a run needs: `modelDescription.xml`, `resources/` (the files the FMU may read at
/// run time) and the folders of this host's library under either standard's name
/// (`binaries/linux64/` and `binaries/x86_64-linux/` on 64-bit Linux; which one is used is
/// the description's to say). The other platforms' libraries, `documentation/`, `sources/`
/// and `extra/` stay in the archive: no run reads them, and a five-platform FMU's other
/// four libraries are most of its bytes.
pub fn is_run_entry(rel: &Path) -> bool {
    let mut parts = rel.components().map(|c| c.as_os_str());
    match parts.next().and_then(|p| p.to_str()) {
        Some("modelDescription.xml") => parts.next().is_none(),
        Some("resources") => true,
        Some("binaries") => {
            let folder = parts.next().and_then(|p| p.to_str());
            let host = inchworm_fmi_abi::platform::host();
            folder.is_some_and(|f| host.is_some_and(|h| h.fmi2 == Some(f) || h.fmi3 == f))
        }
        _ => false,
    }
}

/// Unpacks every entry of `zip` into `dir`, refusing names that leave it and stopping at
/// the first cap passed; regular files only (a symbolic-link entry becomes a plain file
/// holding its target's name, so nothing unpacked points outside `dir`).
pub fn extract<R: Read + Seek>(
    zip: &mut zip::ZipArchive<R>,
    dir: &Path,
    limits: &Limits,
) -> Result<(), ImportError> {
    extract_where(zip, dir, limits, |_| true)
}

/// [`extract`] of the entries `keep` accepts (by their safe relative path). Every name is
/// checked all the same, and the entry cap counts the whole archive. A skipped entry under
/// `binaries/` leaves its platform folder, empty, so that an FMU without this host's
/// library is refused with the platforms it does carry.
pub fn extract_where<R: Read + Seek>(
    zip: &mut zip::ZipArchive<R>,
    dir: &Path,
    limits: &Limits,
    keep: impl Fn(&Path) -> bool,
) -> Result<(), ImportError> {
    if zip.len() as u64 > limits.entries {
        return Err(ImportError::Limit(format!(
            "the archive has {} entries (limit {}; raise it with {ENV_ENTRIES})",
            zip.len(),
            limits.entries
        )));
    }
    // Check every name before writing anything.
    for i in 0..zip.len() {
        let name = zip.name_for_index(i).unwrap_or_default().to_owned();
        safe_relative(&name).ok_or(ImportError::UnsafePath(name))?;
    }
    let mut total = 0u64;
    let mut buf = vec![0u8; 64 << 10];
    for i in 0..zip.len() {
        let mut entry = zip.by_index(i).map_err(ImportError::NotZip)?;
        let name = entry.name().to_owned();
        let rel = safe_relative(&name).ok_or_else(|| ImportError::UnsafePath(name.clone()))?;
        if rel.as_os_str().is_empty() {
            continue;
        }
        let io_err =
            |source: io::Error| ImportError::Io { what: format!("cannot unpack `{name}`"), source };
        if !keep(&rel) {
            let mut parts = rel.components();
            if let (Some(top), Some(platform)) = (parts.next(), parts.next()) {
                if top.as_os_str() == "binaries" && (parts.next().is_some() || entry.is_dir()) {
                    let folder = Path::new(top.as_os_str()).join(platform.as_os_str());
                    fs::create_dir_all(dir.join(folder)).map_err(io_err)?;
                }
            }
            continue;
        }
        let target = dir.join(&rel);
        if entry.is_dir() {
            fs::create_dir_all(&target).map_err(io_err)?;
            continue;
        }
        if let Some(parent) = target.parent() {
            fs::create_dir_all(parent).map_err(io_err)?;
        }
        // create_new: two entries of one name must not overwrite each other unseen.
        let mut out =
            fs::OpenOptions::new().write(true).create_new(true).open(&target).map_err(io_err)?;
        let mut written = 0u64;
        loop {
            let n = match entry.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(io_err(e)),
            };
            written += n as u64;
            total += n as u64;
            if written > limits.entry_bytes {
                return Err(too_big(
                    format!(
                        "the archive entry `{name}` unpacks to more than {} bytes",
                        limits.entry_bytes
                    ),
                    ENV_ENTRY,
                    limits.entry_bytes,
                ));
            }
            if total > limits.total_bytes {
                return Err(too_big(
                    format!("the archive unpacks to more than {} bytes", limits.total_bytes),
                    ENV_TOTAL,
                    limits.total_bytes,
                ));
            }
            io::Write::write_all(&mut out, &buf[..n]).map_err(io_err)?;
        }
    }
    Ok(())
}

/// Unpacks what a run of the FMU at `path` needs ([`is_run_entry`]) within
/// [`Limits::from_env`], through the [`cache`] if it is on; fails if it is not a zip, has
/// an entry pointing outside the directory, passes a cap, or lacks `modelDescription.xml`.
pub fn unpack(path: &Path) -> Result<Unpacked, ImportError> {
    let limits = Limits::from_env()?;
    match cache::root() {
        Some(root) => cache::unpack_cached(path, &root, &limits),
        None => unpack_with(path, &limits),
    }
}

/// [`unpack`] within `limits`, into a temporary directory of its own.
pub fn unpack_with(path: &Path, limits: &Limits) -> Result<Unpacked, ImportError> {
    let mut zip = open_zip(path)?;
    description_index(&mut zip)?;
    unpack_zip(&mut zip, limits)
}

/// What a run needs of `zip`, whose `modelDescription.xml` is known to be at its root,
/// unpacked within `limits` into a temporary directory of its own.
fn unpack_zip<R: Read + Seek>(
    zip: &mut zip::ZipArchive<R>,
    limits: &Limits,
) -> Result<Unpacked, ImportError> {
    let dir = temp_dir("inchworm-fmu-")?;
    extract_where(zip, dir.path(), limits, is_run_entry)?;
    let md = fs::read(dir.path().join("modelDescription.xml"))
        .map_err(|_| ImportError::NoModelDescription)?;
    Ok(Unpacked { dir: Dir::Temp(dir), model_description: description_text(&md)? })
}

/// The text of the `modelDescription.xml` of the FMU at `path`, read from the archive
/// without unpacking anything, within the description cap
/// ([`MAX_DESCRIPTION_BYTES`] or its variable): a master can look at what an FMU declares,
/// and refuse it, before writing a byte of it to disk.
pub fn read_description(path: &Path) -> Result<String, ImportError> {
    let mut zip = open_zip(path)?;
    let i = description_index(&mut zip)?;
    let cap = env_cap(ENV_DESCRIPTION, MAX_DESCRIPTION_BYTES)?;
    let entry = zip.by_index(i).map_err(ImportError::NotZip)?;
    let too_large = |size: String| {
        let env = ENV_DESCRIPTION;
        ImportError::Limit(format!(
            "modelDescription.xml has {size} bytes (limit {cap} bytes; raise it with {env})"
        ))
    };
    // The size the archive declares, then what it really unpacks to (it may lie).
    if entry.size() > cap {
        return Err(too_large(entry.size().to_string()));
    }
    let mut md = Vec::new();
    entry.take(cap + 1).read_to_end(&mut md).map_err(|source| ImportError::Io {
        what: "cannot read modelDescription.xml".into(),
        source,
    })?;
    if md.len() as u64 > cap {
        return Err(too_large(format!("more than {cap}")));
    }
    description_text(&md)
}

fn open_zip(path: &Path) -> Result<zip::ZipArchive<io::BufReader<fs::File>>, ImportError> {
    let file = fs::File::open(path)
        .map_err(|source| ImportError::Io { what: "cannot open the file".into(), source })?;
    zip::ZipArchive::new(io::BufReader::new(file)).map_err(ImportError::NotZip)
}

/// The index of the archive's `modelDescription.xml` (at its root), or why there is none.
fn description_index<R: Read + Seek>(zip: &mut zip::ZipArchive<R>) -> Result<usize, ImportError> {
    let found = (0..zip.len()).find(|&i| {
        zip.name_for_index(i).and_then(safe_relative).as_deref()
            == Some(Path::new("modelDescription.xml"))
    });
    match found {
        Some(i) => Ok(i),
        None => {
            // An unsafe name is the graver finding: report it first.
            for i in 0..zip.len() {
                let name = zip.name_for_index(i).unwrap_or_default().to_owned();
                safe_relative(&name).ok_or(ImportError::UnsafePath(name))?;
            }
            Err(ImportError::NoModelDescription)
        }
    }
}

/// The bytes of `modelDescription.xml` as text: a byte-order mark dropped, UTF-8 required.
fn description_text(md: &[u8]) -> Result<String, ImportError> {
    let md = md.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(md);
    String::from_utf8(md.to_vec()).map_err(|e| {
        let (line, column) =
            line_column(&String::from_utf8_lossy(md), e.utf8_error().valid_up_to());
        ImportError::Description { line, column, message: "the file is not valid UTF-8".into() }
    })
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
