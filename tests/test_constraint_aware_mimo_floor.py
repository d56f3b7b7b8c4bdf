"""Issue 25: the constraint-aware MIMO law's fixed feedback floor (``mimo.C_FLOOR``) on outputs
whose loop gain collapses away from the operating point (the manipulator's local fuzzy basis of
the errors), and the loop-rate budget of such a loop (``ConstraintAware.floor_delay``).
Measured on the manipulator-hardware campaign (docs/hardware.md, "Manipulator ch. 3"): without
the floor the arm is lost within 3 s behind lags above 20 ms with rate and travel limits (the
command ``Pi^T theta`` is exactly 0 once the errors leave the basis). The hardware below is
that of campaign members 1 and 18, with the scenario's own failures; reduced length."""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc.controllers import constraints, mimo
from adaptive_ftc.controllers.constraints import C_FLOOR_SAMPLE, C_NOISE, ConstraintAware
from adaptive_ftc.controllers.mimo import C_FLOOR, C_FLOOR_DELAY, C_RAISE
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.hardware import Actuators, Sensors
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.engine import simulate


@pytest.fixture(scope="module")
def manipulator():
    return load_scenario("manipulator-mimo-s1")


def _member(sc, *, lag, rate, travel, sample_time, noise, t_final):
    """manipulator-mimo-s1 on a campaign member's motors and sensors, the constraint-aware law
    believing them."""
    loop = replace(
        sc.loop,
        actuators=Actuators(tau=lag, rate=rate, lower=-travel, upper=travel),
        sensors=Sensors(noise={"q1": noise[0], "q2": noise[1]}, seed=7),
        sample_time=sample_time,
        t_final=t_final,
    )
    ctrl = replace(loop.controller, constraint_aware=ConstraintAware.from_loop(loop))
    return replace(loop, controller=ctrl)


def _run(loop, solver):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        r = simulate(loop, solver)
    assert r.status == "completed"
    return r


#: campaign member 1: 43.5 ms lag, 34.5 N m/s, +-13.9 N m, continuous
MEMBER_1 = dict(lag=0.0435, rate=34.5, travel=13.9, sample_time=0.0, noise=(3.8e-4, 4.25e-3))
#: campaign member 18: 43.8 ms lag, 173 N m/s, +-15 N m, 200 Hz
MEMBER_18 = dict(lag=0.0438, rate=173.0, travel=15.0, sample_time=0.005, noise=(2.5e-3, 2.1e-4))


def test_a_local_basis_output_gets_a_floor_at_the_loop_rate_the_spacecraft_none(manipulator):
    loop = _member(manipulator, t_final=4.0, **MEMBER_1)
    ctrl = loop.controller.bound(loop)
    # the raw fuzzy basis: fast at zero error, slow at the initial state (1.8 and 10.7 1/s)
    assert all(
        g0 < C_RAISE * ctrl.admitted_rate() <= g
        for g0, g in zip(ctrl.initial_gains, ctrl.output_gains, strict=True)
    )
    assert ctrl.constraint_aware.floor_delay == C_FLOOR_DELAY
    w = ctrl.admitted_rate()
    assert ctrl.output_floor() == pytest.approx((C_FLOOR * w,) * 2, rel=1e-12)
    cfg = ctrl.configuration()
    b = np.asarray(ctrl.input_gains_out)  # |d s_i'/d u0_i| of the healthy arm: 2.0 and 11.7
    np.testing.assert_allclose(cfg.output_feedback, C_FLOOR * w / b, rtol=1e-12)
    # the spacecraft's outputs are raised (their adaptation is slow everywhere): no floor, the
    # shared rule's budget (its trajectories unchanged)
    sc = load_scenario("spacecraft-mimo-s1").loop
    craft = replace(sc.controller, constraint_aware=ConstraintAware(lag=0.05, travel=30.0))
    craft = craft.bound(sc)
    assert craft.output_floor() == ()
    assert craft.constraint_aware.floor_delay is None
    assert craft.configuration().output_feedback == ()


def test_without_the_floor_the_arm_is_lost_within_3_s(manipulator, monkeypatch):
    r = _run(_member(manipulator, t_final=4.0, **MEMBER_1), manipulator.solver)
    k = int(np.searchsorted(r.time, 3.0))
    assert np.max(np.abs(r.e[k])) < 0.2  # held (1.2e-2 and 8.3e-2 rad)
    assert np.max(np.abs(r.u_cmd[-1])) > 0.5
    monkeypatch.setattr(mimo, "C_FLOOR", 0.0)
    # a fresh loop (compiled structures are remembered per controller object)
    lost = _run(_member(manipulator, t_final=4.0, **MEMBER_1), manipulator.solver)
    assert np.max(np.abs(lost.e[k])) > 1.0  # 1.9 rad: the errors left the basis
    assert np.max(np.abs(lost.u_cmd[-1])) < 1e-3  # Pi^T theta = 0: lost for good


def test_the_floor_budget_without_the_filter_lag_meets_the_tracking_target(
    manipulator, monkeypatch
):
    # measured before the reference feedforward (tests/test_constraint_aware_mimo_feedforward.py),
    # which holds this member at either budget
    monkeypatch.setattr(mimo, "C_FEEDFORWARD", False)
    loop = _member(manipulator, t_final=7.5, **MEMBER_18)
    ctrl = loop.controller.bound(loop)
    # w (lag + T + tau_d) <= C_FLOOR_DELAY, the digital MIMO law's s' adding no lag
    assert ctrl.admitted_rate() == pytest.approx(C_FLOOR_DELAY / (0.0438 + 0.005), rel=1e-12)
    r = _run(loop, manipulator.solver)
    assert np.max(r.rms_error(5.5, 7.5)) < 0.05  # 3.4e-2 rad (the tracking claim: 5e-2)
    # the floor at the shared rule's budget (its command filter's lag counted): w = 7.8 1/s
    monkeypatch.setattr(mimo, "C_FLOOR_DELAY", 0.0)
    slow = _member(manipulator, t_final=7.5, **MEMBER_18)
    bound = slow.controller.bound(slow)
    assert bound.constraint_aware.floor_delay is None and bound.output_floor()
    assert bound.admitted_rate() < 0.5 * ctrl.admitted_rate()
    assert np.max(_run(slow, manipulator.solver).rms_error(5.5, 7.5)) > 0.1  # 0.13 rad


def test_behind_a_fast_command_filter_the_floor_passes_through_its_rate_clip(
    manipulator, monkeypatch
):
    # campaign member 409: 1 ms, 45.5 N m/s, continuous, 4.7e-3 rad of noise on q1: the floor
    # carries the noise; after the filter it steps the lag-free motors at their rate limit
    hw = dict(lag=0.001, rate=45.5, travel=11.7, sample_time=0.0, noise=(4.67e-3, 1.64e-3))
    solver = replace(manipulator.solver, record_dt=0.001)  # fine enough to judge activity
    loop = _member(manipulator, t_final=6.0, **hw)
    assert loop.controller.bound(loop).configuration().feedback_filtered
    r = _run(loop, solver)
    assert np.max(r.rms_error(4.0, 6.0)) < 0.05
    assert max(a.rate_limited_fraction for a in r.activity(4.0, 6.0).values()) <= 0.05  # 0
    monkeypatch.setattr(mimo, "C_FLOOR_INSIDE", False)
    after = _member(manipulator, t_final=6.0, **hw)
    assert not after.controller.bound(after).configuration().feedback_filtered
    r_after = _run(after, solver)
    assert max(a.rate_limited_fraction for a in r_after.activity(4.0, 6.0).values()) > 0.2
    # behind a slow filter (capped by a 43.5 ms lag) the floor stays after it
    slow = _member(manipulator, t_final=4.0, **MEMBER_1)
    assert not slow.controller.bound(slow).configuration().feedback_filtered


def test_the_floor_budget_counts_noise_by_its_std_and_adds_no_prefilter():
    # 50 Hz, 15 ms, 4.5e-3 rad: the shared rule's density bound alone gives 10.5 1/s
    ca = ConstraintAware(lag=0.015, rate=30.0, travel=12.0, sample_time=0.02, noise=4.5e-3)
    shared, _ = ca.omega_max(606.0)  # 6.9 1/s (the limited delay budget binds first)
    assert shared <= math.sqrt(constraints.C_NOISE_DENSITY / ca.noise_density) + 1e-12
    floor = replace(ca, floor_delay=C_FLOOR_DELAY, derivative_lag=0.0)
    w, noisy = floor.omega_max(606.0)
    assert not noisy
    assert w == pytest.approx(
        min(C_FLOOR_DELAY / (0.015 + 0.02), C_FLOOR_SAMPLE / 0.02, C_NOISE / 4.5e-3), rel=1e-12
    )
    assert w > 2 * shared
    # where the std bound binds: w = C_NOISE / noise, with no measurement or q prefilter
    loud = replace(floor, noise=2e-2)
    w, noisy = loud.omega_max(606.0)
    assert w == pytest.approx(C_NOISE / 2e-2) and not noisy
    cfg = loud.configure(w0=606.0, b_max=1.0)
    assert not cfg.prefiltered and not cfg.measured_through_filter
    # without limits the shared C_DELAY budget
    free = ConstraintAware(lag=0.05, floor_delay=C_FLOOR_DELAY)
    assert free.omega_max(606.0)[0] == pytest.approx(constraints.C_DELAY / 0.05, rel=1e-12)


def test_floor_delay_is_checked():
    with pytest.raises(ValueError, match="floor_delay"):
        ConstraintAware(lag=0.01, floor_delay=-1.0)


def test_a_digital_floor_loop_keeps_w_t_below_the_floor_sample_bound(manipulator, monkeypatch):
    """Issue 25's 50 Hz case (no limits, the ``s'`` estimate's lag ``T`` declared, as in
    scripts/hardware_cases.py): the floor and the normalised law each move ``u0`` by about ``w
    T s`` per sample; at ``w = 0.5/T`` the sampled loop is lost after the 25 s failure."""

    # measured before the reference feedforward (tests/test_constraint_aware_mimo_feedforward.py),
    # with which the case tracks at 0.5/T too (8.7e-3 rad)
    monkeypatch.setattr(mimo, "C_FEEDFORWARD", False)

    def run():
        loop = replace(manipulator.loop, sample_time=0.02)
        ca = ConstraintAware.from_loop(loop, derivative_lag=0.02)
        loop = replace(loop, controller=replace(loop.controller, constraint_aware=ca))
        ctrl = loop.controller.bound(loop)
        r = _run(loop, replace(manipulator.solver, filter_tau=0.02))
        return ctrl.admitted_rate(), float(np.max(r.rms_error(25.0, 30.0)))

    w, err = run()
    assert w == pytest.approx(C_FLOOR_SAMPLE / 0.02, rel=1e-12)  # 20 1/s
    assert err < 0.05  # 3.4e-2 rad
    monkeypatch.setattr(constraints, "C_FLOOR_SAMPLE", 0.5)
    w, err = run()
    assert w == pytest.approx(25.0, rel=1e-12)
    assert err > 0.1  # 1.1 rad
