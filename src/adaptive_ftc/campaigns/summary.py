"""Campaign summary: success per design (with Wilson 95 % intervals), per severity bin, per
failure model and per compensability verdict, the comparison of each design with the best fair
baseline, figures, and a self-contained HTML page in the visual language of ``report.html``.

What counts as a success is read from the results table through one function,
:func:`member_success` (the ``success`` column the runner wrote, and never a run that did not
complete), so a change of the success definition in the runner reaches every number, table,
figure and sentence of the page.

Diverged runs are failures everywhere: they are counted as failures in every rate, drawn in red
right of every finite error in the error figures (never at a finite value that a completed bad
run could exceed), and rank first among the worst runs.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from adaptive_ftc.campaigns.spec import CampaignSpec
from adaptive_ftc.campaigns.store import read_results

__all__ = [
    "FAIR_COMPETITORS",
    "FLOOR",
    "OUTCOMES",
    "SEVERITY_BINS",
    "SEVERITY_WORDS",
    "draw_figures",
    "headline",
    "member_success",
    "outcome_classes",
    "pct",
    "role",
    "severity_label",
    "stopped_early",
    "success_tables",
    "wilson_interval",
    "write_summary",
]

#: Edges of the severity bins (severity in [0, 1]; unrated failures are shown apart).
SEVERITY_BINS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
#: One word per severity bin, in the order of :data:`SEVERITY_BINS`.
SEVERITY_WORDS = ("mild", "moderate", "serious", "severe", "extreme")
#: Baselines a design is fairly compared with (:mod:`adaptive_ftc.baselines`).
FAIR_COMPETITORS = ("nominal-inverse", "fixed-gain")
#: Adaptation switched off: shown as the floor, never as the baseline to beat.
FLOOR = "frozen"
#: Knows the true failure: a bound, shown but never compared with. ``oracle`` runs under the
#: same hardware, designer's model and feedback design as ``constraint-aware`` (a yardstick:
#: where it fails too, the draw is evidence of infeasibility); ``oracle-filtered`` has that
#: model's filters and smoothing but not the law's fixed feedback (session 12's ``oracle``);
#: ``oracle-plain`` is the thesis-gain oracle with no command filter (see
#: :data:`adaptive_ftc.campaigns.spec.DESIGN_VARIANTS`).
_ORACLE = "oracle"
ORACLES = (_ORACLE, "oracle-filtered", "oracle-plain")

#: Statuses of rows that are not runs of the design: a draw the closed loop refused, Ctrl-C.
NOT_RUN = ("invalid", "interrupted")
#: Outcome classes of a run, in the order of the outcome figure. ``diverged`` is every run that
#: stopped early (``diverged``, ``nonfinite``, ``step_underflow``, ``singular``).
OUTCOMES = ("success", "error too large", "failed another criterion", "diverged", "invalid draw")
_OUTCOME_COLOURS = {
    "success": "#2e7d32",
    "error too large": "#e0a030",
    "failed another criterion": "#8e6bb8",
    "diverged": "#c62828",
    "invalid draw": "#9aa5b1",
}
_CI_NOTE = (
    "95 % confidence interval of the success rate: the Wilson score interval "
    "(scipy.stats.binomtest(k, n).proportion_ci(method='wilson')), which stays inside 0-100 % "
    "and is honest for small counts and for rates near 0 or 100 %."
)


# ------------------------------------------------------------------------------ numbers


def member_success(df) -> Any:
    """Boolean Series: which rows of a results table are successes.

    The one place the page reads success from: the ``success`` column written by the runner
    (:func:`adaptive_ftc.campaigns.runner.outcome`), and never a run that did not complete
    (a diverged or invalid run is a failure whatever the column says).
    """
    ok = df["success"].fillna(False).astype(bool)
    return ok & (df["status"] == "completed")


def stopped_early(df) -> Any:
    """Boolean Series: runs that stopped before the end (diverged, a non-finite signal, a step
    size underflow, a singular plant equation), all shown as ``diverged``."""
    status = df["status"].astype(str)
    return ~status.isin(("completed", *NOT_RUN))


def outcome_classes(df, threshold: float | None = None) -> Any:
    """String Series, one of :data:`OUTCOMES` per row.

    ``error too large``: completed, not a success, final-window RMS error above ``threshold``
    (the spec's ``rms_error_final``); ``failed another criterion``: completed and not a success
    although the error is within the threshold (a criterion besides tracking, such as control
    activity, when the success definition has one).
    """
    import pandas as pd

    ok = member_success(df)
    status = df["status"].astype(str)
    out = pd.Series("error too large", index=df.index, dtype=object)
    if threshold is not None:
        within = df["rms_error_final"].astype(float) <= threshold
        out[(status == "completed") & within] = "failed another criterion"
    out[stopped_early(df)] = "diverged"
    out[status.isin(NOT_RUN)] = "invalid draw"
    out[ok] = "success"
    return out


def wilson_interval(successes: int, runs: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a success rate (``(nan, nan)`` without runs)."""
    if runs <= 0:
        return math.nan, math.nan
    from scipy.stats import binomtest

    ci = binomtest(int(successes), int(runs)).proportion_ci(
        confidence_level=confidence, method="wilson"
    )
    return float(ci.low), float(ci.high)


def _rate_record(ok) -> dict[str, Any]:
    k, n = int(ok.sum()), int(ok.size)
    lo, hi = wilson_interval(k, n)
    return {
        "runs": n,
        "successes": k,
        "rate": k / n if n else math.nan,
        "ci_low": lo,
        "ci_high": hi,
    }


def role(design: str) -> str:
    """What a design is on the page: ``tested``, ``fair baseline``, ``floor`` or ``bound``."""
    if design in FAIR_COMPETITORS:
        return "fair baseline"
    if design == FLOOR:
        return "floor"
    if design in ORACLES:
        return "bound"
    return "tested"


_ROLE_WORDS = {
    "tested": "design under test",
    "fair baseline": "fair baseline",
    "floor": "floor (adaptation frozen)",
    "bound": "bound (knows the failure; not compared with)",
}
#: Role words of the oracles on the page (what tells them apart).
_ORACLE_WORDS = {
    _ORACLE: "bound (knows the failure; the constraint-aware design's hardware model, "
    "filters and fixed feedback; not compared with)",
    "oracle-filtered": "bound (knows the failure; the constraint-aware design's hardware "
    "model and filters, not its fixed feedback; not compared with)",
    "oracle-plain": "bound (knows the failure; thesis gains, no command filter: no yardstick "
    "under hardware; not compared with)",
}


def severity_label(b: int) -> str:
    """Bin ``b`` of :data:`SEVERITY_BINS` in words with its unit, e.g. ``mild (0-20 %)``."""
    lo, hi = SEVERITY_BINS[b], SEVERITY_BINS[b + 1]
    return f"{SEVERITY_WORDS[b]} ({100 * lo:g}–{100 * hi:g} %)"


def _model_words(model: str) -> str:
    return "no drawn failure" if model in ("", "none") else model.replace("_", " ")


def _grouped(df, ok, key: str, values) -> list[dict[str, Any]]:
    rows = []
    for value in values:
        for d in dict.fromkeys(df["design"]):
            sel = (df[key] == value) & (df["design"] == d)
            if sel.any():
                rows.append({key: value, "design": d, **_rate_record(ok[sel])})
    return rows


def success_tables(df, threshold: float | None = None) -> dict[str, Any]:
    """Success rates from a results table (pandas): per design, per failure model, per
    severity bin and per compensability verdict, each with its count and Wilson interval.

    A member counts under every failure model it contains. Unrated members (no severity) form
    their own row of the severity table.
    """
    import pandas as pd

    ok = member_success(df)
    cls = outcome_classes(df, threshold)
    designs = list(dict.fromkeys(df["design"]))
    out: dict[str, Any] = {"designs": designs}
    per = {d: _rate_record(ok[df["design"] == d]) for d in designs}
    out["per_design"] = per
    out["success_rate"] = {d: per[d]["rate"] for d in designs}
    out["runs"] = {d: per[d]["runs"] for d in designs}
    out["outcomes"] = {
        d: {c: int(((df["design"] == d) & (cls == c)).sum()) for c in OUTCOMES} for d in designs
    }
    out["diverged"] = {d: out["outcomes"][d]["diverged"] for d in designs}
    errs = df["rms_error_final"].astype(float).where(df["status"] == "completed")
    out["median_error_final"] = {
        d: float(np.nanmedian(errs[df["design"] == d]))
        if errs[df["design"] == d].notna().any()
        else math.nan
        for d in designs
    }
    members = df.drop_duplicates("index")
    out["members"] = int(len(members))
    if "compensable" in df:
        out["compensable_fraction"] = float(members["compensable"].astype(bool).mean())
    if "models" in df:
        exploded = df.assign(_ok=ok, model=df["models"].fillna("").str.split("+")).explode("model")
        exploded["model"] = exploded["model"].fillna("").replace("", "none")
        out["by_model"] = [
            {**r, "model": _model_words(r["model"])}
            for r in _grouped(exploded, exploded["_ok"], "model", sorted(set(exploded["model"])))
        ]
    sev = df["severity"].astype(float)
    bins = pd.cut(sev, SEVERITY_BINS, include_lowest=True, labels=False)
    labels = bins.map(lambda b: severity_label(int(b)) if pd.notna(b) else "unrated")
    order = [severity_label(b) for b in range(len(SEVERITY_WORDS))] + ["unrated"]
    out["by_severity"] = [
        {**r, "bin": r.pop("_bin")} for r in _grouped(df.assign(_bin=labels), ok, "_bin", order)
    ]
    if "compensable" in df:
        words = (
            df["compensable"]
            .astype(bool)
            .map({True: "compensable (rank condition (3.6) holds)", False: "not compensable"})
        )
        out["by_compensable"] = [
            {**r, "compensable": r.pop("_c")}
            for r in _grouped(
                df.assign(_c=words),
                ok,
                "_c",
                ["compensable (rank condition (3.6) holds)", "not compensable"],
            )
        ]
    out["comparison"] = _comparisons(df, ok, designs, per, out)
    out["oracle_check"] = _oracle_check(df, ok, designs)
    return out


def oracle_weaker(info: dict[str, Any], design: str) -> bool:
    """Whether the ``oracle`` succeeded significantly less often than ``design``: its 95 %
    Wilson interval lies wholly below the design's (the page's test for *worse*, so 99 %
    against 100 % of 100 members is no verdict). Where it is, its failures say nothing of
    infeasibility ("no yardstick")."""
    o, r = info["per_design"][_ORACLE], info["per_design"][design]
    return bool(o["ci_high"] < r["ci_low"])


def _oracle_check(df, ok, designs: list[str]) -> list[dict[str, Any]]:
    """Per design under test, its failed members and how many of them the ``oracle`` failed
    too (empty when no ``oracle`` was run).

    The campaigns' ``oracle`` knows the failure and runs under the same hardware and the same
    designer's model and feedback design (command filter, smoothing, measurement filters,
    placed PID and lead, per-output floors) as ``constraint-aware``:
    where it fails too, the draw is evidence that the task is beyond a controller of this form
    on this hardware; where it succeeds, the member was feasible and the design lost it.
    Members with an invalid draw or an interrupted run (:data:`NOT_RUN`) are left out: nothing
    was tried there. ``oracle-filtered`` and ``oracle-plain`` are weaker yardsticks and are
    not used.
    """
    if _ORACLE not in designs:
        return []
    status = df["status"].astype(str)
    ran = ~status.isin(NOT_RUN)
    o_rows = df["design"] == _ORACLE
    o_ok = ok[o_rows].set_axis(df.loc[o_rows, "index"])
    o_ran = ran[o_rows].set_axis(df.loc[o_rows, "index"])
    out = []
    for d in designs:
        if role(d) != "tested":
            continue
        sel = df["design"] == d
        d_ok = ok[sel].set_axis(df.loc[sel, "index"])
        d_ran = ran[sel].set_axis(df.loc[sel, "index"])
        common = d_ok.index.intersection(o_ok.index)
        tried = d_ran.loc[common] & o_ran.loc[common]
        failed = tried & ~d_ok.loc[common]
        both = failed & ~o_ok.loc[common]
        out.append(
            {
                "design": d,
                "members": int(tried.sum()),
                "failed": int(failed.sum()),
                "oracle_failed_too": int(both.sum()),
                "oracle_succeeded": int((failed & o_ok.loc[common]).sum()),
                "oracle_failed_design_succeeded": int(
                    (tried & d_ok.loc[common] & ~o_ok.loc[common]).sum()
                ),
            }
        )
    return out


#: What decided between baselines tied on success rate, in the order of :func:`_baseline_rank`.
TIE_BREAKS = ("members tracked", "members completed", "median final error", "spec order")


def _baseline_rank(d: str, designs: list[str], info: dict[str, Any]) -> tuple:
    """Sort key of a baseline (higher is better): its success rate; on a tie (0 % for every
    baseline, say) the members it tracked on (completed within the error threshold, whatever
    the other criteria said), then the members it completed without diverging, then the lower
    median final error, then the spec's order. A baseline that diverged on every member is
    never named the best while another tracked on some."""
    o = info["outcomes"][d]
    tracked = o["success"] + o["failed another criterion"]
    completed = tracked + o["error too large"]
    med = info["median_error_final"][d]
    return (
        info["per_design"][d]["rate"],
        tracked,
        completed,
        -med if not math.isnan(med) else -math.inf,
        -designs.index(d),
    )


def _comparisons(
    df, ok, designs: list[str], per: dict[str, dict], info: dict[str, Any]
) -> list[dict[str, Any]]:
    """Each tested design against the best fair baseline run (the floor when none is); the
    best by :func:`_baseline_rank`."""
    fair = [d for d in designs if role(d) == "fair baseline"]
    pool = fair or [d for d in designs if role(d) == "floor"]
    if not pool:
        return []
    ranked = sorted(pool, key=lambda d: _baseline_rank(d, designs, info), reverse=True)
    best = ranked[0]
    kb = _baseline_rank(best, designs, info)
    tied = [d for d in ranked[1:] if per[d]["rate"] == per[best]["rate"]]
    tie_break = None
    if tied:
        kr = _baseline_rank(tied[0], designs, info)
        tie_break = TIE_BREAKS[next(i for i in range(1, len(kb)) if kb[i] != kr[i]) - 1]
    o = info["outcomes"][best]
    out = []
    b_rows = df[df["design"] == best].set_index("index")
    b_ok = ok[df["design"] == best].set_axis(b_rows.index)
    for d in designs:
        if role(d) != "tested":
            continue
        rows = df[df["design"] == d].set_index("index")
        d_ok = ok[df["design"] == d].set_axis(rows.index)
        common = rows.index.intersection(b_rows.index)
        a, b = d_ok.loc[common], b_ok.loc[common]
        ea = rows.loc[common, "rms_error_final"].astype(float)
        eb = b_rows.loc[common, "rms_error_final"].astype(float)
        done = (rows.loc[common, "status"] == "completed") & (
            b_rows.loc[common, "status"] == "completed"
        )
        ratio = (ea / eb)[done & (eb > 0)]
        pa, pb = per[d], per[best]
        if pa["ci_low"] > pb["ci_high"]:
            verdict = "better"
        elif pa["ci_high"] < pb["ci_low"]:
            verdict = "worse"
        else:
            verdict = "not distinguishable"
        out.append(
            {
                "design": d,
                "baseline": best,
                "baseline_role": role(best),
                "difference": pa["rate"] - pb["rate"],
                "verdict": verdict,
                "members": int(len(common)),
                "only_design": int((a & ~b).sum()),
                "only_baseline": int((~a & b).sum()),
                "both": int((a & b).sum()),
                "neither": int((~a & ~b).sum()),
                "median_error_ratio": float(ratio.median()) if len(ratio) else math.nan,
                "tied_with": tied,
                "tie_break": tie_break,
                "baseline_tracked": o["success"] + o["failed another criterion"],
                "baseline_completed": o["success"]
                + o["failed another criterion"]
                + o["error too large"],
            }
        )
    return out


def _tie_words(comp: dict[str, Any], info: dict[str, Any]) -> str:
    """Why ``comp['baseline']`` was chosen among the baselines tied with it on success rate."""
    b = comp["baseline"]
    n = info["per_design"][b]["runs"]
    return {
        "members tracked": f"{b} tracked on the most members ({comp['baseline_tracked']} of {n})",
        "members completed": (
            f"{b} completed the most runs without diverging ({comp['baseline_completed']} of {n})"
        ),
        "median final error": (
            f"{b} had the lowest median final error "
            f"({_num(info['median_error_final'][b])}, completed runs)"
        ),
        "spec order": f"{b} comes first in the spec (tied on every count)",
    }[comp["tie_break"]]


def pct(x: float) -> str:
    """A rate in percent for a reader: one decimal at most, never a rounded 0 % or 100 % that
    is not exact (``<0.1 %``, ``>99.9 %``)."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "no runs"
    v = 100.0 * x
    if 0.0 < v < 0.05:
        return "<0.1\u00a0%"
    if 99.95 <= v < 100.0:
        return ">99.9\u00a0%"
    text = f"{v:.1f}".removesuffix(".0")
    return f"{text}\u00a0%"


def _ci_text(r: dict[str, Any]) -> str:
    if not r["runs"]:
        return "–"
    return f"{pct(r['ci_low'])}–{pct(r['ci_high'])}".replace("\u00a0%–", "–")


def _hardest_model(info: dict[str, Any], design: str) -> dict[str, Any] | None:
    rows = [
        r
        for r in info.get("by_model", [])
        if r["design"] == design and r["model"] != "no drawn failure" and r["runs"] >= 5
    ]
    if len(rows) < 2:
        return None
    worst = min(rows, key=lambda r: (r["rate"], r["model"]))
    return worst if worst["rate"] < max(r["rate"] for r in rows) else None


def headline(info: dict[str, Any]) -> str:
    """What the campaign found, generated from the numbers of :func:`success_tables`: one
    sentence per design under test (a hardware campaign's thesis law and constraint-aware
    law both), in the spec's order."""
    designs = info["designs"]
    tested = [d for d in designs if role(d) == "tested"] or designs[:1]
    if not tested:
        return "The campaign has no runs."
    first = info["per_design"][tested[0]]
    members = info.get("members", first["runs"])
    sentences = [_design_sentence(info, d) for d in tested]
    return f"Over {members} random failure draws, " + " ".join(sentences)


def _design_sentence(info: dict[str, Any], d: str) -> str:
    """``"<design> succeeded in ... ."``: its rate, the comparison with the best fair baseline,
    its diverged runs and the failure model it did worst under."""
    r = info["per_design"][d]
    text = (
        f"{d} succeeded in {pct(r['rate'])} of its runs "
        f"({r['successes']}/{r['runs']}; 95\u00a0% CI {_ci_text(r)})"
    )
    comp = next((c for c in info.get("comparison", []) if c["design"] == d), None)
    if comp is None:
        text += "; no baseline was run to compare it with"
    else:
        b = info["per_design"][comp["baseline"]]
        if comp["baseline_role"] == "floor":
            text += (
                f"; no fair baseline (nominal-inverse, fixed-gain) was run, and the frozen floor "
                f"reached {pct(b['rate'])}"
            )
        else:
            how = {
                "better": "clearly better than",
                "worse": "clearly worse than",
                "not distinguishable": "not distinguishable at this sample size from",
            }[comp["verdict"]]
            if b["successes"] == 0 and comp["tied_with"]:
                # every fair baseline at 0 %: none is "best" by success; say so, and why the
                # paired comparison uses the one it uses
                text += (
                    f", {how} every fair baseline: none succeeded on any member "
                    f"(0\u00a0%, CI {_ci_text(b)}); it is paired with {comp['baseline']}, as "
                    + _tie_words(comp, info)
                )
            else:
                text += (
                    f", {how} the best fair baseline, {comp['baseline']} ({pct(b['rate'])}, "
                    f"CI {_ci_text(b)})"
                )
                if comp["tied_with"]:
                    text += f", tied on success with {', '.join(comp['tied_with'])}: " + _tie_words(
                        comp, info
                    )
    div = info["outcomes"][d]["diverged"]
    if div:
        text += f"; {div} of its runs ({pct(div / r['runs'])}) diverged"
    check = next((c for c in info.get("oracle_check", []) if c["design"] == d), None)
    if check is not None and check["failed"]:
        o = info["per_design"][_ORACLE]
        if oracle_weaker(info, d):
            text += (
                f"; the oracle (knows the failure; same hardware, filters and feedback) "
                f"succeeded significantly less often ({pct(o['rate'])}), so it is no "
                f"yardstick for {d} here"
            )
        else:
            text += (
                f"; the oracle (knows the failure; same hardware, filters and feedback) also "
                f"failed on "
                f"{check['oracle_failed_too']} of the {check['failed']} members {d} failed"
            )
    hard = _hardest_model(info, d)
    if hard is not None:
        text += f"; it did worst under {hard['model']} failures ({pct(hard['rate'])})"
    return text + "."


# ------------------------------------------------------------------------------ figures

_DESIGN_COLOURS = {
    FLOOR: "#7f8c99",
    _ORACLE: "#6a1b9a",
    "oracle-filtered": "#9575cd",
    "oracle-plain": "#b39ddb",
    "nominal-inverse": "#e07b00",
    "fixed-gain": "#2a9d8f",
}
_TESTED_COLOURS = ("#1f5fa8", "#c2185b", "#5d4037", "#00838f", "#827717")


def _colours(designs: list[str]) -> dict[str, str]:
    out, k = {}, 0
    for d in designs:
        if d in _DESIGN_COLOURS:
            out[d] = _DESIGN_COLOURS[d]
        else:
            out[d] = _TESTED_COLOURS[k % len(_TESTED_COLOURS)]
            k += 1
    return out


def _log_axis(values) -> tuple[float, float, float]:
    """(lo, hi, diverged position) of a log10 error axis covering ``values`` (finite)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    lo = float(np.floor(v.min())) if v.size else -6.0
    hi = float(np.ceil(v.max())) if v.size else 0.0
    if hi <= lo:
        hi = lo + 1.0
    return lo, hi, hi + 0.12 * (hi - lo) + 0.35


def _log_ticks(ax, lo: float, hi: float, div: float | None) -> None:
    step = max(1, int(math.ceil((hi - lo) / 7)))
    ticks = list(np.arange(lo, hi + 0.5, step))
    labels = [f"$10^{{{int(t)}}}$" for t in ticks]
    if div is not None:
        ticks.append(div)
        labels.append("diverged")
    ax.set_xticks(ticks, labels)


def draw_figures(
    df,
    *,
    threshold: float | None = None,
    unit: str = "",
    focus: str | None = None,
) -> dict[str, Any]:
    """The campaign's figures as bare matplotlib figures (name -> figure), drawn in the
    project's figure style: outcomes per design, success vs severity with Wilson intervals,
    the final-error distribution per design, the worst runs of ``focus``."""
    from adaptive_ftc.plots import figure_style

    with figure_style():
        return _draw(df, threshold, unit or "output units", focus)


def _draw(df, threshold: float | None, unit: str, focus: str | None) -> dict[str, Any]:
    import pandas as pd
    from matplotlib.ticker import MaxNLocator

    from adaptive_ftc.plots import new_figure, wrap_title

    designs = list(dict.fromkeys(df["design"]))
    colours = _colours(designs)
    ok = member_success(df)
    cls = outcome_classes(df, threshold)
    figs: dict[str, Any] = {}

    # 1. outcomes per design (stacked, % of runs)
    fig = new_figure(7.0, 1.3 + 0.42 * len(designs))
    ax = fig.subplots()
    y = np.arange(len(designs))[::-1]
    left = np.zeros(len(designs))
    for c in OUTCOMES:
        share = np.array([100.0 * (cls[df["design"] == d] == c).mean() for d in designs])
        if not share.any():
            continue
        ax.barh(y, share, left=left, color=_OUTCOME_COLOURS[c], label=c, height=0.62)
        for yi, li, si in zip(y, left, share, strict=True):
            if si >= 14.0:
                ax.text(li + si / 2, yi, f"{si:.0f} %", ha="center", va="center", fontsize=8)
        left += share
    ax.set_yticks(y, designs)
    ax.set_xlim(0, 100)
    ax.set_xlabel("share of the design's runs (%)")
    ax.grid(axis="y", visible=False)
    fig.legend(loc="outside upper center", ncols=min(5, len(ax.get_legend_handles_labels()[0])))
    figs["outcomes"] = fig

    # 2. success vs severity, Wilson 95 % intervals
    sev = df["severity"].astype(float)
    bins = pd.cut(sev, SEVERITY_BINS, include_lowest=True, labels=False)
    centers = 50.0 * (np.array(SEVERITY_BINS[:-1]) + np.array(SEVERITY_BINS[1:]))
    fig = new_figure(7.0, 3.6)
    ax = fig.subplots()
    width = 100.0 * (SEVERITY_BINS[1] - SEVERITY_BINS[0])
    for k, d in enumerate(designs):
        off = (k - (len(designs) - 1) / 2) * min(3.0, 0.5 * width / max(1, len(designs)))
        xs, rates, below, above = [], [], [], []
        for b in range(len(centers)):
            sel = (df["design"] == d) & (bins == b)
            r = _rate_record(ok[sel])  # an empty bin is NaN: the line breaks there
            xs.append(centers[b] + off)
            rates.append(100 * r["rate"])
            below.append(100 * (r["rate"] - r["ci_low"]))
            above.append(100 * (r["ci_high"] - r["rate"]))
        if np.isfinite(rates).any():
            ax.errorbar(
                xs, rates, yerr=[below, above], fmt="o-", capsize=3, color=colours[d], label=d, ms=4
            )
    ax.set_xticks(
        centers,
        [
            f"{w}\n{100 * SEVERITY_BINS[b]:g}–{100 * SEVERITY_BINS[b + 1]:g}"
            for b, w in enumerate(SEVERITY_WORDS)
        ],
    )
    ax.set_xlim(0, 100)
    ax.set_ylim(-4, 104)
    ax.set_xlabel("severity of the worst failure of the member (%)")
    ax.set_ylabel("success rate (% of runs)")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    fig.suptitle(wrap_title("Success vs severity, with 95 % Wilson intervals", 7.0))
    figs["success_vs_severity"] = fig

    # 3. final-window error per design; diverged runs right of every finite error
    err = np.log10(df["rms_error_final"].astype(float).clip(lower=1e-300))
    done = (df["status"] == "completed") & np.isfinite(err)
    lo, hi, div = _log_axis(err[done])
    n_bins = 30
    edges = np.linspace(lo, hi, n_bins + 1)
    fig = new_figure(7.0, 0.9 + 1.05 * len(designs))
    axes = fig.subplots(len(designs), 1, sharex=True, squeeze=False)[:, 0]
    for ax, d in zip(axes, designs, strict=True):
        sel = df["design"] == d
        ax.hist(err[sel & done], bins=edges, color=colours[d], label="completed runs")
        n_div = int((stopped_early(df) & sel).sum())
        if n_div:
            bw = 2.5 * (edges[1] - edges[0])
            ax.bar([div], [n_div], width=bw, color=_OUTCOME_COLOURS["diverged"], label="diverged")
        if threshold is not None and threshold > 0:
            ax.axvline(math.log10(threshold), color="0.15", ls="--", lw=1.0, label="success limit")
        ax.set_title(f"{d}", loc="left", fontsize=9)
        ax.set_ylabel("runs (count)")
        ax.yaxis.set_major_locator(MaxNLocator(nbins=3, integer=True))
        ax.set_xlim(lo - 0.02 * (div - lo), div + 0.06 * (div - lo))
    _log_ticks(axes[-1], lo, hi, div)
    axes[-1].set_xlabel(f"final-window RMS tracking error ({unit}, log scale)")
    handles: dict[str, Any] = {}  # label -> its first handle
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    labels = list(handles)
    fig.legend([handles[k] for k in labels], labels, loc="outside upper center", ncols=3)
    figs["error_histogram"] = fig

    # 4. worst runs of the design in focus
    if focus is None or focus not in designs:
        focus = designs[0]
    worst = _worst(df, focus, 10)
    fig = new_figure(7.0, 1.1 + 0.27 * max(3, len(worst)))
    ax = fig.subplots()
    if len(worst):
        e = np.log10(worst["rms_error_final"].astype(float).clip(lower=1e-300))
        is_div = (worst["status"] != "completed").to_numpy()
        wlo, whi, wdiv = _log_axis(np.concatenate([e[~is_div].to_numpy(), err[done].to_numpy()]))
        wok = member_success(worst).to_numpy()
        vals = np.where(is_div, wdiv, e.to_numpy())
        colour = np.where(
            is_div,
            _OUTCOME_COLOURS["diverged"],
            np.where(wok, _OUTCOME_COLOURS["success"], _OUTCOME_COLOURS["error too large"]),
        )
        pos = np.arange(len(worst))[::-1]
        base = wlo - 0.02 * (wdiv - wlo)
        ax.barh(pos, vals - base, left=base, color=colour, height=0.65)
        ax.set_yticks(pos, [f"member {i}" for i in worst["index"]])
        if threshold is not None and threshold > 0:
            ax.axvline(math.log10(threshold), color="0.15", ls="--", lw=1.0)
        ax.set_xlim(base, wdiv + 0.06 * (wdiv - wlo))
        _log_ticks(ax, wlo, whi, wdiv)
    ax.set_xlabel(f"final-window RMS tracking error of {focus} ({unit}, log scale)")
    ax.grid(axis="y", visible=False)
    from matplotlib.patches import Patch

    keys = ["diverged", "error too large", "success"]
    fig.legend(
        [Patch(color=_OUTCOME_COLOURS[k]) for k in keys],
        ["diverged or stopped (worst)", "error above the success limit", "success"],
        loc="outside upper center",
        ncols=3,
    )
    figs["worst_runs"] = fig
    return figs


def _figures(
    df,
    folder: Path,
    *,
    threshold: float | None = None,
    unit: str = "",
    focus: str | None = None,
) -> dict[str, Path]:
    """Draw :func:`draw_figures` and save them as ``folder/<name>.png``."""
    from adaptive_ftc.plots import DPI, figure_style

    folder.mkdir(parents=True, exist_ok=True)
    figs = draw_figures(df, threshold=threshold, unit=unit, focus=focus)
    paths = {}
    with figure_style():
        for name, fig in figs.items():
            paths[name] = folder / f"{name}.png"
            fig.savefig(paths[name], dpi=DPI, format="png")
    return paths


def _worst(df, design: str, n: int):
    """The ``n`` worst runs of ``design``: diverged runs first (earliest divergence first),
    then completed runs by final-window error, largest first; invalid draws are not runs."""
    sel = df[(df["design"] == design) & ~df["status"].isin(NOT_RUN)].copy()
    diverged = sel["status"] != "completed"
    sel["_rank"] = np.where(diverged, 0, 1)
    t = sel["divergence_time"].astype(float) if "divergence_time" in sel else np.nan
    sel["_key"] = np.where(diverged, np.nan_to_num(t, nan=np.inf), -sel["rms_error_final"])
    return sel.sort_values(["_rank", "_key", "index"]).head(n)


# ------------------------------------------------------------------------------ the page

_EXTRA_CSS = """
.lead{background:#fff;border-left:6px solid #1f5fa8;border-radius:6px;padding:10px 16px;
margin:14px 0;font-size:17px;max-width:1100px;box-shadow:0 1px 2px rgba(0,0,0,.12)}
.tot small{display:block;color:#52606d;font-size:12px}
td.ci{color:#52606d;font-size:12.5px;white-space:nowrap}
td.good{background:#eef7ee}td.bad{background:#fdecec}
section.sc figure{max-width:900px}
code{font-size:12.5px;background:#eef1f4;padding:1px 4px;border-radius:3px}
header code{background:rgba(255,255,255,.18);color:#fff}
td .detail,td.ci{white-space:nowrap}
@media (max-width:700px){.lead{font-size:15px;padding:8px 12px}.tot{flex:1 1 40%;padding:8px 12px}
.tot b{font-size:19px}}
"""


def _img(path: Path, alt: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode()
    return (
        f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{html.escape(alt)}</figcaption></figure>"
    )


def _table(head: list[str], rows: list[list[str]], note: str = "") -> str:
    """A table in a horizontally scrolling container (cells are already HTML)."""
    th = "".join(f"<th>{h}</th>" for h in head)
    body = "".join("<tr>" + "".join(rows_i) + "</tr>" for rows_i in rows)
    note = f'<p class="meta">{note}</p>' if note else ""
    return (
        f'<div class="scroll"><table><thead><tr>{th}</tr></thead><tbody>{body}</tbody>'
        f"</table></div>{note}"
    )


def _num(x: float, unit: str = "") -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if math.isinf(x):
        return "∞"
    return f"{x:.3g}" + (f"\u00a0{html.escape(unit)}" if unit else "")


def _rate_cell(r: dict[str, Any] | None) -> str:
    if r is None or not r["runs"]:
        return '<td class="num">–</td>'
    return (
        f'<td class="num"><b>{pct(r["rate"])}</b> ({r["successes"]}/{r["runs"]})<br>'
        f'<span class="detail">CI {_ci_text(r)}</span></td>'
    )


def _matrix(records: list[dict[str, Any]], key: str, designs: list[str], title: str) -> str:
    rows_order = list(dict.fromkeys(r[key] for r in records))
    by = {(r[key], r["design"]): r for r in records}
    rows = [
        [f"<td>{html.escape(str(k))}</td>"] + [_rate_cell(by.get((k, d))) for d in designs]
        for k in rows_order
    ]
    return _table([html.escape(title)] + [html.escape(d) for d in designs], rows)


def _design_table(info: dict[str, Any], unit: str) -> str:
    rows = []
    for d in info["designs"]:
        r, o = info["per_design"][d], info["outcomes"][d]
        rows.append(
            [
                f"<td><b>{html.escape(d)}</b></td>",
                f"<td>{html.escape(_ORACLE_WORDS.get(d) or _ROLE_WORDS[role(d)])}</td>",
                f'<td class="num"><b>{pct(r["rate"])}</b> ({r["successes"]}/{r["runs"]})</td>',
                f'<td class="ci">{_ci_text(r)}</td>',
                f'<td class="num">{o["error too large"] + o["failed another criterion"]}</td>',
                f'<td class="num">{o["diverged"]}</td>',
                f'<td class="num">{o["invalid draw"]}</td>',
                f'<td class="num">{_num(info["median_error_final"][d], unit)}</td>',
            ]
        )
    return _table(
        [
            "design",
            "role",
            "success (runs)",
            "95&nbsp;% CI",
            "completed, failed",
            "diverged",
            "invalid draws",
            "median final RMS error (completed runs)",
        ],
        rows,
    )


def _comparison_html(info: dict[str, Any], unit: str) -> str:
    comps = info.get("comparison", [])
    if not comps:
        return (
            '<p class="meta">No baseline was run, so no design is compared with one.</p>'
            + _oracle_html(info)
        )
    parts = []
    for c in comps:
        d, b = c["design"], c["baseline"]
        pd_, pb = info["per_design"][d], info["per_design"][b]
        cls = {"better": "good", "worse": "bad"}.get(c["verdict"], "")
        what = (
            "the frozen floor (no fair baseline, nominal-inverse or fixed-gain, was run)"
            if c["baseline_role"] == "floor"
            else f"the best fair baseline, <b>{html.escape(b)}</b>"
        )
        if c["baseline_role"] != "floor" and c["tied_with"]:
            what += (
                " (no fair baseline succeeded on any member; "
                if pb["successes"] == 0
                else f" (tied on success with {html.escape(', '.join(c['tied_with']))}; "
            ) + f"{html.escape(_tie_words(c, info))})"
        rows = [
            [
                f"<td>{html.escape(d)}</td>",
                _rate_cell(pd_),
                _rate_cell(pb),
                f'<td class="num {cls}">{"+" if c["difference"] >= 0 else "−"}'
                f"{pct(abs(c['difference'])).replace(chr(160) + '%', '')} points "
                f"({html.escape(c['verdict'])})</td>",
                f'<td class="num">{c["only_design"]}</td>',
                f'<td class="num">{c["only_baseline"]}</td>',
                f'<td class="num">{c["both"]} / {c["neither"]}</td>',
                f'<td class="num">{_num(c["median_error_ratio"])}</td>',
            ]
        ]
        parts.append(
            f"<p>{html.escape(d)} against {what}:</p>"
            + _table(
                [
                    "design",
                    "its success",
                    f"{html.escape(b)} success",
                    "difference",
                    f"members only {html.escape(d)} survived",
                    f"members only {html.escape(b)} survived",
                    "both / neither",
                    f"median error ratio {html.escape(d)} / {html.escape(b)}",
                ],
                rows,
            )
        )
    note = (
        "Every design runs the same members, so the comparison is paired: which members one "
        "design survived and the other did not. <i>better</i> / <i>worse</i>: the 95&nbsp;% "
        "Wilson intervals do not overlap. The error ratio is the median over members that both "
        "completed of the ratio of their final-window RMS errors (below 1: the design tracks "
        "better). The best fair baseline is the nominal-inverse or fixed-gain run with the "
        "highest success rate; on a tie (0&nbsp;% for both, say), the one that tracked on the "
        "most members (completed within the error threshold), then the one that completed the "
        "most runs without diverging, then the lower median final error. The frozen run is only "
        "a floor, the oracle (knows the failure) a bound; oracle-filtered (without the law's "
        "fixed feedback) and oracle-plain (thesis gains, no command filter) too."
    )
    return "".join(parts) + _oracle_html(info) + f'<p class="meta">{note}</p>'


def _oracle_html(info: dict[str, Any]) -> str:
    """The oracle check of :func:`_oracle_check` in words (empty without an oracle run)."""
    checks = info.get("oracle_check", [])
    if not checks:
        return ""
    o = info["per_design"][_ORACLE]
    lines, worse = [], []
    for c in checks:
        d = html.escape(c["design"])
        weaker = oracle_weaker(info, c["design"])
        if weaker:
            worse.append(d)
        if not c["failed"]:
            lines.append(f"{d} failed on no member the oracle was run on.")
            continue
        why = "" if weaker else " (evidence that these draws are infeasible on their hardware)"
        won = c["oracle_succeeded"]
        lost = f"succeeded on {won} (feasible: {d} lost them)" if won else "succeeded on none"
        lines.append(
            f"Of the {c['failed']} members {d} failed, the oracle failed on "
            f"<b>{c['oracle_failed_too']}</b> too{why} and {lost}; the oracle failed on "
            f"{c['oracle_failed_design_succeeded']} members {d} succeeded on."
        )
    if worse:
        lines.append(
            f"The oracle succeeded significantly less often ({pct(o['rate'])}) than "
            f"{', '.join(worse)}: under this hardware the exact inverse beside the law's "
            "feedback design is weaker than that law, so where it fails is no evidence of "
            "infeasibility here."
        )
    return (
        "<p>The oracle knows the failure and runs under the same hardware, the same "
        "designer's model (command filter, smoothing, measurement filters) and the same fixed "
        "feedback (placed PID and lead, per-output floors) as constraint-aware, with the exact "
        "inverse of the failed plant in place of the adaptation. " + " ".join(lines) + "</p>"
    )


_STOP_WORDS = {
    "diverged": "diverged",
    "nonfinite": "stopped: a signal became non-finite",
    "step_underflow": "stopped: step size underflow",
    "singular": "stopped: singular plant equation",
}


def _outcome_text(r) -> str:
    status = str(r["status"])
    if status == "completed":
        return "completed"
    t = float(r.get("divergence_time", math.nan))
    sig = r.get("divergence_signal", "")
    where = f" at t = {t:.3g} s" if not math.isnan(t) else ""
    return _STOP_WORDS.get(status, status) + where + (f" ({sig})" if sig else "")


def _worst_table(df, design: str, out: Path, unit: str) -> tuple[str, list[dict[str, Any]]]:
    worst = _worst(df, design, 10)
    records, rows = [], []
    for _, r in worst.iterrows():
        rec = {
            "index": int(r["index"]),
            "models": r.get("models", ""),
            "severity": float(r.get("severity", math.nan)),
            "status": r["status"],
            "rms_error_final": float(r["rms_error_final"]),
            "divergence_time": float(r.get("divergence_time", math.nan)),
            "divergence_signal": r.get("divergence_signal", ""),
            "replay": f"aftc campaign replay {out} {int(r['index'])}",
        }
        records.append(rec)
        models = " + ".join(_model_words(m) for m in str(rec["models"]).split("+") if m)
        sev = rec["severity"]
        rows.append(
            [
                f'<td class="num">{rec["index"]}</td>',
                f"<td>{html.escape(models or 'no drawn failure')}</td>",
                f'<td class="num">{"unrated" if math.isnan(sev) else pct(sev)}</td>',
                f"<td>{html.escape(_outcome_text(rec))}</td>",
                f'<td class="num">'
                f"{'–' if r['status'] != 'completed' else _num(rec['rms_error_final'], unit)}</td>",
                f"<td><code>{html.escape(rec['replay'])}</code></td>",
            ]
        )
    table = _table(["member", "failures", "severity", "outcome", "final RMS error", "replay"], rows)
    return table, records


def _unit(spec: CampaignSpec) -> str:
    from adaptive_ftc._units import output_unit

    try:
        return output_unit({"plant": spec.loop.plant.name})
    except Exception:  # a custom plant: no known unit
        return ""


def write_summary(spec: CampaignSpec, out: str | Path) -> dict[str, Any]:
    """Write ``summary.json``, ``figures/*.png`` and ``summary.html`` for a finished campaign.

    Returns
    -------
    dict
        The success tables (as in ``summary.json``).
    """
    from adaptive_ftc._version import __version__
    from adaptive_ftc.report import _CSS

    out = Path(out)
    df = read_results(out)
    unit = _unit(spec)
    info = success_tables(df, spec.success_rms)
    info["name"] = spec.name
    info["runs_per_design"] = spec.runs
    info["unit"] = unit
    thr = _num(spec.success_rms, unit)
    info["success_criterion"] = (
        f"completed, and final-window ({spec.final_window:g} s) RMS tracking error "
        f"≤ {spec.success_rms:g} {unit}".rstrip()
    )
    if spec.activity is not None:  # and its command acceptable (campaigns/activity.py)
        info["success_criterion"] += "; " + spec.activity.describe(spec)
    info["headline"] = headline(info)
    tested = [d for d in info["designs"] if role(d) == "tested"] or info["designs"][:1]
    focus = tested[0]
    paths = _figures(df, out / "figures", threshold=spec.success_rms, unit=unit, focus=focus)
    worst_html, info["worst"] = _worst_table(df, focus, out, unit)
    (out / "summary.json").write_text(json.dumps(info, indent=2, default=str))

    e = html.escape
    r = info["per_design"][focus]
    totals = [
        (str(info["members"]), "members (random failure draws)"),
        (str(len(info["designs"])), "designs, each run on every member"),
        (pct(r["rate"]), f"{focus} success <small>CI {_ci_text(r)}</small>"),
    ]
    comp = next((c for c in info["comparison"] if c["design"] == focus), None)
    if comp is not None:
        b = info["per_design"][comp["baseline"]]
        totals.append((pct(b["rate"]), f"{comp['baseline']} success ({comp['baseline_role']})"))
    totals.append((str(info["outcomes"][focus]["diverged"]), f"{focus} runs diverged"))
    if "compensable_fraction" in info:
        totals.append((pct(info["compensable_fraction"]), "draws compensable (rank cond. 3.6)"))
    tots = "".join(f'<div class="tot"><b>{v}</b>{k}</div>' for v, k in totals)
    designs = info["designs"]
    stamp = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    sections = [
        (
            "Success per design",
            _design_table(info, unit)
            + _img(paths["outcomes"], "What happened to every run, per design")
            + f'<p class="meta">Success: {e(info["success_criterion"])}. A diverged run is a '
            "failure. <i>completed, failed</i>: the run finished but missed the success "
            "criterion; <i>invalid draws</i>: members the closed loop refused to build (counted "
            f"as failures). {e(_CI_NOTE)}</p>",
        ),
        ("Against the best fair baseline", _comparison_html(info, unit)),
        (
            "Success vs severity",
            _img(
                paths["success_vs_severity"],
                "Success rate per severity bin and design; bars: 95 % Wilson intervals",
            )
            + _matrix(info["by_severity"], "bin", designs, "severity of the worst failure")
            + '<p class="meta">Severity of a failure, in %: the share of the actuator\'s '
            "effect that is lost (loss of effectiveness, affine), the bias relative to the "
            "largest drawn bias (bias), 100 % for stuck and reversed actuators; a member's "
            "severity is that of its worst failure. <i>unrated</i>: position limits and "
            "non-affine failures without a named severity.</p>",
        ),
        (
            "Success per failure model",
            _matrix(info.get("by_model", []), "model", designs, "failure model")
            + '<p class="meta">A member with two failure models counts under both.</p>',
        ),
    ]
    if info.get("by_compensable"):
        sections.append(
            (
                "Success by compensability verdict",
                _matrix(info["by_compensable"], "compensable", designs, "drawn failure timeline"),
            )
        )
    sections += [
        (
            "Final-window tracking error",
            _img(
                paths["error_histogram"],
                "Distribution of the final-window RMS tracking error per design "
                f"({unit or 'output units'}); diverged runs in red, right of every finite error",
            ),
        ),
        (
            f"Worst runs of {focus}",
            _img(paths["worst_runs"], f"The ten worst runs of {focus}: diverged runs first")
            + worst_html,
        ),
    ]
    body = "".join(
        f'<section class="sc"><h2>{e(t)}</h2>{content}</section>' for t, content in sections
    )
    page = (
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{e(spec.title)}</title><style>{_CSS}{_EXTRA_CSS}</style></head><body>"
        f"<header><h1>{e(spec.title)}</h1>"
        f"<p>Fault campaign <code>{e(spec.name)}</code> · base scenario "
        f"<b>{e(spec.base.name)}</b> · {spec.runs} members × {len(designs)} designs · seed "
        f"{spec.seed} · success limit {thr} · adaptive-ftc {e(__version__)} · generated "
        f"{stamp}</p></header><main>"
        f'<p class="lead">{e(info["headline"])}</p>'
        f'<div class="totals">{tots}</div>{body}</main></body></html>'
    )
    (out / "summary.html").write_text(page, encoding="utf-8")
    return info
