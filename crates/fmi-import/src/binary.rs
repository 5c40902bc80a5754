//! The FMU's shared library, for both standards: found under `binaries/<platform>/`,
//! checked whole, loaded, and its functions resolved by name (each backend names its own
//! standard's functions and signatures).

use std::ffi::CStr;
use std::path::{Path, PathBuf};

use libloading::Library;

use crate::description::text::cut;
use crate::error::LoadError;
use crate::ImportError;

/// The FMI 2.0 platform folder and library extension of this host, from the project's one
/// platform table. Where FMI 2.0 names no folder (64-bit ARM Linux) the lookup fails
/// with the folders the FMU does carry.
pub fn fmi2_platform() -> (&'static str, &'static str) {
    match inchworm_fmi_abi::platform::host() {
        Some(p) => (p.fmi2.unwrap_or("(none: FMI 2.0 names no folder for this host)"), p.lib_ext),
        None => ("(none: this host is not in the platform table)", "so"),
    }
}

/// The FMI 3.0 platform tuple and library extension of this host.
pub fn fmi3_platform() -> (&'static str, &'static str) {
    match inchworm_fmi_abi::platform::host() {
        Some(p) => (p.fmi3, p.lib_ext),
        None => ("(none: this host is not in the platform table)", "so"),
    }
}

/// `binaries/<platform>/<model_identifier>.<ext>` (relative to `dir`, the unpacked FMU)
/// for a platform folder and library extension (FMI 2.0 and FMI 3.0 name their platform
/// folders differently), or a clear error naming the platforms the FMU does carry.
pub fn library_path_for(
    (platform, ext): (&'static str, &str),
    dir: &Path,
    model_identifier: &str,
) -> Result<PathBuf, ImportError> {
    let file = format!("{model_identifier}.{ext}");
    let relative = Path::new("binaries").join(platform).join(&file);
    if dir.join(&relative).is_file() {
        return Ok(relative);
    }
    let mut available: Vec<String> = std::fs::read_dir(dir.join("binaries"))
        .map(|rd| {
            rd.filter_map(Result::ok)
                .filter(|e| e.path().is_dir())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    available.sort();
    Err(ImportError::NoBinary {
        platform,
        expected: format!("binaries/{platform}/{file}"),
        available,
    })
}

/// A C string from the FMU, copied (`(NULL)` for a NULL pointer).
pub(crate) fn c_text(p: *const std::os::raw::c_char) -> String {
    if p.is_null() {
        "(NULL)".into()
    } else {
        // SAFETY: a non-NULL string from the FMU is NUL-terminated.
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

/// Checks that an ELF file holds every byte its headers point at. `dlopen` maps the
/// segments without checking, so a truncated library kills the process with SIGBUS when
/// the loader touches the missing pages; refuse it with an error instead. Files that are
/// not ELF are left to `dlopen` (which then says "invalid ELF header").
pub(crate) fn check_elf(path: &Path) -> Result<(), LoadError> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = std::fs::File::open(path).map_err(LoadError::Read)?;
    let len = f.metadata().map_err(LoadError::Read)?.len();
    let mut h = [0u8; 64];
    let n = f.read(&mut h).map_err(LoadError::Read)?;
    if n < 4 || &h[..4] != b"\x7fELF" {
        return Ok(());
    }
    let truncated = |need: u64| LoadError::Truncated { len, need };
    let (wide, little) = (h[4] == 2, h[5] != 2);
    let header = if wide { 64 } else { 52 };
    if (n as u64) < header {
        return Err(truncated(header));
    }
    let u = |b: &[u8], at: usize, size: usize| -> u64 {
        let mut v = 0u64;
        for i in 0..size {
            let byte = u64::from(b[at + if little { size - 1 - i } else { i }]);
            v = (v << 8) | byte;
        }
        v
    };
    let (phoff, shoff, phentsize, phnum, shentsize, shnum) = if wide {
        (
            u(&h, 0x20, 8),
            u(&h, 0x28, 8),
            u(&h, 0x36, 2),
            u(&h, 0x38, 2),
            u(&h, 0x3A, 2),
            u(&h, 0x3C, 2),
        )
    } else {
        (
            u(&h, 0x1C, 4),
            u(&h, 0x20, 4),
            u(&h, 0x2A, 2),
            u(&h, 0x2C, 2),
            u(&h, 0x2E, 2),
            u(&h, 0x30, 2),
        )
    };
    let ph_end = phoff.saturating_add(phentsize.saturating_mul(phnum));
    if ph_end > len {
        return Err(truncated(ph_end));
    }
    if shoff != 0 {
        let sh_end = shoff.saturating_add(shentsize.saturating_mul(shnum));
        if sh_end > len {
            return Err(truncated(sh_end));
        }
    }
    let min_entry = if wide { 0x28 } else { 0x14 };
    if phnum > 0 && phentsize < min_entry {
        return Err(LoadError::EntrySize(phentsize));
    }
    let mut ph = vec![0u8; (phentsize * phnum) as usize];
    f.seek(SeekFrom::Start(phoff)).and_then(|_| f.read_exact(&mut ph)).map_err(LoadError::Read)?;
    for e in ph.chunks(phentsize.max(1) as usize) {
        let (offset, filesz) =
            if wide { (u(e, 0x08, 8), u(e, 0x20, 8)) } else { (u(e, 0x04, 4), u(e, 0x10, 4)) };
        let end = offset.saturating_add(filesz);
        if filesz > 0 && end > len {
            return Err(truncated(end));
        }
    }
    Ok(())
}

/// An FMU's shared library, loaded. The functions resolved from it are valid while it lives.
pub(crate) struct Binary {
    /// The path inside the FMU (what errors name).
    pub path: PathBuf,
    /// The path on disk, inside the unpacked directory.
    pub full_path: PathBuf,
    library: Library,
}

impl Binary {
    /// Loads the library at `dir/relative`, after checking that an ELF file is whole;
    /// errors name `relative` (the path inside the FMU).
    pub fn load(dir: &Path, relative: &Path) -> Result<Binary, ImportError> {
        let path = &dir.join(relative);
        let shown = relative.to_path_buf();
        check_elf(path).map_err(|source| ImportError::Load { library: shown.clone(), source })?;
        // SAFETY: loading a library runs its initializers; an FMU's binary is trusted code
        // by the nature of co-simulation (the master runs it).
        let library = unsafe { Library::new(path) }.map_err(|e| ImportError::Load {
            library: shown.clone(),
            source: LoadError::Dlopen(e),
        })?;
        Ok(Binary { path: shown, full_path: path.clone(), library })
    }

    /// The function `name`, or `None` if the library does not export it.
    ///
    /// # Safety
    /// `T` must be the C signature of `name` in the standard the library implements.
    pub unsafe fn optional<T: Copy>(&self, name: &'static str) -> Option<T> {
        let mut symbol = Vec::with_capacity(name.len() + 1);
        symbol.extend_from_slice(name.as_bytes());
        symbol.push(0);
        self.library.get::<T>(&symbol).ok().map(|sym| *sym)
    }

    /// The function `name`; a library without it is refused.
    ///
    /// # Safety
    /// As for [`Binary::optional`].
    pub unsafe fn required<T: Copy>(&self, name: &'static str) -> Result<T, ImportError> {
        self.optional(name)
            .ok_or_else(|| ImportError::MissingSymbol { library: self.path.clone(), symbol: name })
    }

    /// The function `name` if the FMU declares the capability `flag` (`declared`); a
    /// library that declares it but lacks the function is refused, and one that does not
    /// declare it gets `None` (its function is never called, present or not).
    ///
    /// # Safety
    /// As for [`Binary::optional`].
    pub unsafe fn capability<T: Copy>(
        &self,
        name: &'static str,
        flag: &'static str,
        declared: bool,
    ) -> Result<Option<T>, ImportError> {
        if !declared {
            return Ok(None);
        }
        self.optional(name).map(Some).ok_or_else(|| ImportError::MissingCapability {
            library: self.path.clone(),
            symbol: name,
            flag,
        })
    }

    /// Checks what `function` (`fmi2GetVersion`, `fmi3GetVersion`) returned.
    pub fn check_version(
        function: &'static str,
        p: *const std::os::raw::c_char,
        expected: &'static str,
    ) -> Result<String, ImportError> {
        let version = c_text(p);
        if version.starts_with(expected) {
            Ok(version)
        } else {
            Err(ImportError::BinaryVersion { function, found: cut(&version, 100), expected })
        }
    }
}
