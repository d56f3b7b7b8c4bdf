"""Campaign summary: success rates per design, per failure model and per severity bin, figures
(success vs severity, error histograms, worst runs) and a self-contained HTML page."""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path
from typing import Any

import numpy as np

from adaptive_ftc.campaigns.spec import CampaignSpec
from adaptive_ftc.campaigns.store import read_results

__all__ = ["SEVERITY_BINS", "success_tables", "write_summary"]

#: Edges of the severity bins (severity in [0, 1]; unrated failures are left out of the bins).
SEVERITY_BINS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)


def success_tables(df) -> dict[str, Any]:
    """Success rates from a results table (pandas): overall, per model, per severity bin.

    A member counts under every failure model it contains.
    """
    import pandas as pd

    out: dict[str, Any] = {}
    out["success_rate"] = df.groupby("design", sort=False)["success"].mean().to_dict()
    out["runs"] = df.groupby("design", sort=False).size().to_dict()
    out["diverged"] = (
        df.assign(d=df["status"] == "diverged").groupby("design", sort=False)["d"].sum().to_dict()
    )
    out["compensable_fraction"] = float(df.drop_duplicates("index")["compensable"].mean())
    exploded = df.assign(model=df["models"].str.split("+")).explode("model")
    exploded["model"] = exploded["model"].replace("", "none")
    by_model = exploded.groupby(["model", "design"], sort=True)["success"].agg(["mean", "size"])
    out["by_model"] = by_model.reset_index().to_dict("records")
    bins = pd.cut(df["severity"], SEVERITY_BINS, include_lowest=True)
    by_sev = (
        df.assign(bin=bins.astype(str))
        .loc[bins.notna()]
        .groupby(["bin", "design"], sort=True)["success"]
        .agg(["mean", "size"])
    )
    out["by_severity"] = by_sev.reset_index().to_dict("records")
    by_comp = df.groupby(["compensable", "design"])["success"].agg(["mean", "size"])
    out["by_compensable"] = by_comp.reset_index().to_dict("records")
    return out


def _figures(df, folder: Path) -> dict[str, Path]:
    from adaptive_ftc.plots import figure_style

    with figure_style():  # the project's one figure style (constrained layout)
        return _draw_figures(df, folder)


def _draw_figures(df, folder: Path) -> dict[str, Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    folder.mkdir(parents=True, exist_ok=True)
    paths = {}
    designs = list(dict.fromkeys(df["design"]))
    centers = 0.5 * (np.array(SEVERITY_BINS[:-1]) + np.array(SEVERITY_BINS[1:]))
    bins = pd.cut(df["severity"], SEVERITY_BINS, include_lowest=True, labels=False)
    fig, ax = plt.subplots(figsize=(6, 3.6), layout="constrained")
    for d in designs:
        sel = df["design"] == d
        rates = [
            df.loc[sel & (bins == b), "success"].mean() if (sel & (bins == b)).any() else np.nan
            for b in range(len(centers))
        ]
        ax.plot(centers, rates, "o-", label=d)
    ax.set_xlabel("severity of the worst failure (0 to 1)")
    ax.set_ylabel("success rate (fraction of runs)")
    ax.set_ylim(-0.05, 1.05)
    ax.grid(alpha=0.3)
    ax.legend()
    paths["success_vs_severity"] = folder / "success_vs_severity.png"
    fig.savefig(paths["success_vs_severity"], dpi=110)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(6, 3.6), layout="constrained")
    finite = df["rms_error_final"].replace([np.inf, -np.inf], np.nan)
    logs = np.log10(finite.clip(lower=1e-12))
    edges = np.linspace(
        np.nanmin(logs) if logs.notna().any() else -12,
        np.nanmax(logs) if logs.notna().any() else 0,
        40,
    )
    for d in designs:
        vals = logs[(df["design"] == d) & logs.notna()]
        if len(vals):
            ax.hist(vals, bins=edges, alpha=0.55, label=d)
    ax.set_xlabel("log10 of the final-window RMS error (output units)")
    ax.set_ylabel("runs (count)")
    ax.legend()
    paths["error_histogram"] = folder / "error_histogram.png"
    fig.savefig(paths["error_histogram"], dpi=110)
    plt.close(fig)
    worst = _worst(df, designs[0], 10)
    fig, ax = plt.subplots(figsize=(6, 3.6), layout="constrained")
    labels = [str(i) for i in worst["index"]]
    vals = worst["rms_error_final"].fillna(np.inf).clip(upper=1e6)
    ax.barh(labels[::-1], np.asarray(vals)[::-1], color="tab:red")
    ax.set_xscale("log")
    ax.set_xlabel(f"final-window RMS error, {designs[0]} (output units; diverged at 1e6)")
    ax.set_ylabel("campaign member (index)")
    paths["worst_runs"] = folder / "worst_runs.png"
    fig.savefig(paths["worst_runs"], dpi=110)
    plt.close(fig)
    return paths


def _worst(df, design: str, n: int):
    sel = df[df["design"] == design].copy()
    sel["_key"] = sel["rms_error_final"].where(sel["status"] == "completed", np.inf)
    sel["_key"] = sel["_key"].fillna(np.inf)
    return sel.sort_values(["_key", "index"], ascending=[False, True]).head(n)


def _img(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode()
    return f'<img alt="{html.escape(path.stem)}" src="data:image/png;base64,{data}">'


def _table(records: list[dict[str, Any]], cols: list[str]) -> str:
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    body = []
    for r in records:
        cells = []
        for c in cols:
            v = r.get(c, "")
            txt = f"{v:.3g}" if isinstance(v, float) else str(v)
            cells.append(f"<td>{html.escape(txt)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def write_summary(spec: CampaignSpec, out: str | Path) -> dict[str, Any]:
    """Write ``summary.json``, ``figures/*.png`` and ``summary.html`` for a finished campaign.

    Returns
    -------
    dict
        The success tables (as in ``summary.json``).
    """
    out = Path(out)
    df = read_results(out)
    info = success_tables(df)
    info["name"] = spec.name
    info["runs_per_design"] = spec.runs
    info["success_criterion"] = spec.success_text()
    paths = _figures(df, out / "figures")
    worst = _worst(df, spec.designs[0], 10)
    info["worst"] = [
        {
            "index": int(r["index"]),
            "models": r["models"],
            "severity": float(r["severity"]),
            "status": r["status"],
            "rms_error_final": float(r["rms_error_final"]),
            "divergence_time": float(r["divergence_time"]),
            "divergence_signal": r["divergence_signal"],
            "replay": f"aftc campaign replay {out} {int(r['index'])}",
        }
        for _, r in worst.iterrows()
    ]
    (out / "summary.json").write_text(json.dumps(info, indent=2, default=str))
    overall = [
        {
            "design": d,
            "runs": info["runs"][d],
            "success rate": info["success_rate"][d],
            "diverged": info["diverged"][d],
        }
        for d in info["success_rate"]
    ]
    page = f"""<!doctype html><html><head><meta charset="utf-8">
<title>{html.escape(spec.title)}</title>
<style>body{{font-family:sans-serif;max-width:60em;margin:auto}}
table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #ccc;padding:2px 8px}}
img{{max-width:100%}}</style></head><body>
<h1>{html.escape(spec.title)}</h1>
<p>Base scenario <b>{html.escape(spec.base.name)}</b>, {spec.runs} members x
{len(spec.designs)} designs, seed {spec.seed}. Success: {html.escape(info["success_criterion"])}.
Compensable failure timelines (rank condition (3.6)): {info["compensable_fraction"]:.1%}.</p>
<h2>Success per design</h2>{_table(overall, ["design", "runs", "success rate", "diverged"])}
<h2>Success vs severity</h2>{_img(paths["success_vs_severity"])}
{_table(info["by_severity"], ["bin", "design", "mean", "size"])}
<h2>Success per failure model</h2>{_table(info["by_model"], ["model", "design", "mean", "size"])}
<h2>Success by compensability verdict</h2>
{_table(info["by_compensable"], ["compensable", "design", "mean", "size"])}
<h2>Final-window error</h2>{_img(paths["error_histogram"])}
<h2>Worst runs ({html.escape(spec.designs[0])})</h2>{_img(paths["worst_runs"])}
{
        _table(
            info["worst"],
            [
                "index",
                "models",
                "severity",
                "status",
                "rms_error_final",
                "divergence_time",
                "divergence_signal",
                "replay",
            ],
        )
    }
</body></html>"""
    (out / "summary.html").write_text(page, encoding="utf-8")
    return info
