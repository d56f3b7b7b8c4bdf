"""A campaign computes only the signals its rows read (issue 29): ``lean_signals`` leaves the
other signal columns ``nan`` and every row number is the same as with every signal computed
(the truth: ``outcome`` of a plain ``simulate`` of each member)."""

from __future__ import annotations

import copy
import dataclasses
import math
import warnings

import numpy as np
import pytest

from adaptive_ftc.campaigns import draw_member, load_campaign
from adaptive_ftc.campaigns.runner import outcome, run_chunk
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.scenarios import load_scenario
from adaptive_ftc.sim.batch import iter_simulate
from adaptive_ftc.sim.engine import simulate

#: hardware members (lag, rate limit, travel, digital controller, noise) with failures, judged
#: on tracking and activity
HARDWARE = {
    "name": "lean-hw",
    "base": "hypersonic-direct-s1",
    "designs": ["adaptive", "constraint-aware"],
    "runs": 4,
    "seed": 11,
    "chunk_size": 4,
    "duration": 3.0,
    "success": {"rms_error_final": 0.01, "final_window": 1.0},
    "failures": {
        "count": {"integers": [1, 2]},
        "onset": {"uniform": [0.5, 2.0]},
        "models": {
            "stuck": {"value": {"uniform": [-0.1, 0.1]}},
            "loss_of_effectiveness": {"effectiveness": {"uniform": [0.2, 0.9]}},
            "rate_limited": {"rate": {"uniform": [0.5, 2.0]}},
        },
    },
    "hardware": {
        "lag": {"uniform": [0.01, 0.05]},
        "rate_limit": [{"loguniform": [0.5, 10.0]}, 5.0],
        "travel": {"uniform": [0.3, 1.0]},
        "sample_time": {"choice": [0.0, 0.005]},
        "noise": {"alpha": {"uniform": [0.0, 1e-3]}},
    },
}

#: ideal actuators, failures with recoveries (the recovery columns), the default solver
IDEAL = {
    "name": "lean-ideal",
    "base": "hypersonic-direct-s1",
    "designs": ["adaptive"],
    "runs": 5,
    "seed": 7,
    "chunk_size": 5,
    "duration": 6.0,
    "success": {"rms_error_final": 8.7e-4, "final_window": 2.0},
    "failures": {
        "count": {"integers": [1, 2]},
        "onset": {"uniform": [0.5, 4.0]},
        "recovery_probability": 0.5,
        "duration": {"uniform": [0.5, 1.5]},
        "models": {
            "bias": {"bias": {"uniform": [-0.3, 0.3]}},
            "affine": {"effectiveness": {"uniform": [0.5, 1.0]}, "bias": {"uniform": [-0.2, 0.2]}},
        },
    },
}


def _same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


@pytest.mark.parametrize("data", [HARDWARE, IDEAL], ids=["hardware", "ideal"])
def test_lean_rows_equal_the_rows_of_full_runs(data):
    spec = load_campaign(copy.deepcopy(data))
    rows = run_chunk(spec, 0, jobs=2)
    thresholds = spec.activity.thresholds(spec) if spec.activity is not None else None
    k = 0
    checked = 0
    for i in range(spec.runs):
        mem = draw_member(spec, i)
        for d in spec.designs:
            row = rows[k]
            k += 1
            if mem.loop is None:
                continue
            with warnings.catch_warnings():  # a diverged member is a row, not a warning
                warnings.simplefilter("ignore", DivergenceWarning)
                result = simulate(mem.design_loop(d), spec.solver)
            full = outcome(result, spec, thresholds=thresholds)
            for key, value in full.items():
                assert _same(row[key], value), (i, d, key, row[key], value)
            checked += 1
    assert checked >= spec.runs  # every member ran (none invalid in these draws)


def test_lean_signals_are_the_full_ones_where_computed_and_nan_elsewhere():
    sc = load_scenario("hypersonic-direct-s1")
    loop = dataclasses.replace(sc.loop, t_final=3.0)
    full = simulate(loop, sc.solver)
    lean = simulate(loop, sc.solver, lean_signals=True)
    for name in ("time", "states", "adaptive", "e", "u_cmd", "u_applied"):
        assert np.array_equal(getattr(lean, name), getattr(full, name)), name
    for name in ("y", "yd", "s", "sdot", "u0", "gain", "control_gain"):
        lean_value, full_value = getattr(lean, name), getattr(full, name)
        assert lean_value.shape == full_value.shape, name
        assert np.all(np.isnan(lean_value)) and not lean_value.flags.writeable, name
        assert np.all(np.isfinite(full_value)), name  # a plain run keeps them all
    assert lean.metrics(fast=True) == pytest.approx(full.metrics(fast=True), nan_ok=True)
    streamed = list(iter_simulate([loop], sc.solver, jobs=1, lean_signals=True))[0]
    assert np.all(np.isnan(streamed.control_gain))
    assert np.array_equal(streamed.u_cmd, full.u_cmd)


@pytest.mark.parametrize(
    "name",
    [
        "hypersonic-direct-s1-actuators",
        "hypersonic-direct-s1-digital",
        "hypersonic-direct-s1-noise",
        "hypersonic-direct-s2",
        "hypersonic-estimation-s1",
        "hypersonic-nussbaum-s1-neg",
        "hypersonic-sign-s1-rho0pos",
        "manipulator-mimo-s1",
        "spacecraft-mimo-s2",
        "wingrock-estimation-s2",
        "pendulum-sign-reversed",
    ],
)
def test_the_commands_only_rhs_gives_the_commands_of_the_full_one(name):
    """Every part (sensors, digital controller, actuators, Nussbaum and sign laws, MIMO
    allocation, estimation) has its commands before the plant's hook: the lean pass, whose
    rhs stops there, gives the same errors and commands as the full signals."""
    sc = load_scenario(name)
    loop = dataclasses.replace(sc.loop, t_final=min(2.0, sc.loop.t_final))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        full = simulate(loop, sc.solver)
        lean = simulate(loop, sc.solver, lean_signals=True)
    assert full.time.size > 10
    for field in ("e", "u_cmd", "u_applied"):
        assert np.array_equal(getattr(lean, field), getattr(full, field), equal_nan=True), field
    assert np.all(np.isnan(lean.control_gain))


def _rhs_text(source: str) -> str:
    start = source.index("def rhs(t, Y, ph, D, W, dY):")
    end = source.index("\ndef ", start + 1)
    return source[start:end]


@pytest.mark.parametrize("sdot", ["exact", "filtered"])
def test_every_rhs_returns_after_its_commands_when_asked_for_them_only(sdot):
    """The lean pass gives ``rhs`` a ``dY`` one longer than ``Y`` (a derivative a part writes
    before the plant, the constraint-aware command filter's, stays in bounds): every catalogue
    loop's generated ``rhs`` returns there, after its commands (``u``, ``uf``) are set and
    before the plant's equations."""
    from adaptive_ftc.scenarios import list_scenarios
    from adaptive_ftc.sim.compose import generate
    from adaptive_ftc.sim.parts.skeleton import COMMANDS_ONLY_TEST

    guard = f"if {COMMANDS_ONLY_TEST}:"
    for name in list_scenarios():
        sc = load_scenario(name)
        text = _rhs_text(generate(sc.loop, sdot=sdot)[0])
        head, tail = text.split(guard)
        assert "uf[" in head and "u[" in head, name
        assert "plant_dynamics(" in tail and "plant_dynamics(" not in head, name
