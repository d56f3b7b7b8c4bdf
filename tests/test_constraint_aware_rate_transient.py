"""A tight rate limit's failure transient (issue 25, round 6): where the rate limit meets a
failure transient at the loop rate (``C_MARGIN rate_u0 / A_RATE < C_TIGHT w``), a
single-output design filters each actuator's command on its own, at that actuator's rate,
and the compensated error hedges what the actuators deliver together (gain-weighted).
Before, the common command filter's rate was sized for the most-allocated elevator (gain
2): hypersonic-direct-s1 behind 0.5 rad/s elevators held elevator 1 to 0.225 rad/s once
elevator 2 was stuck, and diverged 2.2 s after the bias failure (docs/hardware.md, "Round
6: a tight rate limit's failure transient")."""

from __future__ import annotations

import math
import shutil
import warnings
from dataclasses import replace

import numpy as np
import pytest

from adaptive_ftc.controllers import ConstraintAware
from adaptive_ftc.controllers.constraints import C_HEDGE, C_MARGIN
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.hardware import Actuators
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim.compose import assemble
from adaptive_ftc.sim.engine import simulate

THRESHOLD = 8.7e-4  # the scenario's tracking claim: 1 % of the reference amplitude


def _loop(rate: float, t1: float = 40.0, t2: float = 80.0, t_final: float = 120.0):
    sc = load_scenario("hypersonic-direct-s1")
    first, second = sc.loop.failures.failures
    failures = replace(
        sc.loop.failures, failures=(replace(first, onset=t1), replace(second, onset=t2))
    )
    loop = replace(sc.loop, actuators=Actuators(rate=rate), t_final=t_final, failures=failures)
    ca = ConstraintAware.from_loop(loop)
    return sc, replace(loop, controller=replace(loop.controller, constraint_aware=ca))


def test_a_tight_rate_limit_filters_each_elevator_at_its_own_rate():
    """0.5 rad/s, allocation (1, 2): tight (``0.9 x 0.5 / 2 / A_RATE`` = 5.6 < 2 x 20), so
    each elevator's command has its own filter at 0.45 rad/s (the common filter's ``u0``
    rate stays 0.225: elevator 2's over its gain) and ``xi`` still returns at ``C_HEDGE w``;
    at 10 rad/s (not tight) the loop keeps the common filter alone (no state added)."""
    _, loop = _loop(0.5)
    bound = loop.controller.bound(loop)
    ca = bound.constraint_aware
    w, _ = ca.omega_max(ca.loop_rate, ca.b_max)
    cfg = bound.configuration()
    assert cfg.actuator_rate == pytest.approx(C_MARGIN * 0.5)
    assert cfg.u_rate == pytest.approx(C_MARGIN * 0.5 / 2.0)
    assert cfg.omega_h == pytest.approx(C_HEDGE * w)
    names = assemble(loop).adaptive_names
    assert "actuator_filter1" in names and "actuator_filter2" in names
    _, loop = _loop(10.0)
    assert math.isinf(loop.controller.bound(loop).configuration().actuator_rate)
    assert "actuator_filter1" not in assemble(loop).adaptive_names


def _run(loop, sc):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        return simulate(loop, replace(sc.solver, record_dt=1e-3))


def test_a_half_rad_s_elevator_holds_the_direct_design_through_the_bias_failure():
    """The scenario's failures moved to 20 and 40 s (70 s run) behind 0.5 rad/s elevators:
    the loop holds (error over 60-70 s within the claim's threshold; the delivered elevators
    never at the rate limit there), and every elevator's command respects its rate."""
    sc, loop = _loop(0.5, 20.0, 40.0, 70.0)
    r = _run(loop, sc)
    assert r.status == "completed"
    err = float(np.max(r.rms_error(60.0, 70.0)))
    assert math.isfinite(err) and err <= THRESHOLD, err
    sel = r.time >= 60.0
    pos = np.asarray(r.actuator_position, dtype=float)
    for j in range(pos.shape[1]):
        # the commands are the actuators' own filters (named in the order of the states)
        assert np.array_equal(r.adaptive_state(f"actuator_filter{j + 1}"), r.u_cmd[:, j])
        rate = np.abs(np.gradient(pos[:, j], r.time))
        assert float(np.mean(rate[sel] >= 0.98 * 0.5)) <= 0.05
        cmd_rate = np.abs(np.diff(r.u_cmd[:, j]) / np.diff(r.time))
        assert float(np.max(cmd_rate)) <= C_MARGIN * 0.5 * 1.01  # (dense output)


def test_with_the_common_filter_alone_the_same_run_diverges(monkeypatch):
    """The contrast: without the per-actuator filters (no gain weights: the common filter,
    the rule before round 6) the loop is lost shortly after the 40 s bias failure."""
    import adaptive_ftc.controllers.constraints as constraints

    monkeypatch.setattr(constraints, "_delivery_weights", lambda g: None)
    sc, loop = _loop(0.5, 20.0, 40.0, 70.0)
    r = _run(loop, sc)
    assert r.status != "completed"
    assert 40.0 < float(r.time[-1]) < 45.0


@pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler (cc)")
def test_the_per_actuator_filters_export_to_c_bit_for_bit(tmp_path):
    """The exported controller (C) with the per-actuator filters, in the loop, against the
    simulation: a digital §2.3 law at 256 Hz behind 0.5 rad/s elevators, 42 s (the elevator
    failure at 40 s included)."""
    from adaptive_ftc.export.sil import verify

    path = tmp_path / "tight.toml"
    path.write_text(
        'extends = "hypersonic-direct-s1"\nname = "hypersonic-direct-s1-tight-rate"\n'
        "duration = 42.0\n\n[actuators]\nrate = 0.5\n\n"
        "[controller.constraint_aware]\nfrom_hardware = true\n"
    )
    sc = load_scenario(path)
    loop = replace(sc.loop, sample_time=2.0**-8)
    assert "actuator_filter2" in assemble(loop).adaptive_names
    report = verify(str(path), sample_time=2.0**-8, t_final=42.0, workdir=tmp_path)
    assert report.samples > 100
    assert max(report.command, report.plant_state, report.controller_state) <= 1e-12, report
