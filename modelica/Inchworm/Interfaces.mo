within Inchworm;
package Interfaces "Connectors and partial models, the self-contained equivalents of the Modelica Standard Library's pins and flanges"
  connector Pin "Electrical pin (as Modelica.Electrical.Analog.Interfaces.Pin)"
    Types.Voltage v "Potential at the pin";
    flow Types.Current i "Current flowing into the pin";
  end Pin;

  connector Flange "Translational flange (as Modelica.Mechanics.Translational.Interfaces.Flange)"
    Types.Position s "Absolute position of the flange";
    flow Types.Force f "Cut force directed into the flange";
  end Flange;

  connector RealInput = input Real "Real input signal";
  connector RealOutput = output Real "Real output signal";
  connector IntegerOutput = output Integer "Integer output signal";
  connector BooleanInput = input Boolean "Boolean input signal";
  connector BooleanOutput = output Boolean "Boolean output signal";

  partial model OnePort "Two pins with one current through them (as the MSL's OnePort)"
    Types.Voltage v "Voltage drop p.v - n.v";
    Types.Current i "Current from p through the component to n";
    Pin p "Positive pin";
    Pin n "Negative pin";
  equation
    v = p.v - n.v;
    0 = p.i + n.i;
    i = p.i;
  end OnePort;

  partial model Compliant "Two flanges and the force between them (as the MSL's PartialCompliant)"
    Flange flange_a "Left flange";
    Flange flange_b "Right flange";
    Types.Position s_rel "Distance flange_b.s - flange_a.s";
    Types.Force f "Tension: the force that pulls the flanges together";
  equation
    s_rel = flange_b.s - flange_a.s;
    flange_b.f = f;
    flange_a.f = -f;
  end Compliant;
end Interfaces;
