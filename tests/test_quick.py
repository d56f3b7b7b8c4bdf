"""`aftc reproduce --quick` (issue 28): only the runs the claims are judged on, at full length,
so its verdicts are a full reproduction's; the report and the terminal summary say which claims
it judged and list what it left out (the thesis law's companion verdicts, the runs no claim
needs, the data files, the figures). Real runs of a small subset."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pytest

from adaptive_ftc.cli import main
from adaptive_ftc.reproduce import run_reproduction

# a constraint-aware design (its thesis-law companion is left out: 5 claims), a scenario with a
# baseline_ratio claim (its baselines are run), and one with failures but no adaptation
NAMES = ["hypersonic-direct-s1-sluggish", "hypersonic-direct-s1", "wingrock-free-1deg"]


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("quick") / "r"
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["reproduce", *NAMES, "--out", str(out), "--quick", "--jobs", "1", "--quiet"])
    return out, code, buf.getvalue()


@pytest.fixture(scope="module")
def full(tmp_path_factory):
    """The same scenarios reproduced with every run (figures and data left out: they do not
    change a verdict)."""
    out = tmp_path_factory.mktemp("full") / "r"
    run_reproduction(out, names=NAMES, jobs=1, progress=False, data=False, figure_limit=0)
    return out


def test_quick_runs_only_what_the_claims_need(quick):
    out, code, _ = quick
    assert code == 0
    runs = {(r["scenario"], r["variant"]) for r in _rows(out / "metrics.csv")}
    assert runs == {
        ("hypersonic-direct-s1-sluggish", "adaptive"),
        ("hypersonic-direct-s1", "adaptive"),
        ("hypersonic-direct-s1", "frozen"),
        ("hypersonic-direct-s1", "fixed-gain"),
        ("hypersonic-direct-s1", "nominal-inverse"),
        ("wingrock-free-1deg", "adaptive"),
    }
    # at full length: the claims' windows are reached
    t_end = {r["scenario"]: float(r["t_end"]) for r in _rows(out / "metrics.csv")}
    assert t_end["hypersonic-direct-s1"] == pytest.approx(120.0)
    assert not (out / "data").exists() and not (out / "figures").exists()


def test_quick_verdicts_are_those_of_a_full_reproduction(quick, full):
    def verdicts(out):
        return {
            (r["scenario"], r["kind"], r["text"]): (r["verdict"], r["measured"])
            for r in _rows(out / "claims.csv")
            if r["run"] == "adaptive"
        }

    q, f = verdicts(quick[0]), verdicts(full)
    assert q == f
    assert all(v != "NOT EVALUATED" for v, _ in q.values())
    # the full reproduction also judges the thesis law's companion run; quick mode does not
    assert any(r["run"] == "thesis_law" for r in _rows(full / "claims.csv"))
    assert all(r["run"] == "adaptive" for r in _rows(quick[0] / "claims.csv"))


def test_quick_report_and_summary_list_what_was_judged_and_left_out(quick):
    out, _, stdout = quick
    claims = _rows(out / "claims.csv")
    n = len(claims)
    judged = sum(r["verdict"] != "NOT EVALUATED" for r in claims)
    assert judged == n > 0
    page = (out / "report.html").read_text(encoding="utf-8")
    assert f"judged <b>{judged} of {n} claims</b> on full-length runs" in page
    banner = page.split('<div class="banner">', 1)[1].split("</div>", 1)[0]
    # the thesis law's verdicts left out, by scenario and number of claims
    assert "hypersonic-direct-s1-sluggish (5)" in banner and "5 verdicts" in banner
    for what in ("failure-free runs", "oracle", "data files", "figures: none drawn"):
        assert what in banner, what
    # the terminal says the same
    assert f"quick mode judged {judged} of {n} claims on full-length runs" in stdout
    listed = re.findall(r"^  - (.*)$", stdout, flags=re.M)
    assert any("hypersonic-direct-s1-sluggish (5)" in line for line in listed)
    assert any("data files" in line for line in listed)


def test_a_claim_quick_mode_cannot_judge_is_named_in_the_report(tmp_path):
    # shortened runs (the library's quick=True) leave claims NOT EVALUATED: the banner names
    # each of them by scenario and kind
    out = tmp_path / "r"
    summary = run_reproduction(
        out,
        quick=True,
        claims_only=True,
        data=False,
        figure_limit=0,
        names=["wingrock-direct-s1"],
        jobs=1,
        progress=False,
    )
    claims = _rows(out / "claims.csv")
    missing = [r["kind"] for r in claims if r["verdict"] == "NOT EVALUATED"]
    assert missing and summary["n_not_evaluated"] == len(missing)
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "Not judged (NOT EVALUATED): wingrock-direct-s1: " + ", ".join(missing) in page


@pytest.mark.parametrize(
    "extra", [["--formats", "svg"], ["--dpi", "300"], ["--float32"], ["--decimate", "4"]]
)
def test_quick_refuses_figure_and_data_options_that_would_do_nothing(tmp_path, capsys, extra):
    out = tmp_path / "r"
    assert main(["reproduce", "wingrock-free-1deg", "--out", str(out), "--quick", *extra]) == 2
    err = capsys.readouterr().err
    assert extra[0] in err and "drop --quick" in err
    assert not out.exists()
