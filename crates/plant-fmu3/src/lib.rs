//! `InchwormPlant.so` for FMI 3.0: the FMI 3.0 Co-Simulation entry points of the plant model.
inchworm_fmi_export::export_fmi3!(inchworm_fmu_models::PlantFmu);
