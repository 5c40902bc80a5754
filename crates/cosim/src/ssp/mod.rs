//! Reading an SSP 1.0 file: the system structure (components, connectors, connections)
//! and parameter sets, enough to run a flat system of FMI 2.0 and FMI 3.0 Co-Simulation FMUs.
//! Elements and attributes this master does not use (geometry, annotations of other
//! tools, units) are skipped, not refused.
//!
//! [`Archive`] here is the unpacked file; `structure` reads `SystemStructure.ssd`'s
//! system, `parameters` its parameter bindings and the `.ssv` parameter sets, and `xml`
//! holds the helpers both readers share.

mod parameters;
mod structure;
mod xml;

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use crate::Error;
pub use parameters::*;
pub use structure::*;

/// An SSP archive unpacked into a temporary directory (removed when the last clone is
/// dropped: the parts of a system split over threads share one unpacked folder).
#[derive(Clone)]
pub struct Archive {
    pub dir: PathBuf,
    pub system: System,
    /// Owns `dir`: removes it when the last clone is dropped.
    _unpacked: std::sync::Arc<crate::archive::Unpacked>,
}

impl Archive {
    pub fn open(path: &Path) -> Result<Archive, Error> {
        let unpacked = crate::archive::unpack_ssp(path)?;
        let dir = unpacked.dir().to_path_buf();
        let mut ssd = String::new();
        std::fs::File::open(dir.join("SystemStructure.ssd"))
            .and_then(|mut f| f.read_to_string(&mut ssd))
            .map_err(|source| Error::NoSsd { path: path.to_path_buf(), source })?;
        let system = parse_ssd(&ssd).map_err(|e| e.context(path.display().to_string()))?;
        Ok(Archive { dir, system, _unpacked: std::sync::Arc::new(unpacked) })
    }

    /// The parameter set `name` as `component.variable` → value text: the SSD's
    /// ParameterBindings whose set has that name ([`Archive::bound_parameter_set`]), else
    /// (an SSP without bindings) the file `resources/<name>.ssv` with qualified names.
    pub fn parameter_set(&self, name: &str) -> Result<BTreeMap<String, String>, Error> {
        Ok(self.parameter_set_typed(name)?.into_iter().map(|(n, (_, v))| (n, v)).collect())
    }

    /// [`Archive::parameter_set`] with each value's SSP type.
    pub fn parameter_set_typed(&self, name: &str) -> Result<BTreeMap<String, TypedValue>, Error> {
        if let Some(values) = self.bound_parameter_set_typed(Some(name))? {
            return Ok(values);
        }
        let p = self.dir.join("resources").join(format!("{name}.ssv"));
        let text = std::fs::read_to_string(&p)
            .map_err(|e| Error::Ssp(format!("parameter set {name}: {}: {e}", p.display())))?;
        parse_ssv_typed(&text)
            .map_err(|e| e.context(format!("parameter set {name} (resources/{name}.ssv)")))
    }

    fn read_ssd(&self) -> Result<String, Error> {
        let p = self.dir.join("SystemStructure.ssd");
        std::fs::read_to_string(&p).map_err(|source| Error::Io { path: p, source })
    }

    /// An `.ssv` of a binding, by its `source` relative to the SSP root; a source that
    /// would leave the archive is refused.
    fn read_bound_ssv(&self, source: &str) -> Result<String, Error> {
        let rel = Path::new(source);
        if rel.is_absolute()
            || rel.components().any(|c| !matches!(c, std::path::Component::Normal(_)))
        {
            return Err(Error::Ssp(format!(
                "parameter binding source `{source}` must be a relative path inside the SSP"
            )));
        }
        let p = self.dir.join(rel);
        std::fs::read_to_string(&p).map_err(|e| {
            Error::Ssp(format!("parameter binding source `{source}`: {}: {e}", p.display()))
        })
    }

    /// What a run records by default: the system's output connectors, or for a closed
    /// system (none) every component's output connector (`component.connector`).
    pub fn default_outputs(&self, system_outputs: Vec<String>) -> Result<Vec<String>, Error> {
        if !system_outputs.is_empty() {
            return Ok(system_outputs);
        }
        parse_component_outputs(&self.read_ssd()?)
    }
}
