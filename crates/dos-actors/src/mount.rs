//! The mirror mount: [`Mount`], the kinematics (`MountFmu`: three runner positions to
//! piston, tip and tilt) as a client of its own, for an actor network of three
//! [`Inchworm`] actors and the mount; and [`MirrorMount`], the whole of
//! `dist/MirrorMount.ssp` (three actuators and the mount) as one client.

use inchworm_controller::SAMPLE_PERIOD;
use inchworm_fmi_export::Row;
use inchworm_fmu_models::MountFmu;
use interface::{Data, TryRead, TryUpdate, TryWrite};

use crate::inchworm::write;
use crate::table::Driven;
use crate::uid::*;
use crate::{Error, Inchworm};

/// The mount's kinematics, stepped every `SAMPLE_PERIOD` like the FMU in the SSP: its
/// outputs after a step are the pose of the positions set before it.
pub struct Mount {
    mount: Driven<MountFmu>,
    inputs: [&'static Row<MountFmu>; 3],
    k: u64,
    started: bool,
}

impl Mount {
    pub fn new(name: &str) -> Result<Self, Error> {
        let mount = Driven::<MountFmu>::new(name);
        let inputs = [
            mount.variable(MOUNT_INPUTS[0])?,
            mount.variable(MOUNT_INPUTS[1])?,
            mount.variable(MOUNT_INPUTS[2])?,
        ];
        Ok(Mount { mount, inputs, k: 0, started: false })
    }

    /// Sets a parameter (`radius`, `angle_a`) by its name in the mount FMU's table.
    pub fn parameter(mut self, name: &str, value: f64) -> Result<Self, Error> {
        if self.started {
            let message = format!("parameter `{name}` after the first step or output");
            return Err(Error::Usage { client: self.mount.client().to_owned(), message });
        }
        self.mount.set(name, value)?;
        Ok(self)
    }

    pub fn start(&mut self) -> Result<(), Error> {
        if !self.started {
            self.mount.exit_initialization(0.0)?;
            self.started = true;
        }
        Ok(())
    }

    /// Sets chain `i`'s runner position (m).
    pub fn set_position(&mut self, i: usize, z: f64) -> Result<(), Error> {
        self.mount.set_var(self.inputs[i], z)
    }

    pub fn step(&mut self) -> Result<(), Error> {
        self.start()?;
        self.mount.step(self.k as f64 * SAMPLE_PERIOD, SAMPLE_PERIOD)?;
        self.k += 1;
        Ok(())
    }

    /// An output (`piston`, `tip`, `tilt`) now.
    pub fn output(&mut self, name: &str) -> Result<f64, Error> {
        self.start()?;
        self.mount.get(name)
    }
}

impl TryUpdate for Mount {
    type Error = Error;
    fn try_update(&mut self) -> Result<&mut Self, Error> {
        self.step()?;
        Ok(self)
    }
}

macro_rules! positions {
    ($($id:literal),+) => {$(
        impl TryRead<RunnerPosition<$id>> for Mount {
            type Error = Error;
            fn try_read(&mut self, data: Data<RunnerPosition<$id>>) -> Result<&mut Self, Error> {
                self.set_position($id, *data)?;
                Ok(self)
            }
        }
    )+};
}
positions!(0, 1, 2);

macro_rules! pose {
    ($client:ty: $($uid:ident),+) => {$(
        impl TryWrite<$uid> for $client {
            type Error = Error;
            fn try_write(&mut self) -> Result<Option<Data<$uid>>, Error> {
                write::<$uid>(self.output(<$uid>::NAME))
            }
        }
    )+};
}
pose!(Mount: Piston, Tip, Tilt);

/// `dist/MirrorMount.ssp` as one client: three actuators (chains 0, 1, 2 for a, b, c) and
/// the mount, coupled as the master couples the system's ten FMUs (Jacobi, 2 ms: the mount
/// takes the runner positions at the step's start).
pub struct MirrorMount {
    pub chains: (Inchworm<0>, Inchworm<1>, Inchworm<2>),
    pub mount: Mount,
}

impl MirrorMount {
    pub fn new(name: &str) -> Result<Self, Error> {
        Ok(MirrorMount {
            chains: (
                Inchworm::new(&format!("{name}.a"))?,
                Inchworm::new(&format!("{name}.b"))?,
                Inchworm::new(&format!("{name}.c"))?,
            ),
            mount: Mount::new(&format!("{name}.mount"))?,
        })
    }

    pub fn step(&mut self) -> Result<(), Error> {
        let z = [
            self.chains.0.output(RunnerPosition::<0>::NAME)?,
            self.chains.1.output(RunnerPosition::<1>::NAME)?,
            self.chains.2.output(RunnerPosition::<2>::NAME)?,
        ];
        for (i, z) in z.into_iter().enumerate() {
            self.mount.set_position(i, z)?;
        }
        self.chains.0.step()?;
        self.chains.1.step()?;
        self.chains.2.step()?;
        self.mount.step()
    }

    fn output(&mut self, name: &str) -> Result<f64, Error> {
        self.mount.output(name)
    }
}

impl TryUpdate for MirrorMount {
    type Error = Error;
    fn try_update(&mut self) -> Result<&mut Self, Error> {
        self.step()?;
        Ok(self)
    }
}

pose!(MirrorMount: Piston, Tip, Tilt);

macro_rules! chain_io {
    ($($id:tt),+) => {$(
        impl TryRead<Reference<$id>> for MirrorMount {
            type Error = Error;
            fn try_read(&mut self, data: Data<Reference<$id>>) -> Result<&mut Self, Error> {
                self.chains.$id.set_reference(*data)?;
                Ok(self)
            }
        }
        impl TryWrite<EncoderCounts<$id>> for MirrorMount {
            type Error = Error;
            fn try_write(&mut self) -> Result<Option<Data<EncoderCounts<$id>>>, Error> {
                self.chains.$id.try_write()
            }
        }
        impl TryWrite<RunnerPosition<$id>> for MirrorMount {
            type Error = Error;
            fn try_write(&mut self) -> Result<Option<Data<RunnerPosition<$id>>>, Error> {
                self.chains.$id.try_write()
            }
        }
    )+};
}
chain_io!(0, 1, 2);
