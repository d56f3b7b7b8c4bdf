"""HTML report of a reproduction (inline CSS, no script; figures linked or embedded).

The page loads nothing from the network (no script, font or stylesheet). By default it links the
figure files in ``figures/`` beside it (each image opens at full size, with links to its PDF/SVG
versions), which keeps the page small (well under 3 MB); ``embed=True`` embeds the PNG files as
base64 instead, for a single file that can be mailed. It is readable from phone to desktop
(viewport tag; cards stack and the summary table scrolls on narrow screens).

It opens with the verdict totals and a summary table (scenario, thesis section, figures, claims
passed, frozen/adaptive and best-fair-baseline/adaptive error ratios), then one section per
scenario: its description, failure list and run status, the error ratio of every baseline run
(fixed-gain, nominal inverse, oracle, frozen; :mod:`adaptive_ftc.baselines`), and its figures
beside the thesis's claims with the verdict (PASS, FAIL, NOT EVALUATED, NOT REPRODUCED, FINDING:
an expected, named finding of the project that the data show, never a PASS) and the
measured number with its unit against the threshold; a ``baseline_ratio`` claim lists every
baseline's ratio, the oracle's included (shown, never compared with). A FAIL is shown as such,
with its number. A scenario whose design is constraint-aware also shows the same claims judged
on the thesis law's companion run (what it fails is a named FINDING; counted apart in the
totals as "thesis-law findings").
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
from adaptive_ftc.claims import FAIL, FINDING, NOT_EVALUATED, NOT_REPRODUCED, PASS

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ftc.claims import ClaimResult

__all__ = ["FigureEntry", "ScenarioEntry", "render_report", "write_report"]


@dataclass
class FigureEntry:
    """One rendered figure: thesis number, caption, kind, PNG path, the same figure in other
    formats (``extra``, e.g. its PDF), and an error if it failed."""

    number: str
    caption: str
    kind: str
    path: Path
    error: str = ""
    extra: tuple[Path, ...] = ()


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
    #: baseline name -> its RMS error over the adaptive run's (last 10 % of the run)
    baseline_ratios: dict[str, float] = field(default_factory=dict)
    #: the scenario's claims judged on the thesis law's companion run (constraint-aware
    #: scenarios only; see :func:`adaptive_ftc.claims.evaluate_thesis_law_claims`)
    thesis_law_claims: list[ClaimResult] = field(default_factory=list)

    @property
    def best_fair_ratio(self) -> tuple[str, float]:
        """The non-oracle baseline closest to the adaptive run and its error ratio
        (``("", nan)`` when none was run)."""
        fair = {
            k: v for k, v in self.baseline_ratios.items() if k != "oracle" and not math.isnan(v)
        }
        if not fair:
            return "", math.nan
        best = min(fair, key=fair.__getitem__)
        return best, fair[best]

    @property
    def n_pass(self) -> int:
        """Number of claims that passed."""
        return sum(c.status == PASS for c in self.claims)

    def count(self, verdict: str) -> int:
        """Number of claims with this verdict."""
        return sum(c.status == verdict for c in self.claims)


_CSS = """
*{box-sizing:border-box}
body{font-family:-apple-system,"Segoe UI",Helvetica,Arial,sans-serif;margin:0;color:#1d2329;
background:#f4f6f8;line-height:1.45;overflow-wrap:anywhere}
header{background:#1f3a5f;color:#fff;padding:18px 32px}
header h1{margin:0 0 4px 0;font-size:24px}
header p{margin:2px 0;opacity:.9;font-size:14px}
main{padding:16px 32px 48px 32px;max-width:1500px}
.banner{background:#fff3cd;border:1px solid #e0c36a;padding:8px 12px;border-radius:6px;
margin:12px 0}
.totals{display:flex;gap:14px;margin:14px 0;flex-wrap:wrap}
.tot{background:#fff;border-radius:8px;padding:10px 18px;box-shadow:0 1px 2px rgba(0,0,0,.12)}
.tot b{font-size:22px;display:block}
.scroll{overflow-x:auto;max-width:100%}
.scroll table{min-width:680px}.scroll td,.scroll th{overflow-wrap:normal}
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
.figs{flex:3 1 560px;min-width:0}
.claims{flex:2 1 320px;min-width:0}
figure{margin:0 0 14px 0}
figure img{width:100%;height:auto;border:1px solid #d5dbe1;border-radius:4px}
figcaption{font-size:13px;color:#33404d;margin-top:3px}
figcaption a{margin-left:4px}
.claim{border:1px solid #d5dbe1;border-left:6px solid #999;border-radius:6px;padding:8px 10px;
margin:0 0 10px 0;font-size:14px}
.claim.pass{border-left-color:#2e7d32}
.claim.fail{border-left-color:#c62828;background:#fff5f5}
.claim.noteval{border-left-color:#78909c;background:#f7f9fa}
.claim.notrepro{border-left-color:#b26a00;background:#fffaf0}
.claim.finding{border-left-color:#6a1b9a;background:#faf5fc}
.badge{display:inline-block;font-weight:700;font-size:12px;padding:1px 8px;border-radius:10px;
color:#fff;margin-right:6px}
.badge.pass{background:#2e7d32}.badge.fail{background:#c62828}
.badge.warn,.badge.notrepro{background:#b26a00}
.badge.noteval{background:#78909c}
.badge.finding{background:#6a1b9a}
.kind{font-family:monospace;color:#52606d}
.quote{font-style:italic;margin:4px 0}
.measure{font-variant-numeric:tabular-nums}
.detail{color:#52606d;font-size:12.5px}
.error{color:#c62828;font-family:monospace;font-size:12.5px;white-space:pre-wrap}
a{color:#1f5fa8}
@media (max-width:700px){header{padding:14px 16px}header h1{font-size:20px}
main{padding:10px 12px 32px 12px}section.sc{padding:10px 12px}.figs,.claims{flex-basis:100%}
table{font-size:13px}th,td{padding:4px 6px}}
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


_CLASS = {
    PASS: "pass",
    FAIL: "fail",
    NOT_EVALUATED: "noteval",
    NOT_REPRODUCED: "notrepro",
    FINDING: "finding",
}


def _img(path: Path, embed: bool, alt: str) -> str:
    if embed:
        data = base64.b64encode(path.read_bytes()).decode("ascii")
        return f'<img alt="{_e(alt)}" src="data:image/png;base64,{data}">'
    href = f"figures/{_e(path.name)}"
    return (
        f'<a href="{href}" title="open at full size"><img alt="{_e(alt)}" src="{href}" '
        'loading="lazy"></a>'
    )


def _claims_cell(entry: ScenarioEntry) -> str:
    if entry.claim_error and not entry.claims:
        return '<span class="badge warn">ERROR</span>'
    if not entry.claims:
        return "—"
    k = entry.n_pass
    # judged: every claim with a verdict on the data (NOT REPRODUCED and FINDING included, so
    # "8/8" never hides a claim the data contradict); NOT EVALUATED is left out
    judged = k + sum(entry.count(v) for v in (FAIL, NOT_REPRODUCED, FINDING))
    cls = "fail" if entry.count(FAIL) else ("pass" if judged == k else "warn")
    out = f'<span class="badge {cls}">{k}/{judged}</span>'
    for verdict in (FINDING, NOT_REPRODUCED, NOT_EVALUATED):
        if n := entry.count(verdict):
            out += f' <span class="badge {_CLASS[verdict]}">{n} {verdict.lower()}</span>'
    if n := sum(c.status == FINDING for c in entry.thesis_law_claims):
        out += f' <span class="badge {_CLASS[FINDING]}">thesis law: {n} finding(s)</span>'
    return out


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
            f"<td>{_best_cell(s)}</td>"
            f"<td>{_e(_status_text(s.statuses))}</td>"
            "</tr>"
        )
    return (
        '<div class="scroll"><table><thead><tr><th>scenario</th><th>thesis section</th>'
        "<th>figures</th><th>claims passed / judged</th><th>frozen / adaptive error</th>"
        "<th>best fair baseline / adaptive error</th>"
        f"<th>runs</th></tr></thead><tbody>{''.join(rows)}</tbody></table></div>"
        '<p class="meta">frozen / adaptive error: RMS tracking error of the run with adaptation '
        "frozen divided by that of the adaptive run, over the last 10 % of the run (what "
        "adaptation buys; ∞ = the frozen run diverged). Best fair baseline: the smallest such "
        "ratio over the fixed-gain, nominal-inverse and frozen runs (the oracle, which knows the "
        "true failure, is not a fair competitor and is shown per scenario only); below 1 the "
        "baseline tracks better than the adaptive design.</p>"
    )


def _best_cell(s: ScenarioEntry) -> str:
    name, ratio = s.best_fair_ratio
    return f"{_num(ratio)} ({_e(name)})" if name else "—"


def _baseline_table(s: ScenarioEntry) -> str:
    if not s.baseline_ratios:
        return ""
    cells = "".join(
        f"<tr><td>{_e(k)}{' (knows the failure; not compared with)' if k == 'oracle' else ''}"
        f'</td><td class="num">{_num(v)}</td></tr>'
        for k, v in s.baseline_ratios.items()
    )
    return (
        "<h3>Baselines</h3><table><thead><tr><th>baseline</th><th>baseline / adaptive RMS "
        f"error (last 10 % of the run)</th></tr></thead><tbody>{cells}</tbody></table>"
    )


def _with_unit(x: float, unit: str) -> str:
    text = _num(x)
    return f"{text} {_e(unit)}" if unit and text != "not measured" else text


def _claim_html(c: ClaimResult) -> str:
    cls = _CLASS.get(c.status, "fail")
    unit = getattr(c, "unit", "")
    return (
        f'<div class="claim {cls}"><span class="badge {cls}">{c.verdict}</span>'
        f'<span class="kind">{_e(c.kind)}</span>'
        f'<div class="quote">“{_e(" ".join(c.text.split()))}”</div>{_finding(c)}'
        f'<div class="measure">measured <b>{_with_unit(c.measured, unit)}</b> vs threshold '
        f"<b>{_with_unit(c.threshold, unit)}</b></div>"
        f'<div class="detail">{_e(c.detail)}</div>{_claim_baselines(c)}</div>'
    )


def _finding(c: ClaimResult) -> str:
    name = getattr(c, "finding", "")
    if not name:
        return ""
    shown = "the data show it" if c.status == FINDING else "no longer shown by the data"
    return f'<div class="detail"><b>Expected finding</b> ({shown}): {_e(name)}</div>'


def _claim_baselines(c: ClaimResult) -> str:
    rows = getattr(c, "baselines", ())
    if not rows:
        return ""
    note = " (knows the failure: shown, not compared with)"
    items = "".join(
        f"<li>{_e(name)}{note if name == 'oracle' else ''}: "
        f"RMS {_with_unit(rms, getattr(c, 'unit', ''))} = <b>{_num(ratio)}</b> × adaptive</li>"
        for name, rms, ratio in rows
    )
    return f'<ul class="baselines">{items}</ul>'


def _figure_html(f: FigureEntry, embed: bool = False) -> str:
    cap = f"Fig. {_e(f.number)}: {_e(f.caption)}" if f.number else _e(f.caption)
    if f.error or not f.path.is_file():
        why = f.error or "file not written"
        return (
            f'<figure><div class="error">figure failed: {_e(why)}</div>'
            f"<figcaption>{cap}</figcaption></figure>"
        )
    links = " ".join(
        f'<a href="figures/{_e(p.name)}">{_e(p.suffix.lstrip(".").upper())}</a>'
        for p in (f.path, *f.extra)
        if p.is_file()
    )
    return (
        f"<figure>{_img(f.path, embed, cap)}<figcaption>{cap} · files: {links}"
        "</figcaption></figure>"
    )


def _scenario(s: ScenarioEntry, embed: bool = False) -> str:
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
    figs = "".join(_figure_html(f, embed) for f in s.figures) or '<p class="meta">No figures.</p>'
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
        f"<h3>Failures</h3>{failures}{_baseline_table(s)}"
        f'<div class="cols"><div class="figs">{figs}</div>'
        f'<div class="claims"><h3>Thesis claims ({_claim_counts(s)})</h3>'
        f"{claims}{_thesis_law_claims(s)}</div></div></section>"
    )


def _thesis_law_claims(s: ScenarioEntry) -> str:
    if not s.thesis_law_claims:
        return ""
    n = sum(c.status == FINDING for c in s.thesis_law_claims)
    return (
        f"<h3>The thesis law beside it (constraint-aware option off; {n} finding"
        f"{'s' if n != 1 else ''})</h3>"
        '<p class="meta">The same claims judged on the thesis law\'s run under the same '
        "hardware (variant <code>thesis_law</code>): what it does not meet is a named finding, "
        "not a failure of the scenario.</p>" + "".join(_claim_html(c) for c in s.thesis_law_claims)
    )


def _claim_counts(s: ScenarioEntry) -> str:
    parts = [f"{s.n_pass}/{s.n_pass + s.count(FAIL)} passed"]
    parts += [
        f"{s.count(v)} {v.lower()}" for v in (FINDING, NOT_REPRODUCED, NOT_EVALUATED) if s.count(v)
    ]
    return ", ".join(parts)


_VERDICT_COLOURS = {
    PASS: "#2e7d32",
    FAIL: "#c62828",
    NOT_REPRODUCED: "#b26a00",
    FINDING: "#6a1b9a",
}


def render_report(
    entries: Sequence[ScenarioEntry],
    *,
    quick: bool = False,
    wall_time_s: float = math.nan,
    jobs: int = 1,
    embed: bool = False,
    data_note: str = "",
    left_out: Sequence[str] = (),
) -> str:
    """The report as one HTML string (see the module docstring).

    Parameters
    ----------
    entries
        One entry per scenario, in report order.
    quick
        The runs were shortened: say so in a banner.
    wall_time_s, jobs
        Shown in the totals.
    embed
        Embed the PNG figures as base64 (a single self-contained file) instead of linking the
        files in ``figures/`` beside the report.
    data_note
        What the data files hold (precision, decimation), shown under the totals.
    left_out
        What the reproduction did not do, one sentence each (``aftc reproduce --quick``:
        the runs no claim needs, the data files, the figures): listed in a banner with the
        claims it judged and those it did not.
    """
    n = sum(len(s.claims) for s in entries)
    counts = {v: sum(s.count(v) for s in entries) for v in (PASS, FAIL, NOT_REPRODUCED, FINDING)}
    n_noteval = sum(s.count(NOT_EVALUATED) for s in entries)
    n_thesis = sum(c.status == FINDING for s in entries for c in s.thesis_law_claims)
    stamp = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    banner = (
        '<div class="banner"><b>Quick mode.</b> Every run was shortened (see '
        "<code>adaptive_ftc.reproduce</code>): claims whose window the shortened run does not "
        "reach are <b>not evaluated</b> (grey), which is not a failure; the others are a smoke "
        f"test, not the thesis check: it judged {n - n_noteval} of {n} claims"
        + (
            " ("
            + ", ".join(
                f"{s.name}: {len(s.claims) - s.count(NOT_EVALUATED)}"
                for s in entries
                if len(s.claims) > s.count(NOT_EVALUATED)
            )
            + ")"
            if n > n_noteval
            else ""
        )
        + ". Run <code>aftc reproduce</code> for that (its runs are full length, with or "
        "without <code>--quick</code>).</div>"
        if quick
        else ""
    )
    if left_out:
        banner = _left_out_banner(entries, left_out, shortened=quick)
    tots = "".join(
        f'<div class="tot"><b style="color:{_VERDICT_COLOURS[v]}">{counts[v]}</b>{v}</div>'
        for v in (PASS, FAIL, NOT_REPRODUCED, FINDING)
    )
    totals = (
        '<div class="totals">'
        f'<div class="tot"><b>{len(entries)}</b>scenarios</div>'
        f'<div class="tot"><b>{n}</b>claims</div>{tots}'
        f'<div class="tot"><b style="color:#78909c">{n_noteval}</b>NOT EVALUATED</div>'
        + (
            f'<div class="tot"><b style="color:{_VERDICT_COLOURS[FINDING]}">{n_thesis}</b>'
            "thesis-law findings</div>"
            if n_thesis
            else ""
        )
        + f'<div class="tot"><b>{_num(wall_time_s)} s</b>wall time ({jobs} process'
        f"{'es' if jobs != 1 else ''})</div></div>"
    )
    if data_note:
        totals += f'<p class="data-note">{_e(data_note)}</p>'
    body = "".join(_scenario(s, embed) for s in entries)
    return (
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        "<title>adaptive-ftc: reproduction of the thesis simulations</title>"
        f"<style>{_CSS}</style></head><body>"
        "<header><h1>adaptive-ftc: reproduction of the thesis simulations</h1>"
        f"<p>Adaptive actuator-failure compensation · adaptive-ftc {_e(__version__)} · "
        f"generated {stamp}</p></header><main>{banner}{totals}"
        f"<h2>Summary</h2>{_summary(entries)}{body}</main></body></html>"
    )


def _left_out_banner(
    entries: Sequence[ScenarioEntry], left_out: Sequence[str], shortened: bool = False
) -> str:
    """The banner of a reproduction that left things out (``aftc reproduce --quick``): which
    claims it judged, which it did not, and what else it skipped (``shortened``: the runs
    were also shortened, the library's ``quick=True``)."""
    n = sum(len(s.claims) for s in entries)
    n_noteval = sum(s.count(NOT_EVALUATED) for s in entries)
    unjudged = [
        f"{_e(s.name)}: " + ", ".join(_e(c.kind) for c in s.claims if c.status == NOT_EVALUATED)
        for s in entries
        if s.count(NOT_EVALUATED)
    ]
    judged = (
        f"It judged <b>{n - n_noteval} of {n} claims</b> on shortened runs (a smoke test: "
        "claims whose window a shortened run does not reach are not evaluated)."
        if shortened
        else f"It judged <b>{n - n_noteval} of {n} claims</b> on full-length runs: those "
        "verdicts are the ones a full reproduction gives."
    )
    if unjudged:
        judged += " Not judged (NOT EVALUATED): " + "; ".join(unjudged) + "."
    items = "".join(f"<li>{_e(t)}</li>" for t in left_out)
    return (
        '<div class="banner"><b>Quick mode.</b> Only the runs the claims are judged on were '
        f"made. {judged} Left out:<ul>{items}</ul>Run <code>aftc reproduce</code> without "
        "<code>--quick</code> for everything.</div>"
    )


def write_report(
    path: str | Path,
    entries: Sequence[ScenarioEntry],
    *,
    quick: bool = False,
    wall_time_s: float = math.nan,
    jobs: int = 1,
    embed: bool = False,
    data_note: str = "",
    left_out: Sequence[str] = (),
) -> Path:
    """Write :func:`render_report` to ``path`` (UTF-8) and return the path.

    Without ``embed`` the page links ``figures/<file>`` relative to itself: keep it in the
    folder that holds ``figures/``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    page = render_report(
        entries,
        quick=quick,
        wall_time_s=wall_time_s,
        jobs=jobs,
        embed=embed,
        data_note=data_note,
        left_out=left_out,
    )
    path.write_text(page, encoding="utf-8")
    return path
