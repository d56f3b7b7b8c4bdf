"""Baselines on measured loops and the gain they record (issue 26).

* ``healthy_parameters`` dropped the s' filter states only for ``sdot = "filtered"``, not when
  ``"auto"`` turns the filter on (noise or a digital controller): the fixed-gain baseline of
  hypersonic-direct-s1-noise/-digital got 26 values for 25 adaptive states and ``aftc run``
  exited 2.
* The nominal-inverse and oracle baselines recorded a gain of 0; a design without a gain
  records 1 (SimResult's docstring).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc import load_scenario, simulate
from adaptive_ftc.baselines import fixed_gain, healthy_parameters, nominal_inverse, oracle


@pytest.mark.parametrize("name", ["hypersonic-direct-s1-noise", "hypersonic-direct-s1-digital"])
def test_healthy_parameters_leave_out_the_filter_that_auto_turns_on(name):
    sc = load_scenario(name)
    loop = replace(sc.loop, t_final=1.0)
    assert sc.solver.sdot == "auto" and sc.solver.sdot_for(loop) == "filtered"
    healthy = simulate(loop.without_failures(), sc.solver)
    n_filter = loop.plant.n_outputs
    assert healthy.adaptive_names[-n_filter:] == ("s_filter1",)
    params = healthy_parameters(loop, sc.solver)
    # the adaptive parameters the healthy run ended with, the filter's state left out
    np.testing.assert_array_equal(params, healthy.adaptive[-1, :-n_filter])
    baseline = simulate(fixed_gain(loop, sc.solver), sc.solver)
    assert baseline.status == "completed", baseline.message
    # the tuned parameters start the baseline; the measurement prefilters of a
    # constraint-aware design start at the measured x(0) instead (they are filters, not
    # parameters: tests/test_campaign_activity.py)
    tuned = [i for i, n in enumerate(baseline.adaptive_names[:-n_filter]) if "filter" not in n]
    np.testing.assert_array_equal(baseline.adaptive[0, tuned], np.asarray(params)[tuned])


def test_healthy_parameters_of_an_exact_sdot_loop_keep_every_adaptive_state():
    sc = load_scenario("hypersonic-direct-s1")
    loop = replace(sc.loop, t_final=1.0)
    assert sc.solver.sdot_for(loop) == "exact"
    healthy = simulate(loop.without_failures(), sc.solver)
    np.testing.assert_array_equal(healthy_parameters(loop, sc.solver), healthy.adaptive[-1])


@pytest.mark.parametrize("make", [nominal_inverse, oracle], ids=["nominal-inverse", "oracle"])
@pytest.mark.parametrize("name", ["hypersonic-direct-s1", "spacecraft-mimo-s1"])
def test_exact_inverse_baselines_record_a_gain_of_one(name, make):
    sc = load_scenario(name)
    r = simulate(make(replace(sc.loop, t_final=0.5)), sc.solver)
    assert r.status == "completed", r.message
    assert r.gain.shape == r.time.shape
    np.testing.assert_array_equal(r.gain, 1.0)
