"""A tight rate limit's large transient (issue 25, round 6): where the rate limit binds a
failure transient at the loop rate (``C_MARGIN rate_u0 / A_RATE < C_TIGHT w``), the command
filter lets the least-allocated actuator move at its full rate (``rate / b_min`` instead of
``rate / b_max``: the elevator that is left after the most-allocated one sticks) and the
compensated error returns at ``C_HEDGE_TIGHT w`` instead of ``C_HEDGE w``. Before,
hypersonic-direct-s1 behind 0.5 rad/s elevators diverged 2.2 s after the bias failure:
elevator 1 was held to 0.225 rad/s (elevator 2's rate over its gain 2) and, given its rate,
the loop rode the limit in a growing oscillation with ``xi`` hiding ``s`` from the law
(docs/hardware.md, "Round 6")."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc.controllers import ConstraintAware
from adaptive_ftc.controllers.constraints import C_HEDGE, C_HEDGE_TIGHT, C_MARGIN
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.hardware import Actuators
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import simulate

THRESHOLD = 8.7e-4  # the scenario's tracking claim: 1 % of the reference amplitude


def _loop(rate: float, t1: float = 40.0, t2: float = 80.0, t_final: float = 120.0, **model):
    sc = load_scenario("hypersonic-direct-s1")
    first, second = sc.loop.failures.failures
    failures = replace(
        sc.loop.failures, failures=(replace(first, onset=t1), replace(second, onset=t2))
    )
    loop = replace(sc.loop, actuators=Actuators(rate=rate), t_final=t_final, failures=failures)
    ca = ConstraintAware.from_loop(loop, **model)
    return sc, replace(loop, controller=replace(loop.controller, constraint_aware=ca))


def test_a_tight_rate_limit_lets_the_least_allocated_elevator_use_its_rate():
    """0.5 rad/s, allocation (1, 2): tight (``0.9 x 0.5 / 2 / A_RATE`` = 5.6 < 2 x 20);
    ``u0``'s rate is elevator 1's 0.45 rad/s, not elevator 2's 0.225, and ``xi`` returns at
    ``C_HEDGE_TIGHT w``. At 10 rad/s (not tight) both are the rule's before round 6."""
    _, loop = _loop(0.5)
    bound = loop.controller.bound(loop)
    ca = bound.constraint_aware
    assert (ca.b_min, ca.b_max) == (1.0, 2.0)
    w, _ = ca.omega_max(ca.loop_rate, ca.b_max)
    cfg = bound.configuration()
    assert cfg.u_rate == pytest.approx(C_MARGIN * 0.5 / 1.0)
    assert cfg.omega_h == pytest.approx(C_HEDGE_TIGHT * w)
    _, loop = _loop(10.0)
    bound = loop.controller.bound(loop)
    ca = bound.constraint_aware
    w, _ = ca.omega_max(ca.loop_rate, ca.b_max)
    cfg = bound.configuration()
    assert cfg.u_rate == pytest.approx(C_MARGIN * 10.0 / 2.0)
    assert cfg.omega_h == pytest.approx(C_HEDGE * w)


def test_a_half_rad_s_elevator_holds_the_direct_design_through_the_bias_failure():
    """The scenario's failures moved to 20 and 40 s (70 s run) behind 0.5 rad/s elevators:
    the rule holds the loop (error over 60-70 s within the claim's threshold, the delivered
    elevators never at the rate limit there); the rule before round 6 (``b_min`` = ``b_max``,
    ``xi`` returning at ``C_HEDGE w``) diverges about 2.4 s after the bias failure."""
    sc, loop = _loop(0.5, 20.0, 40.0, 70.0)
    solver = replace(sc.solver, record_dt=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(loop, solver)
    assert r.status == "completed"
    err = float(np.max(r.rms_error(60.0, 70.0)))
    assert math.isfinite(err) and err <= THRESHOLD, err
    sel = r.time >= 60.0
    pos = np.asarray(r.actuator_position, dtype=float)
    for j in range(pos.shape[1]):
        rate = np.abs(np.gradient(pos[:, j], r.time))
        assert float(np.mean(rate[sel] >= 0.98 * 0.5)) <= 0.05


def test_without_the_round_6_rule_the_same_run_diverges(monkeypatch):
    """The contrast: ``b_min`` declared as ``b_max`` and ``C_HEDGE_TIGHT`` at ``C_HEDGE``."""
    import adaptive_ftc.controllers.constraints as constraints

    monkeypatch.setattr(constraints, "C_HEDGE_TIGHT", C_HEDGE)
    sc, loop = _loop(0.5, 20.0, 40.0, 70.0, b_min=2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(loop, replace(sc.solver, record_dt=1e-3))
    assert r.status != "completed"
    assert 40.0 < float(r.time[-1]) < 45.0
