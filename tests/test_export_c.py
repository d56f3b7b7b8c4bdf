"""The C export of a loop's digital controller and its software-in-the-loop checks.

Truth: the project's own simulation of the digital loop (RK4, the command and the controller's
derivatives held between samples). ``verify`` closes the loop around the compiled C (the
project's plant integrated between samples as the simulator integrates it); ``replay`` feeds
the C the simulator's own states at every sample of a whole run.

Sample times are powers of two where the scenario has none: the sample instants are then
exact doubles, so the C's period and the simulator's intervals are the same number and the
only difference left is the rounding of the states' update, which the closed loop amplifies
(windows below are chosen to include a failure where the loop keeps that below 1e-12).
"""

from __future__ import annotations

import ast
import re
import shutil
import subprocess

import pytest

from adaptive_ftc.cli import main
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.export import export_c
from adaptive_ftc.export.pyc import DOUBLE, Source, Translator
from adaptive_ftc.export.sil import CFLAGS, replay, verify
from adaptive_ftc.scenarios.loader import list_scenarios

pytestmark = pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")

TOL = 1e-12
HZ256, HZ1024, HZ4096 = 2.0**-8, 2.0**-10, 2.0**-12

# (scenario, sample time (None: its own), end of the window (s)): every design of the thesis,
# the constraint-aware §2.3 law at its own 200 Hz, a user plant written in a scenario file,
# and loops with actuator dynamics and sensor noise
CLOSED_LOOP = [
    ("hypersonic-direct-s1", HZ256, 42.0),  # §2.3, elevator failure at 40 s
    ("hypersonic-direct-s1-digital", None, 42.0),  # §2.3 constraint-aware, 200 Hz
    ("hypersonic-estimation-s1", HZ1024, 42.0),  # §2.4 on the hypersonic plant
    ("wingrock-direct-s1", HZ256, 7.0),  # wing rock, failures at 3 s and 6 s
    ("manipulator-mimo-s1", HZ1024, 10.0),  # ch. 3, failure at 8 s
    ("spacecraft-mimo-s1", HZ256, 22.0),  # ch. 3, failures at 0 s and 20 s
    ("hypersonic-nussbaum-s1-pos", HZ1024, 42.0),  # §4.3, failure at 40 s
    ("pendulum-nussbaum-reversed", HZ1024, 12.0),  # §4.3, reversed direction at 10 s
    ("pendulum-sign-reversed", HZ256, 12.0),  # §4.4, reversed direction at 10 s
    ("examples/own_plant.toml", HZ256, 22.0),  # user plant (equations in the file), 10/20 s
    # beyond the thesis: the plant side the C never sees, integrated by the simulator's jump
    ("hypersonic-direct-s1-actuators", HZ256, 42.0),  # actuator lag, rate and travel limits
    ("hypersonic-direct-s1-noise", HZ256, 12.0),  # sensor noise and bias (y = x + offset)
]


@pytest.mark.parametrize(("name", "ts", "t_final"), CLOSED_LOOP, ids=[c[0] for c in CLOSED_LOOP])
def test_exported_controller_in_the_loop_equals_the_simulation(name, ts, t_final, tmp_path):
    report = verify(name, sample_time=ts, t_final=t_final, workdir=tmp_path)
    assert report.samples > 100
    assert report.command <= TOL, report
    assert report.plant_state <= TOL, report
    assert report.controller_state <= TOL, report


# the loops that amplify rounding fastest (their Euler-held adaptation is near its stability
# limit at these rates): a short closed-loop window, and the replay over the failures
SENSITIVE = [
    ("wingrock-estimation-s1", HZ4096, 0.5, 7.0),  # §2.4 on wing rock (failures 3 s, 6 s)
    ("hypersonic-sign-s1-rho0pos", HZ1024, 0.6, 12.0),  # §4.4 on the hypersonic plant
]


@pytest.mark.parametrize(
    ("name", "ts", "t_loop", "t_replay"), SENSITIVE, ids=[c[0] for c in SENSITIVE]
)
def test_sensitive_loops_short_window_and_replay(name, ts, t_loop, t_replay, tmp_path):
    report = verify(name, sample_time=ts, t_final=t_loop, workdir=tmp_path / "loop")
    assert report.worst <= TOL, report
    again = replay(name, sample_time=ts, t_final=t_replay, workdir=tmp_path / "replay")
    assert again.samples > 1000
    assert again.worst <= 1e-14, again


def test_replay_of_a_whole_run_gives_the_simulators_commands_bit_for_bit(tmp_path):
    # the C's arithmetic is the simulator's: fed the same states it computes the same command.
    # Its next states differ by rounding: at 200 Hz the simulator's sample intervals are
    # differences of rounded times (0.005 within 1e-15 s at t = 100 s), the C's is 0.005
    report = replay("hypersonic-direct-s1-digital", workdir=tmp_path)
    assert report.samples == 24000  # 120 s at 200 Hz
    assert report.command == 0.0
    assert report.controller_state <= TOL


def test_the_c_compiles_clean_under_the_strict_flags_and_is_self_contained(tmp_path):
    out = export_c("spacecraft-mimo-s1", tmp_path, sample_time=HZ256)
    text = out.source.read_text()
    # libm and the header only: no heap, no other library
    assert re.findall(r"#include <(\w+)\.h>", text) == ["math", "string"]
    assert not re.search(r"\b(malloc|calloc|realloc|free|printf)\s*\(", text)
    lib = tmp_path / "a.so"
    subprocess.run(["cc", *CFLAGS, str(out.source), "-o", str(lib), "-lm"], check=True)
    assert lib.stat().st_size > 0


def test_header_documents_every_input_and_output_with_units(tmp_path):
    out = export_c("hypersonic-direct-s1", tmp_path, sample_time=0.005)
    h = out.header.read_text()
    assert "y[0] = alpha [rad]" in h and "y[1] = q [rad s-1]" in h
    assert "r[0] = desired alpha [rad]" in h and "r[2] = its second derivative [rad s-2]" in h
    assert "u[0] = command of delta_e1 [rad]" in h and "u[1] = command of delta_e2 [rad]" in h
    for k in range(25):
        assert f"states[{k}] = theta_{k + 1}" in h
    assert "states[25] = s_filter1" in h
    for proto in ("aftc_init(", "aftc_reset(", "aftc_step(", "aftc_reference("):
        assert proto in h
    assert (out.n_y, out.n_r, out.n_u, out.n_states) == (2, 3, 2, 26)


def test_retuning_changes_only_the_const_params(tmp_path):
    # two loops of one structure with other gains and filter: the same code, only the
    # numbers of aftc_default_params differ (so a user retunes without regenerating)
    import dataclasses

    from adaptive_ftc.scenarios.loader import load_scenario

    loop = load_scenario("hypersonic-direct-s1").loop
    ctrl = dataclasses.replace(loop.controller, gamma=7.5, lam=3.0, k0=0.5)
    a = export_c(loop, tmp_path / "a", sample_time=0.005)
    b = export_c(dataclasses.replace(loop, controller=ctrl), tmp_path / "b", sample_time=0.005)
    ta, tb = a.source.read_text(), b.source.read_text()

    def code(text: str) -> str:
        return re.sub(r"default_params = \{.*?\n\};", "", text, flags=re.S)

    assert ta != tb and code(ta) == code(tb)
    assert "{7.5, 0.01}, /* gains */" in tb and "{3.0}, /* lam */" in tb
    assert a.header.read_text() == b.header.read_text()


def test_prefix_names_every_symbol(tmp_path):
    out = export_c("hypersonic-direct-s1", tmp_path, sample_time=0.005, prefix="pitch")
    text = out.source.read_text() + out.header.read_text()
    assert "pitch_step(" in text and "PITCH_NY" in text
    assert not re.search(r"\baftc_", text)
    with pytest.raises(ConfigurationError, match="prefix"):
        export_c("hypersonic-direct-s1", tmp_path, sample_time=0.005, prefix="1x")


@pytest.mark.parametrize("name", list_scenarios())
def test_every_catalogue_scenario_exports_and_compiles_clean(name, tmp_path):
    out = export_c(name, tmp_path, sample_time=0.005)
    subprocess.run(
        ["cc", *CFLAGS, str(out.source), "-o", str(tmp_path / "a.so"), "-lm"], check=True
    )


def test_a_design_that_needs_the_plant_model_is_refused(tmp_path):
    from adaptive_ftc.baselines import fixed_gain, nominal_inverse
    from adaptive_ftc.scenarios.loader import load_scenario

    loop = load_scenario("hypersonic-direct-s1").loop
    with pytest.raises(ConfigurationError, match="plant's model or its failures"):
        export_c(nominal_inverse(loop), tmp_path, sample_time=0.005)
    assert export_c(fixed_gain(loop), tmp_path, sample_time=0.005).n_states == 26


def test_a_continuous_controller_needs_a_sample_time(tmp_path):
    with pytest.raises(ConfigurationError, match="--sample-time"):
        export_c("hypersonic-direct-s1", tmp_path)


def test_an_unstable_s_filter_is_refused(tmp_path):
    from adaptive_ftc.scenarios.loader import load_scenario

    sc = load_scenario("hypersonic-direct-s1")
    import dataclasses

    from adaptive_ftc.sim.engine import SolverOptions

    sc = dataclasses.replace(sc, solver=SolverOptions(filter_tau=0.001))
    with pytest.raises(ConfigurationError, match="filter_tau"):
        export_c(sc, tmp_path, sample_time=0.005)


def _with_a_list(x, out):
    """A part with a construct the translator does not take (a list)."""
    v = [x, 2.0 * x]
    out[0] = v[0]


def test_untranslatable_python_is_refused_naming_construct_file_and_line():
    import inspect

    from adaptive_ftc.export.c import _source_of

    src = _source_of(_with_a_list)
    tr = Translator(lambda name: None, [], (), "aftc")
    line = inspect.getsourcelines(_with_a_list)[1] + 2
    with pytest.raises(ConfigurationError) as err:
        tr.function(src, [DOUBLE, "double *"])
    msg = str(err.value)
    assert "the expression List in `[x, 2.0 * x]`" in msg
    assert f"test_export_c.py:{line}" in msg


def test_translation_keeps_python_semantics():
    # true division of integers, floor division and modulo toward minus infinity, min/max
    # ties, tuple returns as out-pointers: compiled and run against Python's answers
    code = """
def parts(a, b):
    return a // b, a % b

def f(x, n, m, out):
    q, r = parts(n, m)
    out[0] = n / m
    out[1] = q
    out[2] = r
    out[3] = min(x, -x, 0.5)
    out[4] = max(abs(x), 2.0) ** 2
    out[5] = x if n > m else -x
"""
    tree = ast.parse(code)
    defs = {n.name: Source(n, "<test>") for n in tree.body}
    tr = Translator(defs.get, [], (), "t")
    tr.function(defs["f"], [DOUBLE, "long", "long", "double *"], name="t_f")
    text = tr.text().replace("static void t_f", "void t_f")
    import ctypes
    import tempfile
    from pathlib import Path

    import numpy as np

    d = Path(tempfile.mkdtemp())
    (d / "t.c").write_text("#include <math.h>\n" + text)
    subprocess.run(["cc", *CFLAGS, str(d / "t.c"), "-o", str(d / "t.so"), "-lm"], check=True)
    lib = ctypes.CDLL(str(d / "t.so"))
    lib.t_f.argtypes = [ctypes.c_double, ctypes.c_long, ctypes.c_long, ctypes.c_void_p]
    ns: dict = {}
    exec(compile(tree, "<test>", "exec"), ns)  # noqa: S102 - the same code, in Python
    for x, n, m in [(-0.7, -7, 2), (1.5, 7, -2), (0.25, 5, 3), (-3.0, -9, -4)]:
        got, want = np.zeros(6), np.zeros(6)
        lib.t_f(x, n, m, got.ctypes.data)
        ns["f"](x, n, m, want)
        assert np.array_equal(got, want), (x, n, m, got, want)


def test_cli_export_c(tmp_path, capsys):
    out = tmp_path / "c"
    assert (
        main(["export", "c", "hypersonic-direct-s1", "--sample-time", "0.005", "--out", str(out)])
        == 0
    )
    assert (out / "aftc.h").exists() and (out / "aftc.c").exists()
    assert "26 controller states" in capsys.readouterr().out
    assert main(["export", "c", "hypersonic-direct-s1", "--out", str(out)]) == 2
    assert "--sample-time" in capsys.readouterr().err
    assert (
        main(["export", "c", "hypersonic-direct-s1-digital", "--out", str(out), "--prefix", "ca"])
        == 0
    )
    assert (out / "ca.c").exists()
    assert main(["export", "c", "--help"]) == 0
    assert "exit status:" in capsys.readouterr().out
