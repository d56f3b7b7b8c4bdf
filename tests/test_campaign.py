"""Fault campaigns (issue 13): spec validation, seeded members, chunked resumable runs,
replay, summary and the CLI. Campaigns here are tiny (6 members of 2-3 s simulated)."""

from __future__ import annotations

import copy
import json

import numpy as np
import pandas as pd
import pytest

from adaptive_ftc.campaigns import (
    CampaignError,
    draw_member,
    list_campaigns,
    load_campaign,
    read_results,
    replay_member,
    run_campaign,
)
from adaptive_ftc.campaigns.store import part_path
from adaptive_ftc.cli import main as aftc

TINY = {
    "name": "tiny",
    "base": "hypersonic-direct-s1",
    "designs": ["adaptive", "frozen"],
    "runs": 6,
    "seed": 7,
    "chunk_size": 2,
    "duration": 3.0,
    "success": {"rms_error_final": 0.01, "final_window": 1.0},
    "failures": {
        "count": {"integers": [1, 2]},
        "onset": {"uniform": [0.5, 2.5]},
        "recovery_probability": 0.3,
        "duration": {"uniform": [0.2, 1.0]},
        "models": {
            "loss_of_effectiveness": {"effectiveness": {"uniform": [0.0, 1.0]}},
            "stuck": {"value": {"uniform": [-0.2, 0.2]}},
            "nonaffine": {
                "output": "{a}*u**3 + {c}",
                "params": {"a": {"uniform": [0.3, 1.0]}, "c": {"uniform": [-0.1, 0.1]}},
                "severity": "c",
            },
        },
    },
    "ranges": {"initial_state": [{"uniform": [0.0, 0.04]}]},
}


def tiny(**changes):
    data = copy.deepcopy(TINY)
    data.update(changes)
    return data


@pytest.fixture(scope="module")
def reference_run(tmp_path_factory):
    """The tiny campaign run once, uninterrupted, on two threads."""
    out = tmp_path_factory.mktemp("ref") / "c"
    run = run_campaign(load_campaign(tiny()), out, jobs=2, progress=False)
    return run, read_results(out)


def test_impossible_spec_is_refused_with_one_line_per_problem():
    bad = tiny()
    bad["failures"] = copy.deepcopy(bad["failures"])
    bad["failures"]["onset"] = {"uniform": [1.0, 5.0]}  # after the 3 s end
    bad["failures"]["actuators"] = [1, 3]  # the hypersonic plant has 2
    bad["failures"]["models"] = {
        "loss_of_effectiveness": {"effectiveness": {"uniform": [-0.5, 0.5]}},  # negative
        "stuk": {"value": 0.1},  # unknown model
    }
    with pytest.raises(CampaignError) as err:
        load_campaign(bad)
    msg = str(err.value)
    lines = [ln for ln in msg.splitlines() if ln.startswith("  - ")]
    assert "4 problem(s), nothing was run" in msg
    assert len(lines) == 4
    assert any("onset after the end" in ln and "3 s" in ln for ln in lines)
    assert any("unknown actuator 3" in ln for ln in lines)
    assert any("effectiveness" in ln and "[0, 1]" in ln for ln in lines)
    assert any(
        "unknown failure model 'stuk'" in ln and "Did you mean 'stuck'" in ln for ln in lines
    )


def test_unknown_keys_and_designs_are_named():
    with pytest.raises(CampaignError) as err:
        load_campaign(tiny(designs=["adaptive", "clairvoyant"], seeds=3))
    msg = str(err.value)
    assert "unknown design 'clairvoyant'" in msg and "unknown key 'seeds'" in msg


def test_member_depends_only_on_seed_and_index():
    a = load_campaign(tiny())
    b = load_campaign(tiny(runs=50, chunk_size=7))
    for i in range(6):
        ma, mb = draw_member(a, i), draw_member(b, i)
        assert json.dumps(ma.columns) == json.dumps(mb.columns)
        assert ma.loop.describe_failures() == mb.loop.describe_failures()
    c = load_campaign(tiny(seed=8))
    assert draw_member(c, 0).columns != draw_member(a, 0).columns


def test_drawn_values_follow_the_spec():
    spec = load_campaign(tiny(runs=200))
    for i in range(200):
        m = draw_member(spec, i)
        assert 1 <= len(m.failures) <= 2
        assert len({f.actuator for f in m.failures}) == len(m.failures)
        for f, sev in zip(m.failures, m.severities, strict=True):
            assert 0.5 <= f.onset <= 2.5
            if f.recovery is not None:
                assert 0.2 <= f.recovery - f.onset <= 1.0
            if type(f).model == "loss_of_effectiveness":
                assert sev == pytest.approx(1.0 - f.effectiveness)
        assert 0.0 <= m.columns["x0_alpha"] <= 0.04


def test_table_has_every_member_and_design_and_the_summary(reference_run):
    run, df = reference_run
    assert run.complete and run.runs_done_now == 12
    assert list(df["index"]) == [0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5]
    assert list(df["design"]) == ["adaptive", "frozen"] * 6
    assert set(df["status"]) <= {"completed", "diverged"}
    # the frozen baseline never beats the adaptive design's final error here
    ad = df[df.design == "adaptive"]["rms_error_final"].to_numpy()
    fr = df[df.design == "frozen"]["rms_error_final"].to_numpy()
    assert np.all(ad < fr)
    assert (run.out / "summary.html").is_file()
    summary = json.loads((run.out / "summary.json").read_text())
    assert summary["success_rate"]["adaptive"] == pytest.approx(
        df[df.design == "adaptive"]["success"].mean()
    )
    for fig in ("success_vs_severity", "error_histogram", "worst_runs"):
        assert (run.out / "figures" / f"{fig}.png").stat().st_size > 1000


def test_same_table_whatever_the_number_of_threads(reference_run, tmp_path):
    _, df = reference_run
    run_campaign(load_campaign(tiny()), tmp_path / "c", jobs=1, progress=False, summary=False)
    pd.testing.assert_frame_equal(read_results(tmp_path / "c"), df, check_exact=True)


def test_interrupted_campaign_resumes_without_redoing_finished_chunks(reference_run, tmp_path):
    _, df = reference_run
    out = tmp_path / "c"
    first = run_campaign(load_campaign(tiny()), out, jobs=2, progress=False, max_chunks=1)
    assert not first.complete and first.results is None
    part0 = part_path(out, 0)
    stamp = (part0.stat().st_ino, part0.stat().st_mtime_ns)
    again = run_campaign(load_campaign(tiny()), out, jobs=2, progress=False, summary=False)
    assert again.complete and again.runs_resumed == 4 and again.runs_done_now == 8
    assert (part0.stat().st_ino, part0.stat().st_mtime_ns) == stamp
    pd.testing.assert_frame_equal(read_results(out), df, check_exact=True)


def test_a_folder_of_another_campaign_is_refused(reference_run):
    run, _ = reference_run
    with pytest.raises(CampaignError, match="different campaign spec"):
        run_campaign(load_campaign(tiny(seed=99)), run.out, progress=False)


def test_replay_reruns_a_member_exactly(reference_run, tmp_path):
    run, df = reference_run
    info = replay_member(run.out, 3, tmp_path / "r", designs=("adaptive",), figures=False)
    assert info["matches_table"] == {"adaptive": True}
    row = df[(df["index"] == 3) & (df.design == "adaptive")].iloc[0]
    assert info["rows"]["adaptive"]["rms_error_final"] == row["rms_error_final"]
    assert (tmp_path / "r" / "data" / "tiny_3_adaptive.nc").is_file()
    with pytest.raises(CampaignError, match="out of range"):
        replay_member(run.out, 6, tmp_path / "r2")


def test_divergence_is_a_recorded_outcome(tmp_path):
    spec = tiny(runs=2, chunk_size=2, designs=["frozen"])
    spec["failures"] = {
        "count": 2,
        "onset": {"uniform": [0.5, 1.0]},
        "models": {"stuck": {"value": 1e9}},
    }
    run_campaign(load_campaign(spec), tmp_path / "c", jobs=1, progress=False, summary=False)
    df = read_results(tmp_path / "c")
    assert list(df["status"]) == ["diverged", "diverged"]
    assert df["divergence_time"].between(0.5, 3.0).all()
    assert (df["divergence_signal"] != "").all() and not df["success"].any()
    assert not df["compensable"].any()  # both actuators stuck: rank condition (3.6) fails


def test_example_specs_load_and_draw_valid_members():
    assert {"hypersonic-loe", "spacecraft-mimo"} <= set(list_campaigns())
    for name in ("hypersonic-loe", "spacecraft-mimo"):
        spec = load_campaign(name)
        for i in range(20):
            m = draw_member(spec, i)
            assert m.loop is not None, m.error


def test_cli_runs_resumes_replays_and_reports_bad_specs(tmp_path, capsys):
    spec = tmp_path / "tiny.toml"
    spec.write_text(
        'name = "cli"\nbase = "hypersonic-direct-s1"\nruns = 2\nseed = 1\nduration = 2.0\n'
        "[success]\nrms_error_final = 0.01\nfinal_window = 0.5\n"
        "[failures]\nonset = {uniform = [0.5, 1.5]}\n"
        "[failures.models.bias]\nbias = {uniform = [-0.1, 0.1]}\n"
    )
    out = tmp_path / "out"
    assert aftc(["campaign", str(spec), "--out", str(out), "--quiet", "--jobs", "1"]) == 0
    assert "success rate" in capsys.readouterr().out
    assert aftc(["campaign", "replay", str(out), "1", "--out", str(tmp_path / "r")]) == 0
    assert "identical to the table" in capsys.readouterr().out
    bad = tmp_path / "bad.toml"
    bad.write_text(spec.read_text().replace("[-0.1, 0.1]", "[0.1, -0.1]").replace("2.0", "1.0"))
    assert aftc(["campaign", str(bad), "--out", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err
    assert "onset after the end" in err and "a <= b" in err
    assert not (tmp_path / "o2").exists()


@pytest.mark.parametrize(
    "module", ["adaptive_ftc.campaigns.spec", "adaptive_ftc.campaigns.sampling"]
)
def test_docstring_examples(module):
    import doctest
    import importlib

    failures, _ = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert failures == 0
