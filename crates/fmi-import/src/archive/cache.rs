//! The cache of unpacked FMUs a process may keep between runs: what a run needs of an FMU
//! ([`super::is_run_entry`]) unpacked once into a folder named by the SHA-256 of the
//! archive's bytes and this host's platform, and taken from there by every later run of
//! the same bytes. Off unless a program turns it on ([`set_root`]); the `inchworm`
//! command turns it on at [`default_root`].
//!
//! Why reusing a folder is safe:
//!
//! * **Keyed by content.** The name is the hash of the very bytes unpacked (the archive is
//!   read into memory once, hashed, and unpacked from that copy), so an archive changed by
//!   one byte, or replaced while it is read, never meets an older archive's folder.
//! * **Complete or absent.** An archive is unpacked into a fresh folder of the cache named
//!   `.unpacking-XXXXXX`, checked (caps, names, `modelDescription.xml`) and only then
//!   renamed to its entry's name, atomically; a refused or interrupted unpacking leaves no
//!   entry (its folder is removed on the way out). Two processes unpacking the same bytes
//!   at once both finish; the second rename fails and the first one's folder, the same
//!   files, is used. An entry is never written after the rename.
//! * **Yours only.** The cache's folder is created readable by its owner only, and one
//!   that is not the user's own or that others may write to is refused, so no other user
//!   can plant or swap a library there.
//! * **One library per load.** A library is loaded at most once per process from its
//!   entry: while an instance of this process uses an entry, a further unpacking of the
//!   same bytes (a component of an FMU that declares `canBeInstantiatedOnlyOncePerProcess`)
//!   gets a private temporary copy, as it would without the cache, so the dynamic loader
//!   never hands two such loads the same library.
//!
//! Entries are never removed by a run; deleting the cache's folder (or any entry in it)
//! between runs is always safe. An archive larger than [`LARGEST_CACHED`] is unpacked
//! into a temporary folder as without the cache.

use std::collections::BTreeSet;
use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

use sha2::{Digest, Sha256};

use super::{description_index, description_text, extract_where, is_run_entry, unpack_zip};
use super::{Dir, Limits, Unpacked};
use crate::ImportError;

/// The variable that names the cache's folder for the `inchworm` command, or turns the
/// cache off (`off`).
pub const ENV_CACHE: &str = "INCHWORM_FMU_CACHE";

/// The largest archive kept in the cache, bytes: it is read into memory whole to be hashed
/// and unpacked from the same bytes.
pub const LARGEST_CACHED: u64 = 256 << 20;

/// The cache layout's version, first in every entry's name: a change to what an entry
/// holds changes it, so no entry of another layout is read.
const LAYOUT: &str = "v1";

/// The cache's folder, if it is on.
static ROOT: Mutex<Option<PathBuf>> = Mutex::new(None);

/// The entries an instance of this process uses.
static IN_USE: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());

/// Turns the cache on at `root` (created on first use), or off with `None`, for every
/// FMU this process unpacks from now on.
pub fn set_root(root: Option<PathBuf>) {
    *ROOT.lock().unwrap_or_else(PoisonError::into_inner) = root;
}

/// The cache's folder, if it is on.
pub fn root() -> Option<PathBuf> {
    ROOT.lock().unwrap_or_else(PoisonError::into_inner).clone()
}

/// The folder the `inchworm` command keeps its cache in: `$INCHWORM_FMU_CACHE` (none if
/// it is `off` or empty), else `$XDG_CACHE_HOME/inchworm/fmu`, else
/// `$HOME/.cache/inchworm/fmu`; none without any of them. A relative
/// `$XDG_CACHE_HOME` is ignored, as its specification asks.
pub fn default_root() -> Option<PathBuf> {
    let var = |name| std::env::var_os(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    if let Some(dir) = std::env::var_os(ENV_CACHE) {
        return (!dir.is_empty() && dir != "off").then(|| PathBuf::from(dir));
    }
    var("XDG_CACHE_HOME")
        .filter(|d| d.is_absolute())
        .or_else(|| var("HOME").map(|h| h.join(".cache")))
        .map(|d| d.join("inchworm").join("fmu"))
}

/// The entry's name for an archive of these bytes on this host, or `None` on a host
/// without an FMI platform (no library could be loaded there anyway).
fn entry_name(bytes: &[u8]) -> Option<String> {
    let host = inchworm_fmi_abi::platform::host()?;
    let hash: String = Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect();
    Some(format!("{LAYOUT}-{}-{hash}", host.fmi3))
}

/// An entry an instance of this process uses, released when dropped.
#[derive(Debug)]
pub(crate) struct InUse(PathBuf);

impl InUse {
    /// The entry at `dir`, unless this process uses it already.
    fn claim(dir: &Path) -> Option<InUse> {
        let mut used = IN_USE.lock().unwrap_or_else(PoisonError::into_inner);
        used.insert(dir.to_path_buf()).then(|| InUse(dir.to_path_buf()))
    }

    pub(crate) fn dir(&self) -> &Path {
        &self.0
    }
}

impl Drop for InUse {
    fn drop(&mut self) {
        IN_USE.lock().unwrap_or_else(PoisonError::into_inner).remove(&self.0);
    }
}

fn io_error(what: String) -> impl FnOnce(io::Error) -> ImportError {
    move |source| ImportError::Io { what, source }
}

/// Creates `root` if need be (readable by its owner only) and refuses it if it is not a
/// folder of this user's that only this user may write to.
fn check_root(root: &Path) -> Result<(), ImportError> {
    let shown = root.display();
    let mut builder = fs::DirBuilder::new();
    builder.recursive(true);
    #[cfg(unix)]
    std::os::unix::fs::DirBuilderExt::mode(&mut builder, 0o700);
    builder.create(root).map_err(io_error(format!("cannot create the FMU cache {shown}")))?;
    let meta =
        fs::metadata(root).map_err(io_error(format!("cannot read the FMU cache {shown}")))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        // SAFETY: geteuid has no preconditions and cannot fail.
        let me = unsafe { libc::geteuid() };
        if meta.uid() != me || meta.mode() & 0o022 != 0 {
            return Err(ImportError::Cache(format!(
                "the FMU cache {shown} belongs to another user or others may write to it (mode {:o}): refused (set {ENV_CACHE} to a folder of your own, or to off)",
                meta.mode() & 0o7777
            )));
        }
    }
    if !meta.is_dir() {
        return Err(ImportError::Cache(format!("the FMU cache {shown} is not a folder: refused")));
    }
    Ok(())
}

/// Whether unpacking `path` would take it from the cache at `root` as it is now, writing
/// nothing: its entry exists and this process does not use it.
pub fn holds(root: &Path, path: &Path) -> bool {
    let small = fs::metadata(path).is_ok_and(|m| m.is_file() && m.len() <= LARGEST_CACHED);
    let Some(name) = small.then(|| fs::read(path).ok()).flatten().and_then(|b| entry_name(&b))
    else {
        return false;
    };
    let entry = root.join(name);
    entry.is_dir() && !IN_USE.lock().unwrap_or_else(PoisonError::into_inner).contains(&entry)
}

/// [`super::unpack_with`] through the cache at `root`: the entry of `path`'s bytes,
/// unpacked into the cache first if it is not there yet.
pub fn unpack_cached(path: &Path, root: &Path, limits: &Limits) -> Result<Unpacked, ImportError> {
    let size = fs::metadata(path).map_err(io_error("cannot open the file".into()))?.len();
    if size > LARGEST_CACHED {
        return super::unpack_with(path, limits);
    }
    let bytes = fs::read(path).map_err(io_error("cannot read the file".into()))?;
    let mut zip = zip::ZipArchive::new(io::Cursor::new(&bytes[..])).map_err(ImportError::NotZip)?;
    description_index(&mut zip)?;
    let Some(name) = entry_name(&bytes) else { return unpack_zip(&mut zip, limits) };
    check_root(root)?;
    let entry = root.join(name);
    let Some(claim) = InUse::claim(&entry) else {
        // This process loaded the library of this entry already: a copy of its own.
        return unpack_zip(&mut zip, limits);
    };
    if !entry.is_dir() {
        let fresh = tempfile::Builder::new()
            .prefix(".unpacking-")
            .tempdir_in(root)
            .map_err(io_error(format!("cannot create a folder in {}", root.display())))?;
        extract_where(&mut zip, fresh.path(), limits, is_run_entry)?;
        if !fresh.path().join("modelDescription.xml").is_file() {
            return Err(ImportError::NoModelDescription);
        }
        // A folder renamed onto an existing entry fails: another process unpacked the
        // same bytes first, and its entry serves (`fresh` is removed on drop).
        match fs::rename(fresh.path(), &entry) {
            // Renamed: nothing is left at `fresh`'s name to remove.
            Ok(()) => drop(fresh.keep()),
            Err(_) if entry.is_dir() => {}
            Err(e) => {
                let what = format!("cannot add {} to the FMU cache", entry.display());
                return Err(io_error(what)(e));
            }
        }
    }
    let md = fs::read(entry.join("modelDescription.xml"))
        .map_err(|_| ImportError::NoModelDescription)?;
    Ok(Unpacked { dir: Dir::Cached(claim), model_description: description_text(&md)? })
}
