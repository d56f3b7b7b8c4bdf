"""The campaign page (issue 28): success with counts and Wilson intervals, severity bins in
words, diverged runs as failures, the best fair baseline, a headline generated from the numbers,
and a real browser (headless Chromium) opening summary.html and report.html at 1400 px and 390 px.

Synthetic result tables, built so every number is known, keep the tests to seconds; one tiny
real campaign (2 members of 2 s, four designs) checks the page end to end.
"""

from __future__ import annotations

import html
import math
import os
import re

import numpy as np
import pagecheck
import pandas as pd
import pytest

from adaptive_ftc.campaigns import load_campaign, summary
from adaptive_ftc.campaigns.summary import (
    headline,
    member_success,
    success_tables,
    wilson_interval,
    write_summary,
)

THRESHOLD = 1e-3
DESIGNS = ("adaptive", "nominal-inverse", "fixed-gain", "frozen")


def spec_for(designs=DESIGNS, runs=10):
    return load_campaign(
        {
            "name": "page",
            "title": "Page test",
            "base": "hypersonic-direct-s1",
            "designs": list(designs),
            "runs": runs,
            "seed": 1,
            "chunk_size": runs,
            "duration": 2.0,
            "success": {"rms_error_final": THRESHOLD, "final_window": 0.5},
            "failures": {
                "count": 1,
                "onset": {"uniform": [0.5, 1.5]},
                "models": {"loss_of_effectiveness": {"effectiveness": {"uniform": [0.1, 0.9]}}},
            },
        }
    )


def frame(outcomes: dict[str, str], *, severity=None, models=None) -> pd.DataFrame:
    """A results table: ``outcomes[design]`` is one letter per member: ``s`` success, ``e``
    completed with too large an error, ``d`` diverged, ``n`` stopped on a non-finite signal,
    ``u`` stopped on a step-size underflow, ``i`` invalid draw."""
    rows = []
    for d, letters in outcomes.items():
        n = len(letters)
        sev = severity if severity is not None else np.linspace(0.05, 0.95, n)
        for i, c in enumerate(letters):
            status = {
                "s": "completed",
                "e": "completed",
                "d": "diverged",
                "n": "nonfinite",
                "u": "step_underflow",
                "i": "invalid",
            }[c]
            rows.append(
                {
                    "index": i,
                    "models": models[i] if models is not None else "loss_of_effectiveness",
                    "severity": sev[i],
                    "compensable": i % 3 != 0,
                    "design": d,
                    "status": status,
                    "success": c == "s",
                    # a completed bad run can have a huge error: still better than diverging
                    "rms_error_final": {"s": 1e-4, "e": 1e8, "i": math.nan}.get(c, 0.3),
                    "divergence_time": 1.0 + 0.1 * i if c in "dnu" else math.nan,
                    "divergence_signal": "theta" if c in "dnu" else "",
                }
            )
    return pd.DataFrame(rows).sort_values(["index"], kind="stable", ignore_index=True)


def page_text(path) -> str:
    text = path.read_text(encoding="utf-8")
    text = re.sub(r"<style>.*?</style>", " ", text, flags=re.S)
    text = re.sub(r'src="data:[^"]*"', "", text)
    text = re.sub(r"<[^>]+>", " ", text)
    return re.sub(r"[ \t\n]+", " ", html.unescape(text))


# ------------------------------------------------------------------------ numbers


@pytest.mark.parametrize("k,n", [(0, 10), (3, 10), (10, 10), (177, 300), (1, 1000)])
def test_wilson_interval_is_the_closed_form(k, n):
    z = 1.959963984540054  # the two-sided 95 % normal quantile
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    lo, hi = wilson_interval(k, n)
    assert lo == pytest.approx(max(0.0, centre - half), abs=1e-12)
    assert hi == pytest.approx(min(1.0, centre + half), abs=1e-12)
    assert all(math.isnan(v) for v in wilson_interval(0, 0))


def test_a_diverged_run_is_never_a_success_whatever_the_column_says():
    df = frame({"adaptive": "sd"})
    df.loc[df["status"] == "diverged", "success"] = True
    assert list(member_success(df)) == [True, False]
    assert success_tables(df, THRESHOLD)["per_design"]["adaptive"]["successes"] == 1


def test_rates_counts_and_intervals_per_design_and_severity_bin_in_words():
    df = frame(
        {
            "adaptive": "ssssssssed",
            "nominal-inverse": "sseeeeeedd",
            "fixed-gain": "ssssseeeei",
            "frozen": "eeeeeeeddd",
        }
    )
    info = success_tables(df, THRESHOLD)
    per = info["per_design"]
    assert [per[d]["successes"] for d in DESIGNS] == [8, 2, 5, 0]
    assert all(per[d]["runs"] == 10 for d in DESIGNS)
    assert (per["adaptive"]["ci_low"], per["adaptive"]["ci_high"]) == wilson_interval(8, 10)
    assert info["outcomes"]["fixed-gain"] == {
        "success": 5,
        "error too large": 4,
        "failed another criterion": 0,
        "diverged": 0,
        "invalid draw": 1,
    }
    assert info["diverged"] == {"adaptive": 1, "nominal-inverse": 2, "fixed-gain": 0, "frozen": 3}
    bins = [r["bin"] for r in info["by_severity"] if r["design"] == "adaptive"]
    assert bins == [
        "mild (0–20 %)",
        "moderate (20–40 %)",
        "serious (40–60 %)",
        "severe (60–80 %)",
        "extreme (80–100 %)",
    ]
    mild = next(r for r in info["by_severity"] if r["design"] == "adaptive")
    # severities 0.05 and 0.15 (members 0, 1): both successes
    assert (mild["successes"], mild["runs"]) == (2, 2)


def test_unrated_failures_have_their_own_severity_row():
    sev = np.array([0.1, np.nan, 0.9])
    info = success_tables(frame({"adaptive": "sse"}, severity=sev), THRESHOLD)
    rows = {r["bin"]: (r["successes"], r["runs"]) for r in info["by_severity"]}
    assert rows == {"mild (0–20 %)": (1, 1), "unrated": (1, 1), "extreme (80–100 %)": (0, 1)}


def test_a_completed_run_within_the_error_limit_that_failed_is_another_criterion():
    df = frame({"adaptive": "ss"})
    df.loc[1, "success"] = False  # e.g. a control-activity criterion of the runner
    info = success_tables(df, THRESHOLD)
    assert info["outcomes"]["adaptive"]["failed another criterion"] == 1


def test_the_page_reads_success_through_one_function(monkeypatch):
    """A stricter success definition (e.g. tracking and control activity) plugged in at
    member_success reaches the tables and the headline."""
    df = frame({"adaptive": "ssss", "nominal-inverse": "ssee"})
    assert success_tables(df)["per_design"]["adaptive"]["successes"] == 4
    monkeypatch.setattr(summary, "member_success", lambda d: (d["index"] < 1) & d["success"])
    info = success_tables(df)
    assert info["per_design"]["adaptive"]["successes"] == 1
    assert "(1/4;" in headline(info)


def test_the_best_fair_baseline_is_nominal_inverse_or_fixed_gain_never_the_frozen_floor():
    df = frame(
        {
            "adaptive": "sssseeeeee",
            "nominal-inverse": "eessseeeee",
            "fixed-gain": "sseeeeeeee",
            "frozen": "ssssssssse",  # the floor, even when it does better
        }
    )
    (comp,) = success_tables(df, THRESHOLD)["comparison"]
    assert comp["baseline"] == "nominal-inverse" and comp["baseline_role"] == "fair baseline"
    # paired: adaptive survives members 0-3, nominal-inverse members 2-4
    assert (comp["only_design"], comp["only_baseline"], comp["both"], comp["neither"]) == (
        2,
        1,
        2,
        5,
    )
    assert comp["difference"] == pytest.approx(0.1)
    assert comp["verdict"] == "not distinguishable"


def test_without_fair_baselines_the_frozen_floor_is_named_as_such():
    info = success_tables(frame({"adaptive": "ssss", "frozen": "eeee"}), THRESHOLD)
    assert info["comparison"][0]["baseline_role"] == "floor"
    assert "no fair baseline (nominal-inverse, fixed-gain) was run" in headline(info)


@pytest.mark.parametrize(
    "adaptive,baseline,word",
    [
        ("s" * 30, "e" * 30, "clearly better than"),
        ("e" * 30, "s" * 30, "clearly worse than"),
        ("s" * 15 + "e" * 15, "s" * 14 + "e" * 16, "not distinguishable at this sample size from"),
    ],
)
def test_the_headline_says_what_the_numbers_say(adaptive, baseline, word):
    info = success_tables(frame({"adaptive": adaptive, "fixed-gain": baseline}), THRESHOLD)
    text = headline(info)
    k = adaptive.count("s")
    assert f"adaptive succeeded in {summary.pct(k / 30)} of its runs ({k}/30;" in text
    rate = summary.pct(baseline.count("s") / 30)
    assert f"{word} the best fair baseline, fixed-gain ({rate}, CI " in text


def test_the_headline_speaks_of_every_design_under_test():
    """A hardware campaign tests two laws (thesis law, constraint-aware): the headline gives
    each its sentence, in the spec's order, each compared with the best fair baseline; the
    baselines and the oracle get none."""
    df = frame(
        {
            "thesis-law": "e" * 30,
            "constraint-aware": "s" * 29 + "e",
            "nominal-inverse": "s" * 10 + "e" * 20,
            "oracle": "s" * 30,
        }
    )
    text = headline(success_tables(df, THRESHOLD))
    assert text.startswith("Over 30 random failure draws, thesis-law succeeded in 0\u00a0% ")
    assert "thesis-law succeeded in 0\u00a0% of its runs (0/30;" in text
    assert "constraint-aware succeeded in 96.7\u00a0% of its runs (29/30;" in text
    assert text.index("thesis-law succeeded") < text.index("constraint-aware succeeded")
    assert text.count("the best fair baseline, nominal-inverse (33.3\u00a0%") == 2
    assert "oracle succeeded" not in text and "nominal-inverse succeeded" not in text


def test_the_headline_names_divergence_and_the_hardest_failure_model():
    models = ["stuck"] * 6 + ["bias"] * 6
    df = frame({"adaptive": "sedeee" + "ssssss", "frozen": "e" * 12}, models=models)
    text = headline(success_tables(df, THRESHOLD))
    assert "1 of its runs (8.3\u00a0%) diverged" in text
    assert "it did worst under stuck failures (16.7\u00a0%)" in text


def test_percentages_never_round_to_a_false_0_or_100():
    assert summary.pct(0.9996) == ">99.9\u00a0%" and summary.pct(1.0) == "100\u00a0%"
    assert summary.pct(0.0004) == "<0.1\u00a0%" and summary.pct(0.0) == "0\u00a0%"
    assert summary.pct(0.4567) == "45.7\u00a0%"


# ------------------------------------------------------------------------ diverged = worst


def test_diverged_runs_rank_and_draw_as_worse_than_any_completed_run():
    df = frame({"adaptive": "sedd", "frozen": "eeee"})  # member 1: completed, error 1e8
    worst = summary._worst(df, "adaptive", 4)
    assert list(worst["index"]) == [2, 3, 1, 0]  # diverged (earliest first), then by error
    figs = summary.draw_figures(df, threshold=THRESHOLD, unit="rad", focus="adaptive")
    ax = figs["worst_runs"].axes[0]
    names = dict(zip(ax.get_yticks(), [t.get_text() for t in ax.get_yticklabels()], strict=True))
    right = {names[p.get_y() + p.get_height() / 2]: p.get_x() + p.get_width() for p in ax.patches}
    assert min(right["member 2"], right["member 3"]) > right["member 1"] > right["member 0"]
    # the error distribution: the diverged bar lies right of every finite bin
    top = figs["error_histogram"].axes[0]
    (red,) = [list(c) for c in top.containers if c.get_label() == "diverged"]
    others = [p for p in top.patches if p not in red and p.get_height() > 0]
    assert len(red) == 1 and red[0].get_height() == 2
    assert red[0].get_x() > max(p.get_x() + p.get_width() for p in others)


def test_every_run_that_stopped_early_is_shown_as_diverged():
    """nonfinite / step_underflow / singular runs stopped before the end: failures shown with
    the diverged runs (as main's summary counts them), worse than any completed run."""
    df = frame({"adaptive": "senui", "frozen": "eeeee"})
    info = success_tables(df, THRESHOLD)
    assert info["diverged"]["adaptive"] == 2 and info["outcomes"]["adaptive"]["invalid draw"] == 1
    worst = summary._worst(df, "adaptive", 5)
    assert list(worst["index"]) == [2, 3, 1, 0]  # stopped first, then by error; invalid: no run
    assert summary._outcome_text(worst.iloc[1]) == (
        "stopped: step size underflow at t = 1.3 s (theta)"
    )


def test_an_empty_severity_bin_breaks_the_line_and_counts_are_whole_runs():
    df = frame({"adaptive": "ssse", "frozen": "eeee"}, severity=np.array([0.1, 0.1, 0.9, 0.9]))
    figs = summary.draw_figures(df, threshold=THRESHOLD, unit="rad")
    (line, *_) = figs["success_vs_severity"].axes[0].get_lines()
    y = np.asarray(line.get_ydata(), dtype=float)
    assert y[0] == 100 and y[-1] == 50 and np.isnan(y[1:4]).all()  # no line across 20-80 %
    for ax in figs["error_histogram"].axes:
        ticks = ax.get_yticks()
        assert np.allclose(ticks, np.round(ticks)), ticks


def test_a_campaign_where_nothing_completed_still_has_a_page(tmp_path):
    frame({"adaptive": "ddi", "nominal-inverse": "did"}).to_parquet(tmp_path / "results.parquet")
    info = write_summary(spec_for(designs=("adaptive", "nominal-inverse"), runs=3), tmp_path)
    assert info["per_design"]["adaptive"]["successes"] == 0
    assert "adaptive succeeded in 0\u00a0% of its runs (0/3;" in info["headline"]
    assert "2 of its runs (66.7\u00a0%) diverged" in info["headline"]


# ------------------------------------------------------------------------ the page


@pytest.fixture(scope="module")
def synthetic_page(tmp_path_factory):
    out = tmp_path_factory.mktemp("page")
    rng = np.random.default_rng(3)
    letters = {
        d: "".join(rng.choice(list("ssed" if d == "adaptive" else "seedd"), 40)) for d in DESIGNS
    }
    models = list(rng.choice(["stuck", "bias", "loss_of_effectiveness+stuck", "nonaffine"], 40))
    sev = rng.uniform(0, 1, 40)
    sev[[m == "nonaffine" for m in models]] = np.nan
    frame(letters, severity=sev, models=models).to_parquet(out / "results.parquet")
    info = write_summary(spec_for(runs=40), out)
    return out, info


def test_the_page_speaks_in_percentages_words_and_units_not_dumps(synthetic_page):
    out, info = synthetic_page
    text = page_text(out / "summary.html")
    for raw in (r"\bnan\b", r"\bNaN\b", r"\bTrue\b", r"\bFalse\b", r"\bmean\b", r"\(-0\.001"):
        assert not re.search(raw, text), raw
    assert info["headline"] in text
    r = info["per_design"]["adaptive"]
    assert f"{summary.pct(r['rate'])} ({r['successes']}/{r['runs']})" in text
    assert "95\u00a0% CI" in text
    for label in ("mild (0–20 %)", "extreme (80–100 %)", "unrated", "loss of effectiveness"):
        assert label in text
    assert "0.001 rad" in text  # the success limit with its unit
    assert "RMS tracking error ≤ 0.001 rad" in text
    assert "nominal-inverse" in text and "best fair baseline" in text
    assert (out / "summary.html").read_text().count('src="data:image/png;base64,') == 4
    for name in ("outcomes", "success_vs_severity", "error_histogram", "worst_runs"):
        assert (out / "figures" / f"{name}.png").stat().st_size > 5000


def test_every_table_scrolls_inside_its_own_container(synthetic_page):
    out, _ = synthetic_page
    page = (out / "summary.html").read_text()
    assert page.count("<table>") == page.count('<div class="scroll"><table>') > 3
    assert '<meta name="viewport"' in page


def test_a_tiny_real_campaign_against_the_fair_baselines(tmp_path, capsys):
    import json

    from adaptive_ftc.cli import main as aftc

    spec = tmp_path / "tiny.toml"
    spec.write_text(
        'name = "tiny"\nbase = "hypersonic-direct-s1"\nruns = 2\nseed = 1\nduration = 2.0\n'
        'designs = ["adaptive", "nominal-inverse", "fixed-gain", "frozen"]\n'
        "[success]\nrms_error_final = 0.001\nfinal_window = 0.5\n"
        "[failures]\nonset = {uniform = [0.5, 1.5]}\n"
        "[failures.models.loss_of_effectiveness]\neffectiveness = {uniform = [0.1, 0.9]}\n"
    )
    out = tmp_path / "c"
    assert aftc(["campaign", str(spec), "--out", str(out), "--quiet", "--jobs", "1"]) == 0
    info = json.loads((out / "summary.json").read_text())
    assert set(info["per_design"]) == set(DESIGNS)
    assert info["comparison"][0]["baseline"] in ("nominal-inverse", "fixed-gain")
    assert info["headline"].startswith("Over 2 random failure draws, adaptive succeeded in ")
    printed = capsys.readouterr().out  # the CLI ends with the headline
    assert info["headline"].replace("\u00a0", " ") in printed
    r = info["per_design"]["nominal-inverse"]
    assert (
        f"nominal-inverse: success rate {r['rate']:.1%} ({r['successes']}/2; 95 % CI "
        f"{r['ci_low']:.1%}-{r['ci_high']:.1%})"
    ) in printed
    assert (out / "summary.html").is_file()


# ------------------------------------------------------------------------ a real browser


def _need_browser():
    if pagecheck.find_chromium() is None:
        if os.environ.get("AFTC_REQUIRE_BROWSER") == "1":
            pytest.fail("AFTC_REQUIRE_BROWSER=1 but no chromium is installed")
        pytest.skip(
            "no chromium on PATH (Debian: apt-get install chromium); the page is not "
            "opened in a browser"
        )


def test_the_browser_check_sees_overflow_broken_images_and_console_errors(tmp_path):
    _need_browser()
    page = tmp_path / "bad.html"
    page.write_text(
        '<!DOCTYPE html><html><head><meta charset="utf-8"></head><body>'
        '<div style="width:700px">wide</div><img alt="gone" src="figures/missing.png">'
        "<script>console.error('boom')</script></body></html>"
    )
    problems = "\n".join(pagecheck.check_page(page, 390).problems())
    assert "horizontal overflow" in problems
    assert "image 'gone' did not load" in problems
    assert "boom" in problems
    assert not list(tmp_path.glob(".pagecheck-*"))  # the instrumented copies are removed


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory):
    from adaptive_ftc.reproduce import run_reproduction

    out = tmp_path_factory.mktemp("report")
    run_reproduction(
        out,
        quick=True,
        names=["hypersonic-direct-s1"],
        progress=False,
        jobs=1,
        formats=("png",),
        fair_baselines=False,
    )
    return out / "report.html"


@pytest.mark.parametrize("width", [1400, 390])
def test_summary_and_report_in_a_real_browser(synthetic_page, quick_report, width):
    _need_browser()
    problems = []
    for page in (synthetic_page[0] / "summary.html", quick_report):
        check = pagecheck.check_page(page, width)
        assert check.images, page  # the figures are there to be loaded
        problems += check.problems()
    assert not problems, "\n".join(problems)
