"""The thesis law beside a constraint-aware design (issue 25, "Done when"): a scenario whose
controller declares ``constraint_aware`` judges its claims on that design, and the thesis law's
companion run (the option removed) is judged on the same claims, what it fails reported as a
named FINDING: never PASS, never a FAIL of the exit codes. In ``aftc reproduce`` (variant
``thesis_law``: data file, metrics row, claims.csv ``run`` column, report, figure overlay) and
in ``aftc run``."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import warnings

import numpy as np
import pytest

from adaptive_ftc.claims import (
    FAIL,
    FINDING,
    PASS,
    THESIS_LAW_FINDING,
    ClaimError,
    evaluate_claim,
    evaluate_thesis_law_claims,
    thesis_law_claim,
)
from adaptive_ftc.cli import main
from adaptive_ftc.report import ScenarioEntry, render_report
from adaptive_ftc.reproduce import _variants, thesis_law_loop
from adaptive_ftc.scenarios import load_scenario
from adaptive_ftc.sim.engine import simulate
from adaptive_ftc.sim.result import SimResult


@pytest.fixture(scope="module")
def run() -> SimResult:
    """hypersonic-direct-s1-actuators (constraint-aware), 6 s, recorded at 1 ms."""
    sc = load_scenario("hypersonic-direct-s1-actuators")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sc.stamp(simulate(dataclasses.replace(sc.loop, t_final=6.0), sc.solver))


def chattering(r: SimResult, amp: float) -> SimResult:
    u = np.column_stack([amp * np.sin(2 * np.pi * 12.0 * r.time)] * 2)
    return dataclasses.replace(r, u_cmd=u, u_applied=np.clip(u, -1.0, 1.0))


QUIET = {"kind": "activity", "text": "quiet", "window": 4.0, "max_fast_rms": 0.01}


def test_the_companion_is_the_same_loop_with_the_option_removed():
    sc = load_scenario("hypersonic-direct-s1-digital")
    assert sc.loop.controller.constraint_aware is not None
    loop = thesis_law_loop(sc.loop)
    assert loop.controller.constraint_aware is None
    assert loop.controller == dataclasses.replace(sc.loop.controller, constraint_aware=None)
    assert loop.sample_time == sc.loop.sample_time and loop.failures == sc.loop.failures
    # the thesis law is the thesis's scenario run at 200 Hz: same trajectory as the scenario
    # without the option (the loader's derivation touches nothing else)
    assert dataclasses.replace(loop, controller=sc.loop.controller) == sc.loop


def test_reproduce_runs_the_companion_only_beside_a_constraint_aware_design():
    assert "thesis_law" in _variants(load_scenario("hypersonic-direct-s1-noise"))
    assert "thesis_law" not in _variants(load_scenario("hypersonic-direct-s1"))


def test_a_claim_the_thesis_law_fails_is_its_named_finding_never_fail(run):
    claim = {**QUIET, "thesis_law_finding": "the thesis law chatters at 12 Hz"}
    loud = chattering(run, 0.5)
    (v,) = evaluate_thesis_law_claims([claim], loud)
    assert v.verdict == FINDING and not v.passed
    assert v.finding == "the thesis law chatters at 12 Hz"
    assert math.isclose(v.measured, 0.5 / math.sqrt(2), rel_tol=1e-2)
    # without a name: the generic one, still a finding
    (v,) = evaluate_thesis_law_claims([QUIET], loud)
    assert v.verdict == FINDING and v.finding == THESIS_LAW_FINDING
    # the same claim on the scenario's own run is a FAIL: the companion never changes that
    assert evaluate_claim(claim, loud).verdict == FAIL
    # a diverged companion: a finding, not a FAIL
    cut = run.time <= 3.0
    arrays = {
        f.name: getattr(run, f.name)[cut]
        for f in dataclasses.fields(run)
        if isinstance(getattr(run, f.name), np.ndarray)
    }
    gone = dataclasses.replace(run, **arrays, status="diverged", message="boom")
    (v,) = evaluate_thesis_law_claims([claim], gone, duration=6.0)
    assert v.verdict == FINDING


def test_a_claim_the_thesis_law_meets_is_a_plain_pass(run):
    quiet = chattering(run, 0.0)
    (v,) = evaluate_thesis_law_claims([QUIET], quiet)
    assert v.verdict == PASS and v.finding == "" and "no longer shows" not in v.detail
    # a named finding that no longer shows says so (a stale name in the catalogue)
    (v,) = evaluate_thesis_law_claims([{**QUIET, "thesis_law_finding": "chatters"}], quiet)
    assert v.verdict == PASS and "no longer shows" in v.detail


def test_the_scenario_notes_belong_to_its_own_run(run):
    claim = {**QUIET, "finding": "mine", "thesis_law_finding": "theirs"}
    assert thesis_law_claim(claim)["finding"] == "theirs"
    assert "thesis_law_finding" not in thesis_law_claim(claim)
    note = {**QUIET, "not_reproduced": "a reason"}
    assert "not_reproduced" not in thesis_law_claim(note)
    (v,) = evaluate_thesis_law_claims([note], chattering(run, 0.5))
    assert v.verdict == FINDING  # not NOT REPRODUCED: that note is the scenario's
    with pytest.raises(ClaimError, match="'thesis_law_finding'.*non-empty text"):
        evaluate_claim({**QUIET, "thesis_law_finding": ""}, run)


def test_report_shows_the_thesis_law_apart(run):
    loud = chattering(run, 0.5)
    own = [evaluate_claim(QUIET, chattering(run, 0.0))]
    companion = evaluate_thesis_law_claims([{**QUIET, "thesis_law_finding": "it chatters"}], loud)
    page = render_report(
        [ScenarioEntry(name="s", title="S", claims=own, thesis_law_claims=companion)]
    )
    assert "The thesis law beside it" in page and "it chatters" in page
    assert "1/1 passed" in page and "thesis law: 1 finding(s)" in page
    assert "thesis-law findings" in page


def _ca_file(tmp_path) -> str:
    """hypersonic-direct-s1-digital (constraint-aware at 200 Hz), 6 s, one fast-content claim."""
    src = tmp_path / "ca.toml"
    src.write_text(
        'extends = "hypersonic-direct-s1-digital"\nname = "ca"\nduration = 6.0\n'
        '[[claims]]\nkind = "activity"\ntext = "quiet above 1 Hz"\nwindow = 3.0\n'
        'max_fast_rms = 0.01\nthesis_law_finding = "the thesis law chatters at 200 Hz"\n'
    )
    return str(src)


def test_aftc_run_runs_and_judges_the_thesis_law_beside_the_design(tmp_path, capsys):
    out = tmp_path / "o"
    # 0: the design passes, the thesis law's failure is a finding
    assert main(["run", _ca_file(tmp_path), "--out", str(out), "--quiet", "--no-baselines"]) == 0
    text = capsys.readouterr().out
    assert "the thesis law beside it" in text and "the thesis law chatters at 200 Hz" in text
    assert (out / "data" / "ca_thesis_law.nc").is_file()
    with (out / "claims.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["run"], r["verdict"]) for r in rows] == [
        ("adaptive", "PASS"),
        ("thesis_law", "FINDING"),
    ]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["runs"]["thesis_law"]["fast_rms_max"] > 0.01
    assert metrics["runs"]["adaptive"]["fast_rms_max"] < 0.01
    assert [c["run"] for c in metrics["claims"]] == ["adaptive", "thesis_law"]


def test_reproduce_overlays_the_thesis_law_on_the_tracking_figures(tmp_path, monkeypatch):
    import adaptive_ftc.reproduce as rep

    seen = []
    real = rep._figure_task

    def spy(result, spec, path, baselines, *args, **kwargs):
        seen.append((spec.get("kind"), sorted(baselines)))
        return real(result, spec, path, baselines, *args, **kwargs)

    monkeypatch.setattr(rep, "_figure_task", spy)
    s = rep.run_reproduction(
        tmp_path / "r",
        names=["hypersonic-direct-s1-noise"],
        quick=True,
        jobs=1,
        progress=False,
        formats=("png",),
    )
    assert s["n_fail"] == 0 and s["n_errors"] == 0
    # the tracking figures overlay the thesis law; the others do not draw baselines, so
    # they are not sent any (session 14: plots.figure_input, reproduce._submit_figures)
    assert "tracking" in {k for k, _ in seen}
    assert all(
        b == (["thesis law (constraint-aware off)"] if k == "tracking" else []) for k, b in seen
    )
