"""A hardware campaign member counts as a success only when it is "acceptable" in every part
of issue 25's definition, each part on its own: no divergence, the final-window RMS error
within the threshold, little fast command content, the peak command within the declared
travel (or within 10x the ideal peak where none is declared), at most 5 % of the final window
at a rate limit. The rows come from :func:`adaptive_ftc.campaigns.runner.outcome` of a real
member's run whose command (and actuator position) is replaced by signals of known activity.
"""

from __future__ import annotations

import copy
import dataclasses
import warnings

import numpy as np
import pytest

from adaptive_ftc.campaigns import draw_member, load_campaign
from adaptive_ftc.campaigns.runner import outcome
from adaptive_ftc.sim.engine import simulate

RATE, TRAVEL = 5.0, 1.0
SPEC = {
    "name": "acceptable",
    "base": "hypersonic-direct-s1",
    "designs": ["constraint-aware"],
    "runs": 1,
    "seed": 3,
    "chunk_size": 1,
    "duration": 3.0,
    # fast content <= 0.03 x 1.0 rad; without a travel, peak <= 10 x 1.0 rad
    "success": {
        "rms_error_final": 0.01,
        "final_window": 1.0,
        "reference_peak_to_peak": 1.0,
        "reference_peak_command": 1.0,
    },
    "failures": {"count": 0},
    "hardware": {"lag": 0.02, "rate_limit": RATE, "travel": TRAVEL},
}


def _spec(hardware=None, **success):
    data = copy.deepcopy(SPEC)
    if hardware is not None:
        data["hardware"] = hardware
    data["success"].update(success)
    return load_campaign(data)


def _member_run(spec):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(draw_member(spec, 0).design_loop("constraint-aware"), spec.solver)


def _quiet(r, u=None, position=None):
    """The run with a slow command (0.2 sin 0.5t, 0.1 rad/s at most) or the one given; the
    actuators follow it (or the position given)."""
    if u is None:
        u = np.column_stack([0.2 * np.sin(0.5 * r.time)] * r.u_cmd.shape[1])
    pos = u if position is None else position
    if r.actuator_position is None:
        return dataclasses.replace(r, u_cmd=u, u_applied=u)
    return dataclasses.replace(r, u_cmd=u, u_applied=pos, actuator_position=pos)


@pytest.fixture(scope="module")
def limited():
    """(spec, run) of a member with a 20 ms lag, 5 rad/s and +-1 rad."""
    spec = _spec()
    return spec, _member_run(spec)


def test_a_quiet_tracking_member_is_a_success(limited):
    spec, r = limited
    row = outcome(_quiet(r), spec)
    assert row["status"] == "completed" and row["rms_error_final"] <= 0.01
    assert row["tracking_ok"] and row["activity_ok"] and row["success"], row["activity_why"]


def test_a_diverged_member_is_never_a_success(limited):
    spec, r = limited
    row = outcome(dataclasses.replace(_quiet(r), status="diverged"), spec)
    assert not row["tracking_ok"] and not row["activity_ok"] and not row["success"]
    assert row["activity_why"] == "the run did not complete"


def test_an_error_above_the_threshold_is_no_success(limited):
    spec, r = limited
    err = outcome(_quiet(r), spec)["rms_error_final"]
    tight = _spec(rms_error_final=0.5 * err)
    row = outcome(_quiet(r), tight)
    assert not row["tracking_ok"] and row["activity_ok"] and not row["success"]


def test_fast_command_content_is_no_success(limited):
    spec, r = limited
    u = _quiet(r).u_cmd + 0.1 * np.sin(2 * np.pi * 12.0 * r.time)[:, None]  # 0.07 rad RMS
    row = outcome(_quiet(r, u, position=_quiet(r).u_cmd), spec)
    assert row["tracking_ok"] and not row["success"]
    assert "fast content" in row["activity_why"] and row["fast_rms_max"] > 0.03


def test_a_peak_command_beyond_the_declared_travel_is_no_success(limited):
    spec, r = limited
    u = np.full_like(r.u_cmd, 1.2 * TRAVEL)  # constant: no fast content, no rate
    row = outcome(_quiet(r, u, position=np.full_like(u, TRAVEL)), spec)
    assert not row["success"] and "1.2 x the travel" in row["activity_why"]
    assert "fast content" not in row["activity_why"]


def test_time_at_a_rate_limit_is_no_success_above_5_percent(limited):
    spec, r = limited
    # the actuator moves at its rate limit (a triangle of slope +-5 rad/s) the whole window,
    # within its travel; the command itself is the slow one
    t = r.time
    tri = 0.25 - np.abs(np.mod(RATE * t, 1.0) - 0.5)
    pos = np.column_stack([tri] * r.u_cmd.shape[1])
    row = outcome(_quiet(r, position=pos), spec)
    assert row["rate_limited_fraction_max"] > 0.9
    assert not row["success"] and "at a rate limit" in row["activity_why"]
    # at rest except 4 % of the window: within the 5 %
    still = np.where(t >= t[-1] - 0.04, tri, 0.0)
    row = outcome(_quiet(r, position=np.column_stack([still] * r.u_cmd.shape[1])), spec)
    assert row["rate_limited_fraction_max"] <= 0.05 and row["success"], row["activity_why"]


def test_without_a_declared_travel_the_peak_is_held_to_10x_the_ideal_peak():
    """No travel drawn: the peak ratio is 0 (nothing to divide by), and the member's peak
    command is held to 10 x the ideal run's (here stated: 1 rad). A 7 rad command used to
    count as a success."""
    spec = _spec(hardware={"lag": 0.02})
    r = _member_run(spec)
    ok = outcome(_quiet(r, np.full_like(r.u_cmd, 9.0)), spec)
    assert ok["peak_command_travel_ratio_max"] == 0.0 and ok["success"], ok["activity_why"]
    row = outcome(_quiet(r, np.full_like(r.u_cmd, 11.0)), spec)
    assert not row["success"] and "peak command 11 > 10" in row["activity_why"]
