//! The models behind the project's FMUs: each is a variable table and a
//! [`inchworm_fmi_export::Model`] implementation mapping value references onto the plain
//! Rust plant or controller (or, for the reference, a small table of its own). The C
//! entry points are exported by the cdylib crates `inchworm-plant-fmu`,
//! `inchworm-plant-full-fmu`, `inchworm-controller-fmu`, `inchworm-reference-fmu`,
//! `inchworm-mount-fmu` and `inchworm-delay-line-fmu` (one `export_fmi2!` line each) and their FMI 3.0 counterparts, so
//! this crate links into tools such as `fmu-build` without clashing `fmi2*` symbols.

mod controller;
pub mod delay_line;
pub mod mount;
mod plant;
pub mod reference;

pub use controller::ControllerFmu;
pub use delay_line::DelayLineFmu;
pub use inchworm_controller::Params as ControllerParams;
/// The plant's declared parts, whose fields name its inputs and parameters
/// (`PlantFmu::var(Dac::EXTENSION)`).
pub use inchworm_plant::{Dac, PlantParams};
pub use mount::MountFmu;
pub use plant::{Formulation, PlantFmu, PlantFullFmu, PlantModel};
pub use reference::ReferenceFmu;
