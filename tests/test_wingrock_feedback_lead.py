"""The lead of the wing rock's placed feedback (issue 25, docs/hardware.md "Wing rock §2.4",
session 12): the PID's output passes ``(lag s + 1) / (tau s + 1)``, which cancels the
declared actuator lag down to ``tau = max(lag / LEAD_MAX, LEAD_SAMPLE T)``, and the gains are
placed behind ``tau``. Truths: the closed-loop poles of the linear model with the lead and the
true lag (state space, apart from the placement's polynomial arithmetic), and short runs of
the wing rock behind 45 ms at 50 Hz, where the placement behind the whole lag has almost no
decay left."""

from __future__ import annotations

import shutil
import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc.controllers import constraints
from adaptive_ftc.controllers.constraints import ConstraintAware, placed_feedback
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.hardware import Actuators
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import simulate

# the wing rock linearised at 1 deg (phi'' = a phi + c phi' + b u0)
A, C = -923.37, 11.016


def _abscissa_with_lead(kp, kd, ki, lag, tau, beta):
    """Largest real part of ``phi'' = A phi + C phi' + beta v``, ``lag v' = u - v``, ``u =
    r f - (r - 1) z``, ``tau z' = f - z``, ``r = lag / tau``, ``f = -(kp phi + kd phi' + ki
    int phi)``: states (phi, phi', v, int phi, z)."""
    r = lag / tau
    f = np.array([-kp, -kd, 0.0, -ki, 0.0])  # f as a row over the states
    z = np.array([0.0, 0.0, 0.0, 0.0, 1.0])
    u = r * f - (r - 1.0) * z
    m = np.zeros((5, 5))
    m[0, 1] = 1.0
    m[1, :] = [A, C, beta, 0.0, 0.0]
    m[2, :] = u / lag
    m[2, 2] -= 1.0 / lag
    m[3, 0] = 1.0
    m[4, :] = (f - z) / tau
    return float(np.linalg.eigvals(m).real.max())


@pytest.mark.parametrize("lag", [0.035, 0.05])
def test_the_lead_gives_the_loop_the_decay_placed_behind_the_shorter_lag(lag):
    ca = ConstraintAware(lag=lag, open_loop=(A, C))
    tau = ca.lead_lag
    assert tau == pytest.approx(lag / constraints.LEAD_MAX)
    kp, kd, ki, decay = placed_feedback(A, C, tau, 0.0)
    # with the lead in front of the true lag the loop has the poles placed behind tau (the
    # lead's zero cancels the lag's pole)
    worst = max(
        _abscissa_with_lead(kp, kd, ki, lag, tau, b) for b in constraints.FEEDBACK_GAIN_SCALES
    )
    assert worst == pytest.approx(decay, rel=1e-6)
    # ... a faster decay than the gains placed behind the whole lag
    assert decay < 2.0 * placed_feedback(A, C, lag, 0.0)[3] < 0.0


def test_the_lead_is_no_faster_than_a_sample_and_only_behind_a_lag():
    assert ConstraintAware(lag=0.045, sample_time=0.02).lead_lag == 0.02  # LEAD_SAMPLE T
    assert ConstraintAware(lag=0.01, sample_time=0.02).lead_lag == 0.01  # no lead
    assert ConstraintAware(sample_time=0.02).lead_lag == 0.0
    loop = load_scenario("wingrock-direct-s1").loop
    loop = replace(loop, actuators=Actuators(tau=0.045, rate=50.0, lower=-6.0, upper=6.0))
    ca = ConstraintAware.from_loop(loop)
    cfg = replace(loop.controller, constraint_aware=ca).bound(loop).configuration()
    assert cfg.feedback_lead == pytest.approx((0.045, 0.015))
    # where the designer states the feedback (a proportional path on s) there is no lead
    stated = replace(ca, feedback=60.0)
    cfg = replace(loop.controller, constraint_aware=stated).bound(loop).configuration()
    assert cfg.feedback_lead == ()


def _hold(lag: float, sample_time: float) -> float:
    sc = load_scenario("wingrock-direct-s1")
    loop = replace(
        sc.loop,
        actuators=Actuators(tau=lag, rate=50.0, lower=-6.0, upper=6.0),
        sample_time=sample_time,
        t_final=3.0,
        failures=(),
    )
    ca = ConstraintAware.from_loop(loop)
    loop = replace(loop, controller=replace(loop.controller, constraint_aware=ca))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(loop, sc.solver)
    assert r.status == "completed"
    return float(r.rms_error(2.0, 3.0)[0])


def test_the_lead_holds_the_roll_behind_45_ms_at_50_hz(monkeypatch):
    """Behind 45 ms at 50 Hz (the lag at a sample's 20 ms) the roll is held to 1e-5 rad
    over 2-3 s; placed behind the whole lag (no lead) it still swings at 6.9e-3."""
    assert _hold(0.045, 0.02) < 1e-4
    monkeypatch.setattr(constraints, "LEAD_MAX", 1.0)
    assert _hold(0.045, 0.02) > 1e-3


@pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")
def test_the_exported_c_controller_runs_the_lead_as_the_simulation(tmp_path):
    from adaptive_ftc.export.sil import verify

    sc = load_scenario("wingrock-direct-s1")
    loop = replace(
        sc.loop,
        actuators=Actuators(tau=0.045, rate=50.0, lower=-6.0, upper=6.0),
        sample_time=0.01,
    )
    ca = ConstraintAware.from_loop(loop)
    loop = replace(loop, controller=replace(loop.controller, constraint_aware=ca))
    assert loop.controller.bound(loop).configuration().feedback_lead == pytest.approx(
        (0.045, 0.015)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        report = verify(loop, t_final=4.0, workdir=tmp_path)
    assert report.samples > 100
    assert report.command <= 1e-12 and report.plant_state <= 1e-12, report
