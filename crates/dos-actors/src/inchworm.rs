//! [`Inchworm`]: one actuator, its controller and its plant, as a dos-actors client. The
//! two models the FMUs export (`ControllerFmu`, `PlantFmu`) are coupled in-process as the
//! co-simulation master couples the two FMUs: a Jacobi step of 2 ms per actor iteration,
//! each side's inputs the other's outputs at the step's start. So the controller's sample
//! timing contract (crates/fmu-models/src/controller.rs: inputs latched at `s_n`, the DAC
//! sample from them held from `s_(n+1)`) is the FMU's, and the traces are those of
//! `inchworm run` bit for bit.

use inchworm_controller::SAMPLE_PERIOD;
use inchworm_fmi_export::Row;
use inchworm_fmu_models::{ControllerFmu, PlantFmu};
use interface::{Data, TryRead, TryUpdate, TryWrite, UniqueIdentifier};

use crate::fmu_client::FmuValue;
use crate::table::Driven;
use crate::uid::*;
use crate::Error;

/// The loop's connections, by the tables' names: controller output, plant input.
const DACS: [&str; 3] = [
    ControllerFmu::name_of(ControllerFmu::DAC_EARTH),
    ControllerFmu::name_of(ControllerFmu::DAC_NONEARTH),
    ControllerFmu::name_of(ControllerFmu::DAC_EXTENSION),
];
const ENCODER: &str = PlantFmu::name_of(PlantFmu::ENCODER_COUNTS);

pub struct Inchworm<const ID: u8> {
    controller: Driven<ControllerFmu>,
    plant: Driven<PlantFmu>,
    /// Steps done: the time is `k × SAMPLE_PERIOD`, as the master keeps it.
    k: u64,
    started: bool,
    /// (controller output, plant input) of each DAC; (plant output, controller input) of
    /// the encoder; the controller's reference input.
    dacs: [(&'static Row<ControllerFmu>, &'static Row<PlantFmu>); 3],
    encoder: (&'static Row<PlantFmu>, &'static Row<ControllerFmu>),
    reference: &'static Row<ControllerFmu>,
}

impl<const ID: u8> Inchworm<ID> {
    /// The actuator with the FMUs' default parameters; `name` names it in errors.
    pub fn new(name: &str) -> Result<Self, Error> {
        let controller = Driven::<ControllerFmu>::new(format!("{name}.controller"));
        let plant = Driven::<PlantFmu>::new(format!("{name}.plant"));
        let mut dacs = Vec::with_capacity(3);
        for n in DACS {
            dacs.push((controller.variable(n)?, plant.variable(n)?));
        }
        let encoder = (plant.variable(ENCODER)?, controller.variable(ENCODER)?);
        let reference = controller.variable(Reference::<ID>::NAME)?;
        Ok(Inchworm {
            dacs: [dacs[0], dacs[1], dacs[2]],
            encoder,
            reference,
            controller,
            plant,
            k: 0,
            started: false,
        })
    }

    /// Sets a controller parameter by its name in the controller FMU's table.
    pub fn controller_parameter(mut self, name: &str, value: f64) -> Result<Self, Error> {
        self.before_start(name)?;
        self.controller.set(name, value)?;
        Ok(self)
    }

    /// Sets a plant parameter by its name in the plant FMU's table.
    pub fn plant_parameter(mut self, name: &str, value: f64) -> Result<Self, Error> {
        self.before_start(name)?;
        self.plant.set(name, value)?;
        Ok(self)
    }

    fn before_start(&self, name: &str) -> Result<(), Error> {
        if self.started {
            let message = format!("parameter `{name}` after the first step or output");
            return Err(Error::Usage { client: self.plant.client().to_owned(), message });
        }
        Ok(())
    }

    /// Leaves initialization (if not yet): both models check their parameters.
    pub fn start(&mut self) -> Result<(), Error> {
        if !self.started {
            self.controller.exit_initialization(0.0)?;
            self.plant.exit_initialization(0.0)?;
            self.started = true;
        }
        Ok(())
    }

    /// One Jacobi step of `SAMPLE_PERIOD`: the DAC volts and the encoder at the step's
    /// start cross over, then both models step.
    pub fn step(&mut self) -> Result<(), Error> {
        self.start()?;
        let t = self.k as f64 * SAMPLE_PERIOD;
        let encoder = self.plant.get_var(self.encoder.0);
        for (out, input) in self.dacs {
            let volts = self.controller.get_var(out);
            self.plant.set_var(input, volts)?;
        }
        self.controller.set_var(self.encoder.1, encoder)?;
        self.controller.step(t, SAMPLE_PERIOD)?;
        self.plant.step(t, SAMPLE_PERIOD)?;
        self.k += 1;
        Ok(())
    }

    /// Sets the reference (m) the next step's controller latches.
    pub fn set_reference(&mut self, reference: f64) -> Result<(), Error> {
        self.controller.set_var(self.reference, reference)
    }

    /// An output of the controller or the plant by its table name, now (the encoder is
    /// the plant's).
    pub fn output(&mut self, name: &str) -> Result<f64, Error> {
        self.start()?;
        if name != ENCODER {
            if let Ok(v) = self.controller.variable(name) {
                return Ok(self.controller.get_var(v));
            }
        }
        self.plant.get(name)
    }
}

impl<const ID: u8> TryUpdate for Inchworm<ID> {
    type Error = Error;
    fn try_update(&mut self) -> Result<&mut Self, Error> {
        self.step()?;
        Ok(self)
    }
}

impl<const ID: u8> TryRead<Reference<ID>> for Inchworm<ID> {
    type Error = Error;
    fn try_read(&mut self, data: Data<Reference<ID>>) -> Result<&mut Self, Error> {
        self.set_reference(*data)?;
        Ok(self)
    }
}

/// An output UID of a native client: its value by its FMU variable's name.
pub(crate) fn write<U>(value: Result<f64, Error>) -> Result<Option<Data<U>>, Error>
where
    U: UniqueIdentifier,
    U::DataType: FmuValue,
{
    value.map(|x| Some(Data::new(<U::DataType as FmuValue>::from_f64(x))))
}

macro_rules! outputs {
    ($($uid:ident),+) => {$(
        impl<const ID: u8> TryWrite<$uid<ID>> for Inchworm<ID> {
            type Error = Error;
            fn try_write(&mut self) -> Result<Option<Data<$uid<ID>>>, Error> {
                write::<$uid<ID>>(self.output(<$uid<ID>>::NAME))
            }
        }
    )+};
}

outputs!(
    EncoderCounts,
    RunnerPosition,
    DacEarth,
    DacNonearth,
    DacExtension,
    DacEarthCode,
    DacNonearthCode,
    DacExtensionCode,
    ServoError,
    DisturbanceEstimate,
    StepForward,
    StepBackward
);
