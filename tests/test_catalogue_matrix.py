"""Catalogue conformance matrix: every catalogue scenario under every command and solver family.

Each case names its scenario and command (or solver) in its test id, e.g.
``test_aftc_run[hypersonic-direct-s1-noise]`` or ``test_solver_family[wingrock-free-1deg-Radau]``:

* ``aftc validate NAME`` and ``aftc run NAME`` with its baselines (through :func:`cli.main`,
  in process; ``--t-final`` keeps the runs short) exit 0;
* the reproduction's per-scenario task (:func:`reproduce._simulate_task`, quick mode shortened
  further) runs every variant of the scenario without an error;
* a short run of every scenario with every solver family (fixed-step, adaptive explicit,
  Rosenbrock, ``auto``, each scipy method) completes with finite states (RK4, DOPRI5 and
  ``auto`` run through the scenario's first failure);
* the docs' example scenario files (TOML blocks of docs/*.md that are whole scenarios, and
  examples/*.toml) are validated and run the same way.

Runs are a few seconds of simulated time (the scipy methods, which run at Python speed, a
fraction of a second), so the whole matrix costs little CPU time once the catalogue's loops are
compiled (they are cached on disk and shared with the rest of the suite).
"""

from __future__ import annotations

import re
import tomllib
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from adaptive_ftc import SolverOptions, list_scenarios, load_scenario, simulate
from adaptive_ftc.cli import EXIT_NOT_COMPENSABLE, EXIT_OK, main

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = tuple(list_scenarios())

#: simulated seconds of the short runs: compiled paths, and the scipy path (Python speed)
SHORT, SHORT_SCIPY = 2.0, 0.25

_SCIPY = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
#: every solver family: fixed-step, adaptive explicit, Rosenbrock, stiffness switching, and
#: each scipy method
METHODS = ("rk4", "dopri5", "rodasp", "rodas5p", "auto", *_SCIPY)

#: fixed steps of scenarios that run an adaptive-step method and are too stiff for RK4 at the
#: default step (1e-3 s): wing-rock estimation needs dt < 3e-5 s (eigenvalue ~8.9e4 1/s; the
#: scenario files' notes), and diverges within 2 ms at 1e-3 s
RK4_DT = {"wingrock-estimation-s1": 2e-5, "wingrock-estimation-s2": 2e-5}

#: methods cheap enough to run each scenario through its first failure (+1 s): the restart at
#: a failure time is exercised too. The Rosenbrock methods are not: at the manipulator's
#: tolerances RODASP needs 33 s of CPU for its first 9 s (DOPRI5: 0.03 s)
THROUGH_FIRST_FAILURE = ("rk4", "dopri5", "auto")


def _t_final(t0: float, t_final: float, span: float = SHORT) -> float:
    return min(t_final, t0 + span)


def _first_failure(sc) -> float | None:
    t0, t1 = sc.loop.t0, sc.loop.t_final
    times = sorted(t for f in sc.loop.failures.failures for t in f.jump_times if t0 < t < t1)
    return times[0] if times else None


def _cli(capsys, *argv: str) -> tuple[int, str]:
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out + out.err


# ------------------------------------------------------------------------------ aftc commands
@pytest.mark.parametrize("name", SCENARIOS)
def test_aftc_validate(name, capsys):
    code, text = _cli(capsys, "validate", name)
    # an open loop (design "none": a zero allocation, the free wing-rock motion) has no
    # effective actuator: validate calls it not compensable (pinned by test_validation.py)
    expected = EXIT_OK if load_scenario(name).loop.R.any() else EXIT_NOT_COMPENSABLE
    assert code == expected, f"aftc validate {name} exited {code}:\n{text}"


@pytest.mark.parametrize("name", SCENARIOS)
def test_aftc_run(name, tmp_path, capsys):
    sc = load_scenario(name)
    t_final = _t_final(sc.loop.t0, sc.loop.t_final)
    argv = ("run", name, "--out", str(tmp_path), "--quiet", "--t-final", repr(t_final))
    code, text = _cli(capsys, *argv)
    assert code == EXIT_OK, f"aftc {' '.join(argv)} exited {code}:\n{text}"
    assert (tmp_path / "data" / f"{sc.name}.nc").is_file()
    assert (tmp_path / "metrics.json").is_file()
    # the baselines ran too (a fixed-gain baseline may be skipped with a note, not an error)
    expected = ["frozen", "failure_free"]
    if sc.loop.adapt and sc.loop.controller.design not in ("nominal-inverse", "oracle"):
        expected += ["nominal-inverse", "oracle"]  # one naming scheme with reproduce
    for key in expected:
        assert (tmp_path / "data" / f"{sc.name}_{key}.nc").is_file(), key


@pytest.mark.parametrize("name", SCENARIOS)
def test_reproduce_task(name, tmp_path, monkeypatch):
    from adaptive_ftc import reproduce

    # quick mode, shortened to a few seconds; the cache of loaded scenarios starts empty
    monkeypatch.setattr(
        reproduce, "quick_duration", lambda sc: _t_final(sc.loop.t0, sc.loop.t_final)
    )
    monkeypatch.setattr(reproduce, "_LOADED", {})
    (tmp_path / "data").mkdir()
    sc = load_scenario(name)
    for variant in reproduce._variants(sc, all_baselines=True):
        out = reproduce._simulate_task(name, variant, True, str(tmp_path))
        assert not out["error"] or out.get("skipped"), (
            f"reproduce task {name} / {variant}: {out['error']}"
        )
        if variant == "adaptive":  # a baseline may diverge (frozen adaptation): a result
            assert out["result"].status == "completed", f"{name}: {out['result'].message}"


# ------------------------------------------------------------------------------ solver families
@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", SCENARIOS)
def test_solver_family(name, method):
    sc = load_scenario(name)
    span = SHORT_SCIPY if method in _SCIPY else SHORT
    first = _first_failure(sc)
    if method in THROUGH_FIRST_FAILURE and first is not None:
        span = first + 1.0 - sc.loop.t0
    loop = replace(sc.loop, t_final=_t_final(sc.loop.t0, sc.loop.t_final, span))
    solver = replace(sc.solver, method=method)
    if method == "rk4" and name in RK4_DT:
        solver = replace(solver, dt=RK4_DT[name])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the status is checked below
        r = simulate(loop, solver)
    assert r.status == "completed", f"{name} with method {method!r}: {r.message}"
    assert r.time[-1] == pytest.approx(loop.t_final)
    assert np.isfinite(r.states).all() and np.isfinite(r.adaptive).all()
    assert r.meta["steps"] > 0 and r.meta["rhs_evaluations"] > 0
    if method in THROUGH_FIRST_FAILURE and first is not None:
        assert first in r.failure_times


# ------------------------------------------------------------------------------ docs' examples
def _doc_scenarios() -> list[tuple[str, str]]:
    """``(id, text)`` of every whole scenario file in the docs: TOML blocks of docs/*.md with
    a plant, a reference and a controller, and examples/*.toml."""
    out = []
    for page in sorted((ROOT / "docs").glob("*.md")):
        blocks = re.findall(r"```toml\n(.*?)```", page.read_text(encoding="utf-8"), flags=re.S)
        for i, block in enumerate(blocks):
            table = tomllib.loads(block)
            if {"plant", "reference", "controller"} <= table.keys():
                out.append((f"docs/{page.name}#{i + 1}", block))
    for path in sorted((ROOT / "examples").glob("*.toml")):
        out.append((f"examples/{path.name}", path.read_text(encoding="utf-8")))
    return out


_DOCS = _doc_scenarios()


def test_the_docs_have_example_scenario_files():
    ids = [i for i, _ in _DOCS]
    assert "docs/scenario-format.md#1" in ids and "examples/own_plant.toml" in ids, ids


@pytest.mark.parametrize(("where", "text"), _DOCS, ids=[i for i, _ in _DOCS])
def test_docs_example_validates_and_runs(where, text, tmp_path, capsys):
    path = tmp_path / "example.toml"
    path.write_text(text, encoding="utf-8")
    code, out = _cli(capsys, "validate", str(path))
    assert code == EXIT_OK, f"aftc validate ({where}) exited {code}:\n{out}"
    sc = load_scenario(path)
    t_final = _t_final(sc.loop.t0, sc.loop.t_final)
    argv = ("run", str(path), "--out", str(tmp_path / "out"), "--quiet", "--t-final", repr(t_final))
    code, out = _cli(capsys, *argv)
    assert code == EXIT_OK, f"aftc run ({where}) exited {code}:\n{out}"


# ------------------------------------------------------------------------------ --t-final
def test_run_t_final_shortens_the_run_and_is_checked(tmp_path, capsys):
    import xarray as xr

    code, text = _cli(
        capsys, "run", "pendulum-direct", "--out", str(tmp_path), "--quiet", "--no-baselines",
        "--t-final", "1.5",
    )  # fmt: skip
    assert code == EXIT_OK, text
    # time is CF "seconds since 1970-01-01": read it as plain seconds
    with xr.open_dataset(tmp_path / "data" / "pendulum-direct.nc", decode_times=False) as ds:
        assert float(ds["time"][-1]) == pytest.approx(1.5)
    code, text = _cli(capsys, "run", "pendulum-direct", "--out", str(tmp_path), "--t-final", "-1")
    assert code == 2 and "--t-final" in text


def test_run_t_final_leaves_the_claims_of_a_shortened_run_unjudged(tmp_path, capsys):
    sc = load_scenario("wingrock-free-1deg")  # a limit-cycle claim over its last 2 s of 10 s
    assert sc.claims and sc.loop.t_final == 10.0
    code, text = _cli(capsys, "run", sc.name, "--out", str(tmp_path), "--quiet", "--t-final", "1")
    assert code == EXIT_OK, text
    assert f"its {len(sc.claims)} claim(s) are not judged" in text
    assert not (tmp_path / "claims.csv").exists()
    # the whole duration (or more) keeps them
    code, text = _cli(capsys, "run", sc.name, "--out", str(tmp_path), "--quiet", "--t-final", "10")
    assert "not judged" not in text


def test_scipy_and_compiled_families_are_all_covered():
    from adaptive_ftc.sim import engine

    assert set(METHODS) == set(engine._METHODS) - {"accurate"}  # "accurate" is "auto"
    assert set(_SCIPY) == set(engine._SCIPY_METHODS)
    assert SolverOptions(method="accurate").compiled_method == "auto"
