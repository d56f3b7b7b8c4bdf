"""§4.3 Nussbaum under sensor noise (issue 25): where the noise is above the density bound,
the law of ``theta`` sees the regressor of prefiltered measurements, ``lam`` is raised at most
``LAM_FACTOR_NOISE`` times and ``tau`` integrates the prefiltered ``q`` at the thesis's rate
(docs/hardware.md, "§4.3 Nussbaum")."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt

from adaptive_ftc.controllers import ConstraintAware
from adaptive_ftc.controllers.constraints import (
    C_MEASURE,
    C_PREFILTER,
    LAM_FACTOR_NOISE,
    adaptation_regressor_rule,
)
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.hardware import Actuators, Sensors
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.compose import source_of
from adaptive_ftc.sim.engine import simulate

SCENARIO = "hypersonic-nussbaum-s1-pos"
NOISE = 8.7e-4  # issue 25's case: 1 % of the reference amplitude (10x on the pitch rate)


def _noisy(loop, noise=NOISE):
    return replace(loop, sensors=Sensors(noise=(noise, 10.0 * noise), rate=1000.0, seed=0))


def _aware(loop, **over):
    ca = ConstraintAware.from_loop(loop, derivative_lag=0.01, **over)
    return replace(loop, controller=replace(loop.controller, constraint_aware=ca))


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(SCENARIO)


def test_noise_above_the_density_bound_prefilters_the_adaptation_regressor(scenario):
    """The rule's configuration of the noise case: ``omega_r = C_MEASURE w``; without noise,
    or with noise below the density bound, none (the lag, 50 Hz and rate cases unchanged)."""
    loop = _noisy(scenario.loop)
    bound = _aware(loop).controller.bound(loop)
    ca = bound.constraint_aware
    w, noisy = ca.omega_max(ca.loop_rate, ca.b_max)
    assert not noisy  # the std bound does not bind: the shared rule has no prefilter here
    cfg = bound.configuration()
    assert cfg.omega_r == pytest.approx(C_MEASURE * w)
    assert cfg.adaptation_regressor_filtered and not cfg.measured_through_filter
    assert cfg.lam_factor == LAM_FACTOR_NOISE  # the shared rule's: 4
    quiet = _noisy(scenario.loop, 1e-5)
    assert not _aware(quiet).controller.bound(quiet).configuration().adaptation_regressor_filtered
    lagged = replace(scenario.loop, actuators=Actuators(tau=0.05))
    cfg = _aware(lagged).controller.bound(lagged).configuration()
    assert math.isinf(cfg.omega_r)
    assert cfg.lam_factor == 4.0


def test_the_rule_leaves_configurations_without_noise_alone():
    cfg = ConstraintAware(lag=0.05).configure(w0=150.0, b_max=2.0)
    assert adaptation_regressor_rule(cfg, ConstraintAware(lag=0.05), 15.0) is cfg


def test_only_the_adaptation_sees_the_filtered_regressor(scenario):
    """``u0 = Pi(x_m)^T theta`` is computed from the measurements; the regressor is computed
    again from the filter states before the adaptive laws."""
    loop = _noisy(scenario.loop)
    src = source_of(_aware(loop))
    assert "the adaptation's regressor of the prefiltered measurements" in src
    head, tail = src.split("the adaptation's regressor of the prefiltered measurements")
    assert "u0[0] = weighted_sum(" in head and "u0[0] = weighted_sum(" not in tail
    assert "sig[i] = x[i] + meas(ph, i, D)" in head
    assert "theta_law(" in tail


@pytest.fixture(scope="module")
def noisy_30s(scenario):
    """The noise case for 30 s (before the failures), recorded at 1 ms."""
    loop = _aware(_noisy(replace(scenario.loop, t_final=30.0)))
    solver = replace(scenario.solver, method="rk4", dt=1e-3, record_dt=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(loop, solver)
    assert r.status == "completed"
    return r


def test_the_prefiltered_regressor_stops_the_noise_driven_drift_of_theta(noisy_30s):
    """``theta' = alpha0 N Pi(x_m) q`` with the pitch-rate noise in both ``Pi`` and ``q``
    has a bias that drifts ``theta``: measured 0.19 at 30 s with the measured regressor,
    0.03 with the prefiltered one."""
    assert float(np.linalg.norm(noisy_30s.theta[-1])) < 0.08


def test_the_capped_lam_quiets_the_command(noisy_30s):
    """``lam`` x2 instead of x4 under the same noise: the command's fast content (RMS above
    1 Hz, 10-30 s, worst elevator) 8.8e-3 rad (x4: 1.13e-2; issue 25's target on the full
    run 1.22e-2), the error within the thesis threshold."""
    r = noisy_30s
    sos = butter(2, 1.0, fs=1000.0, output="sos")
    sel = r.time >= 10.0
    fast = max(float(np.sqrt(np.mean((u - sosfiltfilt(sos, u))[sel] ** 2))) for u in r.u_cmd.T)
    assert fast < 1.0e-2
    assert float(np.max(r.rms_error(10.0, 30.0))) < 8.7e-4


def test_tau_sees_the_prefiltered_q_at_the_thesis_rate(scenario):
    """Where the noise rule applies, ``tau' = alpha1 q_f^2`` with ``q_f`` prefiltered at
    ``C_PREFILTER w`` and the thesis's ``alpha1``; elsewhere round 3's ``r alpha1``."""
    loop = _noisy(scenario.loop)
    bound = _aware(loop).controller.bound(loop)
    ca = bound.constraint_aware
    w, _ = ca.omega_max(ca.loop_rate, ca.b_max)
    assert bound.tau_prefilter() == pytest.approx(C_PREFILTER * w)
    assert bound.gains().alpha1 == scenario.loop.controller.alpha1
    assert "tau_law(Y[" in source_of(_aware(loop))
    lagged = replace(scenario.loop, actuators=Actuators(tau=0.05))
    bound = _aware(lagged).controller.bound(lagged)
    assert math.isinf(bound.tau_prefilter())
    r = bound.adaptation_scale
    assert bound.gains().alpha1 == pytest.approx(r * scenario.loop.controller.alpha1)


def test_the_noise_does_not_drift_the_nussbaum_argument(noisy_30s):
    """``tau`` integrates ``q^2``, the noise's power with the measured ``q``: 1 -> 1.05 in
    30 s at ``r alpha1`` (1.19 at 120 s), and at the thesis's ``alpha1`` the loop is lost at
    49 s; with the prefiltered ``q``, 1.003."""
    assert noisy_30s.adaptive_state("tau")[-1] < 1.01


def test_the_wrong_signed_noisy_loop_finds_its_direction():
    """hypersonic-nussbaum-s1-neg with 1 % noise: with ``lam`` x2 and ``r alpha1`` the
    wrong-signed loop diverged at 0.9 s, before ``N(tau)`` changed sign; the search at the
    thesis's rate finds the direction (5 s)."""
    sc = load_scenario("hypersonic-nussbaum-s1-neg")
    loop = _aware(_noisy(replace(sc.loop, t_final=5.0)))
    solver = replace(sc.solver, method="rk4", dt=1e-3, record_dt=1e-2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(loop, solver)
    assert r.status == "completed"
    assert np.all(r.gain[r.time >= 2.0] < 0)  # the negative direction, for good
    assert float(np.max(r.rms_error(4.0, 5.0))) < 1e-2
