"""Wing rock with three aileron segments and the §2.4 failure-estimation design (thesis §2.4.4).

Truths used: the thesis's claims (Fig. 2.5 limit cycle; Figs 2.6-2.11 regulation,
redistribution, recovered aileron used again, u_f as a fault indicator), a harmonic-balance
estimate of the free limit cycle, and the exact-cancellation torques computed here from the
plant's aileron gains. The claims of each scenario file are evaluated on the data with numpy,
following docs/claims.md.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from functools import cache
from typing import Any

import numpy as np
import pytest
from scipy.optimize import brentq

from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.scenarios.loader import Scenario, load_scenario
from adaptive_ftc.sim.engine import simulate
from adaptive_ftc.sim.result import SimResult

DEG = math.pi / 180.0
#: Plant aileron gains g_j as printed (plants/wingrock.py defaults).
G = np.array([-149.1759, -111.8819, -111.8819])
#: Proportional allocation b_j of the scenario files: thesis magnitudes, sign of g (2.16).
B = np.array([-2.0, -2.0, -1.0])
#: Regulation threshold of the wing-rock claims: 0.1 deg, far below the 36 deg limit cycle.
REGULATED = 0.1 * DEG

FREE = ("wingrock-free-1deg", "wingrock-free-10deg")
CLAIMED = (
    "wingrock-estimation-s1",
    "wingrock-estimation-s2",
    "wingrock-direct-s1",
    "hypersonic-estimation-s1",
)


@cache
def scenario(name: str) -> Scenario:
    return load_scenario(name)


@cache
def run(name: str, adapt: bool = True) -> SimResult:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)  # frozen baselines may diverge
        return scenario(name).run(adapt=adapt)


def between(r: SimResult, a: float, b: float, *, closed: bool = True) -> np.ndarray:
    """Samples with a <= t <= b (or a <= t < b)."""
    return (r.time >= a - 1e-9) & ((r.time <= b + 1e-9) if closed else (r.time < b - 1e-9))


def rms(v: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(v))))


# ---------------------------------------------------------------------------- free motion
def harmonic_balance_cycle(a0, a1, a2, a3, a4) -> tuple[float, float]:
    """Amplitude and angular frequency of phi = A cos(w t) on (2.101) with u = 0.

    First harmonic: stiffness ``w^2 = a0 + 3/4 a3 A^2``; zero net damping per cycle
    ``a1 + a2 (8 / 3 pi) A w + a4 A^2 / 4 = 0``.
    """

    def damping(amp: float) -> float:
        w = math.sqrt(a0 + 0.75 * a3 * amp**2)
        return a1 + a2 * 8.0 / (3.0 * math.pi) * amp * w + a4 * amp**2 / 4.0

    amp = brentq(damping, 1e-6, 5.0)
    return amp, math.sqrt(a0 + 0.75 * a3 * amp**2)


def cycle_peaks(r: SimResult, start: float) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of the local maxima of phi after ``start``."""
    t, phi = r.time, r.states[:, 0]
    i = np.where((phi[1:-1] > phi[:-2]) & (phi[1:-1] >= phi[2:]))[0] + 1
    i = i[t[i] >= start]
    return t[i], phi[i]


@pytest.mark.parametrize("name", FREE)
def test_free_motion_settles_on_a_limit_cycle(name):
    # Fig. 2.5: "the free motion starts to oscillate and settles at a limit cycle".
    r = run(name)
    assert r.status == "completed"
    assert np.all(r.u_applied == 0.0), "design 'none' must leave the ailerons at zero"
    _, peaks = cycle_peaks(r, 5.0)
    assert peaks.size > 20
    per_second = [np.max(r.states[between(r, a, a + 1.0), 0]) for a in (6.0, 7.0, 8.0, 9.0)]
    # steady: neither decaying nor growing over the last 4 s (0.1 % drift at most)
    drift = (max(per_second) - min(per_second)) / max(per_second)
    assert drift < 1e-3, f"amplitude drifts by {drift:.2%} over the last 4 s: {per_second}"
    slope = np.polyfit(np.arange(peaks.size), peaks, 1)[0]
    assert abs(slope) * peaks.size < 1e-3 * peaks.mean()
    # it is a cycle of its own, not the release angle kept: both releases reach the same one
    release = r.states[0, 0]
    assert peaks.mean() > 3 * release


def test_limit_cycle_amplitude_and_period_match_harmonic_balance_and_do_not_depend_on_release():
    plant = scenario(FREE[0]).loop.plant
    amp_hb, w_hb = harmonic_balance_cycle(plant.a0, plant.a1, plant.a2, plant.a3, plant.a4)
    amps, periods = [], []
    for name in FREE:
        r = run(name)
        tp, peaks = cycle_peaks(r, 6.0)
        amps.append(peaks.mean())
        periods.append(np.mean(np.diff(tp)))
    # the same attracting cycle from 1 deg and from 10 deg
    assert amps[0] == pytest.approx(amps[1], rel=1e-3)
    assert periods[0] == pytest.approx(periods[1], rel=1e-2)
    # first-harmonic estimate (independent of the simulation): A ~ 35 deg, T ~ 0.18 s
    assert amps[0] == pytest.approx(amp_hb, rel=0.10), (np.degrees(amps[0]), np.degrees(amp_hb))
    assert periods[0] == pytest.approx(2 * math.pi / w_hb, rel=0.05)


# ---------------------------------------------------------------------------- sign convention
def test_printed_positive_allocation_violates_2_16_and_diverges_negative_one_regulates():
    sc = scenario("wingrock-estimation-s1")
    assert np.allclose(sc.loop.R[0], B)
    assert float(G @ B) > 0  # beta_bar of the healthy plant, assumption (2.16)
    wrong = dataclasses.replace(sc.loop, allocation=tuple(-B))
    assert float(G @ -B) < 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        bad = simulate(wrong, dataclasses.replace(sc.solver, dt=1e-5))
    assert bad.status == "diverged" and bad.time[-1] < 0.01
    assert run("wingrock-estimation-s1").status == "completed"


def test_beta_bar_stays_positive_on_every_failure_interval_of_both_scenarios():
    # (2.16) with the effective gains rho_j of each interval (stuck: 0)
    intervals = {
        "s1": [(1, 1, 1), (1, 1, 0), (1, 0.3, 0), (1, 0.3, 1)],
        "s2": [(1, 1, 1), (1, 1, 0), (1, 0, 0), (0.7, 0, 0), (0.7, 1, 0)],
    }
    lowest = min(float(G @ (B * np.array(rho))) for v in intervals.values() for rho in v)
    assert lowest == pytest.approx(0.7 * 2 * 149.1759, rel=1e-9)
    assert lowest > 0


@pytest.mark.parametrize("name", ["wingrock-estimation-s1", "wingrock-estimation-s2"])
def test_rk4_step_of_the_file_agrees_with_the_accurate_solver(name):
    sc = scenario(name)
    ref = sc.run(solver=dataclasses.replace(sc.solver, method="accurate"))
    r = run(name)
    assert ref.status == r.status == "completed"
    assert np.max(np.abs(r.states[:, 0] - ref.states[:, 0])) < 1e-3 * DEG
    assert np.max(np.abs(r.u_applied - ref.u_applied)) < 1e-3 * np.max(np.abs(ref.u_applied))


# ---------------------------------------------------------------------------- §2.4 claims
@pytest.mark.parametrize("name", ["wingrock-estimation-s1", "wingrock-estimation-s2"])
def test_roll_is_regulated_far_below_the_free_limit_cycle(name):
    r = run(name)
    assert r.status == "completed"
    last = between(r, r.time[-1] - 2.0, r.time[-1])
    regulated = rms(r.states[last, 0])
    free = run(FREE[0])
    cycle = rms(free.states[between(free, 8.0, 10.0), 0])
    assert regulated <= REGULATED, f"RMS |phi| over the last 2 s = {regulated / DEG:.3g} deg"
    assert regulated < 1e-3 * cycle


def _u0_shift_for_stuck(stuck_torque: float, effective: np.ndarray) -> float:
    """Common signal u0 that cancels a stuck torque with the effective ailerons."""
    return -stuck_torque / float(G @ (B * effective))


@pytest.mark.parametrize(
    ("name", "time", "required"),
    [
        # aileron 3 stuck at 10; ailerons 1, 2 healthy
        ("wingrock-estimation-s1", 3.0, _u0_shift_for_stuck(G[2] * 10.0, np.array([1, 1, 0]))),
        # aileron 3 starts on 1 - 30 sin 5t + 20 cos 5t at t = 3
        (
            "wingrock-estimation-s2",
            3.0,
            _u0_shift_for_stuck(
                G[2] * (1 - 30 * math.sin(15.0) + 20 * math.cos(15.0)), np.array([1, 1, 0])
            ),
        ),
    ],
)
def test_stuck_aileron_makes_the_failure_compensator_move(name, time, required):
    # §2.4.4: u_f "gives a rough information about the failure occurrence"
    r = run(name)
    before = r.u_f[between(r, time - 0.5, time, closed=False)]
    after = r.u_f[between(r, time, time + 0.5)]
    assert np.max(np.abs(before)) < 0.01 * abs(required), "u_f must be quiet before"
    moved = np.max(np.abs(after - before[-1]))
    assert moved >= 0.25 * abs(required), (moved, required)
    # and, 10 ms after the onset (failure value still close to its onset value), u_f has
    # moved towards the compensation the failure calls for
    early = r.u_f[between(r, time + 0.01, time + 0.01)][0] - before[-1]
    assert np.sign(early) == np.sign(required) and abs(early) >= 0.25 * abs(required)


def test_healthy_ailerons_cancel_the_failed_torque_in_scenario_2():
    # redistribution in physical terms: when the roll is regulated, the healthy ailerons'
    # torque cancels the failed ones (net aileron torque ~ 0 against thousands)
    r = run("wingrock-estimation-s2")
    m = between(r, 8.0, 10.0)
    torque = r.u_applied[m] * G
    assert rms(torque.sum(axis=1)) < 0.05 * rms(torque[:, 2])
    m = between(r, 5.5, 8.0, closed=False)  # aileron 1 (70 %) alone against ailerons 2 and 3
    torque = r.u_applied[m] * G
    assert rms(torque.sum(axis=1)) < 0.05 * rms(torque[:, 1] + torque[:, 2])


def test_recovered_aileron_carries_its_share_again():
    # §2.4.4 scenario 2: aileron 2 recovers at 8 s and must help cancel aileron 3
    r = run("wingrock-estimation-s2")
    m = between(r, 8.0, 10.0)
    np.testing.assert_allclose(r.u_applied[m, 1], r.u_cmd[m, 1], atol=1e-12)
    t = np.linspace(8.0, 10.0, 200_001)
    u3 = 1 - 30 * np.sin(5 * t) + 20 * np.cos(5 * t)
    u0 = -G[2] * u3 / float(G @ (B * np.array([0.7, 1.0, 0.0])))
    predicted = float(np.mean(np.abs(B[1] * u0)))  # 12.20
    assert np.mean(np.abs(r.u_applied[m, 1])) == pytest.approx(predicted, rel=0.10)
    # scenario 1: aileron 3 leaves 10 at 8 s and is back on its share b3 u0 of the command
    r = run("wingrock-estimation-s1")
    m = between(r, 8.0, 10.0)
    assert np.all(r.u_applied[between(r, 3.0, 8.0, closed=False), 2] == 10.0)
    np.testing.assert_allclose(r.u_applied[m, 2], B[2] * r.u0[m, 0], atol=1e-12)
    np.testing.assert_allclose(r.u_applied[m, 2], r.u_applied[m, 0] / 2.0, atol=1e-12)


def test_exact_failure_basis_beats_a_constant_basis_on_the_oscillating_failure():
    # the documented varpi_j choice: [1, sin 5t, cos 5t] spans scenario 2's pattern exactly
    sc = scenario("wingrock-estimation-s2")
    assert sc.loop.controller.basis == ("1", "sin(5*t)", "cos(5*t)")
    const = dataclasses.replace(
        sc.loop, controller=dataclasses.replace(sc.loop.controller, basis=("1",))
    )
    r1 = simulate(const, sc.solver)
    r3 = run("wingrock-estimation-s2")
    m1 = between(r1, 3.0, 10.0)
    m3 = between(r3, 3.0, 10.0)
    assert r1.status == "completed"
    assert rms(r1.states[m1, 0]) <= REGULATED  # both regulate...
    assert rms(r3.states[m3, 0]) < rms(r1.states[m1, 0])  # ...the exact basis better


# ---------------------------------------------------------------------------- claims as data
def _before(r: SimResult, time: float, window: float) -> np.ndarray:
    return between(r, time - window, time, closed=False)


def check_claim(name: str, claim: dict[str, Any]) -> tuple[bool, float]:
    """Evaluate one ``[[claims]]`` table on the recorded data (docs/claims.md)."""
    r = run(name)
    kind = claim["kind"]
    t_end = float(r.time[-1])
    if kind == "tracking":
        window = float(claim.get("window", 20.0))
        m = between(r, t_end - window, t_end)
        measured = float(np.max(np.sqrt(np.mean(r.e[m] ** 2, axis=0))))
        ok = r.status == "completed" and measured <= claim["threshold"]
        if "baseline_ratio" in claim:
            base = run(name, adapt=False)
            if base.status == "completed" and base.time[-1] >= t_end - 1e-9:
                mb = between(base, t_end - window, t_end)
                ratio = float(np.min(np.sqrt(np.mean(base.e[mb] ** 2, axis=0)))) / measured
            else:
                ratio = math.inf
            ok = ok and ratio >= claim["baseline_ratio"]
        return ok, measured
    if kind == "recovery":
        window = float(claim["window"])
        events = list(r.failure_times) + [t_end]
        worst = 0.0
        for a, b in zip(events[:-1], events[1:], strict=True):
            m = between(r, max(a, b - window), b, closed=b == t_end)
            worst = max(worst, float(np.max(np.sqrt(np.mean(r.e[m] ** 2, axis=0)))))
        return worst <= claim["threshold"], worst
    if kind == "bounded":
        peak = max(
            float(np.max(np.abs(r.states))),
            float(np.max(np.abs(r.u_cmd))),
            float(np.max(np.abs(r.u_applied))),
        )
        return r.status == "completed" and peak <= claim["bound"], peak
    if kind == "redistribution":
        time, window = float(claim["time"]), float(claim["window"])
        settle = float(claim.get("settle", 0.0))
        factor = float(claim.get("factor", 1.1))
        cols = [j - 1 for j in claim["healthy"]]
        before = np.mean(np.abs(r.u_applied[_before(r, time, window)][:, cols]), axis=0)
        after = np.mean(
            np.abs(r.u_applied[between(r, time + settle, time + settle + window)][:, cols]),
            axis=0,
        )
        # each healthy actuator (which implies their mean) grows by the factor
        gain = float(np.min(after / np.maximum(before, 1e-300)))
        return gain > factor, gain
    if kind == "recovered_used":
        time, window = float(claim["time"]), float(claim["window"])
        j = int(claim["actuator"]) - 1
        level = float(np.mean(np.abs(r.u_applied[between(r, time, time + window), j])))
        return level >= claim["min_level"], level
    if kind == "fault_indicator":
        time, window = float(claim["time"]), float(claim["window"])
        ref = r.u_f[_before(r, time, 1.0)][-1]
        moved = float(np.max(np.abs(r.u_f[between(r, time, time + window)] - ref)))
        return moved >= claim["threshold"], moved
    if kind == "rate_tracking":
        window = float(claim.get("window", 20.0))
        m = between(r, t_end - window, t_end)
        measured = float(np.max(np.sqrt(np.mean(r.edot[m] ** 2, axis=0))))
        return r.status == "completed" and measured <= claim["threshold"], measured
    if kind == "parameter_bounded":
        prefixes = tuple(claim.get("parameters", ()))
        cols = [i for i, n in enumerate(r.adaptive_names) if not prefixes or n.startswith(prefixes)]
        measured = float(np.max(np.abs(r.adaptive[:, cols])))
        return r.status == "completed" and measured <= claim["bound"], measured
    raise AssertionError(f"claim kind {kind!r} of {name} is not one of docs/claims.md")


@pytest.mark.parametrize("name", CLAIMED)
def test_every_claim_of_the_scenario_file_holds_on_the_data(name):
    claims = scenario(name).claims
    assert claims, f"{name} has no [[claims]]"
    failed = []
    for claim in claims:
        ok, measured = check_claim(name, claim)
        if not ok:
            failed.append(f"{claim['kind']} ({claim.get('time', '')}): measured {measured:.4g}")
    assert not failed, failed


def test_thesis_claim_kinds_are_all_present():
    kinds = {n: {c["kind"] for c in scenario(n).claims} for n in CLAIMED}
    thesis = {"tracking", "recovery", "redistribution", "fault_indicator", "bounded"}
    assert thesis <= kinds["wingrock-estimation-s1"]
    assert thesis | {"recovered_used"} <= kinds["wingrock-estimation-s2"]


def test_scenario_files_load_with_the_thesis_gains_and_figures():
    expected = {
        "wingrock-free-1deg": {"2.5a": "tracking"},
        "wingrock-free-10deg": {"2.5b": "tracking"},
        "wingrock-estimation-s1": {"2.6": "tracking", "2.7": "control", "2.8": "parameters"},
        "wingrock-estimation-s2": {"2.9": "tracking", "2.10": "control", "2.11": "parameters"},
    }
    for name, figs in expected.items():
        sc = scenario(name)
        assert sc.loop.plant.name == "wingrock"
        assert {f["number"]: f["kind"] for f in sc.figure_specs} == figs
        assert sc.figures == tuple(figs)
    for name, phi0 in (("wingrock-estimation-s1", 1.0), ("wingrock-estimation-s2", 10.0)):
        sc = scenario(name)
        c = sc.loop.controller
        assert (c.design, c.lam, c.eta1, c.eta2, c.sigma, c.eps0, c.k, c.k0) == (
            "estimation",
            5.0,
            20.0,
            20.0,
            0.1,
            0.005,
            20.0,
            10.0,
        )
        assert c.theta0 == 0.0 and c.kappa0 == 0.0
        assert c.regressor.inputs == ("e", "edot") and c.regressor.bias
        assert sc.loop.initial_state == pytest.approx((phi0 * DEG, 0.0))
        assert sc.loop.t_final == 10.0
    assert scenario("wingrock-direct-s1").loop.controller.design == "direct"
    assert scenario("hypersonic-estimation-s1").loop.controller.design == "estimation"
    assert scenario("hypersonic-estimation-s1").loop.plant.name == "hypersonic"
