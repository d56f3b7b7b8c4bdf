"""Batches: streamed results (iter_simulate), the structures a batch shares, and the envelope
check that the signals' pass does."""

from __future__ import annotations

import math
import threading
import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc import (
    Bias,
    DivergenceWarning,
    LossOfEffectiveness,
    SolverOptions,
    Stuck,
    iter_simulate,
    load_scenario,
    simulate,
    simulate_many,
)
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim import compose
from adaptive_ftc.sim.engine import integrate_only


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("hypersonic-direct-s1")


def _loops(sc, n, t_final=3.0):
    out = []
    for k in range(n):
        fails = (
            (LossOfEffectiveness(actuator=1, onset=0.5 + 0.1 * k, effectiveness=0.5),)
            if k % 2
            else (
                Stuck(actuator=2, onset=1.0, value=0.01 * k),
                Bias(actuator=1, onset=2, bias=0.02),
            )
        )
        out.append(replace(sc.loop, t_final=t_final, failures=fails, initial_state=(0.01 * k, 0.0)))
    return out


def test_iter_simulate_yields_what_simulate_gives_in_input_order(scenario):
    loops = _loops(scenario, 7)
    streamed = list(iter_simulate(loops, scenario.solver, jobs=2, window=3))
    assert len(streamed) == len(loops)
    for loop, r in zip(loops, streamed, strict=True):
        alone = simulate(loop, scenario.solver)
        np.testing.assert_array_equal(r.states, alone.states)
        np.testing.assert_array_equal(r.u_applied, alone.u_applied)
        assert r.failures == alone.failures


def test_iter_simulate_draws_at_most_a_window_of_loops_ahead(scenario):
    loops = _loops(scenario, 9, t_final=1.0)
    drawn = []
    lock = threading.Lock()

    def source():
        for loop in loops:
            with lock:
                drawn.append(loop)
            yield loop

    taken = 0
    for _ in iter_simulate(source(), scenario.solver, jobs=2, window=3):
        taken += 1
        # taken results + the window in flight: a generator is never read ahead further
        assert len(drawn) <= taken + 3
    assert taken == len(loops) == len(drawn)


def test_leaving_iter_simulate_early_starts_no_more_runs(scenario):
    loops = _loops(scenario, 12, t_final=1.0)
    started = []
    real = compose.assemble

    def counting(loop, **kw):
        started.append(loop)
        return real(loop, **kw)

    it = iter_simulate(loops, scenario.solver, jobs=2, window=2)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("adaptive_ftc.sim.engine.assemble", counting)
        first = next(it)
        it.close()  # what leaving a for loop does
        n = len(started)
    assert first.status == "completed"
    assert n <= 3  # the first run and at most the window's other two


@pytest.mark.parametrize(
    ("kw", "match"),
    [({"jobs": -1}, "jobs"), ({"jobs": 1.5}, "jobs"), ({"window": 0}, "window")],
)
def test_iter_simulate_refuses_bad_settings(scenario, kw, match):
    with pytest.raises(ConfigurationError, match=match):
        next(iter_simulate(_loops(scenario, 1, t_final=0.5), scenario.solver, **kw))


def test_simulate_many_refuses_negative_jobs(scenario):
    with pytest.raises(ConfigurationError, match="jobs"):
        simulate_many(_loops(scenario, 1, t_final=0.5), scenario.solver, jobs=-2)


def test_loops_that_differ_in_failures_share_their_generated_structure(scenario):
    a, b = _loops(scenario, 2)
    compose._structures.clear()
    text_a, data_a, g_a, _ = compose.generate(a)
    text_b, data_b, g_b, layout_b = compose.generate(b)
    assert g_b is g_a and text_b == text_a  # generated once
    # the numbers are b's own: the same as generating b alone
    compose._structures.clear()
    text_c, data_c, _, layout_c = compose.generate(b)
    assert text_c == text_b
    np.testing.assert_array_equal(data_b.c, data_c.c)
    np.testing.assert_array_equal(data_b.i, data_c.i)
    assert layout_b["bps"] == layout_c["bps"] and layout_b["patterns"] == layout_c["patterns"]
    assert not np.array_equal(data_a.i, data_b.i)  # different failures, different tables


def test_a_new_part_object_is_generated_again(scenario):
    a = _loops(scenario, 1)[0]
    compose._structures.clear()
    _, data_a, g_a, _ = compose.generate(a)
    faster = replace(a, controller=replace(a.controller, k=a.controller.k * 2))
    _, data_b, g_b, _ = compose.generate(faster)
    assert g_b is not g_a
    k_at = compose.generate(a)[3]["c:k"]
    assert data_b.c[k_at][0] == 2 * data_a.c[k_at][0]


def test_the_signals_pass_cuts_a_run_where_the_records_leave_the_envelope(scenario):
    """scipy's path checks no envelope while it integrates: the cut comes from the records.
    The compiled signals' pass must cut where numpy's check of the records does."""
    loop = replace(scenario.loop, allocation=(-1.0, -2.0), t_final=20.0)  # wrong direction
    solver = SolverOptions(method="RK45", rtol=1e-6, atol=1e-9, record_dt=0.01)
    with pytest.warns(DivergenceWarning, match="envelope"):
        r = simulate(loop, solver)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        t, states, _ = integrate_only(loop, solver)  # cut by numpy over the records
    assert r.status == "diverged"
    assert r.time.size == t.size > 0
    np.testing.assert_array_equal(r.states, states[:, :2])
    assert np.all(np.abs(r.states[:, 0]) <= math.pi / 2)
    assert r.u_cmd.shape[0] == r.time.size  # signals cut with the states


def test_the_envelope_cut_names_the_state_that_left_from_the_row_the_signals_found():
    """``_check_envelope`` with the row the compiled signals found: the state named is the one
    outside the envelope on that row (regression: it indexed the checked rows absolutely)."""
    from adaptive_ftc.sim.engine import _check_envelope

    loop = load_scenario("spacecraft-mimo-s1").loop
    names = loop.plant.state_names
    Y = np.zeros((5, len(names)))
    Y[3, 2] = 2.0  # the third state (an angle, envelope pi/2) outside from row 3
    t = np.arange(5.0)
    for first in (None, 3):
        cut, message = _check_envelope(loop, Y, t, 5, "", first=first)
        assert cut == 3
        assert f"signal '{names[2]}'" in message and "t = 3 s" in message
    assert _check_envelope(loop, Y, t, 5, "", first=-1) == (5, "")
