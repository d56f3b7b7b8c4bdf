"""CompiledLoop: one object owns a compiled loop's run (build, integrate, recorded)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from adaptive_ftc import load_scenario, simulate
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.engine import CompiledLoop, integrate_only
from adaptive_ftc.sim.status import RunStatus


@pytest.fixture(scope="module")
def short():
    sc = load_scenario("hypersonic-direct-s1")
    return dataclasses.replace(sc.loop, t_final=2.0), sc.solver


def test_its_three_steps_give_what_simulate_gives(short):
    loop, solver = short
    compiled = CompiledLoop.build(loop, solver)
    run = compiled.integrate()
    assert run.status is RunStatus.COMPLETED and run.reason is None
    T, Y, phases, signals, status, _ = compiled.recorded(run)
    result = simulate(loop, solver)
    np.testing.assert_array_equal(T, result.time)
    np.testing.assert_array_equal(Y, np.hstack([result.states, result.adaptive]))
    assert status is RunStatus.COMPLETED and result.meta["steps"] == int(run.stats[0])
    t, y, _ = integrate_only(loop, solver)
    np.testing.assert_array_equal(y, Y)
    np.testing.assert_array_equal(t, T)


def test_it_integrates_on_a_user_time_grid(short):
    loop, solver = short
    grid = np.array([0.0, 0.25, 1.5])
    compiled = CompiledLoop.build(loop, solver, t_eval=grid)
    run = compiled.integrate()
    assert run.nrec == 3
    np.testing.assert_array_equal(compiled.t_rec, grid)


def test_it_needs_a_closed_loop():
    with pytest.raises(ConfigurationError, match="needs a ClosedLoop; got str"):
        CompiledLoop.build("hypersonic-direct-s1", None)  # type: ignore[arg-type]
