"""Time to first result (issue 29): what ``aftc run`` imports and computes on its warm path, and
that the faster path writes what the slower one did."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy
from scipy.signal import butter, sosfilt_zi, sosfiltfilt

from adaptive_ftc.sim import zerophase


@pytest.mark.parametrize("fs", [1000.0, 200.0, 1234.5])
def test_the_compiled_zero_phase_lowpass_is_scipys_bit_for_bit(fs):
    rng = np.random.default_rng(int(fs))
    sos, zi = zerophase.lowpass_design(4, 1.0, fs)
    truth = butter(4, 1.0, btype="low", fs=fs, output="sos")
    assert np.array_equal(sos, truth)
    assert np.array_equal(zi, sosfilt_zi(truth))
    for n, pad in ((5000, 3000), (400, 399), (100, 27)):
        u = np.cumsum(rng.standard_normal((n, 3)), axis=0) * 1e-3 + 1e-2 * rng.standard_normal(
            (n, 3)
        )
        expected = sosfiltfilt(truth, u, axis=0, padtype="odd", padlen=pad)
        assert np.array_equal(zerophase.sosfiltfilt_odd(sos, zi, u, pad), expected)


def test_a_lowpass_design_is_read_back_from_the_cache_folder_not_redesigned(tmp_path, monkeypatch):
    monkeypatch.setenv("ADAPTIVE_FTC_CACHE_DIR", str(tmp_path))
    zerophase.lowpass_design.cache_clear()
    sos, zi = zerophase.lowpass_design(4, 1.0, 977.0)
    (stored,) = (tmp_path / "loops").glob("lowpass_*.json")
    # a later process reads the file: make it say something scipy would not, to see it used
    data = json.loads(stored.read_text())
    data["sos"][0][0] = 0.5
    stored.write_text(json.dumps(data))
    zerophase.lowpass_design.cache_clear()
    again, _ = zerophase.lowpass_design(4, 1.0, 977.0)
    assert again[0, 0] == 0.5 and np.array_equal(again[1:], sos[1:])
    # a damaged file is redesigned (and rewritten), never an error
    stored.write_text("{not json")
    zerophase.lowpass_design.cache_clear()
    fresh, fresh_zi = zerophase.lowpass_design(4, 1.0, 977.0)
    assert np.array_equal(fresh, sos) and np.array_equal(fresh_zi, zi)
    assert json.loads(stored.read_text())["sos"] == sos.tolist()
    # a design of another scipy version is redesigned by this one
    data = json.loads(stored.read_text())
    data["sos"][0][0] = 0.5
    data["key"] = data["key"].replace(scipy.__version__, "0.0.0")
    stored.write_text(json.dumps(data))
    zerophase.lowpass_design.cache_clear()
    assert np.array_equal(zerophase.lowpass_design(4, 1.0, 977.0)[0], sos)
    zerophase.lowpass_design.cache_clear()


# ------------------------------------------------------------------------------ data files
def _xarray_netcdf(result, path, *, float32=False, decimate=1, complevel=4):
    """The file as SimResult.to_netcdf wrote it through xarray until issue 29: the truth the
    direct netCDF4 writer (sim/ncwrite.py) is held to, byte for byte."""
    ds = result.to_xarray(decimate=decimate, float32=float32)
    encoding = {}
    for name, var in ds.variables.items():
        if var.dtype.kind != "f":
            continue
        enc = {"_FillValue": None}
        if complevel and var.ndim and var.size:
            enc.update(zlib=True, complevel=complevel, shuffle=True)
        if float32 and name != "time":
            enc["dtype"] = "float32"
        encoding[str(name)] = enc
    ds.to_netcdf(path, engine="netcdf4", format="NETCDF4", encoding=encoding)


def _short_runs(name: str, t_final: float = 0.5):
    from adaptive_ftc.baselines import baseline_loop
    from adaptive_ftc.scenarios.loader import load_scenario
    from adaptive_ftc.sim.engine import simulate

    sc = load_scenario(name)
    loop = replace(sc.loop, t_final=t_final)
    runs = [simulate(loop, sc.solver), simulate(baseline_loop(loop, "fixed-gain", sc.solver))]
    return [sc.stamp(r) for r in runs]


@pytest.mark.parametrize("name", ["hypersonic-direct-s1-actuators", "spacecraft-mimo-s1"])
def test_data_files_are_the_bytes_xarray_wrote(name, tmp_path):
    runs = _short_runs(name)
    # and a run without adaptive parameters (an empty dimension, labels of no text)
    r = runs[0]
    runs.append(replace(r, adaptive=r.adaptive[:, :0], adaptive_names=(), theta_slices=(), meta={}))
    assert runs[0].actuator_position is not None or len(runs[0].output_names) > 1
    for i, r in enumerate(runs):
        for options in ({}, {"float32": True, "decimate": 7}, {"complevel": 0}):
            truth, ours = tmp_path / f"xarray{i}.nc", tmp_path / f"ours{i}.nc"
            _xarray_netcdf(r, truth, **options)
            r.to_netcdf(ours, **options)
            assert ours.read_bytes() == truth.read_bytes(), (i, options)


# ------------------------------------------------------------------------------ aftc run
_HEAVY = ("matplotlib", "xarray", "pandas", "dask", "distributed", "scipy.signal", "scipy.stats")


def _aftc_run_in_a_new_process(args: list[str]) -> dict:
    """``aftc run ARGS`` in a fresh interpreter, after a first one filled the caches (the warm
    path: a first run compiles, and designs the activity low-pass with scipy.signal): its exit
    status and which heavy libraries the second process itself imported."""
    out_at = args.index("--out") + 1
    first = [*args[:out_at], args[out_at] + "-first", *args[out_at + 1 :]]
    code = (
        "import json, sys\n"
        "from adaptive_ftc.cli import main\n"
        f"status = main({args!r})\n"
        f"heavy = [m for m in {_HEAVY!r} if m in sys.modules]\n"
        "print(json.dumps({'status': status, 'heavy': heavy}))\n"
    )
    src = Path(__file__).resolve().parents[1] / "src"
    env = {**os.environ, "PYTHONPATH": str(src) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    for argv in (first, args):
        out = subprocess.run(
            [sys.executable, "-c", code.replace(repr(args), repr(argv))],
            capture_output=True,
            text=True,
            timeout=600,
            env=env,
        )
        assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_aftc_run_without_figures_imports_no_plotting_or_table_library(tmp_path):
    out = tmp_path / "out"
    got = _aftc_run_in_a_new_process(
        [
            "run",
            "hypersonic-direct-s1",
            "--t-final",
            "1",
            "--no-figures",
            "--quiet",
            "--out",
            str(out),
        ]
    )
    assert got == {"status": 0, "heavy": []}
    assert sorted(p.name for p in (out / "data").iterdir())[0] == "hypersonic-direct-s1.nc"
    assert not (out / "figures").exists()
    assert json.loads((out / "metrics.json").read_text())["figures"] == []


def _figure_process_available() -> bool:
    from adaptive_ftc._figure_process import FigureProcess

    proc = FigureProcess.start()
    if proc is None:
        return False
    proc.close()
    return True


needs_figure_process = pytest.mark.skipif(
    not _figure_process_available(), reason="figures are drawn in-process here (no fork, 1 CPU)"
)


@needs_figure_process
def test_aftc_run_draws_its_figures_in_a_second_process(tmp_path):
    out = tmp_path / "out"
    got = _aftc_run_in_a_new_process(
        ["run", "hypersonic-direct-s1", "--t-final", "1", "--quiet", "--out", str(out)]
    )
    # the figures are there, and the process that ran the loops never loaded matplotlib
    assert got == {"status": 0, "heavy": []}
    assert sorted(p.name for p in (out / "figures").iterdir()) == ["fig_2.1.png", "fig_2.2.png"]


def _files(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }


@needs_figure_process
def test_figures_from_the_second_process_are_the_ones_drawn_in_process(
    tmp_path, monkeypatch, capsys
):
    from adaptive_ftc._figure_process import FigureProcess
    from adaptive_ftc.cli import main

    args = ["run", "hypersonic-direct-s1", "--t-final", "3", "--quiet", "--out"]
    assert main([*args, str(tmp_path / "forked")]) == 0
    monkeypatch.setattr(FigureProcess, "start", classmethod(lambda cls: None))
    assert main([*args, str(tmp_path / "here")]) == 0
    forked, here = _files(tmp_path / "forked"), _files(tmp_path / "here")
    metrics = "metrics.json"
    assert forked.pop(metrics).replace(b"forked", b"here") == here.pop(metrics)
    assert set(forked) == set(here) and len(forked) == 8  # 6 data files, 2 figures
    for name in forked:
        assert forked[name] == here[name], name


@needs_figure_process
def test_a_figure_that_fails_in_the_second_process_fails_the_run_and_writes_nothing(
    tmp_path, monkeypatch, capsys
):
    from adaptive_ftc import plots
    from adaptive_ftc.cli import EXIT_INTERNAL, EXIT_INVALID, main
    from adaptive_ftc.errors import ConfigurationError

    def refuse(*args, **kwargs):
        raise ConfigurationError("figure refused: the culprit, and the fix")

    # the child is a fork: it inherits the patched function
    monkeypatch.setattr(plots, "save_figure", refuse)
    args = ["run", "hypersonic-direct-s1", "--t-final", "1", "--quiet", "--out"]
    assert main([*args, str(tmp_path / "a")]) == EXIT_INVALID
    assert "error: figure refused: the culprit, and the fix" in capsys.readouterr().err
    assert not (tmp_path / "a").exists() or not any((tmp_path / "a").iterdir())

    def vanish(*args, **kwargs):
        os._exit(3)  # the child dies without a word: the parent must not wait for it

    monkeypatch.setattr(plots, "save_figure", vanish)
    assert main([*args, str(tmp_path / "b")]) == EXIT_INTERNAL
    err = capsys.readouterr().err
    assert "the figure process ended without drawing the figures (exit status 3)" in err
    assert not (tmp_path / "b").exists() or not any((tmp_path / "b").iterdir())


@needs_figure_process
def test_results_that_cannot_be_sent_to_the_figure_process_are_drawn_in_process(
    tmp_path, monkeypatch, capsys
):
    from adaptive_ftc import plots
    from adaptive_ftc.cli import main
    from adaptive_ftc.sim.result import SimResult

    def unpicklable(self):
        raise TypeError("cannot pickle a notebook's function")

    monkeypatch.setattr(SimResult, "__getstate__", unpicklable, raising=False)
    drawn_here = []
    real = plots.save_figure

    def spy(*args, **kwargs):
        drawn_here.append(args[2])
        return real(*args, **kwargs)

    monkeypatch.setattr(plots, "save_figure", spy)
    out = tmp_path / "out"
    args = ["run", "hypersonic-direct-s1", "--t-final", "1", "--quiet", "--out", str(out)]
    assert main(args) == 0
    assert [p.name for p in drawn_here] == ["fig_2.1.png", "fig_2.2.png"]
    assert sorted(p.name for p in (out / "figures").iterdir()) == ["fig_2.1.png", "fig_2.2.png"]
