"""The C reference of the benchmarks (benchmarks/c/hypersonic_loop.c) is a faithful copy of the
hypersonic §2.3 closed loop: it reproduces the library's trajectories to 1e-9 (no timing here;
the speed comparisons live in benchmarks/bench_engine.py and bench_batch.py)."""

from __future__ import annotations

import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_close

from adaptive_ftc import simulate
from adaptive_ftc.faults import Affine, Bias, LossOfEffectiveness, NonAffine, Stuck

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import _cref  # noqa: E402

try:
    _cref.find_compiler()
except _cref.CReferenceError:  # pragma: no cover - depends on the machine
    pytest.skip("no C compiler (cc, gcc, clang) on this machine", allow_module_level=True)

T_FINAL = 10.0


@pytest.fixture(scope="module")
def exe():
    return _cref.build()


@pytest.fixture(scope="module")
def scenario():
    return _cref.rk4_scenario("hypersonic-direct-s1")


def _python(loop, solver):
    r = simulate(loop, solver)
    assert r.status == "completed"
    return r


def test_c_reference_matches_scenario_run_on_alpha_for_10_s(exe, scenario):
    loop = replace(scenario.loop, t_final=T_FINAL)
    r = _python(loop, scenario.solver)
    c = _cref.run_single(exe, t_final=T_FINAL)
    assert c.status == 0
    assert_close(c.time, r.time, atol=1e-12, what="record grid")
    assert_close(c.states[:, 0], r.states[:, 0], atol=1e-9, what="alpha")
    assert_close(c.states[:, 2:], r.adaptive, atol=1e-9, what="theta")
    assert_close(c.signal("e"), r.e[:, 0], atol=1e-9, what="tracking error")
    assert_close(c.signal("u0"), r.u0[:, 0], atol=1e-9, what="u0")


def test_c_reference_matches_scenario_1_failures_moved_into_the_window(exe, scenario):
    # scenario 1's failures (oscillating stuck elevator 2, affine elevator 1) at 3 s and 6 s
    stuck, affine = scenario.loop.failures.failures
    loop = replace(
        scenario.loop,
        t_final=T_FINAL,
        failures=(replace(stuck, onset=3.0), replace(affine, onset=6.0)),
    )
    r = _python(loop, scenario.solver)
    records = [
        (2, 4, 3.0, math.inf, 0.1, 0.05, 0.5, 0.08),
        (1, 3, 6.0, math.inf, 0.75, -0.2, 0.0, 0.0),
    ]
    c = _cref.run_single(exe, t_final=T_FINAL, records=records)
    assert_close(c.states[:, 0], r.states[:, 0], atol=1e-9, what="alpha")
    assert_close(c.signals[:, 11:13], r.u_applied, atol=1e-9, what="applied deflections")
    assert_close(c.signal("control_gain"), r.control_gain, atol=1e-9, what="control gain")


def test_c_batch_matches_simulate_for_each_failure_model_with_recovery(exe, scenario):
    cases = [
        (LossOfEffectiveness(actuator=1, onset=2.0, recovery=5.5, effectiveness=0.3),),
        (Bias(actuator=2, onset=1.5, bias=-0.07), Stuck(actuator=1, onset=4.25, value=0.05)),
        (Affine(actuator=2, onset=3.0, recovery=8.0, effectiveness=0.6, bias=0.04),),
    ]
    loops = [replace(scenario.loop, t_final=T_FINAL, failures=f) for f in cases]
    runs = [((0.03, 0.0), _cref.failure_records(f)) for f in cases]
    _elapsed, rows = _cref.run_batch(exe, runs, threads=2, t_final=T_FINAL)
    for loop, row in zip(loops, rows, strict=True):
        r = _python(loop, scenario.solver)
        assert row[0] == 0 and row[1] == r.time.size
        final = np.concatenate([r.states[-1], r.adaptive[-1]])
        assert_close(row[2:], final, atol=1e-9, what=str(loop.failures.failures))


def test_failures_the_c_cannot_run_are_refused_with_the_culprit():
    with pytest.raises(_cref.CReferenceError, match="NonAffine"):
        _cref.failure_records([NonAffine(actuator=1, onset=1.0, output="u**3")])
    with pytest.raises(_cref.CReferenceError, match="numeric `value`"):
        _cref.failure_records([Stuck(actuator=1, onset=1.0, value="0.1*sin(t)")])
