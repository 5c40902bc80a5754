//! The models behind the project's FMUs: each is a variable table and a
//! [`inchworm_fmi_export::Model`] implementation mapping value references onto the plain
//! Rust plant or controller. The C entry points are exported by the cdylib crates
//! `inchworm-plant-fmu` and `inchworm-controller-fmu` (one `export_fmi2!` line each), so
//! this crate links into tools such as `fmu-build` without clashing `fmi2*` symbols.

mod controller;
mod plant;

pub use controller::ControllerFmu;
pub use plant::PlantFmu;
