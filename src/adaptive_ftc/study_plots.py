"""Figures of the robustness studies (:mod:`adaptive_ftc.studies`), in :mod:`adaptive_ftc.plots`
style (:func:`adaptive_ftc.plots.figure_style`, constrained layout): a bare
:class:`matplotlib.figure.Figure` (no ``pyplot``), SI units on the axes, a grid, legends outside
the data.

:func:`plot_robustness` draws one panel per knob: the RMS tracking error over the last window
against the knob value, log-log, one line per design (the median over the noise seeds), the
harsh end of every axis on the right (the controller-rate and rate-limit axes are reversed).
Runs that did not reach their end are drawn as crosses on a "diverged" band above the data
(``gid="diverged"``); the break threshold is a dotted horizontal line (``gid="threshold"``) and
each design's break point a dashed vertical line in its colour (``gid="break-point"``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.plots import DPI, FORMATS, figure_style, new_figure, wrap_title
from adaptive_ftc.studies import KNOBS, break_points

__all__ = [
    "plot_delay_margins",
    "plot_robustness",
    "save_delay_margin_figure",
    "save_robustness_figure",
]

_TITLES = {
    "noise": "sensor noise (std of the output; rates 10x)",
    "controller_rate": "digital controller rate",
    "lag": "actuator lag (first-order time constant)",
    "rate_limit": "actuator rate limit",
}
_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink")


def plot_robustness(table: pd.DataFrame, *, title: str | None = None) -> Figure:
    """Error against knob value for every design and knob of a :func:`robustness_sweep` table.

    Parameters
    ----------
    table
        Rows of :func:`~adaptive_ftc.studies.robustness_sweep` (several scenarios and knobs
        concatenated).
    title
        Figure title (default: none).
    """
    with figure_style():
        return _plot_robustness(table, title)


def _plot_robustness(table: pd.DataFrame, title: str | None) -> Figure:
    need = {"scenario", "knob", "value", "rms_error", "status", "broken", "threshold"}
    missing = need - set(table.columns)
    if missing or table.empty:
        raise ConfigurationError(
            "plot_robustness() needs a non-empty robustness_sweep table"
            + (f"; columns missing: {', '.join(sorted(missing))}." if missing else ".")
        )
    knobs = [k for k in KNOBS if k in set(table["knob"])]
    scenarios = list(dict.fromkeys(table["scenario"]))
    colors = {s: _COLORS[i % len(_COLORS)] for i, s in enumerate(scenarios)}
    prefix = _common_prefix(scenarios)
    bps = break_points(table).set_index(["scenario", "knob"])
    n_cols = 2 if len(knobs) > 1 else 1
    n_rows = math.ceil(len(knobs) / n_cols)
    fig = new_figure(6.2 * n_cols + 3.4, 0.9 + 3.0 * n_rows)
    axes = fig.subplots(n_rows, n_cols, squeeze=False).ravel()
    noise_units = set(table.loc[table["knob"] == "noise", "unit"]) if "unit" in table else set()
    error_unit = noise_units.pop() if len(noise_units) == 1 else "output unit"
    finite = table["rms_error"].to_numpy(dtype=float)
    finite = finite[np.isfinite(finite) & (finite > 0)]
    top = float(np.max(np.r_[finite, table["threshold"].to_numpy(float)])) * 10.0
    bottom = float(np.min(finite)) / 3.0 if finite.size else top / 1e6
    for ax, knob in zip(axes, knobs, strict=False):
        sub = table[table["knob"] == knob]
        for scen in scenarios:
            rows = sub[sub["scenario"] == scen]
            if rows.empty:
                continue
            per = rows.groupby("value", sort=True).agg(
                rms=("rms_error", "median"),
                diverged=("status", lambda s: (s != "completed").any()),
            )
            ok = per[~per["diverged"]]
            ax.plot(
                ok.index,
                ok["rms"],
                "o-",
                color=colors[scen],
                ms=4,
                lw=1.4,
                label=scen[len(prefix) :],
            )
            bad = per[per["diverged"]]
            if not bad.empty:
                ax.plot(
                    bad.index,
                    np.full(len(bad), top),
                    "x",
                    color=colors[scen],
                    ms=8,
                    mew=2,
                    gid="diverged",
                    label=f"{scen[len(prefix) :]}: diverged",
                )
            if (scen, knob) in bps.index:
                bp = bps.loc[(scen, knob), "break_point"]
                if np.isfinite(bp):
                    ax.axvline(
                        bp,
                        color=colors[scen],
                        ls="--",
                        lw=1.0,
                        gid="break-point",
                        label=f"{scen[len(prefix) :]}: breaks at {bp:g} {KNOBS[knob][0]}",
                    )
        thr = float(sub["threshold"].iloc[0])
        ax.axhline(thr, color="0.3", ls=":", lw=1.0, gid="threshold", label=f"threshold {thr:.2g}")
        ax.axhspan(top / 2.5, top * 2.5, color="tab:red", alpha=0.07, lw=0)
        ax.text(
            0.01, 0.985, "diverged", transform=ax.transAxes, va="top", fontsize=8, color="tab:red"
        )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylim(bottom, top * 2.5)
        _log_ticks(ax.xaxis, sub["value"].to_numpy(dtype=float))
        if not KNOBS[knob][1]:
            ax.invert_xaxis()
        ax.set_xlabel(f"{_TITLES[knob]} ({KNOBS[knob][0]})")
        ax.set_ylabel(f"RMS tracking error, last 20 s ({error_unit})")
        ax.grid(True, which="both", linewidth=0.4, alpha=0.5)
        handles, labels = ax.get_legend_handles_labels()
        ax.legend(
            handles,
            labels,
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            borderaxespad=0.0,
            fontsize=7.5,
        )
    for ax in axes[len(knobs) :]:
        ax.set_visible(False)
    if title:
        fig.suptitle(wrap_title(title, fig.get_figwidth()))
    return fig


def _log_ticks(axis, values: np.ndarray) -> None:
    """Labelled ticks of a log axis that never crowd: 1-2-5 per decade on a span of up to 2.5
    decades, else one per decade; values in plain numbers (``0.001``, ``50``), no minor labels
    (matplotlib labels minor ticks on a short log axis, and they overlapped)."""
    v = values[np.isfinite(values) & (values > 0)]
    decades = math.log10(v.max() / v.min()) if v.size > 1 else 0.0
    subs = (1.0, 2.0, 5.0) if decades <= 2.5 else (1.0,)
    axis.set_major_locator(LogLocator(base=10.0, subs=subs))
    axis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    axis.set_minor_formatter(NullFormatter())


def _common_prefix(names: Sequence[str]) -> str:
    """The shared ``word-`` prefix of the scenario names (dropped from the legend labels)."""
    if len(names) < 2:
        return ""
    head = names[0].split("-")
    k = 0
    while k < len(head) - 1 and all(n.split("-")[: k + 1] == head[: k + 1] for n in names):
        k += 1
    return "-".join(head[:k]) + "-" if k else ""


def save_robustness_figure(
    table: pd.DataFrame,
    path: str | Path,
    *,
    formats: Sequence[str] = ("png", "pdf"),
    title: str | None = None,
    dpi: int | None = None,
) -> list[Path]:
    """Draw :func:`plot_robustness` and write it as ``path`` with each suffix of ``formats``.

    Returns the written files.
    """
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise ConfigurationError(
            f"Figure formats must be among {', '.join(FORMATS)}; got {', '.join(bad) or 'none'}."
        )
    fig = plot_robustness(table, title=title)
    out = []
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    for fmt in formats:
        p = path.with_suffix(f".{fmt}")
        with figure_style():
            fig.savefig(p, dpi=dpi or DPI)
        out.append(p)
    return out


def plot_delay_margins(table: pd.DataFrame, *, title: str | None = None) -> Figure:
    """Time-delay margin per scenario and law of a :func:`~adaptive_ftc.studies.
    delay_margin_study` table: one horizontal bar per (scenario, law), log scale in ms, the
    bracket ``[lower, upper]`` as an error bar, the reason the upper
    delay fails written beside it; a loop whose undelayed run is not acceptable is marked
    "not acceptable undelayed" (``gid="no-margin"``)."""
    need = {"scenario", "law", "margin", "lower", "upper", "how"}
    missing = need - set(table.columns)
    if missing or table.empty:
        raise ConfigurationError(
            "plot_delay_margins() needs a non-empty delay_margin_study table"
            + (f"; columns missing: {', '.join(sorted(missing))}" if missing else "")
            + "."
        )
    with figure_style():
        laws = list(dict.fromkeys(table["law"]))
        scen = list(dict.fromkeys(table["scenario"]))
        fig = new_figure(7.0, 1.0 + 0.35 * len(table))
        ax = fig.add_subplot(1, 1, 1)
        good = table["margin"][np.isfinite(table["margin"]) & (table["margin"] > 0)]
        floor = float(good.min()) * 1e3 / 3 if len(good) else 0.1
        labels = []
        y = 0
        for s in scen:
            for k, law in enumerate(laws):
                rows = table[(table["scenario"] == s) & (table["law"] == law)]
                if rows.empty:
                    continue
                row = rows.iloc[0]
                color = _COLORS[k % len(_COLORS)]
                m = float(row["margin"])
                if not math.isfinite(m):
                    ax.text(floor, y, " not acceptable undelayed", va="center", gid="no-margin")
                else:
                    ms = max(m * 1e3, floor)
                    ax.barh(y, ms - floor, left=floor, color=color, height=0.7)
                    hi = float(row["upper"]) * 1e3
                    if math.isfinite(hi):
                        ax.errorbar(
                            [ms],
                            [y],
                            xerr=[[0.0], [hi - ms]],
                            fmt="none",
                            ecolor="k",
                            capsize=3,
                        )
                    ax.text(
                        (hi if math.isfinite(hi) else ms) * 1.1,
                        y,
                        f"{m * 1e3:.3g} ms" + (f" ({row['how']})" if row["how"] else ""),
                        va="center",
                        fontsize="small",
                    )
                labels.append(f"{s}\n{law}" if k == 0 else law)
                y += 1
        ax.set_yticks(range(len(labels)), labels, fontsize="small")
        ax.invert_yaxis()
        ax.set_xscale("log")
        ax.set_xlabel("time-delay margin (ms)")
        ax.grid(True, axis="x", which="both", alpha=0.3)
        if title:
            fig.suptitle(wrap_title(title, 7.0))
        return fig


def save_delay_margin_figure(
    table: pd.DataFrame, path: str | Path, *, formats: Sequence[str] = ("png", "pdf")
) -> list[Path]:
    """Draw :func:`plot_delay_margins` and write it as ``path`` with each suffix of
    ``formats``; returns the written files."""
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise ConfigurationError(
            f"Figure formats must be among {', '.join(FORMATS)}; got {', '.join(bad) or 'none'}."
        )
    fig = plot_delay_margins(table)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = []
    for fmt in formats:
        p = path.with_suffix(f".{fmt}")
        with figure_style():
            fig.savefig(p, dpi=DPI)
        out.append(p)
    return out
