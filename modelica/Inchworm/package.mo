within;
package Inchworm "JPL's flight inchworm actuator as acausal Modelica components: the plant of the InchwormPlant FMU"
  annotation (
    version = "0.1.0",
    Documentation(info = "<html><p>The plant of docs/model.md section 2 (driver-board analog chain, PZT stack with the passive Maxwell-slip hysteresis, brakes with events at V_th, flexure, runner with the brake disturbance, encoder) as components with electrical pins and translational flanges. <code>InchwormPlant</code> has the FMU's inputs, outputs and parameters (generated into <code>PlantInterface</code> from the same declaration). Self-contained: it needs no Modelica Standard Library. See docs/modelica.md.</p></html>"));
end Inchworm;
