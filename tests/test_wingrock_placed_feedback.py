"""The wing rock's placed fixed feedback (issue 25, docs/hardware.md "Wing rock §2.4", the
session-11 rule): PID gains placed on the designer's linear model behind the declared lag and
hold, robust to a loss of input gain, and the adaptive law slowed below the placed loop's
slowest mode. Truths: the closed-loop poles of the linear model (state space, computed apart
from the placement's polynomial arithmetic) and short runs of the wing rock behind lags
without failures (3 s, where the earlier rules limit-cycle)."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc.controllers import constraints
from adaptive_ftc.controllers.constraints import ConstraintAware, placed_feedback
from adaptive_ftc.errors import ConfigurationError, DivergenceWarning
from adaptive_ftc.hardware import Actuators
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import simulate

# the wing rock linearised at 1 deg (phi'' = a phi + c phi' + b u0)
A, C = -923.37, 11.016


def _abscissa(kp, kd, ki, lag, beta):
    """Largest real part of the closed loop ``phi'' = A phi + C phi' + beta v``, ``lag v' =
    u - v``, ``u = -(kp phi + kd phi' + ki int phi)``: states (phi, phi', v, int phi)."""
    m = np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [A, C, beta, 0.0],
            [-kp / lag, -kd / lag, -1.0 / lag, -ki / lag],
            [1.0, 0.0, 0.0, 0.0],
        ]
    )
    return float(np.linalg.eigvals(m).real.max())


@pytest.mark.parametrize("lag", [0.01, 0.035, 0.05])
def test_placed_gains_have_the_decay_they_claim(lag):
    kp, kd, ki, decay = placed_feedback(A, C, lag, 0.0)
    worst = max(_abscissa(kp, kd, ki, lag, beta) for beta in constraints.FEEDBACK_GAIN_SCALES)
    assert worst == pytest.approx(decay, rel=1e-6, abs=1e-9)
    assert decay < -0.5
    # a proportional path on s at 2 p_u (the rule before: kd = 2 p_u, kp = 2 p_u lam) has no
    # decay there at all behind 35 ms or more
    pu2 = 2.0 * math.sqrt(-A)
    old = max(_abscissa(5.0 * pu2, pu2, 0.0, lag, b) for b in constraints.FEEDBACK_GAIN_SCALES)
    if lag >= 0.035:
        assert old > 0.0


def test_adaptation_runs_below_the_placed_loop():
    loop = load_scenario("wingrock-direct-s1").loop
    loop = replace(loop, actuators=Actuators(tau=0.02, rate=50.0, lower=-6.0, upper=6.0))
    ca = ConstraintAware.from_loop(loop)
    bound = replace(loop.controller, constraint_aware=ca).bound(loop)
    bca = bound.constraint_aware
    cfg = bound.configuration()
    decay = bca.placement(bca.b_max)[3]
    assert decay < 0
    # the adaptive proportional path r g at C_AUGMENT times the placed loop's decay rate
    assert cfg.scale * bca.loop_gain == pytest.approx(constraints.C_AUGMENT * -decay, rel=1e-9)
    with pytest.raises(ConfigurationError, match="open_loop"):
        ConstraintAware(open_loop=(1.0,))
    with pytest.raises(ConfigurationError, match="open_loop"):
        ConstraintAware(open_loop=(1.0, math.nan))
    assert ConstraintAware(open_loop=[-923.0, 11.0]).open_loop == (-923.0, 11.0)


def _hold(lag, sample_time, rate, **over):
    sc = load_scenario("wingrock-direct-s1")
    loop = replace(
        sc.loop,
        actuators=Actuators(tau=lag, rate=rate, lower=-6.0, upper=6.0),
        sample_time=sample_time,
        t_final=3.0,
        failures=(),
    )
    ca = ConstraintAware.from_loop(loop, **over)
    loop = replace(loop, controller=replace(loop.controller, constraint_aware=ca))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(loop, sc.solver)
    assert r.status == "completed"
    return float(r.rms_error(2.0, 3.0)[0])


def test_placed_feedback_holds_the_roll_where_the_proportional_path_limit_cycles():
    """Behind 35 ms (continuous) the proportional path on ``s`` at ``2 p_u`` limit-cycles
    (6.4e-3 rad RMS over 2-3 s); the placed feedback holds the roll (3.6e-6)."""
    assert _hold(0.035, 0.0, 50.0) < 1e-4
    assert _hold(0.035, 0.0, 50.0, feedback=2.0 * math.sqrt(-A)) > 1e-3


def test_adaptation_slowed_below_the_placed_loop_is_quiet(monkeypatch):
    """Behind 17.6 ms at 200 Hz (campaign member 10) the adaptive law at the hardware's loop
    rate on top of the placed loop limit-cycles at 10 Hz (4.7e-3 rad); slowed below the
    placed loop's slowest mode the roll is held (5e-8). The session-11 rule: with the
    placed feedback's lead (session 12, ``LEAD_MAX``) the placed loop is faster and both hold
    (6e-8 at the hardware's loop rate), so the lead is off here."""
    monkeypatch.setattr(constraints, "LEAD_MAX", 1.0)
    assert _hold(0.0176, 0.005, 90.7) < 1e-5
    monkeypatch.setattr(constraints, "C_AUGMENT", math.inf)
    assert _hold(0.0176, 0.005, 90.7) > 1e-3
