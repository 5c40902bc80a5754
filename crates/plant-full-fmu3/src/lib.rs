//! `InchwormPlantFull.so` for FMI 3.0: the entry points of the plant whose Model Exchange is
//! the model's own formulation (17 continuous states; docs/model.md §5).
inchworm_fmi_export::export_fmi3!(inchworm_fmu_models::PlantFullFmu);
