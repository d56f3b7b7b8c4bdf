"""Self-contained HTML report of a reproduction (figures embedded as base64 PNG, inline CSS).

The page has no external resource (no script, font, stylesheet or image link), so it can be
mailed or archived and viewed offline. It opens with a summary table (scenario, thesis section,
figures, claims passed, frozen/adaptive error ratio), then one section per scenario: its
description, failure list and run status, and its figures beside the thesis's claims with the
PASS/FAIL verdict and the measured number against the threshold. A FAIL is shown as such, with
its number.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from adaptive_ftc._version import __version__

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ftc.claims import ClaimResult

__all__ = ["FigureEntry", "ScenarioEntry", "render_report", "write_report"]


@dataclass
class FigureEntry:
    """One rendered figure: thesis number, caption, kind, PNG path, and an error if it failed."""

    number: str
    caption: str
    kind: str
    path: Path
    error: str = ""


@dataclass
class ScenarioEntry:
    """What the report shows about one scenario."""

    name: str
    title: str
    section: str = ""
    thesis_figures: tuple[str, ...] = ()
    description: str = ""
    notes: str = ""
    failures: tuple[str, ...] = ()
    duration: float = math.nan
    figures: list[FigureEntry] = field(default_factory=list)
    claims: list[ClaimResult] = field(default_factory=list)
    claim_error: str = ""
    error_ratio: float = math.nan
    statuses: dict[str, str] = field(default_factory=dict)

    @property
    def n_pass(self) -> int:
        """Number of claims that passed."""
        return sum(c.passed for c in self.claims)


_CSS = """
body{font-family:-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;margin:0;color:#1d2329;
background:#f4f6f8;line-height:1.45}
header{background:#1f3a5f;color:#fff;padding:18px 32px}
header h1{margin:0 0 4px 0;font-size:24px}
header p{margin:2px 0;opacity:.9;font-size:14px}
main{padding:16px 32px 48px 32px;max-width:1500px}
.banner{background:#fff3cd;border:1px solid #e0c36a;padding:8px 12px;border-radius:6px;
margin:12px 0}
.totals{display:flex;gap:14px;margin:14px 0}
.tot{background:#fff;border-radius:8px;padding:10px 18px;box-shadow:0 1px 2px rgba(0,0,0,.12)}
.tot b{font-size:22px;display:block}
table{border-collapse:collapse;background:#fff;font-size:14px}
th,td{border:1px solid #d5dbe1;padding:5px 9px;text-align:left;vertical-align:top}
th{background:#e8edf2}
td.num{text-align:right;font-variant-numeric:tabular-nums}
section.sc{background:#fff;border-radius:10px;padding:14px 20px;margin:22px 0;
box-shadow:0 1px 3px rgba(0,0,0,.12)}
section.sc h2{margin:4px 0 6px 0;font-size:20px}
.meta{color:#52606d;font-size:13px;margin-bottom:8px}
.desc{margin:6px 0;max-width:1100px}
.notes{color:#52606d;font-size:13px;max-width:1100px}
.cols{display:flex;gap:20px;align-items:flex-start;flex-wrap:wrap}
.figs{flex:3 1 640px;min-width:0}
.claims{flex:2 1 380px;min-width:0}
figure{margin:0 0 14px 0}
figure img{width:100%;height:auto;border:1px solid #d5dbe1;border-radius:4px}
figcaption{font-size:13px;color:#33404d;margin-top:3px}
.claim{border:1px solid #d5dbe1;border-left:6px solid #999;border-radius:6px;padding:8px 10px;
margin:0 0 10px 0;font-size:14px}
.claim.pass{border-left-color:#2e7d32}
.claim.fail{border-left-color:#c62828;background:#fff5f5}
.badge{display:inline-block;font-weight:700;font-size:12px;padding:1px 8px;border-radius:10px;
color:#fff;margin-right:6px}
.badge.pass{background:#2e7d32}.badge.fail{background:#c62828}
.badge.warn{background:#b26a00}
.kind{font-family:monospace;color:#52606d}
.quote{font-style:italic;margin:4px 0}
.measure{font-variant-numeric:tabular-nums}
.detail{color:#52606d;font-size:12.5px}
.error{color:#c62828;font-family:monospace;font-size:12.5px;white-space:pre-wrap}
a{color:#1f5fa8}
"""


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)


def _num(x: float) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "not measured"
    if math.isinf(x):
        return "∞" if x > 0 else "-∞"
    return f"{x:.4g}"


def _paragraphs(text: str, cls: str, lead: str = "") -> str:
    """Text with TOML line wraps joined; blank lines separate paragraphs."""
    paras = [" ".join(p.split()) for p in re.split(r"\n\s*\n", text.strip()) if p.strip()]
    out = []
    for i, p in enumerate(paras):
        head = lead if i == 0 else ""
        out.append(f'<p class="{cls}">{head}{_e(p)}</p>')
    return "".join(out)


def _anchor(name: str) -> str:
    return "sc-" + re.sub(r"[^A-Za-z0-9_-]", "-", name)


def _img(path: Path) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<img alt="{_e(path.name)}" src="data:image/png;base64,{data}">'


def _claims_cell(entry: ScenarioEntry) -> str:
    if entry.claim_error and not entry.claims:
        return '<span class="badge warn">ERROR</span>'
    if not entry.claims:
        return "—"
    n, k = len(entry.claims), entry.n_pass
    cls = "pass" if k == n else "fail"
    return f'<span class="badge {cls}">{k}/{n}</span>'


def _status_text(statuses: dict[str, str]) -> str:
    return ", ".join(f"{v}: {s}" for v, s in statuses.items())


def _summary(entries: Sequence[ScenarioEntry]) -> str:
    rows = []
    for s in entries:
        rows.append(
            "<tr>"
            f'<td><a href="#{_anchor(s.name)}">{_e(s.name)}</a></td>'
            f"<td>§{_e(s.section)}</td>"
            f"<td>{_e(', '.join(s.thesis_figures)) or '—'}</td>"
            f"<td>{_claims_cell(s)}</td>"
            f'<td class="num">{_num(s.error_ratio)}</td>'
            f"<td>{_e(_status_text(s.statuses))}</td>"
            "</tr>"
        )
    return (
        "<table><thead><tr><th>scenario</th><th>thesis section</th><th>figures</th>"
        "<th>claims passed</th><th>frozen / adaptive error</th><th>runs</th></tr></thead>"
        f"<tbody>{''.join(rows)}</tbody></table>"
        '<p class="meta">frozen / adaptive error: RMS tracking error of the run with adaptation '
        "frozen divided by that of the adaptive run, over the last 10 % of the run (what "
        "adaptation buys; ∞ = the frozen run diverged).</p>"
    )


def _claim_html(c: ClaimResult) -> str:
    cls = "pass" if c.passed else "fail"
    return (
        f'<div class="claim {cls}"><span class="badge {cls}">{c.verdict}</span>'
        f'<span class="kind">{_e(c.kind)}</span>'
        f'<div class="quote">“{_e(" ".join(c.text.split()))}”</div>'
        f'<div class="measure">measured <b>{_num(c.measured)}</b> vs threshold '
        f"<b>{_num(c.threshold)}</b></div>"
        f'<div class="detail">{_e(c.detail)}</div></div>'
    )


def _figure_html(f: FigureEntry) -> str:
    cap = f"Fig. {_e(f.number)}: {_e(f.caption)}" if f.number else _e(f.caption)
    if f.error or not f.path.is_file():
        why = f.error or "file not written"
        return (
            f'<figure><div class="error">figure failed: {_e(why)}</div>'
            f"<figcaption>{cap}</figcaption></figure>"
        )
    where = f"figures/{_e(f.path.name)}"
    return f"<figure>{_img(f.path)}<figcaption>{cap} · <code>{where}</code></figcaption></figure>"


def _scenario(s: ScenarioEntry) -> str:
    failures = (
        "<ul>" + "".join(f"<li>{_e(x)}</li>" for x in s.failures) + "</ul>"
        if s.failures
        else "<p>No actuator failures.</p>"
    )
    claims = "".join(_claim_html(c) for c in s.claims)
    if s.claim_error:
        claims = (
            f'<div class="error">claims could not be evaluated: {_e(s.claim_error)}</div>' + claims
        )
    if not claims:
        claims = '<p class="meta">No claims are recorded for this scenario.</p>'
    figs = "".join(_figure_html(f) for f in s.figures) or '<p class="meta">No figures.</p>'
    notes = _paragraphs(s.notes, "notes", "<b>Notes.</b> ") if s.notes else ""
    meta = (
        f"<code>{_e(s.name)}</code> · thesis §{_e(s.section)} · figures "
        f"{_e(', '.join(s.thesis_figures)) or '—'} · duration {_num(s.duration)} s · runs: "
        f"{_e(_status_text(s.statuses))}"
    )
    return (
        f'<section class="sc" id="{_anchor(s.name)}"><h2>{_e(s.title)}</h2>'
        f'<div class="meta">{meta}</div>'
        f"{_paragraphs(s.description, 'desc')}{notes}"
        f"<h3>Failures</h3>{failures}"
        f'<div class="cols"><div class="figs">{figs}</div>'
        f'<div class="claims"><h3>Thesis claims ({s.n_pass}/{len(s.claims)} passed)</h3>'
        f"{claims}</div></div></section>"
    )


def render_report(
    entries: Sequence[ScenarioEntry],
    *,
    quick: bool = False,
    wall_time_s: float = math.nan,
    jobs: int = 1,
) -> str:
    """The report as one HTML string (see the module docstring)."""
    n = sum(len(s.claims) for s in entries)
    k = sum(s.n_pass for s in entries)
    stamp = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    banner = (
        '<div class="banner"><b>Quick mode.</b> Every run was shortened (see '
        "<code>adaptive_ftc.reproduce</code>); the verdicts below are a smoke test, not the "
        "thesis check. Run <code>aftc reproduce</code> without <code>--quick</code> for that."
        "</div>"
        if quick
        else ""
    )
    totals = (
        '<div class="totals">'
        f'<div class="tot"><b>{len(entries)}</b>scenarios</div>'
        f'<div class="tot"><b>{n}</b>claims</div>'
        f'<div class="tot"><b style="color:#2e7d32">{k}</b>PASS</div>'
        f'<div class="tot"><b style="color:#c62828">{n - k}</b>FAIL</div>'
        f'<div class="tot"><b>{_num(wall_time_s)} s</b>wall time ({jobs} process'
        f"{'es' if jobs != 1 else ''})</div></div>"
    )
    body = "".join(_scenario(s) for s in entries)
    return (
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        "<title>adaptive-ftc: reproduction of the thesis simulations</title>"
        f"<style>{_CSS}</style></head><body>"
        "<header><h1>adaptive-ftc: reproduction of the thesis simulations</h1>"
        f"<p>Adaptive actuator-failure compensation · adaptive-ftc {_e(__version__)} · "
        f"generated {stamp}</p></header><main>{banner}{totals}"
        f"<h2>Summary</h2>{_summary(entries)}{body}</main></body></html>"
    )


def write_report(
    path: str | Path,
    entries: Sequence[ScenarioEntry],
    *,
    quick: bool = False,
    wall_time_s: float = math.nan,
    jobs: int = 1,
) -> Path:
    """Write :func:`render_report` to ``path`` (UTF-8) and return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        render_report(entries, quick=quick, wall_time_s=wall_time_s, jobs=jobs), encoding="utf-8"
    )
    return path
