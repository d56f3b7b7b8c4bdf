"""Issue 25: the constraint-aware MIMO law (ch. 3) raises the proportional loop gain of an
output whose adaptation is slow to the admitted loop rate (``C_RAISE``), sets its robust slope
and moves its leakage down with the loop; with noise it prefilters its adaptation signal.
Measured on spacecraft-mimo-s1 (docs/hardware.md, "Spacecraft ch. 3")."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt

from adaptive_ftc.controllers.base import AdaptiveController
from adaptive_ftc.controllers.constraints import C_NOISE_DENSITY, C_PREFILTER, ConstraintAware
from adaptive_ftc.controllers.mimo import C_RAISE, C_SLOPE, MimoDirectAdaptive
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.hardware import Actuators, Sensors
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.compose import source_of
from adaptive_ftc.sim.engine import simulate

#: issue 25's fast-content target on spacecraft-mimo-s1: 3 % of the ideal run's command peak
#: to peak over its final window (51.4 N m; scripts/hardware_cases.py)
FAST_MAX = 0.03 * 51.4


@pytest.fixture(scope="module")
def spacecraft():
    return load_scenario("spacecraft-mimo-s1")


def _b(loop):
    G = np.asarray(loop.plant.input_gains(loop.t0, np.asarray(loop.initial_state, float)))
    return np.abs(np.sum(np.asarray(loop.R) * G, axis=1))


def _run(loop, solver, ctrl, window):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(replace(loop, controller=ctrl), solver)
    assert r.status == "completed"
    sel = (r.time >= window[0]) & (r.time <= window[1])
    sos = butter(2, 1.0, fs=1.0 / float(np.median(np.diff(r.time))), output="sos")
    fast = max(float(np.sqrt(np.mean((u - sosfiltfilt(sos, u))[sel] ** 2))) for u in r.u_cmd.T)
    return float(np.max(r.rms_error(*window))), fast


def test_a_slow_output_gets_its_loop_gain_slope_and_leakage_from_the_admitted_rate(spacecraft):
    loop = spacecraft.loop
    thesis = loop.controller
    ctrl = replace(thesis, constraint_aware=ConstraintAware(lag=0.05)).bound(loop)
    ca = ctrl.constraint_aware
    w, _ = ca.omega_max(ca.loop_rate, ca.b_max)
    assert w == pytest.approx(0.1 * ca.loop_rate)  # the cap binds: 4.8 1/s
    g = np.asarray(ctrl.output_gains)  # 0.04-0.11 1/s, far below w
    m = np.asarray(ctrl.output_raise())
    np.testing.assert_allclose(m, C_RAISE * w / g, rtol=1e-12)
    etas, sigmas = np.asarray(ctrl.output_adaptation()).T
    np.testing.assert_allclose(etas, thesis.eta * m, rtol=1e-12)
    # the leakage rate moves down with the loop: eta sigma w / w0 (2 1/s -> 0.2 1/s)
    np.testing.assert_allclose(etas * sigmas, thesis.eta * thesis.sigma * w / ca.loop_rate)
    # normalised: each output's loop gain at the operating point is C w / (1 + C) < w (3w/4)
    c = np.asarray(ctrl.normalization(loop))
    np.testing.assert_allclose(c, etas * _b(loop) / w, rtol=1e-12)
    g_raised = m * g
    np.testing.assert_allclose(g_raised / (1 + g_raised / w), w * C_RAISE / (1 + C_RAISE))
    # the slope of the raised loop is w (C_SLOPE): k (5) lowered to it, the robust term off
    _, k, k0, _ = ctrl.robust_settings()
    assert thesis.k > C_SLOPE * w
    assert k == pytest.approx((C_SLOPE * w,) * 3, rel=1e-12) and k0 == (0.0, 0.0, 0.0)
    # at 10 Hz with limits the loop is slower still, and so is the slope
    slow = replace(thesis, constraint_aware=ConstraintAware(sample_time=0.1, travel=30.0))
    slow = slow.bound(loop)
    w_slow = slow.admitted_rate()
    # the summed lags with the command filter's: half a sample of hold and the filter's floor
    # T (the digital law's s' adds none: it looks ahead through its backward difference)
    assert w_slow == pytest.approx(0.7 / (0.5 * 0.1 + 0.1), rel=1e-12)
    assert w_slow < w
    assert slow.robust_settings()[1] == pytest.approx((C_SLOPE * w_slow,) * 3, rel=1e-12)
    # the generated law reads each output's own gain and leakage
    src = source_of(replace(loop, controller=ctrl, actuators=Actuators(tau=0.05)))
    assert "theta_law(dY, Y, phi, q[0], c[" in src and "D.gains.eta" not in src


def test_an_output_whose_loop_gain_is_at_the_admitted_rate_is_unchanged():
    """The manipulator's loop gains at zero error (103 and 606 1/s) are above 2 w (lag 50 ms:
    w = 20): nothing raised, the law reads the design's gains (as before the rule)."""
    loop = load_scenario("manipulator-mimo-s1").loop
    ctrl = replace(loop.controller, constraint_aware=ConstraintAware(lag=0.05)).bound(loop)
    assert ctrl.output_raise() == (1.0, 1.0)
    assert ctrl.output_adaptation() == ()
    # unchanged but for the fixed feedback floor of its local basis and the reference
    # feedforward beside it (their own rules: tests/test_constraint_aware_mimo_floor.py,
    # tests/test_constraint_aware_mimo_feedforward.py)
    cfg = ctrl.configuration()
    assert cfg.output_feedback and cfg.feedforward >= 0
    bare = cfg._replace(output_feedback=(), feedforward=-1.0)
    assert bare == AdaptiveController.configuration(ctrl)
    noisy = replace(loop.controller, constraint_aware=ConstraintAware(noise=0.1)).bound(loop)
    assert noisy.output_adaptation() == ()
    cfg = noisy.configuration()  # ... and the floor's measurement prefilter
    bare = cfg._replace(output_feedback=(), feedforward=-1.0, omega_m=math.inf)
    assert bare == AdaptiveController.configuration(noisy)
    src = source_of(replace(loop, controller=ctrl, actuators=Actuators(tau=0.05)))
    assert "D.gains.eta, D.gains.sigma, normaliser" in src.replace("gains(D)", "D.gains")


def test_with_noise_a_raised_law_prefilters_its_adaptation_signal(spacecraft):
    loop = spacecraft.loop
    thesis = loop.controller
    noisy = replace(thesis, constraint_aware=ConstraintAware(noise=0.01)).bound(loop)
    w = noisy.admitted_rate()
    shared = AdaptiveController.configuration(noisy)
    assert math.isinf(shared.omega_q)  # the noise's std bound (15 1/s) does not bind
    cfg = noisy.configuration()
    assert cfg.omega_q == pytest.approx(C_PREFILTER * w)
    assert math.isinf(cfg.omega_m)  # not the measurements (the loop is lost with both)
    assert cfg._replace(omega_q=shared.omega_q) == shared
    quiet = replace(thesis, constraint_aware=ConstraintAware(lag=0.05)).bound(loop)
    assert math.isinf(quiet.configuration().omega_q)
    # a noise whose density the raised path carries within the shared rule's density bound
    # (m w^2 n_d <= C_NOISE_DENSITY) is left unfiltered: the prefilter's lag costs more
    faint = replace(thesis, constraint_aware=ConstraintAware(noise=2e-5)).bound(loop)
    m = max(faint.output_raise())
    assert m > 1.0
    wf = faint.admitted_rate()
    assert m * wf * wf * faint.constraint_aware.noise_density <= C_NOISE_DENSITY
    assert math.isinf(faint.configuration().omega_q)


def test_spacecraft_behind_a_50_ms_lag_no_longer_lags_the_reference(spacecraft):
    """Reduced size (40 s, window 30-40 s). Before the rule (each axis's robust slope at the
    admitted rate, the thesis's leakage 2 1/s): 2.4e-3 rad here, 9.3e-3 at 150 s (3.7x the
    2.5e-3 target); with it 5e-4 here and 1.3e-3 at 150 s."""
    loop = replace(spacecraft.loop, t_final=40.0, actuators=Actuators(tau=0.05))
    solver = replace(spacecraft.solver, record_dt=1e-3)
    ctrl = replace(loop.controller, constraint_aware=ConstraintAware.from_loop(loop))
    err, fast = _run(loop, solver, ctrl, (30.0, 40.0))
    assert err < 1e-3 and fast <= FAST_MAX, (err, fast)


def test_spacecraft_with_noise_tracks_and_the_prefilter_keeps_the_command_quiet(
    spacecraft, monkeypatch
):
    """Reduced size (40 s, window 30-40 s), 1e-3 rad and 1e-2 rad/s of noise (1 % of the
    reference): before the rule 2.5e-2 rad of error; with it, error and fast content within
    issue 25's targets (7.7e-4 rad, 1.2 N m), and without the prefilter of ``q`` the raised
    law's command is noisy (4.4 N m)."""
    noise = (1e-3, 1e-2) * 3 + (0.0,) * 12
    loop = replace(spacecraft.loop, t_final=40.0, sensors=Sensors(noise=noise, rate=1000.0, seed=0))
    solver = replace(spacecraft.solver, method="rk4", dt=1e-3, record_dt=1e-3)
    ctrl = replace(loop.controller, constraint_aware=ConstraintAware.from_loop(loop))
    err, fast = _run(loop, solver, ctrl, (30.0, 40.0))
    assert err <= 2.5e-3 and fast <= FAST_MAX, (err, fast)
    monkeypatch.setattr(MimoDirectAdaptive, "configuration", AdaptiveController.configuration)
    unfiltered = replace(ctrl)  # a new object: the loop generated anew (compose.generate)
    assert math.isinf(unfiltered.bound(loop).configuration().omega_q)
    _, fast_unfiltered = _run(loop, solver, unfiltered, (30.0, 40.0))
    assert fast_unfiltered > FAST_MAX


def test_at_10_hz_with_limits_the_raised_slope_follows_the_slower_loop(spacecraft, monkeypatch):
    """Reduced size (40 s, window 30-40 s) of a spacecraft-hardware campaign member: 10 Hz,
    an 11 ms lag, 162 N m/s, +-38.6 N m (the rule's ``w`` = 2.7 1/s). With the slope at
    ``w``: 4.6e-3 rad, 0.28 N m; with a slope far above the loop rate (``C_SLOPE`` = 100; at
    150 s the thesis's ``k`` = 5, 1.9 w, tracked to 0.18 rad with 4.3 N m) the loop is lost
    at 14 s."""
    import adaptive_ftc.controllers.mimo as mimo

    loop = replace(
        spacecraft.loop,
        t_final=40.0,
        sample_time=0.1,
        actuators=Actuators(tau=0.0108, rate=161.7, lower=-38.6, upper=38.6),
    )
    solver = replace(spacecraft.solver, method="rk4", dt=1e-3, filter_tau=0.1, record_dt=1e-3)
    ctrl = replace(loop.controller, constraint_aware=ConstraintAware.from_loop(loop))
    err, fast = _run(loop, solver, ctrl, (30.0, 40.0))
    assert err < 1e-2 and fast <= FAST_MAX, (err, fast)
    monkeypatch.setattr(mimo, "C_SLOPE", 100.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(replace(loop, controller=replace(ctrl)), solver)
    assert r.status != "completed"
