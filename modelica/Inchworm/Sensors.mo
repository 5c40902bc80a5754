within Inchworm;
package Sensors "The encoder (docs/model.md section 2.6)"
  model Encoder "Incremental encoder on the runner: round((s - s_ref)/q), half away from zero, read every T_sample"
    parameter Types.Position q = 1.2e-9 "Resolution per count";
    parameter Types.Position s_ref = 0 "Position of count 0";
    parameter Types.Time T_sample = 0.002 "Read period (the FMU reads at every communication point)";
    Interfaces.Flange flange;
    Integer counts(start = 0, fixed = true) "Reading";
  protected
    Real y "Position in counts";
  equation
    flange.f = 0;
    y = (flange.s - s_ref)/q;
    when sample(0, T_sample) then
      counts = integer(if y >= 0 then floor(y + 0.5) else -floor(0.5 - y));
    end when;
  end Encoder;
end Sensors;
