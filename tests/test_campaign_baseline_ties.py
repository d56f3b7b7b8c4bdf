"""The best fair baseline when the baselines tie on success rate (issue 25 audit): in a
campaign where every baseline scores 0 %, the headline must not name a baseline that diverged on
every member as "best" while another tracked on some (spacecraft-hardware: fixed-gain diverged
on all 500, nominal inverse tracked on 201 and failed the activity criterion).

Synthetic result tables, every count known by construction.
"""

from __future__ import annotations

import math

import pandas as pd
import pytest

from adaptive_ftc.campaigns.summary import headline, success_tables

THRESHOLD = 1e-3


def frame(outcomes: dict[str, str], errors: dict[str, float] | None = None) -> pd.DataFrame:
    """``outcomes[design]``: one letter per member: ``s`` success, ``t`` tracked (completed
    within the threshold) but failed another criterion, ``e`` completed with too large an error,
    ``d`` diverged. ``errors[design]`` overrides the final error of its completed runs."""
    rows = []
    for d, letters in outcomes.items():
        for i, c in enumerate(letters):
            err = {"s": 1e-4, "t": 5e-4, "e": 1e-1, "d": math.nan}[c]
            if errors and d in errors and c != "d":
                err = errors[d]
            rows.append(
                {
                    "index": i,
                    "models": "loss_of_effectiveness",
                    "severity": 0.5,
                    "compensable": True,
                    "design": d,
                    "status": "diverged" if c == "d" else "completed",
                    "success": c == "s",
                    "rms_error_final": err,
                }
            )
    return pd.DataFrame(rows).sort_values(["index"], kind="stable", ignore_index=True)


def test_at_zero_percent_the_baseline_that_tracked_is_chosen_over_one_that_diverged():
    # fixed-gain first in the spec: the old rule (rate, then spec order) named it
    df = frame(
        {
            "aware": "s" * 9 + "e",
            "fixed-gain": "d" * 10,
            "nominal-inverse": "t" * 4 + "e" * 6,
        }
    )
    info = success_tables(df, THRESHOLD)
    (comp,) = info["comparison"]
    assert comp["baseline"] == "nominal-inverse"
    assert comp["tied_with"] == ["fixed-gain"] and comp["tie_break"] == "members tracked"
    assert comp["baseline_tracked"] == 4
    text = headline(info)
    assert "the best fair baseline" not in text
    assert "every fair baseline: none succeeded on any member" in text
    assert (
        "paired with nominal-inverse, as nominal-inverse tracked on the most members (4 of 10)"
        in text
    )


def test_ties_fall_to_completed_runs_then_to_the_lower_median_error():
    df = frame({"aware": "s" * 4, "fixed-gain": "dddd", "nominal-inverse": "eedd"})
    (comp,) = success_tables(df, THRESHOLD)["comparison"]
    assert (comp["baseline"], comp["tie_break"]) == ("nominal-inverse", "members completed")
    assert "completed the most runs without diverging (2 of 4)" in headline(
        success_tables(df, THRESHOLD)
    )
    df = frame(
        {"aware": "s" * 4, "fixed-gain": "eeee", "nominal-inverse": "eeee"},
        errors={"fixed-gain": 0.3, "nominal-inverse": 0.2},
    )
    (comp,) = success_tables(df, THRESHOLD)["comparison"]
    assert (comp["baseline"], comp["tie_break"]) == ("nominal-inverse", "median final error")


def test_a_tie_at_a_nonzero_rate_names_the_best_and_why():
    df = frame({"aware": "s" * 6, "fixed-gain": "ssdddd", "nominal-inverse": "sstttt"})
    info = success_tables(df, THRESHOLD)
    (comp,) = info["comparison"]
    assert comp["baseline"] == "nominal-inverse" and comp["tie_break"] == "members tracked"
    text = headline(info)
    assert "the best fair baseline, nominal-inverse (33.3\u00a0%" in text
    assert (
        "tied on success with fixed-gain: nominal-inverse tracked on the most members (6 of 6)"
        in text
    )


@pytest.mark.parametrize(
    "order", [("fixed-gain", "nominal-inverse"), ("nominal-inverse", "fixed-gain")]
)
def test_a_higher_rate_still_decides_before_any_tie_break(order):
    letters = {"fixed-gain": "sddd", "nominal-inverse": "tttt"}
    df = frame({"aware": "ssss", **{d: letters[d] for d in order}})
    info = success_tables(df, THRESHOLD)
    (comp,) = info["comparison"]
    assert (
        comp["baseline"] == "fixed-gain" and comp["tied_with"] == [] and comp["tie_break"] is None
    )
    assert "tied on success" not in headline(info)
