"""Thesis-style figures: every kind renders real runs, failure times are marked where they happen,
output selection and baselines work, and mistakes are reported clearly."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from matplotlib.figure import Figure

from adaptive_ftc import load_scenario
from adaptive_ftc.plots import (
    DPI,
    KINDS,
    FigurePlot,
    check_formats,
    default_figure_specs,
    plot,
    save_figure,
)
from adaptive_ftc.sim.result import SimResult


def _short_run(name: str, t_final: float, **kwargs) -> SimResult:
    sc = load_scenario(name)
    sc = dataclasses.replace(sc, loop=dataclasses.replace(sc.loop, t_final=t_final))
    return sc.run(**kwargs)


@pytest.fixture(scope="module")
def direct() -> SimResult:
    # hypersonic-direct-s1 up to 50 s: the stuck failure of elevator 2 at 40 s is inside
    return _short_run("hypersonic-direct-s1", 50.0)


@pytest.fixture(scope="module")
def nussbaum() -> SimResult:
    return _short_run("hypersonic-nussbaum-s1-pos", 50.0)


def _modal_result() -> SimResult:
    """Synthetic two-output run with modal states ``eta1, eta2`` and their rates."""
    t = np.linspace(0.0, 10.0, 501)
    n, p, m = t.size, 2, 3
    eta = np.exp(-0.3 * t)[:, None] * np.sin(np.outer(t, [2.0, 3.0]))
    states = np.column_stack([np.sin(t), np.cos(t), eta, np.gradient(eta, t, axis=0)])
    z = np.zeros((n, p))
    return SimResult(
        time=t,
        states=states,
        adaptive=np.zeros((n, 2)),
        y=states[:, :2],
        yd=states[:, :2],
        yd_dot=z,
        e=z,
        edot=z,
        s=z,
        sdot=z,
        u0=z,
        u_cmd=np.zeros((n, m)),
        u_applied=np.zeros((n, m)),
        u_f=np.zeros(n),
        gain=np.ones(n),
        control_gain=np.ones(n),
        state_names=("a", "b", "eta1", "eta2", "eta1_dot", "eta2_dot"),
        output_names=("a", "b"),
        actuator_names=("u1", "u2", "u3"),
        adaptive_names=("theta1_1", "theta2_1"),
        theta_slices=(slice(0, 1), slice(1, 2)),
        failure_times=(3.0, 7.5),
        failures=("t=3 s: u1 -> 0", "recovers at 7.5 s"),
        meta={"design": "mimo", "plant": "spacecraft", "t_final": 10.0},
    )


def _assert_line_follows(line, time: np.ndarray, signal: np.ndarray, atol: float = 0.0) -> None:
    """The drawn line's samples are the signal at those sample times (figures may thin samples)."""
    x = np.asarray(line.get_xdata(), dtype=float)
    idx = np.searchsorted(time, x)
    np.testing.assert_array_equal(time[idx], x)
    assert x[0] == time[0] and x[-1] == time[-1]
    np.testing.assert_allclose(line.get_ydata(), signal[idx], rtol=0, atol=atol)


def _event_lines(fig: Figure) -> list[list[float]]:
    """x positions of the dashed failure/recovery lines, per axes."""
    out = []
    for ax in fig.axes:
        xs = sorted(
            float(line.get_xdata()[0])
            for line in ax.get_lines()
            if line.get_gid() == "failure-event"
        )
        out.append(xs)
    return out


@pytest.mark.parametrize("kind", ["tracking", "control", "parameters", "control_parameters"])
def test_every_kind_renders_a_real_run_with_failure_lines_at_the_failure_time(
    direct, kind, tmp_path
):
    fig = plot(direct, kind, title=f"Fig. test: {kind}")
    assert isinstance(fig, FigurePlot) and isinstance(fig.figure, Figure)
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert visible
    for xs, ax in zip(_event_lines(fig), fig.axes, strict=True):
        if not ax.get_visible():
            continue
        assert xs == [40.0], f"{kind}: failure lines at {xs}, expected the failure at 40 s"
        assert ax.get_xlim() == (0.0, 50.0)
        for line in ax.get_lines():
            if line.get_gid() == "failure-event":
                assert line.get_linestyle() == "--"
    # the bottom panel is labelled with time and unit
    assert visible[-1].get_xlabel() == "time (s)"
    fig.savefig(tmp_path / f"{kind}.png")
    assert (tmp_path / f"{kind}.png").stat().st_size > 10_000


def test_tracking_draws_output_and_reference_position_and_velocity(direct):
    fig = plot(direct, "tracking")
    ax_pos, ax_vel = fig.axes
    assert ax_pos.get_ylabel() == r"$\alpha$ (rad)"
    assert ax_vel.get_ylabel() == r"$\dot{\alpha}$ (rad/s)"
    lines = {line.get_label(): line for line in ax_pos.get_lines()}
    _assert_line_follows(lines["reference"], direct.time, direct.yd[:, 0])
    _assert_line_follows(lines[r"$\alpha$"], direct.time, direct.y[:, 0])
    # velocity is y' = yd' - e', which for this plant is the pitch rate state q
    vel = {line.get_label(): line for line in ax_vel.get_lines()}[r"$\dot{\alpha}$"]
    _assert_line_follows(vel, direct.time, direct.states[:, 1], atol=1e-9)
    assert ax_pos.get_legend() is not None


def test_direction_figure_compares_estimate_sign_with_true_sign(nussbaum):
    fig = plot(nussbaum, "direction")
    ax_sign = fig.axes[1]
    labels = {line.get_label(): line for line in ax_sign.get_lines()}
    true = labels["true direction sign(control gain)"]
    _assert_line_follows(true, nussbaum.time, np.sign(nussbaum.control_gain))
    est = labels[r"sign($N(\tau)$)"]
    _assert_line_follows(est, nussbaum.time, np.sign(nussbaum.gain))
    assert _event_lines(fig)[1] == [40.0]


def test_modal_figure_draws_eta_displacements_and_rates():
    r = _modal_result()
    fig = plot(r, "modal")
    disp, rate = fig.axes
    assert [line.get_label() for line in disp.get_lines() if line.get_gid() is None] == [
        r"$\eta_{1}$",
        r"$\eta_{2}$",
    ]
    assert len([line for line in rate.get_lines() if line.get_gid() is None]) == 2
    assert _event_lines(fig) == [[3.0, 7.5], [3.0, 7.5]]


def test_modal_figure_without_eta_states_says_so(direct):
    with pytest.raises(ValueError, match="'modal' figure needs states named 'eta"):
        plot(direct, "modal")


def test_outputs_selection_draws_only_the_chosen_outputs():
    r = _modal_result()
    assert len(plot(r, "tracking").axes) == 4  # 2 outputs x (position, velocity)
    fig = plot(r, "tracking", outputs=[2])
    assert len(fig.axes) == 2
    assert fig.axes[0].get_ylabel() == "$b$ (rad)"
    with pytest.raises(ValueError, match="output numbers from 1 to 2"):
        plot(r, "tracking", outputs=[3])
    with pytest.raises(ValueError, match="output numbers from 1 to 2"):
        plot(r, "tracking", outputs=[0])


def test_unknown_kind_names_the_valid_kinds(direct):
    with pytest.raises(ValueError) as info:
        plot(direct, "trackign")
    msg = str(info.value)
    assert "Unknown figure kind 'trackign'" in msg and "Did you mean 'tracking'?" in msg
    for kind in KINDS:
        assert kind in msg


def test_baseline_is_drawn_dashed_and_a_diverged_one_stops_where_it_stopped(direct):
    stop = 200
    diverged = dataclasses.replace(
        direct,
        **{
            f.name: getattr(direct, f.name)[:stop]
            for f in dataclasses.fields(direct)
            if isinstance(getattr(direct, f.name), np.ndarray)
        },
        status="diverged",
        message="state left the bound",
    )
    fig = plot(direct, "tracking", baselines={"frozen adaptation": diverged})
    lines = {line.get_label(): line for line in fig.axes[0].get_lines()}
    base = lines["frozen adaptation (diverged)"]
    assert base.get_linestyle() == "--"
    assert base.get_xdata()[-1] == pytest.approx(direct.time[stop - 1])
    # the axis still spans the whole run
    assert fig.axes[0].get_xlim() == (0.0, 50.0)


def test_save_figure_writes_png_with_thesis_title(direct, tmp_path):
    spec = {"number": "2.1", "kind": "tracking", "caption": "Angle of attack (scenario 1)"}
    path = save_figure(direct, spec, tmp_path / "figs" / "fig_2.1.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    fig = plot(direct, "tracking", title="Fig. 2.1: Angle of attack (scenario 1)")
    assert fig._suptitle.get_text() == "Fig. 2.1: Angle of attack (scenario 1)"


def test_default_figure_specs_follow_the_design_and_states(direct, nussbaum):
    assert [s["kind"] for s in default_figure_specs(direct)] == [
        "tracking",
        "control",
        "parameters",
    ]
    assert [s["kind"] for s in default_figure_specs(nussbaum)][-1] == "direction"
    assert "modal" in [s["kind"] for s in default_figure_specs(_modal_result())]
    for spec in default_figure_specs(nussbaum):
        assert isinstance(plot(nussbaum, spec["kind"]).figure, Figure)


# ---------------------------------------------------------------------------- issue 15
@pytest.mark.parametrize("kind", ["tracking", "control", "parameters", "control_parameters"])
def test_every_axis_carries_a_unit_and_legends_sit_outside_the_data(direct, kind):
    fp = plot(direct, kind)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fp.figure).get_renderer()
    fp.figure.draw(renderer)
    for ax in fp.axes:
        assert ax.get_ylabel().endswith(")"), f"{kind}: no unit on '{ax.get_ylabel()}'"
        legend = ax.get_legend()
        if legend is not None:  # right of the panel, so it never covers a line
            assert legend.get_window_extent(renderer).x0 >= ax.get_window_extent(renderer).x1
            assert legend.get_texts()[0].get_fontsize() >= 8
    assert fp.axes[-1].get_xlabel() == "time (s)"


def test_wingrock_aileron_and_modal_axes_have_si_units():
    r = _modal_result()
    fp = plot(dataclasses.replace(r, meta={**r.meta, "plant": "spacecraft"}), "modal")
    assert [ax.get_ylabel() for ax in fp.axes] == [
        "modal displacement (√kg·m)",
        "modal rate (√kg·m/s)",
    ]
    wing = dataclasses.replace(r, meta={**r.meta, "plant": "wingrock"})
    labels = [ax.get_ylabel() for ax in plot(wing, "control").axes]
    assert labels[0] == "$u_{1}$ (rad)" and labels[-1] == "design signal (rad)"


def test_figure_plot_holds_axes_and_lines_and_saves_like_a_figure(direct, tmp_path):
    fp = plot(direct, "tracking")
    assert len(fp.axes) == len(fp.lines) == 2
    labels = [ln.get_label() for ln in fp.lines[0]]
    assert labels == ["reference", r"$\alpha$"]  # data lines only, no failure markers
    fp.savefig(tmp_path / "a.png")  # delegates to the figure, at DPI
    assert (tmp_path / "a.png").stat().st_size > 10_000
    assert fp.get_figwidth() == fp.figure.get_figwidth()  # other attributes: the figure's
    assert "panels=2" in repr(fp)
    assert direct.plot("tracking").kind == "tracking"  # SimResult.plot delegates


def test_direction_figure_zooms_on_a_sign_switch_shorter_than_one_percent():
    r = _short_run("hypersonic-sign-s1-rho0neg", 30.0)  # rho(0) = -1 flips within 0.02 s
    fp = plot(r, "direction")
    assert len(fp.axes) == 4
    zoom = fp.axes[3]
    assert zoom.get_gid() == "zoom"
    lo, hi = zoom.get_xlim()
    assert lo == 0.0 and hi < 0.3  # < 1 % of the 30 s axis
    lines = {ln.get_label(): ln for ln in zoom.get_lines()}
    est = lines[r"$\rho$"]
    assert est.get_ydata()[0] == pytest.approx(-1.0)  # the estimate starts at rho(0) = -1
    assert est.get_ydata()[-1] > 0  # and has switched inside the zoom window
    assert len(est.get_xdata()) > 10  # at full resolution
    # a run whose estimate never has the wrong sign gets no zoom panel
    assert len(plot(_short_run("hypersonic-sign-s1-rho0pos", 30.0), "direction").axes) == 3
    with pytest.raises(ValueError, match="`zoom` must be"):
        plot(r, "direction", zoom=[1.0, 0.5])


def test_save_figure_writes_vector_formats_beside_png_at_the_chosen_dpi(direct, tmp_path):
    spec = {"number": "2.1", "kind": "tracking", "caption": "Angle of attack"}
    path = save_figure(
        direct, spec, tmp_path / "fig_2.1.png", formats=("png", "pdf", "svg"), dpi=80
    )
    assert path == tmp_path / "fig_2.1.png"
    assert (tmp_path / "fig_2.1.pdf").read_bytes()[:5] == b"%PDF-"
    assert b"<svg" in (tmp_path / "fig_2.1.svg").read_bytes()[:2000]
    import matplotlib.image as mpimg

    width_px = mpimg.imread(path).shape[1]
    assert width_px == pytest.approx(plot(direct, "tracking").get_figwidth() * 80, abs=2)
    assert DPI >= 150
    with pytest.raises(ValueError, match="Unknown figure format 'jpeg'"):
        check_formats(["png", "jpeg"])


def test_figures_of_a_user_scenario_are_titled_by_the_scenario_not_fig_1(direct, tmp_path):
    specs = default_figure_specs(direct, title="My hypersonic test")
    assert all("number" not in s for s in specs)
    assert specs[0]["caption"] == "My hypersonic test: outputs and references"
    save_figure(direct, specs[0], tmp_path / "t.png")
    fp = plot(direct, "tracking", title=specs[0]["caption"])
    assert fp.figure._suptitle.get_text() == "My hypersonic test: outputs and references"
