"""The aftc command line as a new user meets it (issue 28): help texts, list width, solver
options, file names, subsets, campaign specs, missing dependencies, first-run feedback, the
solvers page against the catalogue, t_eval and the python-control export's inputs."""

from __future__ import annotations

import math
import re
import sys
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from adaptive_ftc.cli import LIST_WIDTH, main

ROOT = Path(__file__).resolve().parents[1]
SUBCOMMANDS = ("list", "validate", "run", "reproduce", "schema", "campaign", "study")


# ----------------------------------------------------------------------------- help texts
@pytest.mark.parametrize("command", SUBCOMMANDS)
def test_every_subcommand_has_a_description_and_keeps_its_exit_status_lines(command, capsys):
    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    usage, _, rest = out.partition("\n\n")
    description = rest.split("\n\n")[0]
    assert not description.lstrip().startswith(("positional", "options")), out
    assert len(description.split()) >= 8, description
    assert max(map(len, description.splitlines())) <= 100, description  # wrapped
    # the epilog's table, one code a line, not reflowed into a paragraph
    codes = re.findall(r"^  (\d+) +\S", out, flags=re.M)
    assert "exit status:" in out and "0" in codes and "2" in codes and len(codes) >= 3, out


# ----------------------------------------------------------------------------- list
def test_list_fits_100_columns_and_long_has_the_full_titles(capsys):
    from adaptive_ftc.scenarios.loader import list_scenarios, load_scenario

    assert main(["list"]) == 0
    short = capsys.readouterr().out.splitlines()
    assert max(map(len, short)) <= LIST_WIDTH == 100
    names = list_scenarios()
    assert all(any(line.startswith(n + " ") for line in short) for n in names)
    assert main(["list", "--long"]) == 0
    long = capsys.readouterr().out
    for n in names:
        sc = load_scenario(n)
        assert sc.title in long
        for fig in sc.figures:
            assert fig in long


def test_list_ranges_consecutive_figures():
    from adaptive_ftc.cli import _figure_ranges

    assert _figure_ranges(["3.9", "3.10", "3.11", "3.13"]) == "3.9-3.11, 3.13"
    assert _figure_ranges(["2.5a"]) == "2.5a"
    assert _figure_ranges(["2.1", "3.2"]) == "2.1, 3.2"
    assert _figure_ranges(["4.11", "4.12"]) == "4.11, 4.12"


# ----------------------------------------------------------------------------- run options
def test_run_method_offers_every_solver(capsys):
    from adaptive_ftc.sim.engine import _METHODS

    assert main(["run", "--help"]) == 0
    help_text = " ".join(capsys.readouterr().out.split())
    for method in _METHODS:
        assert method in help_text
    assert main(["run", "hypersonic-direct-s1", "--method", "euler"]) == 2
    assert "euler" in capsys.readouterr().err


def test_dt_with_an_adaptive_method_is_an_error_that_names_the_fix(tmp_path, capsys):
    out = tmp_path / "o"
    # the catalogue's hypersonic-direct-s1 runs dopri5
    assert main(["run", "hypersonic-direct-s1", "--dt", "1e-3", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--dt" in err and "dopri5" in err and "--method rk4" in err and "max_step" in err
    assert not out.exists()
    # an explicit --method with a fixed step is the same error
    assert main(["run", "wingrock-free-1deg", "--method", "rodas5p", "--dt", "1e-3"]) == 2


def test_run_refuses_a_bad_figure_format_before_writing(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["run", "wingrock-free-1deg", "--out", str(out), "--formats", "png,gif"]) == 2
    assert "gif" in capsys.readouterr().err
    assert not out.exists()


def test_run_names_baselines_like_reproduce_writes_formats_and_says_what_it_does(
    tmp_path, capsys, monkeypatch
):
    """One naming scheme (data/<name>_fixed-gain.nc as in reproduce), --formats/--dpi, a
    compiling line before the first compile and the files being written after the runs."""
    from adaptive_ftc import _feedback, baselines
    from adaptive_ftc.reproduce import _data_path
    from adaptive_ftc.sim import compose

    monkeypatch.setattr(compose, "is_compiled", lambda loop, sdot="exact": False)
    order: list[str] = []
    for module, name in ((_feedback, "compile_plan"), (baselines, "baseline_loop")):
        real = getattr(module, name)

        def spy(*a, _real=real, _name=name, **k):
            order.append(_name)
            return _real(*a, **k)

        monkeypatch.setattr(module, name, spy)
    src = tmp_path / "short.toml"
    src.write_text(
        'extends = "hypersonic-direct-s1"\nname = "short"\nfigures = ["2.1"]\nduration = 12.0\n'
    )
    out = tmp_path / "o"
    args = ["run", str(src), "--out", str(out), "--formats", "png,svg", "--dpi", "40"]
    assert main(args) == 0
    err = capsys.readouterr().err
    # adaptive, frozen, failure-free and fixed-gain share one structure; the exact inverse
    # (nominal-inverse and oracle) is another
    assert re.search(r"compiling 2 loop structures \(first run only, ~\d+ s", err), err
    # the line comes before the fixed-gain baseline's tuning run, the first compile
    assert order[0] == "compile_plan" and "baseline_loop" in order, order
    assert "writing" in err and "figures/fig_" in err
    data = sorted(p.name for p in (out / "data").iterdir())
    for variant in ("frozen", "failure_free", "fixed-gain", "nominal-inverse", "oracle"):
        assert _data_path(out, "short", variant).name in data
    assert not [n for n in data if "fixed_gain" in n or "nominal_inverse" in n]
    pngs = sorted((out / "figures").glob("*.png"))
    assert pngs and all(p.with_suffix(".svg").is_file() for p in pngs)
    assert not list((out / "figures").glob("*.pdf"))


# ----------------------------------------------------------------------------- reproduce
def test_reproduce_a_chosen_subset_with_a_fixed_progress_total(tmp_path, capsys, monkeypatch):
    import tqdm.auto

    totals: list[tuple[int, int]] = []
    real = tqdm.auto.tqdm

    class Recording(real):
        def refresh(self, *a, **k):
            totals.append((self.n, self.total))
            return super().refresh(*a, **k)

        def update(self, n=1):
            out = super().update(n)
            totals.append((self.n, self.total))
            return out

    monkeypatch.setattr(tqdm.auto, "tqdm", Recording)
    out = tmp_path / "r"
    args = ["reproduce", "hypersonic-direct-s1", "--out", str(out), "--quick", "--jobs", "1"]
    assert main(args) == 0
    stdout = capsys.readouterr().out
    assert "reproduced 1 scenarios" in stdout
    rows = (out / "metrics.csv").read_text().splitlines()[1:]
    assert rows and all(r.startswith("hypersonic-direct-s1,") for r in rows)
    assert {t for _, t in totals} == {totals[0][1]}, totals  # the total never changes
    assert totals[-1][0] == totals[-1][1]  # and the bar ends at 100 %
    # quick mode: the runs the claims need (the adaptive run; its baseline_ratio claim's
    # frozen, fixed-gain and nominal-inverse baselines), no figures, no data files
    assert totals[0][1] == 4
    assert not (out / "figures").exists() and not (out / "data").exists()
    # the output and the report say how many claims quick mode judged
    claims = (out / "claims.csv").read_text().splitlines()[1:]
    judged = sum(",NOT EVALUATED," not in row for row in claims)
    assert f"quick mode judged {judged} of {len(claims)} claims" in stdout
    assert f"judged <b>{judged} of {len(claims)} claims" in (out / "report.html").read_text()


def test_reproduce_says_what_it_compiles_before_the_bar(tmp_path, capsys, monkeypatch):
    from adaptive_ftc.sim import compose

    monkeypatch.setattr(compose, "is_compiled", lambda loop, sdot="exact": False)
    out = tmp_path / "r"
    args = ["reproduce", "wingrock-free-1deg", "--out", str(out), "--quick", "--jobs", "1"]
    assert main(args) == 0
    err = capsys.readouterr().err
    line = re.search(r"compiling 1 loop structure \(first run only, ~\d+ s", err)
    assert line, err
    assert "reproduce:" not in err[: line.start()]  # before the bar starts


def test_reproduce_an_unknown_name_is_refused_before_writing(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["reproduce", "wingrock-free-1dg", "--out", str(out)]) == 2
    assert "wingrock-free-1deg" in capsys.readouterr().err  # did you mean
    assert not out.exists()
    own = tmp_path / "own.toml"
    own.write_text('extends = "wingrock-free-1deg"\nname = "own"\n')
    assert main(["reproduce", str(own), "--out", str(out)]) == 2
    assert "aftc run" in capsys.readouterr().err
    assert not out.exists()


# ----------------------------------------------------------------------------- campaigns
def test_campaign_show_prints_and_init_copies_a_shipped_spec(tmp_path, capsys):
    from adaptive_ftc.campaigns.spec import EXAMPLES, list_campaigns, load_campaign

    name = list_campaigns()[0]
    shipped = (EXAMPLES / f"{name}.toml").read_text(encoding="utf-8")
    assert main(["campaign", "show", name]) == 0
    assert capsys.readouterr().out == shipped
    target = tmp_path / "mine.toml"
    assert main(["campaign", "init", name, str(target)]) == 0
    assert target.read_text(encoding="utf-8") == shipped
    assert load_campaign(target).name == name  # the copy loads from its new place
    assert main(["campaign", "init", name, str(target)]) == 2  # never overwrites
    assert "exists" in capsys.readouterr().err
    assert main(["campaign", "show", "hypersonic-le"]) == 2
    assert "hypersonic-loe" in capsys.readouterr().err


def test_missing_pyarrow_is_caught_before_anything_is_written(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import pyarrow -> ImportError
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    out = tmp_path / "c"
    assert main(["campaign", "hypersonic-loe", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert not out.exists()
    assert "%" not in err  # no progress bar started
    assert 'pip install -e ".[campaigns]"' in err and 'pip install "adaptive-ftc[campaigns]"' in err
    # the extra it names exists in this project and holds the package it names
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert project["name"] == "adaptive-ftc"
    assert any(r.startswith("pyarrow") for r in project["optional-dependencies"]["campaigns"])
    assert "pip install pyarrow" in err


# ----------------------------------------------------------------------------- first run
def test_compile_plan_counts_distinct_uncompiled_structures(monkeypatch):
    from adaptive_ftc import _feedback, load_scenario
    from adaptive_ftc.sim import compose

    loop = load_scenario("hypersonic-direct-s1").loop
    pairs = [(loop, "exact"), (loop.frozen(), "exact"), (loop.without_failures(), "exact")]
    texts = {compose.generate(lp, sdot=s)[0] for lp, s in pairs}
    monkeypatch.setattr(compose, "is_compiled", lambda lp, sdot="exact": False)
    n, seconds = _feedback.compile_plan(pairs)
    assert n == len(texts)
    assert seconds >= n * _feedback.SECONDS_PER_STRUCTURE
    monkeypatch.setattr(compose, "is_compiled", lambda lp, sdot="exact": True)
    assert _feedback.compile_plan(pairs) == (0, 0.0)


# ----------------------------------------------------------------------------- solvers page
BEGIN = "<!-- catalogue-solvers:begin -->"
END = "<!-- catalogue-solvers:end -->"


def catalogue_solver_table() -> str:
    """The table of docs/solvers.md between the markers, from the catalogue itself."""
    from adaptive_ftc.scenarios.loader import list_scenarios, load_scenario

    lines = [
        "| scenario | method | step / tolerances | recorded every |",
        "|---|---|---|---|",
    ]
    for name in list_scenarios():
        s = load_scenario(name).solver
        if s.compiled_method == "rk4":
            setting = f"dt {s.dt:g} s"
        else:
            atol = "per state" if isinstance(s.atol, tuple) else f"{s.atol:g}"
            setting = f"rtol {s.rtol:g}, atol {atol}"
            if math.isfinite(s.max_step):
                setting += f", max_step {s.max_step:g} s"
        lines.append(f"| {name} | {s.method} | {setting} | {s.record_dt:g} s |")
    return "\n".join(lines)


def test_solvers_page_states_the_tolerances_the_catalogue_uses():
    text = (ROOT / "docs" / "solvers.md").read_text(encoding="utf-8")
    assert BEGIN in text and END in text
    table = text.split(BEGIN)[1].split(END)[0].strip()
    want = catalogue_solver_table()
    assert table == want, "docs/solvers.md is out of date; the table should read:\n" + want
    # and the prose does not contradict it (issue 28: s2 inherits s1's rtol 1e-6)
    assert "| hypersonic-direct-s2 | dopri5 | rtol 1e-06" in want


# ----------------------------------------------------------------------------- t_eval
def test_simulate_records_on_a_user_grid():
    from adaptive_ftc import load_scenario, simulate

    sc = load_scenario("hypersonic-direct-s1")
    loop = replace(sc.loop, t_final=3.0)
    default = simulate(loop, sc.solver)
    grid = np.linspace(0.0, 3.0, 1201)  # 2.5 ms: finer than record_dt = 10 ms
    dense = simulate(loop, sc.solver, t_eval=grid)
    np.testing.assert_array_equal(dense.time, grid)
    common = np.isin(np.round(grid, 9), np.round(default.time, 9))
    assert common.sum() == default.time.size
    # the steps do not depend on the grid: the same interpolant read at the same times
    np.testing.assert_allclose(dense.states[common], default.states, rtol=0, atol=1e-12)
    np.testing.assert_allclose(dense.adaptive[common], default.adaptive, rtol=0, atol=1e-12)
    # also on RK4 (Hermite between steps, exact where a step ends)
    rk4 = replace(sc.solver, method="rk4")
    a, b = simulate(loop, rk4), simulate(loop, rk4, t_eval=grid)
    np.testing.assert_allclose(b.states[common], a.states, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("t_eval", "words"),
    [
        ([0.0, 2.0, 1.0], "strictly increasing"),
        ([0.0, 5.0], "outside the run"),
        ([[0.0, 1.0]], "1-D"),
        ([0.0, float("nan")], "non-finite"),
    ],
)
def test_a_bad_t_eval_is_a_clear_error(t_eval, words):
    from adaptive_ftc import ConfigurationError, load_scenario, simulate

    sc = load_scenario("hypersonic-direct-s1")
    with pytest.raises(ConfigurationError, match=words):
        simulate(replace(sc.loop, t_final=3.0), sc.solver, t_eval=t_eval)


# ----------------------------------------------------------------------------- python-control
def test_control_export_takes_the_reference_as_inputs_and_interconnects():
    """The loop with its reference as inputs, fed by a reference source system through
    control.interconnect, matches our simulate (same sin reference) before the first failure,
    where python-control integrates without jumps."""
    control = pytest.importorskip("control")
    from adaptive_ftc import SolverOptions, load_scenario, simulate
    from adaptive_ftc.interop import control_initial_state, reference_input_names, to_control

    loop = load_scenario("hypersonic-direct-s1").loop
    first = loop.failures.breakpoints(loop.t0, loop.t_final)[1]
    short = replace(loop, t_final=min(first, 20.0))
    ours = simulate(short, SolverOptions(method="dopri5", rtol=1e-11, atol=1e-13, record_dt=0.05))
    sys_ = to_control(short, inputs=("reference",))
    names = reference_input_names(short)
    assert list(sys_.input_labels) == names == ["yd_alpha", "yd_alpha_dot", "yd_alpha_ddot"]
    # the catalogue's reference pi/36 sin(0.2 t) and its derivatives, as a source system
    a, w = math.pi / 36, 0.2
    source = control.NonlinearIOSystem(
        None,
        lambda t, x, u, params: [
            a * math.sin(w * t),
            a * w * math.cos(w * t),
            -a * w * w * math.sin(w * t),
        ],
        inputs=0,
        outputs=names,
        name="reference",
    )
    closed = control.interconnect(
        [source, sys_], inputs=[], outputs=list(sys_.output_labels), name="wired"
    )
    resp = control.input_output_response(
        closed,
        ours.time,
        initial_state=control_initial_state(short),
        solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12},
    )
    assert resp.success
    err = np.abs(np.ravel(resp.outputs) - ours.y[:, 0]).max()
    assert err < 1e-8, err
    # a different reference through the inputs gives a different response
    zero = control.input_output_response(
        sys_, ours.time[:20], U=np.zeros((3, 20)), initial_state=control_initial_state(short)
    )
    assert np.abs(np.ravel(zero.outputs) - ours.y[:20, 0]).max() > 0


def test_control_export_disturbance_adds_to_the_velocity_derivative():
    pytest.importorskip("control")
    from adaptive_ftc import ConfigurationError, load_scenario
    from adaptive_ftc.interop import control_initial_state, to_control

    loop = load_scenario("hypersonic-direct-s1").loop
    plain = to_control(loop)
    sys_ = to_control(loop, inputs=("disturbance",))
    assert list(sys_.input_labels) == ["d_alpha"]
    x = control_initial_state(loop) + 0.01
    base = plain.updfcn(1.0, x, [], None)
    got = sys_.updfcn(1.0, x, [0.25], None)
    want = base.copy()
    want[loop.plant.velocity_index[0]] += 0.25
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    both = to_control(loop, inputs=("reference", "disturbance"))
    assert both.ninputs == 4
    with pytest.raises(ConfigurationError, match="reference"):
        to_control(loop, inputs=("wind",))


def test_interop_page_example_runs_on_a_dense_grid_and_agrees(monkeypatch):
    """docs/interop.md's example: a dense grid (not 4 points), the interconnected reference
    source, and python-control against simulate(t_eval=T) (measured 7e-11 and 4e-12 rad)."""
    pytest.importorskip("control")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    text = (ROOT / "docs" / "interop.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    ns: dict = {}
    for block in blocks:
        exec(block, ns)  # noqa: S102 - the page's own example
    plt.close("all")
    assert ns["T"].size >= 1000 and ns["ours"].time.size == ns["T"].size
    assert np.abs(ns["full"].outputs[0] - ns["ours"].y[:, 0]).max() < 1e-8
    early = ns["T"] < 40.0
    assert np.abs(ns["resp"].outputs[0] - ns["ours"].y[early, 0]).max() < 1e-8
