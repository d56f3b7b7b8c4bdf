"""Print-ready figures: every figure kind the project makes is rendered and checked, artist by
artist, with the renderer's own boxes: no text, legend, label, tick label or title leaves the
canvas, and no two text boxes overlap (tick labels of one axis included).

Synthetic runs shaped like the catalogue's plants (1 to 3 outputs, 2 to 6 actuators, modal
states, diverged baselines) carry the real figure tables and titles of every catalogue scenario,
so the test stays fast; the zoom of a direction figure is checked on a real (short) run.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.text import Text

from adaptive_ftc import list_scenarios, load_scenario
from adaptive_ftc import plots
from adaptive_ftc.sim.result import SimResult
from adaptive_ftc.study_plots import plot_robustness

# ---------------------------------------------------------------------------- the check


def _boxes(fig: Figure) -> list[tuple[str, object]]:
    """(description, window extent) of every visible text-like artist of the figure.

    A legend counts as one box (its texts lie inside it); tick labels, axis labels, offset
    texts, titles, free texts and the figure's own texts each count separately.
    """
    canvas = FigureCanvasAgg(fig)  # a bare Figure has no renderer of its own
    canvas.draw()
    renderer = canvas.get_renderer()
    out: list[tuple[str, object]] = []

    def add(label: str, artist) -> None:
        if artist is None or not artist.get_visible():
            return
        if isinstance(artist, Text) and not artist.get_text().strip():
            return
        bb = artist.get_window_extent(renderer)
        if bb.width > 0 and bb.height > 0:
            out.append((label, bb))

    for t in fig.texts:  # the suptitle is one of them
        add(f"figure text {t.get_text()[:40]!r}", t)
    for legend in fig.legends:
        add("figure legend", legend)
    for a, ax in enumerate(fig.axes):
        if not ax.get_visible():
            continue
        name = f"axes {a} ({ax.get_ylabel()[:25]!r})"
        for title in (ax.title, ax._left_title, ax._right_title):
            add(f"{name} title {title.get_text()[:40]!r}", title)
        for which, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            add(f"{name} {which}label", axis.label)
            add(f"{name} {which} offset text", axis.get_offset_text())
            ticks = axis.get_major_ticks() + axis.get_minor_ticks()
            lo, hi = sorted(axis.get_view_interval())
            for tick in ticks:
                loc = tick.get_loc()
                if loc is None or not lo - 1e-9 * (hi - lo) <= loc <= hi + 1e-9 * (hi - lo):
                    continue  # matplotlib does not draw ticks outside the view
                for lab in (tick.label1, tick.label2):
                    add(f"{name} {which} tick {lab.get_text()!r}", lab)
        if ax.get_legend() is not None:
            add(f"{name} legend", ax.get_legend())
        for t in ax.texts:
            add(f"{name} text {t.get_text()[:30]!r}", t)
    return out


def layout_problems(fig: Figure, tol: float = 0.5) -> list[str]:
    """Every box that leaves the canvas and every pair of overlapping boxes (in pixels)."""
    boxes = _boxes(fig)
    w, h = fig.bbox.width, fig.bbox.height
    problems = []
    for label, bb in boxes:
        if bb.x0 < -tol or bb.y0 < -tol or bb.x1 > w + tol or bb.y1 > h + tol:
            problems.append(
                f"{label} leaves the {w:.0f}x{h:.0f} canvas: "
                f"x {bb.x0:.0f}..{bb.x1:.0f}, y {bb.y0:.0f}..{bb.y1:.0f}"
            )
    for (la, a), (lb, b) in itertools.combinations(boxes, 2):
        dx = min(a.x1, b.x1) - max(a.x0, b.x0)
        dy = min(a.y1, b.y1) - max(a.y0, b.y0)
        if dx > tol and dy > tol:
            problems.append(f"{la} overlaps {lb} ({dx:.0f} x {dy:.0f} px)")
    return problems


def assert_print_ready(fig: Figure, what: str) -> None:
    problems = layout_problems(fig)
    assert not problems, f"{what}:\n  " + "\n  ".join(problems[:12])


# ---------------------------------------------------------------------------- synthetic runs
def _synthetic(
    outputs: tuple[str, ...],
    actuators: tuple[str, ...],
    *,
    t_final: float = 150.0,
    n: int = 1500,
    modal: int = 0,
    n_theta: int = 24,
    adaptive_extra: tuple[str, ...] = (),
    design: str = "mimo",
    failure_times: tuple[float, ...] = (20.0, 50.0, 60.0, 70.0, 90.0),
    status: str = "completed",
    open_loop: bool = False,
    scale: float = 1.0,
) -> SimResult:
    """A run shaped like a catalogue plant: sines of different sizes on every signal."""
    t = np.linspace(0.0, t_final, n)
    p, m = len(outputs), len(actuators)
    rng = np.random.default_rng(len(outputs) * 10 + m)

    def sig(k: int, amp: float = 1.0) -> np.ndarray:
        f = rng.uniform(0.05, 0.5, k)
        return amp * np.sin(np.outer(t, f) + rng.uniform(0, 6, k))

    eta = sig(modal, 1e-3) if modal else np.zeros((n, 0))
    states = np.column_stack([sig(2 * p, scale), eta, sig(modal, 1e-3) if modal else eta])
    names = tuple(outputs) + tuple(f"{o}_dot" for o in outputs)
    names += tuple(f"eta{i + 1}" for i in range(modal))
    names += tuple(f"eta{i + 1}_dot" for i in range(modal))
    z = np.zeros((n, p))
    u = np.zeros((n, m)) if open_loop else sig(m, 20.0)
    adaptive_names = tuple(f"theta{i + 1}_1" for i in range(n_theta)) + adaptive_extra
    gain = np.ones(n)
    if "rho" in adaptive_extra:
        gain = np.where(t < 0.02, -1.0 + 100 * t, 1.0 - 1e-3 * t)
    return SimResult(
        time=t,
        states=states,
        adaptive=sig(len(adaptive_names), 10.0),
        y=states[:, :p],
        yd=z if open_loop else 0.9 * states[:, :p],
        yd_dot=z,
        e=z,
        edot=z,
        s=z,
        sdot=z,
        u0=sig(p, 5.0),
        u_cmd=u,
        u_applied=0.9 * u,
        u_f=np.zeros(n),
        gain=gain,
        control_gain=np.ones(n),
        state_names=names,
        output_names=outputs,
        actuator_names=actuators,
        adaptive_names=adaptive_names,
        theta_slices=(slice(0, n_theta),),
        failure_times=failure_times,
        failures=tuple(f"t={x} s" for x in failure_times),
        status=status,
        meta={
            "design": design,
            "plant": "synthetic",
            "t_final": t_final,
            "adapt": not open_loop,
        },
    )


_SHAPES = {
    "spacecraft": dict(
        outputs=("phi", "theta", "psi"),
        actuators=tuple(f"wheel{i}" for i in range(1, 7)),
        modal=4,
    ),
    "hypersonic": dict(
        outputs=("alpha",),
        actuators=("delta_e1", "delta_e2"),
        n_theta=9,
        t_final=120.0,
        failure_times=(60.0, 80.0),
        scale=0.05,
    ),
    "manipulator": dict(outputs=("q1", "q2"), actuators=("tau1", "tau2", "tau3", "tau4")),
    "wingrock": dict(outputs=("phi",), actuators=("delta_a1", "delta_a2", "delta_a3", "delta_a4")),
}


def _shape_of(scenario_name: str) -> str:
    for key in _SHAPES:
        if key in scenario_name:
            return key
    return "hypersonic"


def _catalogue_figures() -> list[tuple[str, dict]]:
    """(scenario, figure table) of every catalogue figure and of every default figure."""
    out = []
    for name in list_scenarios():
        sc = load_scenario(name)
        specs = [dict(s) for s in sc.figure_specs]
        if not specs:  # the beyond-thesis scenarios: default figures titled by the scenario
            r = _synthetic(**_SHAPES[_shape_of(name)])
            cf = f" (cf. thesis Fig. {', '.join(sc.figures)})" if sc.figures else ""
            specs = [
                dict(s, caption=s["caption"] + cf)
                for s in plots.default_figure_specs(r, title=sc.title or sc.name)
            ]
        out += [(name, s) for s in specs]
    return out


def _result_for(name: str, spec: dict) -> SimResult:
    shape = dict(_SHAPES[_shape_of(name)])
    kind = spec["kind"]
    if "free" in name:  # the open-loop wing rock runs
        shape.update(open_loop=True, n_theta=1)
    if kind == "direction" or "sign" in name or "nussbaum" in name:
        shape.update(
            adaptive_extra=("rho",) if "sign" in name else ("tau",),
            design="sign" if "sign" in name else "nussbaum",
        )
    if kind == "modal":
        shape.setdefault("modal", 4)
    return _synthetic(**shape)


_FIGURES = _catalogue_figures()


@pytest.mark.parametrize(
    ("name", "spec"),
    _FIGURES,
    ids=[f"{n}-{s.get('number') or s['kind']}" for n, s in _FIGURES],
)
def test_every_catalogue_figure_fits_its_canvas(name, spec):
    r = _result_for(name, spec)
    number, caption = spec.get("number"), spec["caption"]
    title = f"Fig. {number}: {caption}" if number else caption
    kwargs = {}
    if spec["kind"] == "tracking":
        base = dataclasses.replace(r, status="diverged")
        kwargs["baselines"] = {"frozen adaptation": base, "nominal inverse": r}
    fp = plots.plot(r, spec["kind"], outputs=spec.get("outputs"), title=title, **kwargs)
    assert_print_ready(fp.figure, f"{name}: {title}")
