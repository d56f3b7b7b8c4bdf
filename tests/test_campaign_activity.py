"""Campaign success counts tracking and control activity (issue 25 item 5): the criterion of
``campaigns/activity.py`` against rows of known numbers and the base's ideal run, the
``thesis-law`` / ``constraint-aware`` designs of a member, and the spec's validation."""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
import pytest

from adaptive_ftc.campaigns import CampaignError, draw_member, load_campaign
from adaptive_ftc.campaigns.activity import ActivityCriterion, ideal_reference
from adaptive_ftc.campaigns.runner import outcome
from adaptive_ftc.scenarios import load_scenario
from adaptive_ftc.sim.activity import max_record_dt
from adaptive_ftc.sim.engine import simulate

SPEC = {
    "name": "act",
    "base": "hypersonic-direct-s1",
    "designs": ["thesis-law", "constraint-aware"],
    "runs": 4,
    "seed": 3,
    "chunk_size": 2,
    "duration": 4.0,
    "success": {"rms_error_final": 0.01, "final_window": 1.0},
    "failures": {"count": 0},
    "hardware": {"lag": {"uniform": [0.02, 0.05]}, "sample_time": {"choice": [0.0, 0.01]}},
}


def spec_with(**success):
    data = copy.deepcopy(SPEC)
    data["success"].update(success)
    return data


QUIET = {
    "activity_record_ok": True,
    "fast_rms_max": 0.01,
    "rate_limited_fraction_max": math.nan,
    "peak_command_travel_ratio_max": math.nan,
    "peak_command_final": 1.0,
}


def test_the_criterion_holds_each_number_to_its_threshold():
    c = ActivityCriterion(reference_peak_to_peak=0.5, reference_peak_command=0.3)
    assert c.thresholds(None) == pytest.approx((0.015, 3.0))
    assert c.judge(QUIET, None) == (True, "")
    ok, why = c.judge({**QUIET, "fast_rms_max": 0.016}, None)
    assert not ok and "fast content 0.016 > 0.015" in why
    ok, why = c.judge({**QUIET, "rate_limited_fraction_max": 0.06}, None)
    assert not ok and "rate limit" in why
    assert c.judge({**QUIET, "rate_limited_fraction_max": 0.05}, None)[0]
    # a declared travel: the peak is held to it, not to 10x the ideal peak
    assert c.judge({**QUIET, "peak_command_travel_ratio_max": 1.0, "peak_command_final": 9}, None)[
        0
    ]
    ok, why = c.judge({**QUIET, "peak_command_travel_ratio_max": 1.2}, None)
    assert not ok and "1.2 x the travel" in why
    ok, why = c.judge({**QUIET, "peak_command_final": 3.5}, None)
    assert not ok and "peak command 3.5 > 3" in why
    # a record too coarse, or a nan fast content: never a success
    assert not c.judge({**QUIET, "activity_record_ok": False}, None)[0]
    assert not c.judge({**QUIET, "fast_rms_max": math.nan}, None)[0]


def test_the_references_default_to_the_base_scenarios_ideal_run():
    spec = load_campaign(spec_with())
    p2p, peak = ideal_reference(spec)
    sc = load_scenario("hypersonic-direct-s1")
    r = simulate(dataclasses.replace(sc.loop, t_final=4.0), sc.solver)
    u = r.u_cmd[r.window(r.time[-1] - 1.0)]
    assert p2p == pytest.approx(float(np.max(np.ptp(u, axis=0))), rel=1e-12)
    assert peak == pytest.approx(float(np.max(np.abs(u))), rel=1e-12)
    assert spec.activity.thresholds(spec) == pytest.approx((0.03 * p2p, 10 * peak))
    stated = load_campaign(spec_with(reference_peak_to_peak=0.2, reference_peak_command=0.1))
    assert stated.activity.thresholds(stated) == pytest.approx((0.006, 1.0))
    assert "0.006" in stated.success_text() and "RMS error <= 0.01" in stated.success_text()


def test_success_is_tracking_and_activity():
    spec = load_campaign(spec_with(reference_peak_to_peak=0.2, reference_peak_command=0.1))
    mem = draw_member(spec, 0)
    r = simulate(mem.design_loop("thesis-law"), spec.solver)
    row = outcome(r, spec)
    assert row["activity_record_ok"] and row["tracking_ok"]
    # the thesis law behind a 20-50 ms lag chatters above 3 % of 0.2 rad
    assert row["fast_rms_max"] > 0.006 and not row["activity_ok"] and not row["success"]
    assert "fast content" in row["activity_why"]
    loose = load_campaign(spec_with(activity=False))
    row = outcome(r, loose)
    assert row["success"] == row["tracking_ok"] is True and row["activity_why"] == ""


def test_members_record_fine_enough_to_judge_their_activity():
    from adaptive_ftc.campaigns.store import column_units

    spec = load_campaign(spec_with())
    assert column_units(spec)["peak_command_final"] == "rad"  # the elevators' unit
    # the smallest drawable sample time is 0.01 s: records every 1 ms (<= T_s / 5)
    assert spec.solver.record_dt == pytest.approx(max_record_dt(1.0, 0.01))
    off = load_campaign(spec_with(activity=False))
    assert off.solver == off.base.solver


def test_the_designs_are_the_base_design_without_and_with_the_option():
    spec = load_campaign(spec_with())
    for i in range(spec.runs):
        mem = draw_member(spec, i)
        thesis = mem.design_loop("thesis-law").controller
        aware = mem.design_loop("constraint-aware").controller
        assert thesis.constraint_aware is None
        assert aware.constraint_aware.lag == pytest.approx(mem.columns["hw_lag"])
        assert aware.constraint_aware.sample_time == mem.columns["hw_sample_time"]
        assert dataclasses.replace(aware, constraint_aware=None) == thesis


def test_the_spec_refuses_a_malformed_activity_criterion():
    with pytest.raises(CampaignError) as exc:
        load_campaign(spec_with(activity="yes", max_fast_rms_relative=-1, reference_peak_to_peak=0))
    msg = str(exc.value)
    assert "`activity` must be true or false" in msg
    assert "`max_fast_rms_relative`" in msg and "`reference_peak_to_peak`" in msg
    with pytest.raises(CampaignError, match="activity = false` judges tracking only: remove"):
        load_campaign(spec_with(activity=False, max_rate_limited_fraction=0.1))
    with pytest.raises(CampaignError, match="unknown key 'max_fast_rms_relativ'"):
        load_campaign(spec_with(max_fast_rms_relativ=0.03))


def test_a_fixed_gain_baseline_of_a_noisy_loop_freezes_only_the_adaptive_states():
    """With sensor noise ``sdot = "auto"`` resolves to the s' filter, whose states are not
    adaptive parameters: the tuned parameters leave them out (a campaign drawing noise ran
    no fixed-gain member before)."""
    from adaptive_ftc.baselines import fixed_gain
    from adaptive_ftc.sim.engine import SolverOptions

    sc = load_scenario("hypersonic-direct-s1-noise")
    loop = dataclasses.replace(sc.loop, t_final=1.0)
    solver = SolverOptions(method="rk4", dt=1e-3, sdot="auto")
    base = fixed_gain(loop, solver)
    r = simulate(base, solver)
    assert r.status == "completed"
    assert len(base.adaptive_initial) == r.adaptive.shape[1] - loop.plant.n_outputs
