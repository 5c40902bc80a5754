//! `InchwormDelayLine.so`: the FMI 2.0 Co-Simulation entry points of the delay line.
inchworm_fmi_export::export_fmi2!(inchworm_fmu_models::DelayLineFmu);
