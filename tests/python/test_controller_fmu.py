"""InchwormController.fmu in FMPy: validation, default simulation, and the timing contract."""
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu



def test_validates_without_problems(controller_fmu):
    assert validate_fmu(controller_fmu) == []


def test_simulates_with_defaults_and_starts_stepping_towards_the_reference(controller_fmu):
    # Encoder held at 0, reference 100 µm: the controller plans 3 full forward steps of ~26 µm and a
    # fraction, and drives the forward gait (non-earth brake powered from sample 15).
    result = simulate_fmu(controller_fmu, stop_time=0.2, start_values={"reference": 100e-6},
                          output=["dac_nonearth", "dac_nonearth_code", "n_steps", "moving"])
    assert result["n_steps"][-1] == 3
    assert result["dac_nonearth_code"].max() == 65535
    assert result["dac_nonearth"].max() == 10.0
    assert result["moving"][-1]


def test_step_sizes_other_than_multiples_of_2_ms_are_refused(controller_fmu):
    with pytest.raises(Exception):
        simulate_fmu(controller_fmu, stop_time=0.03, output_interval=0.003)
    result = simulate_fmu(controller_fmu, stop_time=0.04, output_interval=0.004)
    assert len(result) == 11
