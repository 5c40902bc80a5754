within Inchworm;
package Types "SI types, the self-contained equivalents of Modelica.Units.SI that the components use"
  type Voltage = Real(quantity = "ElectricPotential", unit = "V");
  type Current = Real(quantity = "ElectricCurrent", unit = "A");
  type Charge = Real(quantity = "ElectricCharge", unit = "C");
  type Capacitance = Real(quantity = "Capacitance", unit = "F", min = 0);
  type Frequency = Real(quantity = "Frequency", unit = "Hz");
  type Time = Real(quantity = "Time", unit = "s");
  type Position = Real(quantity = "Length", unit = "m");
  type Velocity = Real(quantity = "Velocity", unit = "m/s");
  type Force = Real(quantity = "Force", unit = "N");
  type Mass = Real(quantity = "Mass", unit = "kg", min = 0);
  type TranslationalSpringConstant = Real(unit = "N/m");
  type TranslationalDampingConstant = Real(unit = "N.s/m");
  type TransducerConstant = Real(unit = "N/V") "Force per volt, equivalently charge per metre";
end Types;
