//! The FMU's shared library: found under `binaries/<platform>/`, loaded, its `fmi2*`
//! functions resolved and its platform and version checked.

use std::ffi::CStr;
use std::path::{Path, PathBuf};

use libloading::Library;

use crate::ffi::*;
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

/// The Co-Simulation functions of one binary. The required ones are plain pointers; the
/// optional ones (FMU state) are `None` when absent. All functions of the FMI 2.0 CS API
/// are resolved (a binary missing one is refused up front), not all are called yet.
#[allow(dead_code)]
#[derive(Clone, Copy)]
pub(crate) struct Api {
    pub get_types_platform: fmi2GetTypesPlatformTYPE,
    pub get_version: fmi2GetVersionTYPE,
    pub set_debug_logging: fmi2SetDebugLoggingTYPE,
    pub instantiate: fmi2InstantiateTYPE,
    pub free_instance: fmi2FreeInstanceTYPE,
    pub setup_experiment: fmi2SetupExperimentTYPE,
    pub enter_initialization_mode: fmi2EnterInitializationModeTYPE,
    pub exit_initialization_mode: fmi2ExitInitializationModeTYPE,
    pub terminate: fmi2TerminateTYPE,
    pub reset: fmi2ResetTYPE,
    pub get_real: fmi2GetRealTYPE,
    pub get_integer: fmi2GetIntegerTYPE,
    pub get_boolean: fmi2GetBooleanTYPE,
    pub get_string: fmi2GetStringTYPE,
    pub set_real: fmi2SetRealTYPE,
    pub set_integer: fmi2SetIntegerTYPE,
    pub set_boolean: fmi2SetBooleanTYPE,
    pub set_string: fmi2SetStringTYPE,
    pub do_step: fmi2DoStepTYPE,
    pub cancel_step: fmi2CancelStepTYPE,
    pub get_status: fmi2GetStatusTYPE,
    pub get_real_status: fmi2GetRealStatusTYPE,
    pub get_integer_status: fmi2GetIntegerStatusTYPE,
    pub get_boolean_status: fmi2GetBooleanStatusTYPE,
    pub get_string_status: fmi2GetStringStatusTYPE,
    pub get_fmu_state: Option<fmi2GetFMUstateTYPE>,
    pub set_fmu_state: Option<fmi2SetFMUstateTYPE>,
    pub free_fmu_state: Option<fmi2FreeFMUstateTYPE>,
    pub serialized_fmu_state_size: Option<fmi2SerializedFMUstateSizeTYPE>,
    pub serialize_fmu_state: Option<fmi2SerializeFMUstateTYPE>,
    pub de_serialize_fmu_state: Option<fmi2DeSerializeFMUstateTYPE>,
}

/// A loaded FMU binary. The function pointers in `api` are valid while `library` lives.
pub(crate) struct Binary {
    pub api: Api,
    pub path: PathBuf,
    #[allow(dead_code)]
    pub types_platform: String,
    pub version: String,
    // Held to keep the functions loaded; last, so unloaded after everything else here.
    #[allow(dead_code)]
    pub library: Library,
}

/// `binaries/<platform>/<model_identifier>.<ext>` (relative to `dir`, the unpacked FMU),
/// or a clear error naming the platforms the FMU does carry.
pub fn library_path(dir: &Path, model_identifier: &str) -> Result<PathBuf, ImportError> {
    library_path_for(fmi2_platform(), dir, model_identifier)
}

/// [`library_path`] for a platform folder and library extension (FMI 2.0 and FMI 3.0 name
/// their platform folders differently).
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

fn c_text(p: *const std::os::raw::c_char) -> String {
    if p.is_null() {
        "(NULL)".into()
    } else {
        // SAFETY: a non-NULL `fmi2String` from the FMU is a NUL-terminated string.
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

/// Checks that an ELF file holds every byte its headers point at. `dlopen` maps the
/// segments without checking, so a truncated library kills the process with SIGBUS when
/// the loader touches the missing pages; refuse it with an error instead. Files that are
/// not ELF are left to `dlopen` (which then says "invalid ELF header").
pub(crate) fn check_elf(path: &Path) -> Result<(), String> {
    use std::io::{Read, Seek, SeekFrom};
    let mut f = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let len = f.metadata().map_err(|e| e.to_string())?.len();
    let mut h = [0u8; 64];
    let n = f.read(&mut h).map_err(|e| e.to_string())?;
    if n < 4 || &h[..4] != b"\x7fELF" {
        return Ok(());
    }
    let truncated = |need: u64| {
        format!("the file is truncated or damaged: it has {len} bytes, its ELF headers need {need}")
    };
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
        return Err(format!("the file is damaged: program header entries of {phentsize} bytes"));
    }
    let mut ph = vec![0u8; (phentsize * phnum) as usize];
    f.seek(SeekFrom::Start(phoff))
        .and_then(|_| f.read_exact(&mut ph))
        .map_err(|e| e.to_string())?;
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

impl Binary {
    /// Loads the library at `dir/relative` and resolves its functions; errors name
    /// `relative` (the path inside the FMU).
    pub fn load(dir: &Path, relative: &Path) -> Result<Binary, ImportError> {
        let path = &dir.join(relative);
        let shown = relative.to_path_buf();
        check_elf(path).map_err(|message| ImportError::Load { library: shown.clone(), message })?;
        // SAFETY: loading a library runs its initializers; an FMU's binary is trusted code
        // by the nature of co-simulation (the master runs it).
        let library = unsafe { Library::new(path) }
            .map_err(|e| ImportError::Load { library: shown.clone(), message: e.to_string() })?;
        macro_rules! required {
            ($name:literal) => {{
                // SAFETY: the type is the FMI 2.0 signature of this function.
                match unsafe { library.get(concat!($name, "\0").as_bytes()) } {
                    Ok(sym) => *sym,
                    Err(_) => {
                        return Err(ImportError::MissingSymbol {
                            library: shown.clone(),
                            symbol: $name,
                        })
                    }
                }
            }};
        }
        macro_rules! optional {
            ($name:literal) => {{
                // SAFETY: as above.
                unsafe { library.get(concat!($name, "\0").as_bytes()) }.ok().map(|sym| *sym)
            }};
        }
        let api = Api {
            get_types_platform: required!("fmi2GetTypesPlatform"),
            get_version: required!("fmi2GetVersion"),
            set_debug_logging: required!("fmi2SetDebugLogging"),
            instantiate: required!("fmi2Instantiate"),
            free_instance: required!("fmi2FreeInstance"),
            setup_experiment: required!("fmi2SetupExperiment"),
            enter_initialization_mode: required!("fmi2EnterInitializationMode"),
            exit_initialization_mode: required!("fmi2ExitInitializationMode"),
            terminate: required!("fmi2Terminate"),
            reset: required!("fmi2Reset"),
            get_real: required!("fmi2GetReal"),
            get_integer: required!("fmi2GetInteger"),
            get_boolean: required!("fmi2GetBoolean"),
            get_string: required!("fmi2GetString"),
            set_real: required!("fmi2SetReal"),
            set_integer: required!("fmi2SetInteger"),
            set_boolean: required!("fmi2SetBoolean"),
            set_string: required!("fmi2SetString"),
            do_step: required!("fmi2DoStep"),
            cancel_step: required!("fmi2CancelStep"),
            get_status: required!("fmi2GetStatus"),
            get_real_status: required!("fmi2GetRealStatus"),
            get_integer_status: required!("fmi2GetIntegerStatus"),
            get_boolean_status: required!("fmi2GetBooleanStatus"),
            get_string_status: required!("fmi2GetStringStatus"),
            get_fmu_state: optional!("fmi2GetFMUstate"),
            set_fmu_state: optional!("fmi2SetFMUstate"),
            free_fmu_state: optional!("fmi2FreeFMUstate"),
            serialized_fmu_state_size: optional!("fmi2SerializedFMUstateSize"),
            serialize_fmu_state: optional!("fmi2SerializeFMUstate"),
            de_serialize_fmu_state: optional!("fmi2DeSerializeFMUstate"),
        };
        // SAFETY: both return a static NUL-terminated string.
        let types_platform = c_text(unsafe { (api.get_types_platform)() });
        if types_platform != "default" {
            return Err(ImportError::TypesPlatform(types_platform));
        }
        let version = c_text(unsafe { (api.get_version)() });
        if !version.starts_with("2.") {
            return Err(ImportError::BinaryVersion(version));
        }
        Ok(Binary { api, path: path.to_path_buf(), types_platform, version, library })
    }
}
