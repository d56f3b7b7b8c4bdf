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

from adaptive_ftc import list_scenarios, load_scenario, plots
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


def test_the_check_catches_a_legend_clipped_at_the_right_edge():
    """The check itself: a two-column legend pushed past the right edge is reported."""
    r = _result_for("spacecraft-mimo-s1", {"kind": "control_parameters"})
    fp = plots.plot(r, "control_parameters", title="Fig. 3.12")
    assert not layout_problems(fp.figure)
    fp.axes[0].get_legend().set_bbox_to_anchor((1.3, 1.0), transform=fp.axes[0].transAxes)
    fp.figure.set_layout_engine("none")
    assert any("legend leaves" in p for p in layout_problems(fp.figure))


def test_long_titles_are_wrapped_inside_the_canvas():
    title = "Hypersonic angle of attack, failure estimation and compensation design (§2.4), " * 3
    r = _synthetic(**_SHAPES["hypersonic"])
    fp = plots.plot(r, "tracking", title=title)
    suptitle = fp.figure.get_suptitle()
    assert suptitle.count("\n") >= 2 and suptitle.replace("\n", " ") == title.strip()
    assert_print_ready(fp.figure, "long title")


def test_an_open_loop_run_draws_no_reference():
    r = _synthetic(**_SHAPES["wingrock"], open_loop=True, n_theta=1)
    fp = plots.plot(r, "tracking")
    labels = [ln.get_label() for ax in fp.axes for ln in ax.get_lines()]
    assert "reference" not in labels
    closed = plots.plot(_synthetic(**_SHAPES["wingrock"]), "tracking")
    assert "reference" in [ln.get_label() for ax in closed.axes for ln in ax.get_lines()]


def test_every_axis_of_a_real_run_has_a_unit():
    r = _real_sign_run()
    for kind in plots.KINDS:
        if kind == "modal":
            continue
        fp = plots.plot(r, kind, title=f"{kind} of a real run")
        for ax in fp.figure.axes:
            if not ax.get_visible():
                continue
            for label in (ax.get_xlabel(), ax.get_ylabel()):
                assert not label or label.rstrip().endswith(")"), (kind, label)
        assert_print_ready(fp.figure, kind)


# ---------------------------------------------------------------------------- Fig. 4.12's zoom
_REAL: dict[str, object] = {}


def _real_sign_run():
    """hypersonic-sign-s1-rho0neg (Fig. 4.12) over 10 s: rho(0) = -1 turns positive at 0.02 s."""
    if "r" not in _REAL:
        sc = load_scenario("hypersonic-sign-s1-rho0neg")
        sc = dataclasses.replace(sc, loop=dataclasses.replace(sc.loop, t_final=10.0))
        _REAL["sc"], _REAL["r"] = sc, sc.run()
    return _REAL["r"]


def test_the_direction_zoom_shows_the_solver_resolution():
    r = _real_sign_run()
    sc = _REAL["sc"]
    spec = next(s for s in load_scenario(sc.name).figure_specs if s["kind"] == "direction")
    a, b = plots.zoom_window(r, spec)
    coarse = np.count_nonzero((r.time >= a) & (r.time <= b))
    assert coarse <= 20  # what the recorded run alone shows: a handful of samples
    dense = plots.dense_zoom(sc, r, spec)
    fp = plots.plot(r, "direction", title="Fig. 4.12", zoom_result=dense)
    zoom = next(ax for ax in fp.figure.axes if ax.get_gid() == "zoom")
    estimate = next(ln for ln in zoom.get_lines() if ln.get_marker() == ".")
    t = np.asarray(estimate.get_xdata(), dtype=float)
    assert t.size >= 500 and t[0] >= a - 1e-12 and t[-1] <= b + 1e-12
    assert np.max(np.diff(t)) <= (b - a) / 900
    assert "re-simulated" in zoom.get_legend().get_title().get_text()
    # the re-simulation is the same run: it agrees with the recorded samples where both exist
    common = np.isin(np.round(r.time, 9), np.round(dense.time, 9)) & (r.time <= b)
    idx = np.searchsorted(dense.time, r.time[common] - 1e-12)
    np.testing.assert_allclose(dense.gain[idx], r.gain[common], rtol=1e-5, atol=1e-8)
    assert_print_ready(fp.figure, "Fig. 4.12 with its zoom")
    # without the dense run the zoom says it draws the recorded samples
    plain = plots.plot(r, "direction")
    zoom = next(ax for ax in plain.figure.axes if ax.get_gid() == "zoom")
    assert "recorded samples" in zoom.get_legend().get_title().get_text()


# ---------------------------------------------------------------------------- study and campaign
def _robustness_table(rate_limits=(20.0, 50.0, 100.0, 200.0, 500.0)) -> pd.DataFrame:
    rows = []
    for scen in ("hypersonic-direct-s1", "hypersonic-sign-s1-rho0pos"):
        for knob, values, unit in (
            ("noise", (1e-6, 1e-5, 1e-4, 1e-3, 1e-2), "rad"),
            ("controller_rate", (5000.0, 2000.0, 1000.0, 500.0, 200.0, 100.0, 50.0), "Hz"),
            ("lag", (1e-4, 1e-3, 1e-2, 0.1, 0.2), "s"),
            ("rate_limit", rate_limits, "rad/s"),
        ):
            for k, v in enumerate(values):
                diverged = k == len(values) - 1
                rows.append(
                    {
                        "scenario": scen,
                        "knob": knob,
                        "value": v,
                        "unit": unit,
                        "seed": 0,
                        "status": "diverged" if diverged else "completed",
                        "rms_error": np.nan if diverged else 1e-6 * 10**k,
                        "threshold": 8.7e-4,
                        "broken": diverged or 1e-6 * 10**k > 8.7e-4,
                    }
                )
    return pd.DataFrame(rows)


@pytest.mark.parametrize(
    "rate_limits", [(20.0, 50.0, 100.0, 200.0, 500.0), (5.0, 7.0, 10.0, 15.0, 20.0, 30.0)]
)
def test_the_robustness_figure_fits_its_canvas(rate_limits):
    fig = plot_robustness(
        _robustness_table(rate_limits),
        title="Robustness of the hypersonic designs (§2.3 direct, §4.4 sign estimation)",
    )
    assert_print_ready(fig, f"robustness figure, rate limits {rate_limits}")
    for ax in fig.axes:
        assert ax.get_ylabel().endswith("(rad)")


def test_the_shipped_robustness_table_draws_print_ready():
    from pathlib import Path

    csv = Path(__file__).resolve().parents[1] / "docs" / "figures" / "robustness.csv"
    if not csv.is_file():
        pytest.skip("docs/figures/robustness.csv is not in this checkout")
    assert_print_ready(plot_robustness(pd.read_csv(csv), title="Robustness"), "robustness.csv")


def test_the_campaign_figures_fit_their_canvas():
    from adaptive_ftc.campaigns import summary

    rng = np.random.default_rng(0)
    n = 60
    df = pd.concat(
        [
            pd.DataFrame(
                {
                    "index": np.arange(n),
                    "design": design,
                    "severity": rng.uniform(0, 1, n),
                    "success": rng.uniform(0, 1, n) > 0.3,
                    "rms_error_final": 10 ** rng.uniform(-6, 0, n),
                    "status": np.where(rng.uniform(0, 1, n) > 0.9, "diverged", "completed"),
                }
            )
            for design in ("direct-adaptive", "nominal-inverse", "fixed-gain", "frozen")
        ],
        ignore_index=True,
    )
    figs = summary.draw_figures(df, threshold=1e-3, unit="rad")
    assert len(figs) == 4
    for name, fig in figs.items():
        assert_print_ready(fig, f"campaign figure {name}")
        for ax in fig.axes:  # every labelled axis gives its unit
            for label in (ax.get_xlabel(), ax.get_ylabel()):
                assert not label or label.endswith(")"), (name, label)


def test_figure_titles_quote_angles_in_the_unit_of_their_axes():
    """The figures draw angles in rad: a caption quoting degrees also gives the value in rad
    (Fig. 2.5's title said "1 deg" above a rad axis)."""
    import re

    for name, spec in _FIGURES:
        caption = spec["caption"]
        for value in re.findall(r"([\d.]+) deg\b", caption):
            rad = np.deg2rad(float(value))
            quoted = [float(v) for v in re.findall(r"([\d.]+) rad\b", caption)]
            assert any(abs(q - rad) <= 5e-4 * max(rad, 1.0) for q in quoted), (name, caption)


def test_aftc_run_draws_the_direction_zoom_re_simulated(tmp_path, monkeypatch):
    from adaptive_ftc._figure_process import FigureProcess
    from adaptive_ftc.cli import main

    src = tmp_path / "short.toml"
    src.write_text(
        'extends = "hypersonic-sign-s1-rho0neg"\nname = "short"\nduration = 10.0\n'
        '[[figure]]\nkind = "direction"\ncaption = "direction"\n'
    )
    seen = []
    real = plots.save_figure

    def spy(result, spec, path, **kwargs):
        seen.append((spec["kind"], kwargs.get("zoom_result")))
        return real(result, spec, path, **kwargs)

    monkeypatch.setattr(plots, "save_figure", spy)
    # drawn in this process, where the spy sees the call (not in aftc run's figure process)
    monkeypatch.setattr(FigureProcess, "start", classmethod(lambda cls: None))
    assert main(["run", str(src), "--out", str(tmp_path / "o"), "--quiet", "--no-baselines"]) == 0
    (kind, zoom), *_ = seen
    assert kind == "direction" and zoom is not None and zoom.time.size > 500
    assert zoom.time[-1] <= 0.2 and (tmp_path / "o" / "figures" / "fig_1.png").is_file()
