"""Per-actuator limits of a single-output design's command filter (issue 25, session 13).

Issue 25's second hardware combination (lag 50 ms, rate 2 rad/s, travel +-0.5 rad, 50 Hz,
noise 1e-4) on hypersonic-direct-s1 diverged 2.4 s after the bias failure: the common
command filter bounded ``u0`` by the *most*-allocated elevator's travel (``0.9 x 0.5 / 2``
= 0.225 rad), while elevator 1, alone once elevator 2 is stuck, needs 0.27 rad to cancel
the bias (-0.2 rad at 75 %). With ``ConstraintAware.per_actuator`` (set by ``bound`` for
a single-output design with a fixed allocation and no placed feedback): ``u0`` is bounded
by the *least*-allocated actuator's travel and every actuator's command is clipped to its
own travel after the allocation (the hedge sees only what no actuator can deliver); a
digital law's command filter is a discrete limiter (at ``C_EULER / T``, its value after the
sample's step) that adds no lag to the delay budget (docs/hardware.md, "Round 7")."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc.controllers import ConstraintAware
from adaptive_ftc.controllers.constraints import (
    C_DELAY_LIMITED,
    C_EULER,
    C_LAM_LIMITED,
    C_MARGIN,
)
from adaptive_ftc.errors import ConfigurationError, DivergenceWarning
from adaptive_ftc.hardware import Actuators
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import simulate
from tests.conftest import combination_2

LAG, RATE, TRAVEL, T, NOISE = 0.05, 2.0, 0.5, 0.02, 1e-4


def _combination(per_actuator=None, t1=20.0, t2=40.0, t_final=46.0):
    """hypersonic-direct-s1 under issue 25's second combination, its failures moved to
    ``t1`` and ``t2`` (tests/conftest.combination_2)."""
    over = {} if per_actuator is None else {"per_actuator": per_actuator}
    return combination_2("hypersonic-direct-s1", t1=t1, t2=t2, t_final=t_final, **over)


def test_bound_sets_per_actuator_for_a_single_output_design_with_a_fixed_allocation():
    loop, _ = _combination()
    ca = loop.controller.bound(loop).constraint_aware
    assert ca.per_actuator is True and ca.discrete_limiter
    # a designer's explicit choice is kept
    loop, _ = _combination(per_actuator=False)
    ca = loop.controller.bound(loop).constraint_aware
    assert ca.per_actuator is False and not ca.discrete_limiter


def test_the_wing_rock_placed_feedback_keeps_its_command_filter():
    """The wing rock's placed feedback was sized with the filter it has: ``bound`` leaves
    ``per_actuator`` off there (its configuration, and so its campaign, unchanged)."""
    sc = load_scenario("wingrock-direct-s1")
    loop = replace(sc.loop, actuators=Actuators(tau=0.02, rate=20.0), sample_time=0.01)
    loop = replace(
        loop, controller=replace(loop.controller, constraint_aware=ConstraintAware.from_loop(loop))
    )
    ca = loop.controller.bound(loop).constraint_aware
    assert ca.fast_unstable(ca.b_max) and ca.per_actuator is False


def test_the_discrete_limiter_adds_no_lag_to_the_delay_budget():
    """The budget counts the loop's own lags only: ``w (lag + T/2 + tau_d) = C_DELAY_LIMITED``
    (8.75 1/s here); the filter at ``min(C_FILTER w, 1/lag, C_EULER/T)`` = ``1/lag``
    added the actuator's lag once more (5.4 1/s)."""
    loop, _ = _combination()
    ca = loop.controller.bound(loop).constraint_aware
    w, noisy = ca.omega_max(ca.loop_rate, ca.b_max)
    assert not noisy
    assert w * (LAG + T / 2 + T) == pytest.approx(C_DELAY_LIMITED)
    old = replace(ca, per_actuator=False)
    w_old, _ = old.omega_max(ca.loop_rate, ca.b_max)
    assert w_old == pytest.approx(C_DELAY_LIMITED / (LAG + T / 2 + T + LAG))
    cfg = loop.controller.bound(loop).configuration()
    assert cfg.omega_f == pytest.approx(C_EULER / T) and cfg.step == pytest.approx(T)
    # a continuous loop keeps its filter (no step)
    cont = replace(ca, sample_time=0.0)
    assert not cont.discrete_limiter


def test_the_travel_is_per_actuator_and_lam_stays_the_limited_loops():
    loop, _ = _combination()
    bound = loop.controller.bound(loop)
    ca = bound.constraint_aware
    cfg = bound.configuration()
    w, _ = ca.omega_max(ca.loop_rate, ca.b_max)
    assert cfg.actuator_travel == pytest.approx(C_MARGIN * TRAVEL)
    lam = float(loop.controller.lam)
    assert cfg.lam_factor == pytest.approx(max(1.0, min(C_LAM_LIMITED * w / lam, 4.0)))
    old = replace(loop.controller, constraint_aware=replace(ca, per_actuator=False))
    assert math.isinf(old.configuration().actuator_travel)


def _run(loop, solver):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        return simulate(loop, solver)


def test_elevator_1_reaches_past_the_most_allocated_travel_bound_and_holds_the_bias():
    """Failures at 20 s (elevator 2 stuck) and 40 s (elevator 1 at 75 %, -0.2 rad bias), 46
    s: with the common filter's bound of 0.225 rad the loop is lost within 3 s of the bias;
    per actuator it completes, elevator 1's command goes past 0.225 rad and every command
    stays within ``0.9 x travel`` and moves by at most ``T x 0.9 rate / 2`` per sample."""
    loop, solver = _combination(per_actuator=False)
    r = _run(loop, solver)
    assert r.status == "diverged" and r.time[-1] < 44.0
    loop, solver = _combination()
    r = _run(loop, solver)
    assert r.status == "completed"
    u = np.asarray(r.u_cmd, dtype=float)
    after = r.time >= 40.0
    assert np.max(np.abs(u)) <= C_MARGIN * TRAVEL + 1e-12
    assert np.max(u[after, 0]) > C_MARGIN * TRAVEL / 2.0 + 0.02
    step = np.max(np.abs(np.diff(u[:, 0])))
    assert step <= T * C_MARGIN * RATE / 2.0 + 1e-9
    err = float(np.max(r.rms_error(44.0, 46.0)))
    assert err < 0.05, err


def test_per_actuator_must_be_a_bool():
    with pytest.raises(ConfigurationError, match="per_actuator"):
        ConstraintAware(rate=1.0, per_actuator=1)
