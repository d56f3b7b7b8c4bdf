"""The C export of the constraint-aware MIMO law with its model feedforward (issue 25).

The feedforward (``mimo.C_FEEDFORWARD``, ``ConstraintAware.model_feedforward``) evaluates the
healthy plant's equations on the reference read ahead: the exported controller carries the
plant's equations and nominal parameters for it (``nominal_dynamics``, ``params.plant``).

Truth: the simulator's digital run, as in ``tests/test_export_c.py`` (closed loop and replay,
a power-of-two sample time so that the sample instants are exact doubles). The manipulator
under campaign-like motors (40 ms lag, 20 N m/s, +-10 N m: the rate limit binds, so the
hedging states move too) at 128 Hz over 10 s, through the scenario's motor failure at 8 s.
"""

from __future__ import annotations

import ctypes
import dataclasses
import math
import re
import shutil
from dataclasses import dataclass, replace

import numpy as np
import pytest

from adaptive_ftc.baselines import nominal_inverse, oracle
from adaptive_ftc.controllers.constraints import ConstraintAware
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.export import export_c
from adaptive_ftc.export.sil import CompiledController, compile_library, replay, verify
from adaptive_ftc.hardware import Actuators
from adaptive_ftc.plants.manipulator import TwoLinkManipulator
from adaptive_ftc.scenarios.loader import load_scenario

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")

TOL = 1e-12
HZ128 = 2.0**-7


def _hardware(loop, **ca):
    """``loop`` on the motors above at 128 Hz, with the constraint-aware law its hardware
    gives (``ca``: changes of it)."""
    loop = replace(
        loop,
        actuators=Actuators(tau=0.04, rate=20.0, lower=-10.0, upper=10.0),
        sample_time=HZ128,
    )
    aware = replace(ConstraintAware.from_loop(loop), **ca)
    return replace(loop, controller=replace(loop.controller, constraint_aware=aware))


@pytest.fixture(scope="module")
def arm():
    return _hardware(load_scenario("manipulator-mimo-s1").loop)


def test_the_feedforward_exports_and_equals_the_simulation_in_the_loop(arm, tmp_path):
    cfg = arm.controller.bound(arm).configuration()
    assert cfg.feedforward > 0  # on, read ahead by the lags (84 ms)
    report = verify(arm, t_final=10.0, workdir=tmp_path / "loop")
    assert report.samples == 1280
    assert report.command <= TOL, report  # 4.5e-15
    assert report.plant_state <= TOL, report
    assert report.controller_state <= TOL, report  # 3.1e-14
    again = replay(arm, t_final=10.0, workdir=tmp_path / "replay")
    assert again.command == 0.0  # the simulator's arithmetic, bit for bit
    assert again.controller_state <= TOL


def test_the_controller_carries_the_plants_nominal_model(arm, tmp_path):
    out = export_c(arm, tmp_path)
    text, header = out.source.read_text(), out.header.read_text()
    # the plant's equations (plants/manipulator.py), called by the designer's model only
    assert "static void aftc_dynamics(" in text
    calls = re.findall(r"\baftc_dynamics\(", text)
    assert len(calls) == 2  # its definition and the call in aftc_nominal_dynamics
    assert re.search(r"aftc_nominal_dynamics\(t, wb \+ \d+", text)
    # the plant's nominal parameters, a field of the params, as the scenario gives them
    a = arm.plant.parameter_values()
    assert "double plant[4];" in header and "Model feedforward" in header
    assert "{" + ", ".join(repr(float(v)) for v in a) + "}, /* plant */" in text
    # no failure, actuator or plant-side buffer in the controller
    assert not re.search(r"\b(aftc_failure\w*|aftc_act|aftc_instance)\(", text)


def test_the_feedforward_reads_params_plant(arm, tmp_path):
    # the plant's numbers are the params' (a user sets their plant's nominal ones): other
    # numbers give another command at the first sample, from the same state and reference
    out = export_c(arm, tmp_path)
    lib = compile_library(out.source, tmp_path / "lib.so")
    nw = int(re.search(r"#define AFTC_NW (\d+)", out.header.read_text()).group(1))
    ctrl = CompiledController(lib, out.n_y, out.n_states, out.n_u, nw)
    y = np.array(arm.initial_state, dtype=float)
    r = np.zeros(6)
    u_scenario = ctrl.step(y, r, 0.0)
    plant = _writable_plant_params(ctrl, out, tmp_path)
    assert np.array_equal(plant, arm.plant.parameter_values())
    ctrl.init()
    assert np.array_equal(ctrl.step(y, r, 0.0), u_scenario)  # the copy: the same command
    plant *= 1.5
    ctrl.init()
    assert not np.allclose(ctrl.step(y, r, 0.0), u_scenario, rtol=1e-6, atol=0.0)


def _writable_plant_params(ctrl: CompiledController, out, tmp_path) -> np.ndarray:
    """Point ``ctrl`` at a writable copy of ``aftc_default_params`` (const in the library)
    and return a view of its ``plant`` field (offset and size from a probe compiled against
    the header)."""
    probe = tmp_path / "probe.c"
    probe.write_text(
        f'#include <stddef.h>\n#include "{out.header}"\n'
        "long plant_at(void) { return (long)offsetof(aftc_params, plant); }\n"
        "long params_size(void) { return (long)sizeof(aftc_params); }\n"
    )
    so = compile_library(probe, tmp_path / "probe.so")
    lib = ctypes.CDLL(str(so))
    for f in (lib.plant_at, lib.params_size):
        f.restype = ctypes.c_long
    buf = ctypes.create_string_buffer(lib.params_size())
    ctypes.memmove(buf, ctrl.params, lib.params_size())
    ctrl.params = ctypes.addressof(buf)
    ctrl.params_copy = buf  # kept alive with the controller
    return np.frombuffer(memoryview(buf), dtype=np.float64, count=4, offset=lib.plant_at())


def test_without_the_feedforward_the_plant_stays_out(tmp_path):
    loop = _hardware(load_scenario("manipulator-mimo-s1").loop, model_feedforward=False)
    out = export_c(loop, tmp_path)
    assert "aftc_dynamics" not in out.source.read_text()
    assert "plant" not in re.sub(r"plant states|plant '", "", out.header.read_text())


def test_designs_that_need_the_true_plant_stay_refused(arm, tmp_path):
    for design in (nominal_inverse, oracle):
        with pytest.raises(ConfigurationError, match="plant's model or its failures"):
            export_c(design(arm), tmp_path)


def _erf_arm(t, x, uf, p, xdot):
    """Two decoupled joints whose equations use ``math.erf`` (numba takes it, the C export
    does not)."""
    xdot[0] = x[1]
    xdot[1] = (uf[0] + uf[1]) / p.a1 + 0.0 * math.erf(x[0])
    xdot[2] = x[3]
    xdot[3] = (uf[2] + uf[3]) / p.a2


@dataclass(frozen=True, kw_only=True)
class _ErfArm(TwoLinkManipulator):
    equations = staticmethod(_erf_arm)


def test_a_plant_the_export_cannot_translate_names_model_feedforward_false(tmp_path):
    sc = load_scenario("manipulator-mimo-s1")
    p = sc.loop.plant
    plant = _ErfArm(**{f.name: getattr(p, f.name) for f in dataclasses.fields(p) if f.init})
    loop = _hardware(replace(sc.loop, plant=plant))
    with pytest.raises(ConfigurationError) as err:
        export_c(loop, tmp_path)
    msg = str(err.value)
    assert "math.erf" in msg and "test_export_c_feedforward.py" in msg
    assert "plant's model" in msg and "ConstraintAware(model_feedforward=False)" in msg
    off = _hardware(replace(sc.loop, plant=plant), model_feedforward=False)
    assert export_c(off, tmp_path).source.is_file()


def test_the_fmus_carry_it_too(arm, tmp_path):
    # the controller FMU (built from the same C) and the closed-loop FMU (the plant side
    # translated beside it), against the simulator's run
    pytest.importorskip("fmpy")
    from adaptive_ftc.export.sil import verify_fmu, verify_loop_fmu

    ctrl = verify_fmu(arm, t_final=10.0, workdir=tmp_path / "controller")
    assert ctrl.samples > 1000 and ctrl.worst <= TOL, ctrl
    loop = verify_loop_fmu(arm, t_final=10.0, workdir=tmp_path / "loop")
    assert loop.samples == 1280 and loop.worst <= TOL, loop
