"""The rate limit's bound on the loop rate (issue 25, round 5): ``w <= C_MARGIN rate_u0 /
A_LOOP`` sizes the loop's small-signal oscillation (``A_LOOP`` = 0.01 rad of ``u0``), while
the "tight" test that lowers ``lam`` keeps the large-signal amplitude ``A_RATE`` (0.04):
hypersonic-sign-s1-rho0pos behind a 0.5 rad/s elevator tracks (rounds 1-4: ``w`` = 5.6,
error 7.1e-3 rad after the failures) and hypersonic-direct-s1 at 2 rad/s keeps its low
``lam`` (docs/hardware.md, "§4.4 sign estimation")."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc.controllers import ConstraintAware
from adaptive_ftc.controllers.constraints import A_LOOP, A_RATE, C_LAM_LIMITED, C_MARGIN
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.hardware import Actuators
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import simulate

THRESHOLD = 8.7e-4  # the scenarios' tracking claim: 1 % of the reference amplitude


def _bound(name: str, rate: float, **changes):
    sc = load_scenario(name)
    loop = replace(sc.loop, actuators=Actuators(rate=rate), **changes)
    aware = replace(loop.controller, constraint_aware=ConstraintAware.from_loop(loop))
    loop = replace(loop, controller=aware)
    return sc, loop, aware.bound(loop)


def test_the_rate_bound_on_the_loop_rate_takes_the_small_signal_amplitude():
    """At 0.5 rad/s (``u0`` limited to 0.25 rad/s by elevator 2's gain 2) the rate bound is
    ``0.9 x 0.25 / A_LOOP`` = 22.5 1/s, the binding one on the §4.4 loop; the limit is
    tight (``lam`` at ``C_LAM_LIMITED w``, not ``C_LAM w``)."""
    _, _, bound = _bound("hypersonic-sign-s1-rho0pos", 0.5)
    ca = bound.constraint_aware
    assert (A_LOOP, A_RATE) == (0.01, 0.04)
    w, noisy = ca.omega_max(ca.loop_rate, ca.b_max)
    assert not noisy
    assert w == pytest.approx(C_MARGIN * 0.5 / ca.b_max / A_LOOP) == pytest.approx(22.5)
    lam = bound.lam
    assert bound.configuration().lam_factor == pytest.approx(C_LAM_LIMITED * w / lam)


def test_a_2_rad_s_elevator_stays_tight_on_the_direct_design():
    """hypersonic-direct-s1 at 2 rad/s: its loop rate is the cap (``0.1 w0``, 20 1/s) under
    either amplitude, and the limit is tight by ``A_RATE`` (22.5 < 2 x 20), so ``lam`` is
    raised to ``C_LAM_LIMITED w`` only (x1.26); non-tight (``lam`` x4) the loop was lost at
    86.7 s."""
    _, _, bound = _bound("hypersonic-direct-s1", 2.0)
    ca = bound.constraint_aware
    w, _ = ca.omega_max(ca.loop_rate, ca.b_max)
    assert w == pytest.approx(0.1 * ca.loop_rate)
    assert C_MARGIN * 2.0 / ca.b_max / A_RATE < 2.0 * w
    assert bound.configuration().lam_factor == pytest.approx(C_LAM_LIMITED * w / bound.lam)


def test_a_half_rad_s_elevator_holds_the_sign_estimation_loop_through_both_failures():
    """The scenario's failures moved to 5 and 10 s (25 s run) behind a 0.5 rad/s elevator:
    at round 4's ``w`` = 5.6 the error over 15-25 s was 9.0e-3 rad; at 22.5, 3.3e-4, and the
    delivered elevators never sit at the rate limit."""
    sc = load_scenario("hypersonic-sign-s1-rho0pos")
    first, second = sc.loop.failures.failures
    failures = replace(
        sc.loop.failures, failures=(replace(first, onset=5.0), replace(second, onset=10.0))
    )
    _, loop, _ = _bound("hypersonic-sign-s1-rho0pos", 0.5, t_final=25.0, failures=failures)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(loop, replace(sc.solver, record_dt=1e-3))
    assert r.status == "completed"
    err = float(np.max(r.rms_error(15.0, 25.0)))
    assert math.isfinite(err) and err <= THRESHOLD, err
    sel = r.time >= 15.0
    pos = np.asarray(r.actuator_position, dtype=float)
    for j in range(pos.shape[1]):
        rate = np.abs(np.gradient(pos[:, j], r.time))
        assert float(np.mean(rate[sel] >= 0.98 * 0.5)) <= 0.05
