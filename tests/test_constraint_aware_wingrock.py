"""The constraint-aware rule on the wing rock (issue 25, §2.4 cases; docs/hardware.md, "Wing
rock §2.4"): the fixed proportional feedback for a plant with a fast unstable open-loop mode,
the §2.4 compensator's path in the measured loop gain, the cap on the linear regressor's
``|Pi|^2``, the design's own slope where the loop gain exceeds it, and the zero-reference
definitions of scripts/hardware_cases.py. Runs at reduced length."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from adaptive_ftc.controllers import constraints
from adaptive_ftc.controllers.constraints import ConstraintAware, capped_gain
from adaptive_ftc.errors import ConfigurationError, DivergenceWarning
from adaptive_ftc.hardware import Actuators
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import simulate
from tests.conftest import load_script

ROOT = Path(__file__).resolve().parents[1]


def _hardware_cases():
    return load_script("hardware_cases")


def _aware(loop, **over):
    ca = ConstraintAware.from_loop(loop, **over)
    return replace(loop, controller=replace(loop.controller, constraint_aware=ca))


def _run(loop, solver):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        return simulate(loop, solver)


def test_open_loop_unstable_rate_is_the_linearised_wing_rock():
    loop = load_scenario("wingrock-direct-s1").loop
    p = loop.plant
    phi0 = float(loop.initial_state[0])
    # phi'' = -(a0 + 3 a3 phi0^2) phi - (a1 + a4 phi0^2) phi' at (phi0, 0): a complex pair
    # with a positive real part (a1 < 0), modulus sqrt(a0 + 3 a3 phi0^2)
    truth = math.sqrt(p.a0 + 3.0 * p.a3 * phi0**2)
    rate = loop.controller.open_loop_unstable_rate(loop)
    assert rate == pytest.approx(truth, rel=1e-6)


def test_feedback_only_where_the_unstable_mode_is_near_the_loop_rate():
    wr = load_scenario("wingrock-direct-s1").loop
    wr = replace(wr, actuators=Actuators(tau=0.02))
    bound = _aware(wr).controller.bound(wr)
    ca = bound.constraint_aware
    cfg = bound.configuration()
    # placed on the designer's linear model (the plant linearised at t0, the 20 ms lag
    # behind the feedback's lead: LEAD_MAX; no rate limit: its integral grid extended,
    # FEEDBACK_KI_EXTEND)
    assert ca.lead_lag == pytest.approx(0.02 / constraints.LEAD_MAX)
    extend = constraints.FEEDBACK_KI_EXTEND
    kp, kd, ki, _ = constraints.placed_feedback(*ca.open_loop, ca.lead_lag, 0.0, ki_extend=extend)
    b = ca.input_gain
    assert (cfg.feedback, cfg.feedback_e, cfg.feedback_i) == pytest.approx(
        (kd / b, kp / b, ki / b), rel=1e-12
    )
    # the designer may state it (a proportional path on s at that loop gain): 0 = none
    off = replace(bound, constraint_aware=replace(ca, feedback=0.0))
    assert off.configuration().feedback == 0.0
    assert off.configuration().feedback_i == 0.0
    stated = replace(bound, constraint_aware=replace(ca, feedback=60.0)).configuration()
    lam = wr.controller.lam * stated.lam_factor
    assert (stated.feedback, stated.feedback_e) == pytest.approx((60.0 / b, 60.0 * lam / b))
    # the hypersonic loop's unstable mode (0.75 1/s) is far below its slowed loop rate: the
    # rule adds nothing there (its trajectories stay the thesis-rule's)
    hy = load_scenario("hypersonic-direct-s1").loop
    hy = replace(hy, actuators=Actuators(tau=0.05))
    hb = _aware(hy).controller.bound(hy)
    assert 0 < hb.constraint_aware.unstable_rate < 1.0
    assert hb.configuration().feedback == 0.0
    # ... not even on the most limited hypersonic hardware of docs/hardware.md (lag 50 ms,
    # 2 rad/s, +-0.5 rad, 50 Hz, noise): the hardware admits 4.5 1/s, the gate needs 3.0
    combo = replace(
        hy, actuators=Actuators(tau=0.05, rate=2.0, lower=-0.5, upper=0.5), sample_time=0.02
    )
    cb = _aware(combo, noise=1e-3, derivative_lag=0.04).controller.bound(combo)
    w_hw, _ = cb.constraint_aware.omega_max(math.inf, cb.constraint_aware.b_max)
    assert constraints.C_FEEDBACK * cb.constraint_aware.unstable_rate < (
        constraints.C_FEEDBACK_GATE * w_hw
    )
    assert cb.configuration().feedback == 0.0
    with pytest.raises(ConfigurationError, match="feedback"):
        ConstraintAware(feedback=-1.0)


def test_feedback_holds_the_roll_behind_a_lag():
    """Behind a 20 ms lag the slowed law alone (loop rate 50 1/s on its gains at ``t0``)
    cannot damp the wing rock's 30 rad/s mode: the roll grows into the limit cycle before
    any failure and leaves the fuzzy basis; with the fixed feedback it is regulated."""
    sc = load_scenario("wingrock-direct-s1")
    loop = replace(sc.loop, actuators=Actuators(tau=0.02), t_final=2.9)
    with_fb = _run(_aware(loop), sc.solver)
    without = _run(_aware(loop, feedback=0.0), sc.solver)
    assert with_fb.status == "completed"
    assert float(with_fb.rms_error(2.0, 2.9)[0]) < 1e-4
    assert float(without.rms_error(2.0, 2.9)[0]) > 0.1


def test_compensator_path_counts_in_the_loop_gain():
    loop = load_scenario("wingrock-estimation-s1").loop
    loop = replace(loop, actuators=Actuators(tau=0.05))
    c = loop.controller
    bound = _aware(loop).controller.bound(loop)
    phi0 = float(loop.initial_state[0])
    b = bound.constraint_aware.input_gain
    # Pi = (e, e', 1) at t0: |Pi|^2 = phi0^2 + 1; varpi_j = (1, sin 5t, cos 5t): 2 per aileron
    truth = b * (c.eta1 * (phi0**2 + 1.0) + c.eta2 * 2.0 * loop.plant.n_actuators)
    assert bound.constraint_aware.loop_gain == pytest.approx(truth, rel=1e-9)
    assert _aware(loop).controller.compensator_gain(loop) == pytest.approx(c.eta2 * 6.0)
    assert c.compensator_gain(loop) == 0.0  # the thesis law: no rule


def test_hypersonic_estimation_keeps_the_previous_rule():
    """The hypersonic plant's unstable mode (0.75 1/s) is far below what its hardware
    admits: §2.4's compensator is not counted and its regressor is not capped there (with
    them, hypersonic-estimation-s1 behind a 50 ms lag lost the accuracy it had, 1.6e-4 ->
    1.4e-2 rad)."""
    loop = load_scenario("hypersonic-estimation-s1").loop
    loop = replace(loop, actuators=Actuators(tau=0.05))
    aware = _aware(loop).controller
    assert aware.compensator_gain(loop) == 0.0
    bound = aware.bound(loop)
    assert not bound.constraint_aware.fast_unstable(bound.constraint_aware.b_max)
    assert bound.regressor_cap(loop) == 0.0
    assert bound.configuration().feedback == 0.0


def test_capped_gain():
    phi = np.array([0.0, 3.0, 4.0, 0.0])
    assert capped_gain(phi, 5.0, 1, 2) == pytest.approx(5.0 / 25.0)
    assert capped_gain(phi, 50.0, 1, 2) == 1.0


def test_capped_regressor_keeps_the_rate_limited_law_quiet():
    """§2.4 with a rate limit (half the ideal peak rate): without the cap the linear
    regressor's |Pi|^2 grows with the error after the 3 s failure and the slowed law's loop
    gain with it (command peak 24 on the full run, fast content 9.4)."""
    sc = load_scenario("wingrock-estimation-s1")
    loop = replace(sc.loop, actuators=Actuators(rate=3080.0), t_final=4.0)
    aware = _aware(loop)
    assert aware.controller.bound(loop).regressor_cap(loop) == pytest.approx(
        float(loop.initial_state[0]) ** 2 + 1.0
    )
    r = _run(aware, replace(sc.solver, record_dt=1e-3))
    assert r.status == "completed"
    assert float(np.max(np.abs(r.u_cmd))) < 10.0


def test_slope_where_the_loop_gain_exceeds_it():
    """Where g >= K the loop rate w0 = g says nothing of K: the design's own slope is used,
    so sqrt(g' K') = w (with K taken as g the integral path fell to w K / g)."""
    ca = ConstraintAware(lag=0.05, loop_rate=1000.0, loop_gain=1000.0)
    w = 1.0 / 0.05
    with_slope = ca.configure(w0=1000.0, b_max=1.0, slope=100.0)
    assert with_slope.scale == pytest.approx(w / 1000.0)
    assert with_slope.slope_scale == pytest.approx(w / 100.0)
    assert ca.configure(w0=1000.0, b_max=1.0).slope_scale == pytest.approx(w / 1000.0)


def test_zero_reference_definitions():
    hc = _hardware_cases()
    assert hc.final_window(10.0, 2.0, (3.0, 6.0, 8.0)) == (8.5, 10.0)
    assert hc.final_window(10.0, 2.0, (3.0, 6.0)) == (8.0, 10.0)
    sc = load_scenario("wingrock-estimation-s1")
    r = _run(replace(sc.loop, t_final=0.01), sc.solver)
    # a zero reference: the initial deviation (1 deg) is the amplitude
    assert hc.reference_amplitude(r) == pytest.approx(math.radians(1.0))
    assert float(np.ptp(r.yd)) == 0.0
