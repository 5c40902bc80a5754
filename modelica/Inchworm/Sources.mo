within Inchworm;
package Sources "Recorded DAC sequences"
  block DacSequence "Recorded DAC volts of the three channels, each held for one sample (the board's zero-order hold); the last value is held after the end"
    parameter Types.Time T_sample = 0.002 "Sample period";
    parameter Real earth[:] = {0} "Earth-brake DAC volts, one per sample";
    parameter Real nonearth[size(earth, 1)] = zeros(size(earth, 1)) "Non-earth-brake DAC volts";
    parameter Real extension[size(earth, 1)] = zeros(size(earth, 1)) "Extension DAC volts";
    Interfaces.RealOutput y_earth(unit = "V", start = 0, fixed = true);
    Interfaces.RealOutput y_nonearth(unit = "V", start = 0, fixed = true);
    Interfaces.RealOutput y_extension(unit = "V", start = 0, fixed = true);
  protected
    Integer k(start = 0, fixed = true) "Samples taken";
  equation
    when sample(0, T_sample) then
      k = pre(k) + 1;
      y_earth = earth[min(pre(k) + 1, size(earth, 1))];
      y_nonearth = nonearth[min(pre(k) + 1, size(earth, 1))];
      y_extension = extension[min(pre(k) + 1, size(earth, 1))];
    end when;
  end DacSequence;
end Sources;
