"""Campaigns with allocators and annunciated failures (issue 31): designs that name an
allocator (``adaptive+wls``), failures reported to the allocator with a drawn probability and
detection delay, and rows that say which allocator ran and which axis was unreachable."""

from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest

from adaptive_ftc.allocation import AdaptiveAllocation, PseudoInverse, WeightedLeastSquares
from adaptive_ftc.campaigns import CampaignError, draw_member, load_campaign, read_results
from adaptive_ftc.campaigns.runner import run_campaign
from adaptive_ftc.campaigns.spec import EXAMPLES
from adaptive_ftc.campaigns.store import schema

SHIPPED = tomllib.loads((EXAMPLES / "spacecraft-allocation.toml").read_text(encoding="utf-8"))

SMALL = {
    "name": "alloc",
    "base": "spacecraft-mimo-s1",
    "designs": ["adaptive", "adaptive+fixed", "adaptive+pinv", "adaptive+adaptive"],
    "runs": 30,
    "seed": 7,
    "duration": 20.0,
    "success": {"rms_error_final": 0.0025, "final_window": 5.0},
    "failures": {
        "count": {"integers": [1, 3]},
        "onset": {"uniform": [2.0, 10.0]},
        "annunciated": 0.5,
        "detection_delay": [0.5, 1.5],
        "models": {"stuck": {"value": {"uniform": [-5.0, 5.0]}}},
    },
    "allocation": {"adaptive": {"gain": 5.0}},
}


def spec(**changes):
    data = copy.deepcopy(SMALL)
    for key, value in changes.items():
        if key.startswith("failures."):
            data["failures"][key.split(".", 1)[1]] = value
        else:
            data[key] = value
    return data


def without(data, *keys):
    for key in keys:
        data["failures"].pop(key, None)
    return data


def problems(data) -> list[str]:
    with pytest.raises(CampaignError) as err:
        load_campaign(data)
    return [ln.strip()[2:] for ln in str(err.value).splitlines()[1:]]


# ---------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    "designs, culprit, choices",
    [
        (["adaptive+lsq"], "unknown allocation kind 'lsq'", "fixed, pinv, wls, adaptive"),
        (["adaptive+wsl"], "Did you mean 'wls'", "fixed, pinv, wls, adaptive"),
        (["adaptiv+wls"], "unknown design 'adaptiv'", "Did you mean 'adaptive'"),
    ],
)
def test_an_unknown_allocator_or_design_in_a_design_name_is_one_clear_problem(
    designs, culprit, choices
):
    (p,) = problems(spec(designs=designs, allocation={}))
    assert culprit in p and choices in p and designs[0] in p and p.startswith("[top]")


@pytest.mark.parametrize(
    "allocation, culprit",
    [
        ({"lsq": {}}, "[allocation] unknown key 'lsq'"),
        ({"fixed": {}}, "[allocation] unknown key 'fixed'"),
        ({"wls": {"gamma": 1.0}}, "[allocation.wls] options for an allocator no design uses"),
        ({"adaptive": {"gain": -1.0}}, "[allocation.adaptive] `gain`"),
        ({"adaptive": {"gian": 1.0}}, "[allocation.adaptive] Bad option"),
        ({"adaptive": 5.0}, "[allocation.adaptive] must be a table"),
    ],
)
def test_allocator_options_are_validated_naming_the_table(allocation, culprit):
    found = problems(spec(allocation=allocation))
    assert len(found) == 1 and found[0].startswith(culprit), found


@pytest.mark.parametrize(
    "changes, culprit",
    [
        ({"failures.annunciated": 2}, "`annunciated` must be true, false or the probability"),
        ({"failures.annunciated": "yes"}, "`annunciated` must be true, false or the probability"),
        ({"failures.detection_delay": [-1.0, 1.0]}, "[failures.detection_delay] delays must be"),
        ({"failures.detection_delay": [2.0, 1.0]}, "`uniform` needs a <= b"),
        ({"failures.annunciated": False}, "`detection_delay` is given but `annunciated = false`"),
    ],
)
def test_annunciation_settings_are_validated(changes, culprit):
    found = problems(spec(**changes))
    assert len(found) == 1 and culprit in found[0], found


def test_a_detection_delay_without_annunciation_is_refused():
    (p,) = problems(without(spec(), "annunciated"))
    assert "`detection_delay` is given but no failure is annunciated" in p


# ---------------------------------------------------------------------------- drawing
def test_design_names_pick_the_allocator_with_the_spec_options():
    sp = load_campaign(
        spec(
            designs=[
                "adaptive",
                "adaptive+fixed",
                "adaptive+wls",
                "adaptive+pinv",
                "adaptive+adaptive",
            ]
        )
    )
    mem = draw_member(sp, 0)
    assert mem.design_loop("adaptive").allocator is None  # the base scenario's (fixed)
    assert mem.design_loop("adaptive+fixed").allocator is None
    assert mem.design_loop("adaptive+wls").allocator == WeightedLeastSquares()
    assert mem.design_loop("adaptive+pinv").allocator == PseudoInverse()
    assert mem.design_loop("adaptive+adaptive").allocator == AdaptiveAllocation(gain=5.0)
    assert mem.design_loop("adaptive+wls").failures == mem.loop.failures
    kinds = [sp.allocator_kind(d) for d in sp.designs]
    assert kinds == ["fixed", "fixed", "wls", "pinv", "adaptive"]


def test_annunciated_failures_are_drawn_per_failure_with_one_delay_per_member():
    sp = load_campaign(spec())
    members = [draw_member(sp, i) for i in range(sp.runs)]
    counts = []
    for mem in members:
        anns = mem.loop.annunciations
        cols = mem.columns
        assert cols["annunciated"] == len(anns)
        by_actuator = {f.actuator: f for f in mem.failures}
        for a in anns:  # an annunciation belongs to a drawn failure: same actuator and onset
            assert a.onset == by_actuator[a.actuator].onset
            assert a.delay == cols["detection_delay"] and 0.5 <= a.delay <= 1.5
        if not anns:
            assert math.isnan(cols["detection_delay"])
        flags = [cols[f"f{j + 1}_annunciated"] for j in range(len(mem.failures))]
        assert flags == [f.actuator in {a.actuator for a in anns} for f in mem.failures]
        assert not any(cols[f"f{j + 1}_annunciated"] for j in range(len(mem.failures), 3))
        counts.append((len(anns), len(mem.failures)))
    assert any(0 < k < n for k, n in counts)  # some failures reported, others silent
    assert any(k == 0 for k, _ in counts) and any(k == n > 0 for k, n in counts)
    assert len({c["detection_delay"] for c in (m.columns for m in members)} - {math.nan}) > 5
    again = draw_member(sp, 4)
    assert again.columns == members[4].columns and again.loop == members[4].loop


def test_annunciation_is_drawn_after_everything_else():
    silent = load_campaign(without(spec(), "annunciated", "detection_delay"))
    known = load_campaign(spec(**{"failures.annunciated": True}))
    for i in range(5):
        a, b = draw_member(silent, i), draw_member(known, i)
        assert a.failures == b.failures  # the same failures, only reported or not
        assert a.loop.annunciations == ()
        assert [x.actuator for x in b.loop.annunciations] == [f.actuator for f in b.failures]
    assert "annunciated" in schema(silent).names  # a design names an allocator: the columns


def test_a_plain_campaign_has_no_allocation_columns():
    data = without(spec(designs=["adaptive", "frozen"]), "annunciated", "detection_delay")
    del data["allocation"]
    sp = load_campaign(data)
    assert not sp.allocation_columns
    names = schema(sp).names
    for col in ("allocator", "annunciated", "detection_delay", "reachable", "reachability"):
        assert col not in names
        assert col not in draw_member(sp, 0).columns


def test_the_reachability_verdict_names_the_lost_axis_and_when():
    # both roll wheels (1 and 4) stuck: phi is unreachable from the second onset on
    data = spec(**{"failures.actuators": [1, 4], "failures.count": 2})
    mem = draw_member(load_campaign(data), 0)
    second = max(f.onset for f in mem.failures)
    assert mem.columns["reachable"] is False
    assert mem.columns["reachability"] == f"phi from {second:g} s (actuators 1, 4 lost)"
    # a wheel of each of two axes: still every axis (rank 3 of 3)
    data = spec(**{"failures.actuators": [1, 2], "failures.count": 2})
    mem = draw_member(load_campaign(data), 0)
    assert mem.columns["reachable"] is True and mem.columns["reachability"] == ""


# ---------------------------------------------------------------------------- the shipped spec
@pytest.mark.parametrize(
    "name, axes",
    [("spacecraft-allocation", ("phi", "theta", "psi")), ("manipulator-allocation", ("q1", "q2"))],
)
def test_the_shipped_specs_compare_four_allocators_and_reach_the_rank_limit(name, axes):
    sp = load_campaign(name)
    assert sp.runs >= 200
    assert [sp.allocator_kind(d) for d in sp.designs] == ["fixed", "pinv", "wls", "adaptive"]
    assert sp.annunciated == 0.5
    cols = [draw_member(sp, i).columns for i in range(sp.runs)]
    lost = [c["reachability"] for c in cols if not c["reachable"]]
    assert lost and all(c.split(" from ")[0] in axes for c in lost)
    two = [c for c in cols if c["n_failures"] == 2]
    assert any(c["reachable"] for c in two) and any(not c["reachable"] for c in two)
    assert {c["annunciated"] for c in cols} >= {0, 1, 2}


def test_the_shipped_spec_runs_with_one_row_per_member_and_allocator(tmp_path):
    data = copy.deepcopy(SHIPPED)
    data.update(runs=2, chunk_size=2, duration=12.0)
    data["success"]["final_window"] = 4.0
    # a constructed member: both pitch wheels (2 and 5) stuck (a loss of effectiveness keeps
    # the axis reachable), each silent or annunciated after a delay
    data["failures"].update(actuators=[2, 5], count=2, onset={"uniform": [2.0, 6.0]})
    data["failures"]["models"] = {"stuck": SHIPPED["failures"]["models"]["stuck"]}
    run = run_campaign(load_campaign(data), tmp_path / "out", jobs=1, progress=False)
    assert run.complete
    df = read_results(run.out)
    assert len(df) == 2 * 4
    assert sorted(df.groupby(["index", "allocator"]).size().tolist()) == [1] * 8
    assert set(df["allocator"]) == {"fixed", "pinv", "wls", "adaptive"}
    assert (df["design"] == "adaptive+" + df["allocator"]).all()
    assert df["reachability"].str.startswith("theta from ").all()
    assert not df["reachable"].any()
    assert (df["n_failures"] == 2).all()
    ann = df.groupby("index")["annunciated"].first()
    delays = df.groupby("index")["detection_delay"].first()
    assert ((ann > 0) == delays.notna()).all()
    assert np.all((delays.dropna() >= 0) & (delays.dropna() <= 2))


# ---------------------------------------------------------------------------- false alarms
def test_a_false_alarm_reports_a_healthy_actuator_at_a_drawn_time():
    data = spec(**{"failures.false_alarm": 0.5, "failures.false_alarm_time": [3.0, 9.0]})
    sp = load_campaign(data)
    plain = load_campaign(spec())
    raised = 0
    for i in range(sp.runs):
        mem, ref = draw_member(sp, i), draw_member(plain, i)
        assert mem.failures == ref.failures  # drawn after everything else
        assert mem.loop.annunciations[: len(ref.loop.annunciations)] == ref.loop.annunciations
        extra = mem.loop.annunciations[len(ref.loop.annunciations) :]
        j, t = mem.columns["false_alarm"], mem.columns["false_alarm_time"]
        if j == 0:
            assert extra == () and math.isnan(t)
            continue
        raised += 1
        assert j not in {f.actuator for f in mem.failures}  # a healthy actuator
        assert 3.0 <= t <= 9.0
        (alarm,) = extra
        assert (alarm.actuator, alarm.onset, alarm.delay, alarm.recovery) == (j, t, 0.0, None)
    assert 5 <= raised <= 25
    assert {"false_alarm", "false_alarm_time"} <= set(schema(sp).names)


@pytest.mark.parametrize(
    "changes, culprit",
    [
        ({"failures.false_alarm": 1.5}, "`false_alarm` must be the probability"),
        ({"failures.false_alarm_time": [1.0, 2.0]}, "`false_alarm_time` is given without"),
        (
            {"failures.false_alarm": 0.1, "failures.false_alarm_time": [1.0, 30.0]},
            "[failures.false_alarm_time] false alarms must fall in [0, 20)",
        ),
    ],
)
def test_false_alarm_settings_are_validated(changes, culprit):
    found = problems(spec(**changes))
    assert len(found) == 1 and culprit in found[0], found


def test_a_false_alarm_changes_what_a_reallocating_allocator_commands():
    data = spec(**{"failures.false_alarm": 1.0, "failures.count": 0})
    data["failures"].pop("annunciated")
    data["failures"].pop("detection_delay")
    mem = draw_member(load_campaign(data), 0)
    (alarm,) = mem.loop.annunciations
    from adaptive_ftc.sim.engine import simulate

    loop = mem.design_loop("adaptive+pinv")
    base = simulate(mem.design_loop("adaptive+fixed"))
    moved = simulate(loop)
    j = alarm.actuator - 1
    before = moved.time < alarm.onset - 0.1
    after = moved.time > alarm.onset + 0.1
    # no failure at all: pinv gives the fixed commands until the alarm, then drops the actuator
    assert np.allclose(moved.u_cmd[before], base.u_cmd[before], atol=1e-8)
    assert np.all(moved.u_cmd[after, j] == 0.0) and np.any(base.u_cmd[after, j] != 0.0)


# ---------------------------------------------------------------------------- aftc validate
def test_validate_prints_the_reachability_timeline(tmp_path, capsys):
    from adaptive_ftc.cli import main
    from adaptive_ftc.scenarios.loader import load_scenario

    text = load_scenario("spacecraft-mimo-s1").text
    old = 'actuator = 1\nmodel = "loss_of_effectiveness"\nonset = 90.0\neffectiveness = 0.5\n'
    assert old in text
    path = tmp_path / "two-roll-wheels.toml"  # wheel 1 stuck at 90 s; wheel 4 stuck since 70 s
    path.write_text(text.replace(old, 'actuator = 1\nmodel = "stuck"\nonset = 90.0\n'))
    main(["validate", str(path)])
    out = capsys.readouterr().out
    lines = out.split("reachability (allocation matrix R")[1].splitlines()[1:]
    assert lines[0].strip().startswith("t = 0 s (lost actuators: none): all axes reachable")
    assert "t = 70 s (lost actuators: 4, 5): all axes reachable" in lines[2]
    assert "t = 90 s (lost actuators: 1, 4, 5): NOT reachable: phi (rank 2 of 3" in lines[3]
