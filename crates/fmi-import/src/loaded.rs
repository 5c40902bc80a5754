//! [`Loaded`]: an FMU loaded in the interface a master picks from its description, before
//! the archive is unpacked: a [`CsFmu`] (with event mode or without), an [`MeFmu`] or an
//! [`SeFmu`].

use std::path::Path;
use std::sync::Arc;

use crate::instance::importing;
use crate::{archive, CsFmu, FmuError, Instance, Interface, MeFmu, ModelDescription, SeFmu};

/// An FMU instantiated for the interface its master picked.
#[derive(Debug)]
pub enum Loaded {
    /// Co-Simulation, with event mode or without ([`CsFmu::event_mode_used`]).
    Cs(CsFmu),
    Me(MeFmu),
    Se(SeFmu),
}

impl Loaded {
    /// Reads `path`'s `modelDescription.xml` from the archive (nothing written to disk),
    /// picks the interface with `model_exchange` (Model Exchange if it says so of the
    /// description, else Co-Simulation) and hands both to `vet`; then unpacks the archive
    /// and instantiates the FMU for that interface. A master that picks the interface by
    /// what an FMU offers decides on the description, in one place, and unpacks the
    /// archive once whichever it picks; an FMU `vet` refuses is never
    /// unpacked nor loaded. A master bounds there what it will allocate from the
    /// description (its states, its event indicators), so that an FMU declaring too much
    /// is refused with a message instead of failing an allocation, before any temporary
    /// file exists. The instance keeps the description `vet` saw.
    pub fn load_vetted<E: From<FmuError>>(
        path: &Path,
        instance_name: &str,
        logging_on: bool,
        model_exchange: impl FnOnce(&ModelDescription) -> bool,
        vet: impl FnOnce(&ModelDescription, bool) -> Result<(), E>,
    ) -> Result<Loaded, E> {
        let pick = |md: &ModelDescription| match model_exchange(md) {
            true => Interface::ModelExchange,
            false => Interface::CoSimulation,
        };
        Self::load_picked(path, instance_name, logging_on, pick, |md, i| {
            vet(md, i == Interface::ModelExchange)
        })
    }

    /// [`Loaded::load_vetted`] with the interface picked among all four (Co-Simulation
    /// with or without event mode, Model Exchange, Scheduled Execution). An interface the
    /// FMU does not offer is refused before it is unpacked.
    pub fn load_picked<E: From<FmuError>>(
        path: &Path,
        instance_name: &str,
        logging_on: bool,
        pick: impl FnOnce(&ModelDescription) -> Interface,
        vet: impl FnOnce(&ModelDescription, Interface) -> Result<(), E>,
    ) -> Result<Loaded, E> {
        if !path.is_file() {
            return Err(FmuError::Missing(path.to_path_buf()).into());
        }
        let import = importing(path);
        let text = archive::read_description(path).map_err(import)?;
        let description = ModelDescription::parse(&text).map_err(import)?;
        let interface = pick(&description);
        interface.check_offered(&description)?;
        vet(&description, interface)?;
        let unpacked = Arc::new(archive::unpack(path).map_err(import)?);
        let instance = Instance::from_description(
            path,
            unpacked,
            description,
            instance_name,
            (logging_on, |_: &ModelDescription| interface),
        )?;
        Ok(Self::wrap(instance)?)
    }

    /// The wrapper of the interface `instance` was instantiated for.
    fn wrap(instance: Instance) -> Result<Loaded, FmuError> {
        Ok(match instance.interface() {
            Interface::ModelExchange => Loaded::Me(MeFmu::wrap(instance)),
            Interface::ScheduledExecution => Loaded::Se(SeFmu::wrap(instance)),
            Interface::CoSimulation | Interface::CoSimulationEventMode => {
                Loaded::Cs(CsFmu::wrap(instance))
            }
        })
    }
}
