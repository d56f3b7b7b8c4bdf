"""The constraint-aware rule's noise path (issue 25, round 5): where the noise's std bound sets
the loop rate, the law's measurement and adaptation-signal prefilters sit at ``8 w``, 7 deg of
phase each at the loop rate (round 2's ``4 w`` and ``2 w`` took 41 deg and the loop, its gain
lowered by the failures, resonated on the noise at 1.5-2 Hz; docs/hardware.md, "§4.4 sign
estimation")."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt

from adaptive_ftc.controllers import ConstraintAware
from adaptive_ftc.controllers.constraints import C_MEASURE_NOISE, C_PREFILTER_NOISE
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.hardware import Sensors
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import simulate

SCENARIO = "hypersonic-sign-s1-rho0pos"
THRESHOLD = 8.7e-4  # the scenario's tracking claim: 1 % of the reference amplitude
#: issue 25's activity target: 3 % of the ideal run's command peak to peak over 100-120 s
#: (0.289 rad on this scenario, docs/hardware.md)
FAST_MAX = 0.03 * 0.289


def _noisy_loop():
    """The issue's noise case (1e-3 rad on alpha, 1e-2 rad/s on q, 1 kHz) on the §4.4 loop,
    its failures moved to 10 and 20 s (40 s run): the constraint-aware law from the declared
    sensors (``s'`` filtered at 10 ms, the solver's default with noise)."""
    sc = load_scenario(SCENARIO)
    first, second = sc.loop.failures.failures
    failures = replace(
        sc.loop.failures, failures=(replace(first, onset=10.0), replace(second, onset=20.0))
    )
    loop = replace(
        sc.loop,
        t_final=40.0,
        failures=failures,
        sensors=Sensors(noise=(1e-3, 1e-2), rate=1000.0, seed=0),
    )
    ca = ConstraintAware.from_loop(loop, derivative_lag=0.01)
    loop = replace(loop, controller=replace(loop.controller, constraint_aware=ca))
    return loop, replace(sc.solver, method="rk4", dt=1e-3, record_dt=1e-3)


def _fast_content(r, t0: float, t1: float) -> float:
    """RMS of the command minus its zero-phase 1 Hz low-pass over ``[t0, t1]``, the largest
    over the actuators (the whole record filtered, then the window cut)."""
    u = np.asarray(r.u_cmd, dtype=float)
    sel = (r.time >= t0) & (r.time <= t1)
    sos = butter(2, 1.0, fs=1.0 / float(np.median(np.diff(r.time))), output="sos")
    return max(
        float(np.sqrt(np.mean((u[:, j] - sosfiltfilt(sos, u[:, j]))[sel] ** 2)))
        for j in range(u.shape[1])
    )


def test_the_noise_paths_prefilters_sit_at_eight_times_the_loop_rate():
    """Where the std bound binds (``omega_max`` says so), ``omega_q`` and ``omega_m`` are
    ``C_PREFILTER_NOISE w`` and ``C_MEASURE_NOISE w`` (8 w each)."""
    loop, _ = _noisy_loop()
    bound = loop.controller.bound(loop)
    ca = bound.constraint_aware
    w, noisy = ca.omega_max(ca.loop_rate, ca.b_max)
    assert noisy and w == pytest.approx(0.15 / ca.noise)
    cfg = bound.configuration()
    assert C_PREFILTER_NOISE == C_MEASURE_NOISE == 8.0
    assert cfg.omega_q == pytest.approx(8.0 * w)
    assert cfg.omega_m == pytest.approx(8.0 * w)


def test_the_noise_case_is_quiet_after_the_failures():
    """The failures lower the loop's input gain; with the prefilters at ``2 w`` and ``4 w``
    the loop then resonated on the noise (measured here: fast command content 1.5e-2 rad over
    30-40 s, error 6.9e-4); at ``8 w`` the command meets the activity target (7.0e-3) and
    the error the claim's threshold (4.7e-4)."""
    loop, solver = _noisy_loop()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(loop, solver)
    assert r.status == "completed"
    err = float(np.max(r.rms_error(30.0, 40.0)))
    assert math.isfinite(err) and err <= THRESHOLD, err
    fast = _fast_content(r, 30.0, 40.0)
    assert fast <= FAST_MAX, fast
