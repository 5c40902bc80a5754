//! The one discipline for every file the project's programs write (the `inchworm` command,
//! `fmu-build`): a user's file is never destroyed by a run that is refused or fails.
//!
//! * **Checked before any work** ([`check`]): every output is a file (not a folder), in a
//!   folder that exists or can be made, distinct from every other output and from every
//!   input, compared by canonical path and, where both exist, by device and inode (a hard
//!   link is the same file under two names).
//! * **Written beside the target** ([`Pending`]): into a uniquely named temporary file in
//!   the target's folder (`.<name>.<random>.partial.<ext>`, never a fixed name that may be
//!   a user's), renamed over the target only when complete ([`Pending::commit`]); a
//!   `Pending` dropped without a commit removes its temporary, so a refused or failed run
//!   leaves every existing file as it was and no temporary behind.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// An output refused before any work.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// Two outputs name the same file.
    #[error("{}: named as {first} and as {second}: the two would be written over each other", path.display())]
    Twice { path: PathBuf, first: String, second: String },
    /// An output names an input of the run.
    #[error("{}: the {role} would overwrite the input {}", path.display(), input.display())]
    Input { path: PathBuf, role: String, input: PathBuf },
    /// An output names a folder.
    #[error("{}: the {role} is a folder, not a file", path.display())]
    Folder { path: PathBuf, role: String },
    /// An output's folder cannot be made or written in.
    #[error("{}: the {role}'s folder {}: {source}", path.display(), folder.display())]
    Unwritable {
        path: PathBuf,
        role: String,
        folder: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Where a file is, as a comparison key: its folder's canonical path and its name, and its
/// device and inode where it exists.
#[derive(Debug, PartialEq)]
struct Identity {
    path: PathBuf,
    inode: Option<(u64, u64)>,
}

impl Identity {
    fn same(&self, other: &Identity) -> bool {
        self.path == other.path || (self.inode.is_some() && self.inode == other.inode)
    }
}

fn inode(path: &Path) -> Option<(u64, u64)> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// The identity of `path` (whose folder exists).
fn identity(path: &Path) -> Identity {
    let canonical = std::fs::canonicalize(path).ok().or_else(|| {
        let folder = folder_of(path);
        let name = path.file_name()?;
        Some(std::fs::canonicalize(folder).ok()?.join(name))
    });
    Identity { path: canonical.unwrap_or_else(|| path.to_path_buf()), inode: inode(path) }
}

/// The folder `path` is in (`.` for a bare name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Checks the run's `outputs` (each with the role a message names it by: `"--out"`,
/// `"--poses"`) against each other and against its `inputs`, making each output's folder
/// where it is missing; nothing else is created or changed.
pub fn check(outputs: &[(&str, &Path)], inputs: &[&Path]) -> Result<(), OutputError> {
    let mut seen: Vec<(&str, Identity)> = Vec::new();
    let inputs: Vec<(&Path, Identity)> = inputs.iter().map(|p| (*p, identity(p))).collect();
    for &(role, path) in outputs {
        if path.is_dir() || path.as_os_str().is_empty() {
            return Err(OutputError::Folder { path: path.into(), role: role.into() });
        }
        let folder = folder_of(path);
        let unwritable = |source| OutputError::Unwritable {
            path: path.into(),
            role: role.into(),
            folder: folder.into(),
            source,
        };
        std::fs::create_dir_all(folder).map_err(unwritable)?;
        // The folder takes a new file: the one test that holds on every platform.
        tempfile::Builder::new()
            .prefix(".inchworm-check.")
            .tempfile_in(folder)
            .map_err(unwritable)?;
        let id = identity(path);
        if let Some((input, _)) = inputs.iter().find(|(_, i)| i.same(&id)) {
            return Err(OutputError::Input {
                path: path.into(),
                role: role.into(),
                input: input.to_path_buf(),
            });
        }
        if let Some((first, _)) = seen.iter().find(|(_, i)| i.same(&id)) {
            return Err(OutputError::Twice {
                path: path.into(),
                first: first.to_string(),
                second: role.into(),
            });
        }
        seen.push((role, id));
    }
    Ok(())
}

/// A file being written: a uniquely named temporary beside its target, which
/// [`Pending::commit`] renames over the target; dropped uncommitted, it is removed.
pub struct Pending {
    target: PathBuf,
    file: BufWriter<tempfile::NamedTempFile>,
}

impl Pending {
    /// A new temporary beside `target` (whose folder exists), named
    /// `.<name>.<random>.partial.<ext>` so a program that reads the format from the
    /// extension (a PNG encoder) writes it as the target's.
    pub fn new(target: &Path) -> std::io::Result<Pending> {
        let name = target.file_name().map(|n| n.to_string_lossy().into_owned());
        let name = name.unwrap_or_else(|| "output".into());
        let suffix = match target.extension() {
            Some(ext) => format!(".partial.{}", ext.to_string_lossy()),
            None => ".partial".into(),
        };
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(&suffix);
        // A new file's mode, as `File::create` gives it (0666 less the umask), not a
        // temporary's private 0600: the output is for its user's tools to read.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(std::fs::Permissions::from_mode(0o666));
        }
        let tmp = builder.tempfile_in(folder_of(target))?;
        Ok(Pending { target: target.to_path_buf(), file: BufWriter::new(tmp) })
    }

    /// The file it will become.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// The temporary's path, for a writer that opens the file itself (a plot).
    pub fn path(&self) -> &Path {
        self.file.get_ref().path()
    }

    /// Flushes the temporary, gives it the target's permissions where the target exists
    /// (a user's mode is kept), and renames it over the target.
    pub fn commit(self) -> std::io::Result<()> {
        let tmp = self.file.into_inner().map_err(|e| e.into_error())?;
        tmp.as_file().sync_all()?;
        if let Ok(m) = std::fs::metadata(&self.target) {
            std::fs::set_permissions(tmp.path(), m.permissions())?;
        }
        tmp.persist(&self.target).map_err(|e| e.error)?;
        Ok(())
    }

    /// The temporary as a `File`, for a writer that needs one (an archive).
    pub fn file(&mut self) -> &mut File {
        self.file.get_mut().as_file_mut()
    }
}

/// Writes `bytes` as `target` through a [`Pending`]: all of them, or `target` as it was.
pub fn write(target: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut p = Pending::new(target)?;
    p.write_all(bytes)?;
    p.commit()
}

impl Write for Pending {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_committed_file_replaces_the_target_and_leaves_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("run.csv");
        std::fs::write(&target, "old").unwrap();
        let mut p = Pending::new(&target).unwrap();
        assert!(p.path().to_string_lossy().ends_with(".partial.csv"));
        p.write_all(b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "old", "not before the commit");
        p.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
        assert_eq!(names(dir.path()), ["run.csv"]);
    }

    #[cfg(unix)]
    #[test]
    fn a_new_file_has_a_new_file_s_mode_and_a_replaced_one_keeps_its_own() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain.csv");
        std::fs::write(&plain, "x").unwrap();
        let want = std::fs::metadata(&plain).unwrap().permissions().mode() & 0o777;
        std::fs::remove_file(&plain).unwrap();
        Pending::new(&plain).unwrap().commit().unwrap();
        assert_eq!(std::fs::metadata(&plain).unwrap().permissions().mode() & 0o777, want);
        let own = dir.path().join("own.csv");
        std::fs::write(&own, "x").unwrap();
        std::fs::set_permissions(&own, std::fs::Permissions::from_mode(0o640)).unwrap();
        Pending::new(&own).unwrap().commit().unwrap();
        assert_eq!(std::fs::metadata(&own).unwrap().permissions().mode() & 0o777, 0o640);
    }

    #[test]
    fn an_uncommitted_file_leaves_the_target_as_it_was_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("run.csv");
        std::fs::write(&target, "old").unwrap();
        // A user's file with the name a fixed-name scheme would take.
        std::fs::write(dir.path().join("run.partial"), "mine").unwrap();
        {
            let mut p = Pending::new(&target).unwrap();
            p.write_all(b"half").unwrap();
        }
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "old");
        assert_eq!(std::fs::read_to_string(dir.path().join("run.partial")).unwrap(), "mine");
        assert_eq!(names(dir.path()), ["run.csv", "run.partial"]);
    }

    #[test]
    fn outputs_are_refused_when_they_meet_each_other_an_input_or_a_folder() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let input = d.join("system.ssp");
        std::fs::write(&input, "ssp").unwrap();
        let out = d.join("out.csv");
        // The same file by two spellings.
        let other = d.join("sub").join("..").join("out.csv");
        std::fs::create_dir(d.join("sub")).unwrap();
        let e = check(&[("--out", &out), ("--poses", &other)], &[]).unwrap_err();
        assert!(matches!(e, OutputError::Twice { .. }), "{e}");
        assert!(e.to_string().contains("named as --out and as --poses"), "{e}");
        let e = check(&[("--poses", &input)], &[&input]).unwrap_err();
        assert!(matches!(e, OutputError::Input { .. }), "{e}");
        let e = check(&[("--out", d)], &[]).unwrap_err();
        assert!(matches!(e, OutputError::Folder { .. }), "{e}");
        #[cfg(unix)]
        {
            // A hard link is the input under another name.
            let link = d.join("link.ssp");
            std::fs::hard_link(&input, &link).unwrap();
            let e = check(&[("--out", &link)], &[&input]).unwrap_err();
            assert!(matches!(e, OutputError::Input { .. }), "{e}");
        }
        check(&[("--out", &out), ("--poses", &d.join("new").join("poses.csv"))], &[&input])
            .unwrap();
        assert_eq!(std::fs::read_to_string(&input).unwrap(), "ssp");
        assert!(d.join("new").is_dir(), "the missing folder is made");
        assert!(!names(d).iter().any(|n| n.contains("inchworm-check")), "{:?}", names(d));
    }
}
