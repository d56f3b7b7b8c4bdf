"""Thesis-style figures of a :class:`~adaptive_ftc.sim.result.SimResult` (matplotlib, Agg).

Every figure is built on a bare :class:`matplotlib.figure.Figure` (no ``pyplot``, no GUI, no
global state), with axes labelled in SI units, a legend outside the data (right of each panel),
a grid and every failure onset/recovery time marked as a dashed vertical line
(``gid="failure-event"``). A diverged run is drawn up to where it stopped, with a red dotted line
(``gid="divergence"``) at the last sample. :func:`plot` returns a :class:`FigurePlot` holding the
figure, its axes and its lines (like python-control's ``ControlPlot``).

Every figure of the project (these, the robustness study's and the campaign's) is drawn and
saved in one style, :data:`STYLE` applied by :func:`figure_style`, with constrained layout
(:func:`new_figure`): legends, wrapped titles and tick labels fit the canvas without overlapping
(``tests/test_figure_layout.py`` checks every text box of every figure kind). An open-loop run
(``design = "none"``) is drawn without a reference.

Kinds
-----
``tracking``
    Per output: position ``y`` against the reference ``y_d`` and, below it, the velocity
    ``y' = y_d' - e'`` against ``y_d'`` (the thesis's angle of attack and pitch rate, Fig. 2.1).
``control``
    Per actuator: commanded ``u_j`` (dashed) and applied ``u_j^f`` (solid); then ``u0``.
``parameters``
    The regressor parameters ``theta`` (thin lines), and ``kappa`` / ``tau`` / ``rho`` if present.
``control_parameters``
    All actuator signals in one panel, then the parameters (the thesis's Fig. 2.2).
``modal``
    Modal displacements ``eta`` and their rates (flexible spacecraft, Figs 3.12-3.13).
``direction``
    Control signals; the sign of the direction estimate ``N(tau)`` or ``rho`` against the true
    control direction ``sign(control gain)``; the estimate itself (Figs 4.3-4.4, 4.11-4.12).
    When the estimate's sign settles within 1 % of the time axis (Fig. 4.12: 0.02 s of 120 s)
    or the figure table gives ``zoom = [start, end]``, a fourth panel zooms on it
    (``gid="zoom"``): on the run re-simulated over the window at the solver's resolution when
    one is given (``zoom_result``, from :func:`dense_zoom`; ``aftc run`` and ``aftc
    reproduce`` do), else on the recorded samples, and its legend says which.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import math
import re
import textwrap
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptive_ftc._units import actuator_unit, output_unit, rate_unit, state_unit

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.typing import RcKeyType

    from adaptive_ftc.sim.result import SimResult

__all__ = [
    "DPI",
    "FORMATS",
    "KINDS",
    "FigurePlot",
    "STYLE",
    "check_formats",
    "default_figure_specs",
    "dense_zoom",
    "figure_input",
    "figure_style",
    "new_figure",
    "plot",
    "save_figure",
    "wrap_title",
    "zoom_window",
]

#: Figure kinds understood by :func:`plot`.
KINDS: tuple[str, ...] = (
    "tracking",
    "control",
    "parameters",
    "control_parameters",
    "modal",
    "direction",
)

#: File formats :func:`save_figure` writes.
FORMATS: tuple[str, ...] = ("png", "pdf", "svg")

_GREEK = {
    "alpha",
    "beta",
    "gamma",
    "delta",
    "eta",
    "theta",
    "kappa",
    "lambda",
    "rho",
    "sigma",
    "tau",
    "phi",
    "psi",
    "omega",
}

_WIDTH = 10.0
_LEGEND_W = 2.4  # inches right of the panels for the legends
_MAX_POINTS = 4000  # samples per line after thinning (rendering cost grows with points)
_ROW_HEIGHT = 2.3
#: Default resolution of PNG files (dots per inch).
DPI = 150
#: zlib level of PNG files (PIL's default is 6): 13 % less time per figure for 7-20 % larger
#: files, measured on the hypersonic figures (``aftc reproduce`` writes 80 of them)
PNG_COMPRESS = 3
_ZOOM_FRACTION = 0.01  # events shorter than this fraction of the time axis get a zoom panel

#: The one figure style of the project (matplotlib rcParams): the thesis figures, the
#: beyond-thesis figures, the robustness study figure and the campaign figures are all drawn and
#: saved inside :func:`figure_style`, on figures from :func:`new_figure` (constrained layout:
#: legends outside the panels, wrapped titles and tick labels all fit the canvas).
STYLE: dict[RcKeyType, Any] = {
    "font.size": 9.0,
    "axes.titlesize": 10.0,
    "axes.labelsize": 9.5,
    "xtick.labelsize": 8.5,
    "ytick.labelsize": 8.5,
    "legend.fontsize": 8.5,
    "legend.title_fontsize": 8.5,
    "legend.frameon": False,
    "legend.handlelength": 1.8,
    "figure.titlesize": 11.0,
    "axes.grid": True,
    "grid.linewidth": 0.4,
    "grid.alpha": 0.6,
    "lines.linewidth": 1.2,
    "figure.dpi": DPI,
    "savefig.dpi": DPI,
    "savefig.bbox": None,  # the layout already fits the canvas: files keep the figure's size
    "figure.constrained_layout.h_pad": 0.06,
    "figure.constrained_layout.w_pad": 0.06,
    "figure.constrained_layout.hspace": 0.04,
    "figure.constrained_layout.wspace": 0.04,
    "pdf.fonttype": 42,  # TrueType fonts in PDF (editable, accepted by print workflows)
    "ps.fonttype": 42,
    "svg.fonttype": "path",
}


@contextlib.contextmanager
def figure_style() -> Iterator[None]:
    """Context in which every project figure is drawn and saved (:data:`STYLE`)."""
    import matplotlib

    with matplotlib.rc_context(STYLE):
        yield


def new_figure(width: float, height: float) -> Figure:
    """A bare figure (no ``pyplot``) of ``width`` x ``height`` inches with constrained layout."""
    # imported here: `aftc run` picks figure tables and zoom windows from this module before
    # (and without) drawing, and matplotlib costs a fresh process ~0.4 s
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), dpi=DPI, layout="constrained")


def wrap_title(title: str, width: float, fontsize: float | None = None) -> str:
    """``title`` broken into lines that fit ``width`` inches at ``fontsize`` points (default:
    the style's figure title size), at word boundaries."""
    size = float(fontsize or STYLE["figure.titlesize"])
    # 0.62 em: a wide average glyph of DejaVu Sans (measured: 0.55-0.60 em on the titles)
    chars = max(20, int(0.92 * width * 72.0 / (0.62 * size)))
    lines = []
    for line in str(title).splitlines() or [""]:
        lines += textwrap.wrap(line, chars, break_long_words=False) or [""]
    return "\n".join(lines)


# ---------------------------------------------------------------------------- helpers
def _tex(name: str) -> str:
    """Math-text label of a signal name: ``"q1_dot"`` -> ``$\\dot{q}_{1}$``, ``"alpha"`` -> α."""
    dot = name.endswith("_dot")
    base = name[: -len("_dot")] if dot else name
    m = re.fullmatch(r"([A-Za-z]+)_?(\w*)", base)
    if not m:
        return name
    stem, sub = m.group(1), m.group(2)
    core = f"\\{stem}" if stem in _GREEK else stem
    if len(stem) > 1 and stem not in _GREEK:
        core = f"\\mathrm{{{stem}}}"
    if dot:
        core = f"\\dot{{{core}}}"
    if sub:
        core = f"{core}_{{{sub.replace('_', ',')}}}"
    return f"${core}$"


def _unit(result: SimResult, which: int) -> str:
    return (output_unit, rate_unit, actuator_unit)[which](result.meta)


def _with_unit(label: str, unit: str) -> str:
    return f"{label} ({unit})" if unit else label


def _t_end(result: SimResult) -> float:
    t_final = result.meta.get("t_final")
    if t_final is not None and math.isfinite(float(t_final)):
        return float(t_final)
    return float(result.time[-1]) if result.time.size else 1.0


def _new_figure(n_rows: int, n_cols: int = 1, *, sharex: bool = True) -> tuple[Figure, list[Axes]]:
    width = _WIDTH if n_cols == 1 else 6.0 * n_cols + _LEGEND_W
    fig = new_figure(width, 1.2 + _ROW_HEIGHT * n_rows)
    axes = fig.subplots(n_rows, n_cols, sharex=sharex, squeeze=False)
    return fig, list(axes.ravel())


def _decorate(ax: Axes, result: SimResult, *, legend: bool = True, loc: str = "best") -> None:
    """Grid, failure/recovery lines, divergence line, time limits and legend."""
    ax.grid(True, linewidth=0.4, alpha=0.6)
    first = True
    for t in result.failure_times:
        ax.axvline(
            t,
            color="0.35",
            linestyle="--",
            linewidth=0.9,
            gid="failure-event",
            label="failure / recovery" if first else "_nolegend_",
        )
        first = False
    if result.status != "completed" and result.time.size:
        ax.axvline(
            float(result.time[-1]),
            color="tab:red",
            linestyle=":",
            linewidth=1.2,
            gid="divergence",
            label=f"diverged at t = {result.time[-1]:.3g} s",
        )
    t0 = float(result.time[0]) if result.time.size else 0.0
    t1 = _t_end(result)
    if t1 > t0:
        ax.set_xlim(t0, t1)
    if legend:
        _legend(ax)


def _legend(ax: Axes) -> None:
    """Legend outside the data, right of the panel, at a readable size."""
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return
    ncol = 1 if len(handles) <= 7 else 2
    ax.legend(
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        borderaxespad=0.0,
        ncol=ncol,
        columnspacing=1.0,
        alignment="left",
    )


def _finish(fig: Figure, axes: Sequence[Axes], title: str | None) -> Figure:
    for ax in axes:
        spec = ax.get_subplotspec()
        if spec is not None and spec.is_last_row():
            ax.set_xlabel("time (s)")
    if title:
        fig.suptitle(wrap_title(title, fig.get_figwidth()))
    return fig


def _thin(result: SimResult, max_points: int = _MAX_POINTS) -> SimResult:
    """A copy keeping about ``max_points`` evenly strided samples (first and last kept)."""
    n = result.time.size
    if n <= max_points:
        return result
    idx = np.unique(np.r_[np.arange(0, n, math.ceil(n / max_points)), n - 1])
    changes = {
        f.name: getattr(result, f.name)[idx]
        for f in dataclasses.fields(result)
        if isinstance(getattr(result, f.name), np.ndarray)
        and getattr(result, f.name).shape[:1] == (n,)
    }
    return dataclasses.replace(result, **changes)


def figure_input(result: SimResult, kind: str) -> SimResult:
    """The part of ``result`` that :func:`plot` draws on a figure of ``kind``: the thinned copy
    it would make itself (every kind but ``direction``, whose zoom reads the whole record), or
    ``result`` where thinning the copy again would change it. ``plot(figure_input(r, kind),
    kind)`` draws the figure ``plot(r, kind)`` draws, so a process that draws it can be sent this
    copy instead of the run (1.5 MB instead of 45 MB for 120 s recorded every millisecond)."""
    if kind == "direction":
        return result
    thin = _thin(result)
    return thin if _thin(thin) is thin else result


def _select_outputs(result: SimResult, outputs: Sequence[int] | None) -> list[int]:
    p = len(result.output_names)
    if outputs is None:
        return list(range(p))
    picked = []
    for o in outputs:
        if isinstance(o, bool) or not isinstance(o, (int, np.integer)) or not 1 <= o <= p:
            raise ValueError(
                f"`outputs` must list output numbers from 1 to {p} "
                f"({', '.join(result.output_names)}); got {o!r}."
            )
        picked.append(int(o) - 1)
    if not picked:
        raise ValueError("`outputs` must name at least one output; got an empty list.")
    return picked


def _velocity(result: SimResult) -> np.ndarray:
    """Output velocity ``y' = y_d' - e'`` (from ``e = y_d - y``)."""
    return result.yd_dot - result.edot


def _other_adaptive(result: SimResult) -> list[tuple[str, np.ndarray]]:
    """kappa / tau / rho adaptive states (not theta, not filter states)."""
    out = []
    for i, name in enumerate(result.adaptive_names):
        if name.startswith(("kappa", "tau", "rho")):
            out.append((name, result.adaptive[:, i]))
    return out


# ---------------------------------------------------------------------------- panels
def _tracking_panels(
    axes: Sequence[Axes],
    result: SimResult,
    picked: Sequence[int],
    baselines: Mapping[str, SimResult],
) -> None:
    pos_unit, vel_unit = _unit(result, 0), _unit(result, 1)
    vel = _velocity(result)
    closed = not _open_loop(result)
    for k, i in enumerate(picked):
        name = result.output_names[i]
        ax_p, ax_v = axes[2 * k], axes[2 * k + 1]
        if closed:
            ax_p.plot(
                result.time,
                result.yd[:, i],
                color="k",
                linewidth=1.0,
                linestyle=":",
                label="reference",
            )
        ax_p.plot(
            result.time, result.y[:, i], color="tab:blue", linewidth=1.2, zorder=3, label=_tex(name)
        )
        if closed:
            ax_v.plot(
                result.time,
                result.yd_dot[:, i],
                color="k",
                linewidth=1.0,
                linestyle=":",
                label="reference",
            )
        ax_v.plot(
            result.time,
            vel[:, i],
            color="tab:blue",
            linewidth=1.2,
            zorder=3,
            label=_tex(f"{name}_dot"),
        )
        for c, (label, base) in enumerate(baselines.items()):
            color = f"C{(c + 1) % 10}"
            if base.time.size == 0:
                continue
            diverged = base.status != "completed"
            suffix = " (diverged)" if diverged else ""
            ax_p.plot(
                base.time,
                base.y[:, i],
                color=color,
                linestyle="--",
                linewidth=0.9,
                alpha=0.85,
                zorder=2,
                label=f"{label}{suffix}",
            )
            ax_v.plot(
                base.time,
                _velocity(base)[:, i],
                color=color,
                linestyle="--",
                linewidth=0.9,
                alpha=0.85,
                zorder=2,
                label=f"{label}{suffix}",
            )
            if diverged:
                for ax, sig in ((ax_p, base.y[:, i]), (ax_v, _velocity(base)[:, i])):
                    ax.plot(base.time[-1:], sig[-1:], marker="x", color=color, linestyle="none")
        ax_p.set_ylabel(_with_unit(_tex(name), pos_unit))
        ax_v.set_ylabel(_with_unit(_tex(f"{name}_dot"), vel_unit))
        _clip_to_main(ax_p, result.y[:, i], *([result.yd[:, i]] if closed else []))
        _clip_to_main(ax_v, vel[:, i], *([result.yd_dot[:, i]] if closed else []))
        _decorate(ax_p, result)
        _decorate(ax_v, result)


def _open_loop(result: SimResult) -> bool:
    """An open-loop run (``design = "none"``: no adaptation, every command zero): it tracks no
    reference, so none is drawn."""
    return result.meta.get("adapt") is False and not np.any(result.u_cmd)


def _clip_to_main(ax: Axes, *signals: np.ndarray) -> None:
    """Keep the y-range on the main run so that a diverging baseline does not flatten it."""
    vals = np.concatenate([np.asarray(s, dtype=float).ravel() for s in signals])
    vals = vals[np.isfinite(vals)]
    if vals.size == 0:
        return
    lo, hi = float(vals.min()), float(vals.max())
    pad = 0.25 * (hi - lo) if hi > lo else max(abs(hi), 1e-6) * 0.5
    ax.set_ylim(lo - pad, hi + pad)


def _actuator_panel(ax: Axes, result: SimResult, j: int) -> None:
    name = result.actuator_names[j]
    color = f"C{j % 10}"
    ax.plot(
        result.time,
        result.u_cmd[:, j],
        color=color,
        linestyle="--",
        linewidth=0.9,
        alpha=0.8,
        label=f"{_tex(name)} commanded",
    )
    ax.plot(
        result.time,
        result.u_applied[:, j],
        color=color,
        linewidth=1.2,
        label=f"{_tex(name)} applied",
    )
    ax.set_ylabel(_with_unit(_tex(name), _unit(result, 2)))
    _decorate(ax, result)


def _u0_panel(ax: Axes, result: SimResult) -> None:
    for i, name in enumerate(result.output_names):
        label = "$u_0$" if len(result.output_names) == 1 else f"$u_{{0,{i + 1}}}$ ({name})"
        ax.plot(result.time, result.u0[:, i], color=f"C{i % 10}", linewidth=1.1, label=label)
    if np.any(result.u_f != 0):
        ax.plot(
            result.time,
            result.u_f,
            color="tab:purple",
            linewidth=1.1,
            linestyle="-.",
            label="$u_f$ (compensator)",
        )
    ax.set_ylabel(_with_unit("design signal", _unit(result, 2)))
    _decorate(ax, result)


def _all_actuators_panel(ax: Axes, result: SimResult) -> None:
    for j, name in enumerate(result.actuator_names):
        color = f"C{j % 10}"
        ax.plot(result.time, result.u_applied[:, j], color=color, linewidth=1.1, label=_tex(name))
        ax.plot(
            result.time,
            result.u_cmd[:, j],
            color=color,
            linewidth=0.7,
            linestyle=":",
            alpha=0.8,
            label="commanded (dotted)" if j == 0 else "_nolegend_",
        )
    if len(result.output_names) == 1:
        ax.plot(result.time, result.u0[:, 0], color="k", linewidth=0.7, alpha=0.6, label="$u_0$")
    ax.set_ylabel(_with_unit("control", _unit(result, 2)))
    _decorate(ax, result)


def _theta_panel(ax: Axes, result: SimResult) -> None:
    theta = result.theta
    n = theta.shape[1]
    if n:
        ax.plot(result.time, theta, linewidth=0.5, alpha=0.75)
        norm = np.linalg.norm(theta, axis=1)
        ax.plot(
            result.time, norm, color="k", linewidth=1.3, label=rf"$\|\theta\|$ ({n} components)"
        )
    else:
        ax.text(0.5, 0.5, "no adaptive parameters", transform=ax.transAxes, ha="center")
    ax.set_ylabel(r"$\theta$ (mixed units)")
    _decorate(ax, result)


def _other_adaptive_panel(
    ax: Axes, result: SimResult, series: list[tuple[str, np.ndarray]]
) -> None:
    for c, (name, values) in enumerate(series):
        ax.plot(result.time, values, color=f"C{c % 10}", linewidth=1.1, label=_tex(name))
    stems = sorted({re.sub(r"[\d_]+$", "", n) for n, _ in series})
    unit = _unit(result, 2) if stems == ["kappa"] else ("–" if "kappa" not in stems else "mixed")
    ax.set_ylabel(_with_unit(", ".join(_tex(s) for s in stems), unit))
    _decorate(ax, result)


# ---------------------------------------------------------------------------- kinds
def _plot_tracking(result, outputs, baselines, **_):
    picked = _select_outputs(result, outputs)
    fig, axes = _new_figure(2 * len(picked))
    _tracking_panels(axes, result, picked, baselines)
    return fig, axes


def _plot_control(result, outputs, baselines, **_):
    m = len(result.actuator_names)
    n_cols = 1 if m <= 3 else 2
    n_rows = math.ceil((m + 1) / n_cols)
    fig, axes = _new_figure(n_rows, n_cols)
    for j in range(m):
        _actuator_panel(axes[j], result, j)
    _u0_panel(axes[m], result)
    for k in range(m + 1, len(axes)):
        axes[k].set_visible(False)
        above = axes[k - n_cols]  # the panel above a hidden one is the last of its column
        above.tick_params(labelbottom=True)
        above.set_xlabel("time (s)")
    return fig, axes[: m + 1]


def _plot_parameters(result, outputs, baselines, **_):
    others = _other_adaptive(result)
    fig, axes = _new_figure(1 + bool(others))
    _theta_panel(axes[0], result)
    if others:
        _other_adaptive_panel(axes[1], result, others)
    return fig, axes


def _plot_control_parameters(result, outputs, baselines, **_):
    others = _other_adaptive(result)
    fig, axes = _new_figure(2 + bool(others))
    _all_actuators_panel(axes[0], result)
    _theta_panel(axes[1], result)
    if others:
        _other_adaptive_panel(axes[2], result, others)
    return fig, axes


def _plot_modal(result, outputs, baselines, **_):
    disp = [
        i
        for i, n in enumerate(result.state_names)
        if n.startswith("eta") and not n.endswith("_dot")
    ]
    rate = [
        i for i, n in enumerate(result.state_names) if n.startswith("eta") and n.endswith("_dot")
    ]
    if not disp and not rate:
        raise ValueError(
            f"A 'modal' figure needs states named 'eta...'; this run's states are "
            f"{', '.join(result.state_names)}."
        )
    fig, axes = _new_figure(2)
    for ax, idx, ylabel in ((axes[0], disp, "modal displacement"), (axes[1], rate, "modal rate")):
        for c, i in enumerate(idx):
            name = result.state_names[i]
            ax.plot(
                result.time,
                result.states[:, i],
                color=f"C{c % 10}",
                linewidth=1.0,
                label=_tex(name),
            )
        unit = state_unit(result.meta, result.state_names[idx[0]]) if idx else ""
        ax.set_ylabel(_with_unit(ylabel, unit))
        _decorate(ax, result)
    return fig, axes


def _auto_zoom(result: SimResult) -> tuple[float, float] | None:
    """Window around the direction estimate's sign mismatches when they all end within
    1 % of the time axis (too short to see at full scale), else ``None``."""
    if result.time.size < 2:
        return None
    wrong = np.flatnonzero(np.sign(result.gain) != np.sign(result.control_gain))
    if wrong.size == 0:
        return None
    t0, t1 = float(result.time[0]), _t_end(result)
    a = float(result.time[wrong[0]])
    b = float(result.time[min(wrong[-1] + 1, result.time.size - 1)])
    if b - a > _ZOOM_FRACTION * (t1 - t0):
        return None
    dt = float(np.min(np.diff(result.time)))
    pad = max(2.0 * (b - a), 10.0 * dt)
    return max(t0, a - pad), min(t1, b + pad)


def zoom_window(result: SimResult, spec: Mapping[str, Any]) -> tuple[float, float] | None:
    """The zoom window ``(start, end)`` in s of a figure table, or ``None`` when it has none.

    Only ``direction`` figures zoom: on the table's ``zoom = [start, end]``, else automatically
    on the direction estimate's sign mismatches when they all end within 1 % of the time axis.
    A caller that can re-simulate records the run densely on ``[t0, end]`` and passes it as
    ``zoom_result`` to :func:`plot` / :func:`save_figure`, so the zoom shows the solver's own
    resolution rather than the recorded samples.
    """
    if spec.get("kind") != "direction" or result.time.size == 0:
        return None
    zoom = spec.get("zoom")
    if zoom is not None:
        return float(zoom[0]), float(zoom[1])
    return _auto_zoom(result)


def dense_zoom(
    scenario: Any, result: SimResult, spec: Mapping[str, Any], solver: Any = None
) -> SimResult | None:
    """The run re-simulated up to the end of a figure's zoom window (:func:`zoom_window`) and
    recorded at the solver's own resolution: every step of the fixed-step RK4, 1000 samples
    over the window for an adaptive-step method.

    Parameters
    ----------
    scenario
        The :class:`~adaptive_ftc.scenarios.loader.Scenario` that produced ``result``.
    result, spec
        The run and its figure table.
    solver
        The :class:`~adaptive_ftc.sim.engine.SolverOptions` the run used (default: the
        scenario's).

    Returns
    -------
    SimResult or None
        ``None`` when the figure has no zoom or the short run does not complete (the zoom
        panel then draws the recorded samples, and says so).
    """
    window = zoom_window(result, spec)
    if window is None:
        return None
    a, b = window[0], min(window[1], _t_end(result))
    if not b > a:
        return None
    solver = solver or scenario.solver
    step = solver.dt if solver.method == "rk4" else (b - a) / 1000.0
    short = dataclasses.replace(scenario, loop=dataclasses.replace(scenario.loop, t_final=b))
    try:
        dense = short.run(solver=dataclasses.replace(solver, record_dt=min(step, solver.record_dt)))
    except Exception:  # noqa: BLE001 - a zoom must not stop the figure
        return None
    return dense if dense.status == "completed" else None


def _zoom_panel(
    ax: Axes, full: SimResult, window: tuple[float, float], est: str, dense: bool
) -> None:
    a, b = window
    m = (full.time >= a - 1e-12) & (full.time <= b + 1e-12)
    t = full.time[m]
    ax.step(
        t,
        np.sign(full.control_gain[m]),
        where="post",
        color="k",
        linewidth=1.6,
        label="true direction",
    )
    ax.step(
        t,
        np.sign(full.gain[m]),
        where="post",
        color="tab:orange",
        linewidth=1.1,
        linestyle="--",
        label=f"sign(${est}$)",
    )
    ax.plot(
        t,
        full.gain[m],
        color="tab:orange",
        linewidth=0.9,
        alpha=0.6,
        marker=".",
        markersize=2.5,
        label=f"${est}$",
    )
    ax.axhline(0.0, color="0.5", linewidth=0.6)
    ax.set_xlim(a, b)
    ax.set_gid("zoom")
    ax.set_ylabel("zoom (–)")
    ax.grid(True, linewidth=0.4, alpha=0.6)
    ax.set_xlabel("time (s)")
    _legend(ax)
    step = float(np.median(np.diff(t))) if t.size > 1 else float("nan")
    how = "re-simulated, a sample" if dense else "recorded samples,"
    legend = ax.get_legend()
    assert legend is not None  # the panel's three lines are labelled
    # matplotlib takes a dict for prop (FontProperties._from_any); its stubs do not say so
    legend.set_title(
        f"zoom on {a:.3g} to {b:.3g} s\n({how} every {step:.2g} s)",
        prop={"size": 8.5},  # type: ignore[arg-type]
    )


def _plot_direction(result, outputs, baselines, *, full=None, zoom=None, zoom_result=None, **_):
    full = result if full is None else full
    window = tuple(float(v) for v in zoom) if zoom is not None else _auto_zoom(full)
    fig, axes = _new_figure(3 + (window is not None), sharex=False)
    for ax in axes[1:3]:
        ax.sharex(axes[0])
    for ax in axes[:2]:
        ax.tick_params(labelbottom=False)
    _all_actuators_panel(axes[0], result)
    design = str(result.meta.get("design", ""))
    est = r"N(\tau)" if design == "nussbaum" else (r"\rho" if design == "sign" else "gain")
    ax = axes[1]
    ax.step(
        result.time,
        np.sign(result.control_gain),
        where="post",
        color="k",
        linewidth=1.6,
        label="true direction sign(control gain)",
    )
    ax.step(
        result.time,
        np.sign(result.gain),
        where="post",
        color="tab:orange",
        linewidth=1.1,
        linestyle="--",
        label=f"sign(${est}$)",
    )
    ax.set_ylim(-1.4, 1.4)
    ax.set_yticks([-1, 0, 1])
    ax.set_ylabel("control direction (–)")
    _decorate(ax, result)
    ax = axes[2]
    ax.plot(result.time, result.gain, color="tab:orange", linewidth=1.1, label=f"${est}$")
    for name, values in _other_adaptive(result):
        if name == "tau":
            ax.plot(result.time, values, color="tab:green", linewidth=0.9, label=r"$\tau$")
    ax.axhline(0.0, color="0.5", linewidth=0.6)
    ax.set_ylabel("direction estimate (–)")
    _decorate(ax, result)
    if window is not None:
        for ax in axes[1:3]:
            ax.axvspan(*window, color="tab:orange", alpha=0.25, gid="zoom-region")
        axes[2].tick_params(labelbottom=True)
        dense = zoom_result is not None and zoom_result.time.size > 1
        _zoom_panel(axes[3], zoom_result if dense else full, window, est, dense)
    return fig, axes


_BUILDERS = {
    "tracking": _plot_tracking,
    "control": _plot_control,
    "parameters": _plot_parameters,
    "control_parameters": _plot_control_parameters,
    "modal": _plot_modal,
    "direction": _plot_direction,
}


# ---------------------------------------------------------------------------- public API
@dataclasses.dataclass(frozen=True, eq=False)
class FigurePlot:
    """A drawn figure with its panels and lines (what :func:`plot` returns).

    Attributes
    ----------
    figure
        The :class:`matplotlib.figure.Figure` (Agg-renderable, no ``pyplot`` state).
    axes
        The data panels, top to bottom (then left to right).
    lines
        Per panel, the data lines drawn on it (failure markers excluded).
    kind, title
        The figure kind and title.

    Any other attribute is the figure's (``fp.savefig(...)``, ``fp.suptitle``), so code that
    used the bare ``Figure`` returned by earlier versions keeps working.
    """

    figure: Figure
    axes: tuple[Axes, ...]
    lines: tuple[tuple[Line2D, ...], ...]
    kind: str
    title: str | None = None

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.figure, name)

    def savefig(self, fname: Any, **kwargs: Any) -> None:
        """Save the figure (``Figure.savefig``; PNG at :data:`DPI` unless ``dpi`` is given)."""
        kwargs.setdefault("dpi", DPI)
        with figure_style():
            self.figure.savefig(fname, **kwargs)

    def _repr_png_(self) -> bytes:  # Jupyter
        import io

        buf = io.BytesIO()
        with figure_style():
            self.figure.savefig(buf, format="png", dpi=100)
        return buf.getvalue()

    def __repr__(self) -> str:
        return (
            f"FigurePlot(kind={self.kind!r}, title={self.title!r}, panels={len(self.axes)}, "
            f"lines={sum(len(x) for x in self.lines)})"
        )


def _data_lines(ax: Axes) -> tuple[Line2D, ...]:
    return tuple(ln for ln in ax.get_lines() if ln.get_gid() not in ("failure-event", "divergence"))


def check_formats(formats: str | Sequence[str]) -> tuple[str, ...]:
    """Validated figure formats (lower case, without dots), e.g. ``("png", "pdf")``.

    Raises
    ------
    ValueError
        For a format outside :data:`FORMATS`, naming it and the valid ones.
    """
    if isinstance(formats, str):
        formats = [f for f in formats.replace(",", " ").split() if f]
    out = []
    for f in formats:
        f = str(f).lower().lstrip(".")
        if f not in FORMATS:
            from adaptive_ftc.errors import did_you_mean

            raise ValueError(
                f"Unknown figure format '{f}'.{did_you_mean(f, FORMATS)} "
                f"Valid formats: {', '.join(FORMATS)}."
            )
        if f not in out:
            out.append(f)
    if not out:
        raise ValueError(f"Give at least one figure format ({', '.join(FORMATS)}); got none.")
    return tuple(out)


def plot(
    result: SimResult,
    kind: str = "tracking",
    *,
    outputs: Sequence[int] | None = None,
    title: str | None = None,
    baselines: Mapping[str, SimResult] | None = None,
    zoom: Sequence[float] | None = None,
    zoom_result: SimResult | None = None,
) -> FigurePlot:
    """Draw a thesis-style figure of a recorded run.

    Parameters
    ----------
    result
        The run to draw.
    kind
        One of :data:`KINDS` (see the module docstring).
    outputs
        1-based output numbers to draw on ``tracking`` figures (default: all).
    title
        Figure title (``suptitle``).
    baselines
        Label -> other run (e.g. ``{"frozen adaptation": r_frozen}``), drawn dashed on the
        tracking panels; a diverged baseline is drawn up to where it stopped.
    zoom
        ``(start, end)`` in s of the zoom panel of a ``direction`` figure (default: automatic
        when the direction estimate settles within 1 % of the time axis).
    zoom_result
        The same run recorded densely over the zoom window (see :func:`zoom_window`): the zoom
        panel draws it instead of the recorded samples of ``result``.

    Returns
    -------
    FigurePlot
        The figure, its panels and their lines; ``.savefig(path)`` writes it.

    Raises
    ------
    ValueError
        For an unknown ``kind`` (the message lists the valid kinds), an output number out of
        range, a malformed ``zoom`` or a ``modal`` figure of a run without ``eta`` states.

    Examples
    --------
    >>> from adaptive_ftc import load_scenario
    >>> r = load_scenario("hypersonic-direct-s1").run()          # doctest: +SKIP
    >>> fp = plot(r, "tracking", title="Fig. 2.1")                # doctest: +SKIP
    >>> fp.axes[0].get_ylabel()                                   # doctest: +SKIP
    '$\\alpha$ (rad)'
    >>> fp.savefig("fig_2.1.pdf")                                 # doctest: +SKIP
    """
    if kind not in _BUILDERS:
        from adaptive_ftc.errors import did_you_mean

        raise ValueError(
            f"Unknown figure kind '{kind}'.{did_you_mean(kind, KINDS)} "
            f"Valid kinds: {', '.join(KINDS)}."
        )
    if result.time.size == 0:
        raise ValueError("Cannot plot a run with no recorded samples.")
    if zoom is not None:
        ok = (
            isinstance(zoom, Sequence)
            and len(zoom) == 2
            and all(isinstance(v, (int, float)) and math.isfinite(v) for v in zoom)
            and zoom[0] < zoom[1]
        )
        if not ok:
            raise ValueError(f"`zoom` must be [start, end] in s with start < end; got {zoom!r}.")
    thin_baselines = {k: _thin(v) for k, v in (baselines or {}).items()}
    with figure_style():
        fig, axes = _BUILDERS[kind](
            _thin(result), outputs, thin_baselines, full=result, zoom=zoom, zoom_result=zoom_result
        )
        _finish(fig, axes, title)
    return FigurePlot(
        figure=fig,
        axes=tuple(axes),
        lines=tuple(_data_lines(ax) for ax in axes),
        kind=kind,
        title=title,
    )


def save_figure(
    result: SimResult,
    spec: Mapping[str, Any],
    path: str | Path,
    *,
    baselines: Mapping[str, SimResult] | None = None,
    formats: str | Sequence[str] | None = None,
    dpi: int | None = None,
    zoom_result: SimResult | None = None,
) -> Path:
    """Render one ``[[figure]]`` table of a scenario to image files.

    Parameters
    ----------
    result
        The run to draw.
    spec
        A figure table: ``kind``, ``caption`` and optionally ``number`` (the thesis figure
        number), ``outputs`` (1-based output numbers) and ``zoom`` (``[start, end]`` s). The
        title reads ``"Fig. <number>: <caption>"``, or the caption alone without a number.
    path
        Destination file; its suffix is the first format unless ``formats`` is given (parent
        folders are created).
    baselines
        See :func:`plot`; only tracking panels draw them.
    formats
        Formats to write beside each other with the same stem (e.g. ``("png", "pdf")``); one of
        :data:`FORMATS` each. Default: the suffix of ``path``.
    dpi
        Resolution of raster files (default :data:`DPI`).
    zoom_result
        See :func:`plot`.

    Returns
    -------
    pathlib.Path
        The file written for the first format.
    """
    if "kind" not in spec:
        raise ValueError(
            f"Figure table {dict(spec)!r} is missing the key 'kind' (one of {', '.join(KINDS)})."
        )
    path = Path(path)
    fmts = check_formats(formats if formats is not None else (path.suffix or ".png"))
    if dpi is not None and (isinstance(dpi, bool) or not isinstance(dpi, int) or dpi < 10):
        raise ValueError(f"`dpi` must be an integer >= 10; got {dpi!r}.")
    number = spec.get("number")
    caption = str(spec.get("caption", "")).strip()
    title = f"Fig. {number}: {caption}" if number not in (None, "") else caption or None
    fp = plot(
        result,
        str(spec["kind"]),
        outputs=spec.get("outputs"),
        title=title,
        baselines=baselines,
        zoom=spec.get("zoom"),
        zoom_result=zoom_result,
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    first = None
    for fmt in fmts:
        target = path.with_suffix(f".{fmt}")
        extra: dict[str, Any] = (
            {"pil_kwargs": {"compress_level": PNG_COMPRESS}} if fmt == "png" else {}
        )
        with figure_style():
            if fmt == "png":
                _save_png_laid_out_once(fp.figure, target, dpi or DPI, _metadata(fmt, title))
            else:
                fp.figure.savefig(
                    target, dpi=dpi or DPI, format=fmt, metadata=_metadata(fmt, title), **extra
                )
        first = first or target
    assert first is not None  # check_formats gives at least one format
    return first


def _save_png_laid_out_once(
    figure: Figure, target: Path, dpi: int, metadata: Mapping[str, Any]
) -> None:
    """``figure.savefig(target, format="png", dpi=dpi, ...)`` with one draw instead of two.

    With a layout engine, ``savefig`` first draws the whole figure with drawing disabled (every
    tick and text laid out) only to run the constrained layout, then draws it again with the
    layout off. Agg's ``print_png`` draws once: ``Figure.draw`` runs the layout engine, then
    draws the artists at their new places, at the file's resolution as ``savefig`` does. Same
    positions, same pixels (tests/test_figure_speed.py compares the bytes with ``savefig``'s)
    for one draw less. Under a matplotlibrc that sets ``savefig`` colours, transparency or
    ``bbox``, ``savefig`` itself writes the file (it applies them).
    """
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    rc = matplotlib.rcParams
    if (
        rc["savefig.facecolor"] != "auto"
        or rc["savefig.edgecolor"] != "auto"
        or rc["savefig.transparent"]
        or rc["savefig.bbox"] is not None
    ):  # a matplotlibrc's savefig settings: savefig applies them
        figure.savefig(
            target,
            dpi=dpi,
            format="png",
            metadata=dict(metadata),
            pil_kwargs={"compress_level": PNG_COMPRESS},
        )
        return
    canvas = figure.canvas
    if not isinstance(canvas, FigureCanvasAgg):
        canvas = FigureCanvasAgg(figure)  # attaches itself: savefig would switch to it for PNG
    figure_dpi = figure.dpi
    figure.dpi = dpi  # savefig lays out and draws at the file's resolution
    try:
        # the renderer print_png lays out and draws with (same size and dpi: reused), given
        # the mathtext parses of the figures drawn before (_shared_mathtext)
        _share_mathtext(canvas.get_renderer())
        canvas.print_png(
            target, metadata=dict(metadata), pil_kwargs={"compress_level": PNG_COMPRESS}
        )
    finally:
        figure.dpi = figure_dpi


def _share_mathtext(renderer: Any) -> None:
    """Let ``renderer`` parse math text with the process's one cached parser.

    Each Agg renderer (a new one per figure) makes its own ``MathTextParser``, and
    matplotlib's cache of parses (50 entries, shared by all parsers) is keyed by the parser:
    every label, legend entry and title in math text (``$\\alpha$ (rad)``, ``$u_{1}$
    commanded``) was parsed again for every figure, about a fifth of a figure's layout. A
    parse depends only on its arguments (the text, dpi, font properties, antialiasing and
    glyph loading flags: the cache's key), not on the renderer, so one parser with a larger
    cache gives the same glyphs and the same pixels (tests/test_figure_speed.py compares the
    bytes). A renderer whose parser is not matplotlib's own is left alone.
    """
    from matplotlib.mathtext import MathTextParser

    current = getattr(renderer, "mathtext_parser", None)
    output = {"vector": "path", "raster": "agg"}.get(getattr(current, "_output_type", ""))
    if type(current) is MathTextParser and output is not None:
        parser = _mathtext_parser(output)
        if parser is not None:
            renderer.mathtext_parser = parser


@functools.cache
def _mathtext_parser(output: str) -> Any:
    """The process's one ``MathTextParser(output)``, with a cache of 1024 parses (``None``
    where matplotlib's parser has no cached ``_parse_cached`` to wrap)."""
    from matplotlib.mathtext import MathTextParser

    wrapped = getattr(getattr(MathTextParser, "_parse_cached", None), "__wrapped__", None)
    if wrapped is None:  # pragma: no cover - another matplotlib's internals
        return None
    parse: Any = wrapped

    class _CachedParser(MathTextParser):
        @functools.lru_cache(1024)  # noqa: B019 - one instance per output, kept for the process
        def _parse_cached(self, *args: Any) -> Any:
            return parse(self, *args)

    cls: Any = _CachedParser
    return cls(output)


def _metadata(fmt: str, title: str | None) -> dict[str, Any]:
    from adaptive_ftc._version import __version__

    creator = f"adaptive-ftc {__version__}"
    if fmt == "png":
        return {"Title": title or "", "Software": creator}
    if fmt == "pdf":
        return {"Title": title or "", "Creator": creator, "CreationDate": None}
    return {"Title": title or "", "Creator": creator, "Date": None}


def default_figure_specs(result: SimResult, title: str | None = None) -> list[dict[str, Any]]:
    """Figure tables for a run without its own: tracking, control, parameters (+ modal, direction).

    ``modal`` is added when the run has ``eta`` states, ``direction`` for the ``nussbaum`` and
    ``sign`` designs. The tables carry no thesis ``number``: the figure title is the caption,
    which starts with ``title`` (default: the scenario's name from ``result.meta``).
    """
    name = title or str(result.meta.get("scenario", result.meta.get("name", "run")))
    kinds = ["tracking", "control", "parameters"]
    if any(n.startswith("eta") for n in result.state_names):
        kinds.append("modal")
    if result.meta.get("design") in ("nussbaum", "sign"):
        kinds.append("direction")
    captions = {
        "tracking": "outputs and references",
        "control": "actuator commands and outputs",
        "parameters": "adaptive parameters",
        "modal": "modal displacements and rates",
        "direction": "control direction estimate",
    }
    return [{"kind": k, "caption": f"{name}: {captions[k]}"} for k in kinds]
