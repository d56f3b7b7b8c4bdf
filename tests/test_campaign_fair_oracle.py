"""The campaigns' oracle under the same hardware (issue 25, items 3 and 5): the ``oracle``
design runs with the member's constraint-aware designer's model (the same command filter,
smoothing and measurement filters, derived from the drawn hardware) and knows the failure;
``oracle-plain`` is the thesis-gain oracle with no command filter, kept for comparison. On a
hardware member the plain one chatters and the fair one does not (the activity verdict); the
page says on how many of a design's failed members the oracle failed too. Since session 13 the
``oracle`` also keeps the law's fixed feedback (``tests/test_law_oracle.py``); the former one is
``oracle-filtered``."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pandas as pd
import pytest

from adaptive_ftc import simulate
from adaptive_ftc.campaigns import (
    DESIGN_VARIANTS,
    CampaignError,
    draw_member,
    load_campaign,
    read_results,
    run_campaign,
    summary,
)
from adaptive_ftc.campaigns.spec import EXAMPLES
from adaptive_ftc.campaigns.summary import headline, role, success_tables
from adaptive_ftc.controllers import OracleInverse

HARDWARE_CAMPAIGNS = (
    "hypersonic-hardware",
    "wingrock-hardware",
    "manipulator-hardware",
    "spacecraft-hardware",
)


def shipped(name: str, **update) -> dict:
    data = tomllib.loads((EXAMPLES / f"{name}.toml").read_text(encoding="utf-8"))
    data.update(update)
    return data


@pytest.mark.parametrize("name", HARDWARE_CAMPAIGNS)
def test_the_campaign_oracle_carries_the_members_constraint_aware_model(name):
    """Structure: the oracle's controller is the oracle inverse with the constraint-aware
    design's model of this member (completed from the loop as the compiled loop uses it), on
    the member's own actuators, sampling and sensors; the plain oracle has no model."""
    spec = load_campaign(shipped(name, runs=2, chunk_size=2))
    member = draw_member(spec, 1)
    aware = member.design_loop("constraint-aware")
    fair = member.design_loop("oracle")
    plain = member.design_loop("oracle-plain")
    model = aware.controller.bound(aware).constraint_aware
    assert model is not None and not model.is_ideal  # the member's drawn hardware
    for loop in (fair, plain):
        assert type(loop.controller) is OracleInverse
        assert loop.failures == member.loop.failures
        assert loop.actuators == member.loop.actuators and loop.sensors == member.loop.sensors
        assert loop.sample_time == member.loop.sample_time
    # the same model, but the smoothing command filter where the law has the discrete
    # limiter (spec._oracle_model: the oracle's exact inverse does not smooth its command)
    assert fair.controller.constraint_aware == dataclasses.replace(model, per_actuator=False)
    assert not fair.controller.bound(fair).constraint_aware.discrete_limiter
    if name == "hypersonic-hardware":  # member 1: 100 Hz, limited: the law has the limiter
        assert model.discrete_limiter
    assert plain.controller.constraint_aware is None
    # the thesis gains in both; the fair one scales them by its model when it runs
    for key in ("lam", "k", "k0", "eps0"):
        assert getattr(fair.controller, key) == getattr(member.loop.controller, key)
        assert getattr(plain.controller, key) == getattr(member.loop.controller, key)


def test_on_hardware_the_plain_oracle_chatters_and_the_fair_one_does_not(tmp_path):
    """Two hypersonic-hardware members at 4 s (references of the activity verdict stated: the
    base's 120 s ideal run, 0.577 rad peak to peak, 0.6 rad peak): the oracle with the
    constraint-aware filters tracks with a quiet command; the thesis-gain oracle tracks too,
    but its command's fast content is 3-200x larger and fails the verdict."""
    data = shipped("hypersonic-hardware", runs=2, chunk_size=2, duration=4.0)
    data["designs"] = ["oracle", "oracle-plain"]
    data["success"].update(
        final_window=1.0, reference_peak_to_peak=0.577, reference_peak_command=0.6
    )
    data["failures"]["onset"] = {"uniform": [1.0, 2.0]}
    spec = load_campaign(data)
    run_campaign(spec, tmp_path / "c", jobs=1, progress=False, summary=False)
    df = read_results(tmp_path / "c").set_index(["index", "design"])
    assert (df["status"] == "completed").all() and df["tracking_ok"].all()
    fast_max = 0.03 * 0.577
    for i in range(2):
        fair, plain = df.loc[(i, "oracle")], df.loc[(i, "oracle-plain")]
        assert fair["activity_ok"] and fair["success"], fair["activity_why"]
        assert fair["fast_rms_max"] < fast_max
        assert not plain["activity_ok"] and not plain["success"]
        assert "fast content" in plain["activity_why"] and plain["fast_rms_max"] > fast_max


def test_without_hardware_the_campaign_oracle_is_the_thesis_gain_oracle():
    """On ideal hardware the constraint-aware model is ideal and the design reduces to the
    thesis law: the oracle's trajectory is the plain oracle's, bit for bit (the oracle rows of
    campaigns without hardware do not move)."""
    spec = load_campaign(
        {
            "name": "ideal-oracle",
            "base": "hypersonic-direct-s1",
            "designs": ["oracle", "oracle-plain"],
            "runs": 1,
            "seed": 3,
            "duration": 3.0,
            "success": {"rms_error_final": 0.01, "final_window": 1.0},
            "failures": {
                "count": 1,
                "onset": {"uniform": [0.5, 1.5]},
                "models": {"loss_of_effectiveness": {"effectiveness": {"uniform": [0.2, 0.8]}}},
            },
        }
    )
    member = draw_member(spec, 0)
    fair, plain = member.design_loop("oracle"), member.design_loop("oracle-plain")
    assert fair.controller.constraint_aware.is_ideal
    a, b = simulate(fair, spec.solver), simulate(plain, spec.solver)
    assert a.status == b.status == "completed"
    np.testing.assert_array_equal(a.time, b.time)
    np.testing.assert_array_equal(a.states, b.states)
    np.testing.assert_array_equal(a.u_cmd, b.u_cmd)


def test_the_design_list_names_both_oracles():
    assert {"oracle", "oracle-plain"} <= set(DESIGN_VARIANTS)
    with pytest.raises(CampaignError, match="oracle_plain.*'oracle-plain'"):
        load_campaign(shipped("hypersonic-hardware", designs=["oracle_plain"]))


def frame(outcomes: dict[str, str]) -> pd.DataFrame:
    """A results table: one letter per member, ``s`` success, ``e`` completed with too large
    an error, ``i`` invalid draw."""
    status = {"s": "completed", "e": "completed", "i": "invalid"}
    rows = [
        {
            "index": i,
            "design": d,
            "status": status[c],
            "success": c == "s",
            "rms_error_final": 1e-4 if c == "s" else 1e-2,
            "severity": 0.5,
        }
        for d, letters in outcomes.items()
        for i, c in enumerate(letters)
    ]
    return pd.DataFrame(rows)


def test_the_page_says_where_the_oracle_fails_too():
    """Truth by construction: constraint-aware fails members 2, 3, 4, 5 (and 6, an invalid
    draw, left out); the oracle fails 3 and 5 of them and member 0, which constraint-aware
    succeeds on. Both oracles are bounds, never designs under test."""
    df = frame(
        {
            "constraint-aware": "ssee" + "eei",
            "oracle": "esse" + "sei",
            "oracle-plain": "eeee" + "eei",
            "nominal-inverse": "eeee" + "eei",
        }
    )
    info = success_tables(df, 1e-3)
    assert role("oracle") == role("oracle-plain") == "bound"
    (check,) = info["oracle_check"]
    assert check == {
        "design": "constraint-aware",
        "members": 6,
        "failed": 4,
        "oracle_failed_too": 2,
        "oracle_succeeded": 2,
        "oracle_failed_design_succeeded": 1,
    }
    text = headline(info)
    assert (
        "oracle (knows the failure; same hardware, filters and feedback) also failed on 2 of "
        "the 4 members constraint-aware failed" in text
    )
    assert "oracle-plain succeeded" not in text and "oracle succeeded" not in text
    page = summary._comparison_html(info, "rad")
    assert "Of the 4 members constraint-aware failed, the oracle failed on <b>2</b> too" in page
    assert "succeeded on 2 (feasible" in page
    assert "too (evidence that these draws are infeasible on their hardware)" in page
    # an oracle that succeeds significantly less often than the design (its Wilson interval
    # wholly below the design's: 4 of 20 against 19 of 20) is no yardstick: the page says so
    weak = success_tables(
        frame(
            {
                "constraint-aware": "s" * 19 + "e",
                "oracle": "e" * 15 + "sssse",
                "nominal-inverse": "e" * 20,
            }
        ),
        1e-3,
    )
    text = headline(weak)
    assert (
        "succeeded significantly less often (20\u00a0%), so it is no yardstick for "
        "constraint-aware" in text
    )
    assert "also failed on 1 of the 1" not in text
    weak_page = summary._comparison_html(weak, "rad")
    assert "so where it fails is no evidence of infeasibility" in weak_page
    assert "evidence that these draws are infeasible" not in weak_page
    assert "failed on <b>1</b> too and succeeded on none;" in weak_page
    assert "no evidence of infeasibility" not in page
    # without an oracle run, no such sentence
    no_oracle = success_tables(df[df["design"] != "oracle"], 1e-3)
    assert no_oracle["oracle_check"] == [] and "oracle (knows" not in headline(no_oracle)
