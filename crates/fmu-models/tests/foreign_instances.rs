//! Each model's entry points, in both standards, given the instance of another model of
//! the project (Co-Simulation or Model Exchange): refused with an error, and the instance
//! left alone. In one process the models share the export layer's registry, which tells
//! their instances apart by type; in their own libraries each registry simply does not
//! know the other's pointers.

use inchworm_fmi_export::api::Fmi2;
use inchworm_fmi_export::fmi3::api::Fmi3;
use inchworm_fmi_export::testing::{assert_every_entry_point_refuses as refuses, Harness, Master};
use inchworm_fmi_export::Model;
use inchworm_fmu_models::{ControllerFmu, MountFmu, PlantFmu, ReferenceFmu};

type C = *mut std::ffi::c_void;

/// The instances of the other models, by what they are.
fn refused_by<S: Master, M: Model>(all: usize, others: &[(C, &str)]) {
    for &(c, what) in others {
        // SAFETY: live instances of other models; the layer must not read them as `M`.
        assert_eq!(unsafe { refuses::<S, M>(c, what) }, all);
    }
}

fn every_model_refuses_the_others<S: Master>(all: usize) {
    let plant = Harness::<PlantFmu, S>::init("plant");
    let plant_me = Harness::<PlantFmu, S>::init_me("plant_me");
    let controller = Harness::<ControllerFmu, S>::init("controller");
    let controller_me = Harness::<ControllerFmu, S>::init_me("controller_me");
    let reference = Harness::<ReferenceFmu, S>::init("reference");
    let mount = Harness::<MountFmu, S>::init("mount");
    let (p, pm, c, cm, r, m) =
        (plant.c, plant_me.c, controller.c, controller_me.c, reference.c, mount.c);
    let (pw, cw) = ("the plant's instance", "the controller's instance");
    let (rw, mw) = ("the reference's instance", "the mount's instance");
    let (pmw, cmw) = ("the plant's ME instance", "the controller's ME instance");
    refused_by::<S, PlantFmu>(all, &[(c, cw), (cm, cmw), (r, rw), (m, mw)]);
    refused_by::<S, ControllerFmu>(all, &[(p, pw), (pm, pmw), (r, rw), (m, mw)]);
    refused_by::<S, ReferenceFmu>(all, &[(p, pw), (pm, pmw), (c, cw), (cm, cmw), (m, mw)]);
    refused_by::<S, MountFmu>(all, &[(p, pw), (pm, pmw), (c, cw), (cm, cmw), (r, rw)]);
    // Left alone: each still steps, and none logged a word.
    let h = 0.002;
    assert_eq!(plant.step(0.0, h), 0, "{:?}", plant.logged());
    assert_eq!(controller.step(0.0, h), 0, "{:?}", controller.logged());
    assert_eq!(reference.step(0.0, h), 0, "{:?}", reference.logged());
    assert_eq!(mount.step(0.0, h), 0, "{:?}", mount.logged());
    assert_eq!(plant_me.enter_continuous_time_mode(), 0);
    assert_eq!(controller_me.enter_continuous_time_mode(), 0);
    for l in [plant.logged(), plant_me.logged(), controller.logged(), controller_me.logged()] {
        assert!(l.is_empty(), "{l:?}");
    }
}

#[test]
fn fmi2_every_model_refuses_the_others_instances() {
    every_model_refuses_the_others::<Fmi2>(41);
}

#[test]
fn fmi3_every_model_refuses_the_others_instances() {
    every_model_refuses_the_others::<Fmi3>(71);
}
