"""The FMI 2.0 co-simulation FMUs of a loop's digital controller and of its closed loop,
checked with FMPy.

Truth: the project's own simulation of the digital loop. FMPy drives the controller FMU with
that run's measurements and references at every sample (its input table), and runs the loop
FMU on its own; commands and states must equal the run's to 1e-9 relative (measured: 1e-13 or
less; sample times that are powers of two where the scenario has none, as in
test_export_c.py).
"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
import zipfile

import pytest

from adaptive_ftc.cli import main
from adaptive_ftc.errors import ConfigurationError

pytest.importorskip("fmpy")
pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")

from adaptive_ftc.export import export_fmu  # noqa: E402
from adaptive_ftc.export.sil import verify_fmu, verify_loop_fmu  # noqa: E402

TOL = 1e-9

CASES = [
    ("hypersonic-direct-s1", 0.005, None),  # §2.3, the whole 120 s
    ("hypersonic-direct-s1-digital", None, 45.0),  # constraint-aware, its own 200 Hz
    ("spacecraft-mimo-s1", 2.0**-8, 25.0),  # ch. 3 (MIMO), failures at 0 s and 20 s
    ("hypersonic-direct-s1-noise", 0.005, 20.0),  # sensor noise: filters started as the run
]


@pytest.mark.parametrize(("name", "ts", "t_final"), CASES, ids=[c[0] for c in CASES])
def test_fmu_validates_and_fmpy_reproduces_the_digital_run(name, ts, t_final, tmp_path):
    report = verify_fmu(name, sample_time=ts, t_final=t_final, workdir=tmp_path)
    assert report.samples > 1000
    assert report.command <= TOL, report
    assert report.controller_state <= TOL, report


def test_model_description_has_units_and_descriptions_of_every_variable(tmp_path):
    from fmpy.validation import validate_fmu

    fmu = export_fmu("hypersonic-direct-s1", tmp_path, sample_time=0.005)
    assert validate_fmu(str(fmu.path)) == []
    with zipfile.ZipFile(fmu.path) as z:
        names = set(z.namelist())
        md = ET.fromstring(z.read("modelDescription.xml"))
    assert {"sources/fmu.c", "sources/aftc.c", "sources/aftc.h"} <= names
    assert f"binaries/linux64/{fmu.model_identifier}.so" in names
    assert md.get("fmiVersion") == "2.0"
    variables = md.find("ModelVariables")
    by_name = {v.get("name"): v for v in variables}
    assert list(by_name) == list(fmu.variables)
    for v in variables:
        assert v.get("description"), v.get("name")
    units = {u.get("name") for u in md.find("UnitDefinitions")}
    assert by_name["y.alpha"].find("Real").get("unit") == "rad"
    assert by_name["y.q"].find("Real").get("unit") == "rad s-1"
    assert by_name["r.der2(alpha)"].find("Real").get("unit") == "rad s-2"
    assert by_name["u.delta_e1"].find("Real").get("unit") == "rad"
    assert {"rad", "rad s-1", "rad s-2", "s"} <= units
    assert by_name["u.delta_e1"].get("causality") == "output"
    assert by_name["gains.gamma"].get("causality") == "parameter"
    assert by_name["gains.gamma"].find("Real").get("start") == "5.0"


def test_fmu_parameters_retune_the_controller(tmp_path):
    # gamma set as a start value gives what the FMU exported with that gamma gives
    import dataclasses

    import numpy as np
    from fmpy import simulate_fmu

    from adaptive_ftc.scenarios.loader import load_scenario

    loop = load_scenario("hypersonic-direct-s1").loop
    a = export_fmu(loop, tmp_path / "a", sample_time=0.005, name="a")
    ctrl = dataclasses.replace(loop.controller, gamma=9.0)
    b = export_fmu(dataclasses.replace(loop, controller=ctrl), tmp_path / "b", sample_time=0.005,
                   name="b")  # fmt: skip
    t = np.arange(0.0, 2.0, 0.005)
    table = np.zeros(t.size, dtype=[("time", float), ("y.alpha", float), ("y.q", float),
                                    ("r.alpha", float)])  # fmt: skip
    table["time"], table["y.alpha"], table["r.alpha"] = t, 0.01 * np.sin(t), 0.05
    kw = dict(stop_time=1.5, step_size=0.005, output_interval=0.005, input=table,
              output=["u.delta_e1"])  # fmt: skip
    ua = simulate_fmu(str(a.path), start_values={"gains.gamma": 9.0}, **kw)["u.delta_e1"]
    ub = simulate_fmu(str(b.path), **kw)["u.delta_e1"]
    u0 = simulate_fmu(str(a.path), **kw)["u.delta_e1"]
    assert np.array_equal(ua, ub)
    assert not np.allclose(ua, u0)


LOOPS = [
    ("hypersonic-direct-s1", 2.0**-8, 42.0),  # §2.3, elevator failure at 40 s
    ("wingrock-direct-s1", 2.0**-8, 7.0),  # a NamedTuple with a tuple field, failures 3/6 s
    ("spacecraft-mimo-s1", 2.0**-8, 22.0),  # ch. 3, six wheels, failures at 0 s and 20 s
    ("hypersonic-nussbaum-s1-pos", 2.0**-10, 42.0),  # §4.3, non-affine failure patterns
    ("examples/own_plant.toml", 2.0**-8, 22.0),  # user plant written as equations
    ("hypersonic-direct-s1-actuators", 2.0**-8, 42.0),  # actuator lag, rate and travel
    ("hypersonic-direct-s1-noise", 0.005, 12.0),  # sensor noise and bias
]


@pytest.mark.parametrize(("name", "ts", "t_final"), LOOPS, ids=[c[0] for c in LOOPS])
def test_loop_fmu_reproduces_the_digital_run(name, ts, t_final, tmp_path):
    report = verify_loop_fmu(name, sample_time=ts, t_final=t_final, workdir=tmp_path)
    assert report.samples > 1000
    assert report.worst <= TOL, report


def test_loop_fmu_refuses_communication_points_between_break_times(tmp_path):
    from fmpy import simulate_fmu

    fmu = export_fmu("hypersonic-direct-s1", tmp_path, part="loop", sample_time=0.005)
    assert fmu.model_identifier == "hypersonic_direct_s1_loop"
    with pytest.raises(Exception, match="fmi2DoStep"):
        simulate_fmu(str(fmu.path), stop_time=0.1, step_size=0.003, output_interval=0.003)


def test_unknown_part_is_refused(tmp_path):
    with pytest.raises(ConfigurationError, match="'controller' or 'loop'"):
        export_fmu("hypersonic-direct-s1", tmp_path, part="plant", sample_time=0.005)


def test_cli_export_fmu(tmp_path, capsys):
    out = tmp_path / "f"
    args = ["export", "fmu", "hypersonic-direct-s1-digital", "--out", str(out)]
    assert main(args) == 0
    assert (out / "hypersonic_direct_s1_digital_controller.fmu").exists()
    assert "FMI 2.0 co-simulation" in capsys.readouterr().out
    assert main([*args, "--part", "loop"]) == 0
    assert (out / "hypersonic_direct_s1_digital_loop.fmu").exists()
    assert main([*args, "--part", "plant"]) == 2
