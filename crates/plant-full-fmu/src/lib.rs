//! `InchwormPlantFull.so`: the FMI 2.0 entry points of the plant whose Model Exchange is the
//! model's own formulation (17 continuous states; docs/model.md §5).
inchworm_fmi_export::export_fmi2!(inchworm_fmu_models::PlantFullFmu);
