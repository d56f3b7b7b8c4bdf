"""Thesis §3.4 (Figs 3.2-3.18): the MIMO direct adaptive design (§3.3) on the redundant-joint
two-link manipulator and on the flexible spacecraft with six reaction wheels.

Each scenario's ``[[claims]]`` tables (docs/claims.md) are evaluated with
:mod:`adaptive_ftc.claims` on the recorded run and on the frozen-adaptation baseline; the
remaining tests check the failure patterns against an independent computation, the integrator
against the accurate solver, and record the finding that the printed manipulator gain
eta = 0.001 does not adapt.
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from functools import cache

import numpy as np
import pytest
from conftest import assert_close

from adaptive_ftc import DivergenceWarning, load_scenario, simulate
from adaptive_ftc.claims import evaluate_claims
from adaptive_ftc.sim.engine import SolverOptions

MANIPULATOR = ("manipulator-mimo-s1", "manipulator-mimo-s2")
SPACECRAFT = ("spacecraft-mimo-s1", "spacecraft-mimo-s2")
ALL = MANIPULATOR + SPACECRAFT


@cache
def runs(name: str):
    """(scenario, adaptive run, frozen-adaptation baseline), computed once per session."""
    sc = load_scenario(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        return sc, sc.run(), sc.run(adapt=False)


# ------------------------------------------------------------------ claims (docs/claims.md)
@pytest.mark.parametrize("name", ALL)
def test_every_thesis_claim_of_the_scenario_passes(name):
    sc, res, frozen = runs(name)
    assert res.status == "completed"
    verdicts = evaluate_claims(sc.claims, res, frozen=frozen)
    failed = [(v.kind, v.detail) for v in verdicts if not v.passed]
    assert not failed, f"{name}: claims FAIL: {failed}"
    kinds = {c["kind"] for c in sc.claims}
    assert {"tracking", "recovery", "bounded", "redistribution"} <= kinds
    if name in SPACECRAFT:
        assert "modal_decay" in kinds
    # on the spacecraft the baseline comparison is a separate (catalogue) tracking claim
    assert any(c.get("baseline_ratio", 0) >= 10.0 for c in sc.claims if c["kind"] == "tracking")


@pytest.mark.parametrize("name", ALL)
def test_the_tracking_recovery_bounded_and_modal_checks_fail_on_the_frozen_baseline(name):
    # The checks above can fail: with adaptation frozen (theta = theta(0)) the arm spins away
    # under the stuck torques and the spacecraft tumbles (hundreds of rad of error).
    sc, _, frozen = runs(name)
    judged = [
        c for c in sc.claims if c["kind"] in ("tracking", "recovery", "bounded", "modal_decay")
    ]
    assert len(judged) >= 3
    for verdict in evaluate_claims(judged, frozen, frozen=frozen):
        assert not verdict.passed, (verdict.kind, verdict.detail)


# ------------------------------------------------------------------ measured numbers
# RMS tracking error per output over the last 5 s / last 20 s (rad), recorded with the catalogue
# settings of the time; frozen adaptation loses the attitude in every case.
RECORDED = {
    "manipulator-mimo-s1": ([1.08e-4, 3.36e-5], [1.07e-4, 3.54e-5]),
    "manipulator-mimo-s2": ([1.11e-4, 5.17e-5], [9.14e-5, 4.39e-5]),
    "spacecraft-mimo-s1": ([1.46e-3, 1.06e-4, 4.78e-5], [9.16e-4, 9.34e-5, 2.31e-4]),
    "spacecraft-mimo-s2": ([1.97e-3, 1.50e-4, 1.95e-4], [1.25e-3, 1.27e-4, 1.00e-3]),
}


@pytest.mark.parametrize("name", ALL)
def test_final_tracking_errors_match_the_recorded_numbers(name):
    _, res, frozen = runs(name)
    t_end = res.time[-1]
    last5, last20 = RECORDED[name]
    # regression guard: the same run reproduces to 2 % (changes in the kernel show up here)
    assert_close(res.rms_error(t_end - 5), last5, atol=0.0, rtol=0.02, what=name)
    assert_close(res.rms_error(t_end - 20), last20, atol=0.0, rtol=0.02, what=name)
    # frozen adaptation loses the attitude: past 20 rad (manipulator) or out of the small-angle
    # envelope of the spacecraft model (reported as a divergence)
    assert frozen.status == "diverged" or np.all(frozen.rms_error(t_end - 5) > 20.0)


def test_printed_manipulator_gain_eta_0_001_does_not_adapt():
    """Thesis §3.4.1.2 prints eta = 0.001; the catalogue uses eta = 1 (see the scenario notes)."""
    sc, res, frozen = runs("manipulator-mimo-s1")
    printed = simulate(
        replace(sc.loop, controller=replace(sc.loop.controller, eta=0.001)), sc.solver
    )
    moved = np.abs(printed.theta - printed.theta[0]).max()
    assert moved < 0.01  # theta barely leaves 0 in 30 s ...
    # ... so the printed gain tracks no better than frozen adaptation (both > 50 rad RMS on
    # link 1 over the last 5 s: the arm spins away under the stuck 3.5 N·m torque)
    rms_printed = printed.rms_error(25.0)
    rms_frozen = frozen.rms_error(25.0)
    assert np.all(rms_printed > 50.0)
    assert np.all(rms_printed > 0.5 * rms_frozen)
    # with eta = 1 theta moves ~100x more and the error drops by six orders of magnitude
    assert np.abs(res.theta - res.theta[0]).max() > 50 * moved
    assert np.all(res.rms_error(25.0) < 1e-5 * rms_printed)


# ------------------------------------------------------------------ failures act as printed
def test_manipulator_s1_applied_torques_follow_the_printed_failures():
    _, res, _ = runs("manipulator-mimo-s1")
    t, cmd, app = res.time, res.u_cmd, res.u_applied
    healthy = res.window(0, 7.99)
    # u = R^T u0: the two actuators of a joint get the same command (3.65)
    assert_close(cmd[:, 0], cmd[:, 1], atol=1e-12)
    assert_close(cmd[:, 2], cmd[:, 3], atol=1e-12)
    assert_close(app[healthy], cmd[healthy], atol=1e-12)
    stuck12 = res.window(12, 30)
    assert_close(app[stuck12, 1], 3.5, atol=1e-12)
    locked22 = res.window(8, 17.99)
    assert_close(app[locked22, 3], 2.5, atol=1e-12)
    recovered = res.window(18, 30)
    assert_close(app[recovered, 3], cmd[recovered, 3], atol=1e-12)  # used again after 18 s
    fading = res.window(25, 30)
    assert_close(app[fading, 2], np.exp(-(t[fading] - 25)) * cmd[fading, 2], atol=1e-12)


def test_manipulator_healthy_twin_carries_the_whole_time_varying_torque():
    # After tau12 locks at 3.5 N·m (t = 12 s), tau11 alone must supply the torque variation:
    # its standard deviation over one reference period doubles w.r.t. sharing it equally.
    _, res, _ = runs("manipulator-mimo-s1")
    period = 2 * np.pi
    before = np.std(res.u_applied[res.window(12 - period, 12), 0])
    after = np.std(res.u_applied[res.window(12, 12 + period), 0])
    joint1_after = res.u_applied[res.window(12, 12 + period), :2].sum(axis=1)
    assert after > 1.5 * before
    assert_close(after, np.std(joint1_after), atol=1e-12)


def test_spacecraft_s2_applied_torques_follow_the_state_dependent_failures():
    _, res, _ = runs("spacecraft-mimo-s2")
    t, x, cmd, app = res.time, res.states, res.u_cmd, res.u_applied
    w = res.window(60, 150)
    assert_close(
        app[w, 3], (4 + x[w, 2]) * np.cos(2 * t[w]) - (2 + x[w, 3]) * np.sin(2 * t[w]), atol=1e-12
    )
    w = res.window(20, 150)
    assert_close(app[w, 2], (3 + np.tanh((50 - t[w]) / 10)) / 4 * cmd[w, 2], atol=1e-12)
    assert_close(app[w, 0], 0.6 * cmd[w, 0] + 8, atol=1e-12)
    w = res.window(30, 150)
    assert_close(app[w, 5], x[w, 4] + x[w, 5] - 7, atol=1e-12)
    w = res.window(100, 150)
    assert_close(app[w, 4], 5 + 0.1 * x[w, 3] * np.cos(3 * t[w]), atol=1e-12)
    # rho3 settles at the stated 50 %
    assert abs((3 + np.tanh((50 - 150) / 10)) / 4 - 0.5) < 1e-4


def test_spacecraft_s1_wheel_6_fails_from_the_start():
    _, res, _ = runs("spacecraft-mimo-s1")
    assert_close(res.u_applied[:, 5], 0.5 * res.u_cmd[:, 5] - 7, atol=1e-12)


# ------------------------------------------------------------------ spacecraft specifics
@pytest.mark.parametrize("name", SPACECRAFT)
def test_spacecraft_attitude_modes_and_wheel_torques_stay_small(name):
    _, res, _ = runs(name)
    names = res.state_names
    attitude = np.abs(res.states[:, :6]).max(axis=0)
    modes = np.abs(res.states[:, names.index("eta1") : names.index("eta3") + 1]).max()
    # attitude within about the reference amplitude (0.1 rad), modes and torques moderate
    assert np.all(attitude[[0, 2, 4]] < 0.11)
    assert np.all(attitude[[1, 3, 5]] < 0.05)
    assert 1e-3 < modes < 0.1  # the modes are really excited by the coupling delta ...
    assert np.abs(res.u_applied).max() < 40.0
    assert np.abs(res.theta).max() < 50.0


# ------------------------------------------------------------------ integrator choice
def test_spacecraft_catalogue_solver_agrees_with_a_tighter_one():
    sc, res, _ = runs("spacecraft-mimo-s2")
    assert sc.solver.method == "dopri5" and sc.solver.rtol == 1e-7
    ref = sc.run(solver=replace(sc.solver, rtol=1e-10, atol=1e-13))
    assert np.abs(res.y - ref.y).max() < 1e-7
    assert np.abs(res.u_applied - ref.u_applied).max() < 1e-2
    assert_close(res.rms_error(130.0), ref.rms_error(130.0), atol=1e-7)


def test_manipulator_catalogue_solver_agrees_with_fine_rk4():
    sc, res, _ = runs("manipulator-mimo-s2")
    fine = sc.run(solver=SolverOptions(method="rk4", dt=2.5e-4, record_dt=sc.solver.record_dt))
    assert sc.solver.method == "dopri5"
    assert np.abs(res.y - fine.y).max() < 1e-6
    assert np.abs(res.u_applied - fine.u_applied).max() < 1e-2


# ------------------------------------------------------------------ figures
LAYOUT = {
    "manipulator-mimo-s1": [
        ("3.2", "tracking", [1]),
        ("3.3", "tracking", [2]),
        ("3.4", "control", None),
    ],
    "manipulator-mimo-s2": [
        ("3.5", "tracking", [1]),
        ("3.6", "tracking", [2]),
        ("3.7", "control", None),
    ],
    "spacecraft-mimo-s1": [
        ("3.9", "tracking", [1]),
        ("3.10", "tracking", [2]),
        ("3.11", "tracking", [3]),
        ("3.12", "control_parameters", None),
        ("3.13", "modal", None),
    ],
    "spacecraft-mimo-s2": [
        ("3.14", "tracking", [1]),
        ("3.15", "tracking", [2]),
        ("3.16", "tracking", [3]),
        ("3.17", "control_parameters", None),
        ("3.18", "modal", None),
    ],
}


@pytest.mark.parametrize("name", ALL)
def test_figure_tables_follow_the_thesis_layout(name):
    sc = load_scenario(name)
    layout = [(f["number"], f["kind"], f.get("outputs")) for f in sc.figure_specs]
    assert layout == LAYOUT[name]
    assert sc.figures == tuple(n for n, _, _ in LAYOUT[name])
    assert all(f.get("caption") for f in sc.figure_specs)


@pytest.mark.parametrize("name", ["manipulator-mimo-s1", "spacecraft-mimo-s1"])
def test_figure_tables_draw(name):
    from adaptive_ftc import plots

    sc, res, _ = runs(name)
    for spec in sc.figure_specs:
        fig = plots.plot(res, spec["kind"], outputs=spec.get("outputs"))
        assert fig.axes
