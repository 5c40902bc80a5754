within Inchworm;
package Electrical "The driver board's analog chain and the PZTs' electrical side (docs/model.md sections 2.1, 2.2, 2.4)"
  model Ground "Zero potential"
    Interfaces.Pin p;
  equation
    p.v = 0;
  end Ground;

  block BesselFilter "Unity-gain second-order Bessel low-pass, -3 dB at f_bessel (docs/model.md section 2.1)"
    parameter Types.Frequency f_bessel = 300 "-3 dB frequency";
    final parameter Real w(unit = "rad/s") = 2*3.14159265358979323846*f_bessel/1.36165 "Natural frequency: 1.36165 rad/s is the -3 dB point of s^2 + 3 s + 3";
    Interfaces.RealInput u(unit = "V") "DAC volts";
    Interfaces.RealOutput y(unit = "V", start = 0, fixed = true) "Filtered volts";
    Real dy(unit = "V/s", start = 0, fixed = true) "Rate of the output";
  equation
    der(y) = dy;
    der(dy) = 3*w*w*(u - y) - 3*w*dy;
  end BesselFilter;

  model Amplifier "PZT amplifier: gain amp_gain with a first-order roll-off at f_amp, an ideal voltage source at its output (docs/model.md section 2.1)"
    extends Interfaces.OnePort(v(start = 0, fixed = true));
    parameter Real amp_gain = 10 "Voltage gain";
    parameter Types.Frequency f_amp = 475 "Roll-off frequency";
    Interfaces.RealInput u(unit = "V") "Filtered DAC volts";
  equation
    der(v) = 2*3.14159265358979323846*f_amp*(amp_gain*u - v);
  end Amplifier;

  model BrakePZT "A brake's PZT as the driver sees it: its voltage decides the brake at V_th; it draws no current (docs/model.md section 2.2)"
    extends Interfaces.OnePort;
    parameter Types.Voltage V_th = 50 "Threshold voltage";
    parameter Boolean powerOn "true: closed while v >= V_th (the non-earth brake); false: closed while v < V_th (the power-off earth brake)";
    Interfaces.BooleanOutput closed "The brake clamps";
  equation
    i = 0;
    closed = if powerOn then v >= V_th else v < V_th;
  end BrakePZT;

  model HysteresisElement "Passive Maxwell-slip hysteresis: elastic-slip elements in series with the PZT capacitance (docs/model.md section 2.4.2)"
    extends Interfaces.OnePort;
    parameter Types.Voltage r[:] = {15, 30, 45, 60, 75} "Slip radii of the stop operators";
    parameter Real w[size(r, 1)] = {0.08, 0.07, 0.06, 0.05, 0.04} "Weights: element k is the capacitance C/w[k]";
    parameter Types.Capacitance C = 4e-6 "PZT capacitance";
    Types.Voltage E[size(r, 1)](each start = 0, each fixed = true) "Stop outputs clamp(xi - p, -r, r): each element's charge over C";
    Boolean slipping[size(r, 1)] "Element at its clamp with the charge moving outward";
  equation
    for k in 1:size(r, 1) loop
      slipping[k] = E[k] >= r[k] and i > 0 or E[k] <= -r[k] and i < 0;
      der(E[k]) = if slipping[k] then 0 else i/C;
    end for;
    v = w*E;
  end HysteresisElement;

  model PiezoTransducer "The PZT stack as a two-port: voltage and charge, force and elongation, coupled by T_em (docs/model.md section 2.4.1)"
    extends Interfaces.OnePort;
    parameter Types.TransducerConstant T_em = 8.8 "Electromechanical transformer ratio";
    parameter Types.Capacitance C = 4e-6 "Capacitance";
    parameter Types.Position L = 0.036 "Rest length";
    Interfaces.Flange flange_a "Base end";
    Interfaces.Flange flange_b "Moving end";
    Types.Position delta "Elongation flange_b.s - flange_a.s - L";
    Types.Force F "Piezo force, pushing the flanges apart";
  equation
    delta = flange_b.s - flange_a.s - L;
    i = C*der(v) + T_em*der(delta);
    F = T_em*v;
    flange_b.f = -F;
    flange_a.f = F;
  end PiezoTransducer;
end Electrical;
