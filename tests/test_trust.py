"""Issue 11: trustworthy runs and outputs (validation, budget, atomic files, self-describing
data, exit codes)."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from adaptive_ftc import load_scenario
from adaptive_ftc.cli import EXIT_INVALID, EXIT_NOT_COMPENSABLE, main
from adaptive_ftc.errors import ConfigurationError, ExpressionError, ScenarioError
from adaptive_ftc.scenarios.expressions import Expression
from adaptive_ftc.scenarios.loader import CATALOG, list_scenarios, scenario_schema
from adaptive_ftc.sim.budget import MAX_RECORDED_BYTES, check_run_size
from adaptive_ftc.sim.engine import SolverOptions
from adaptive_ftc.sim.result import SimResult


@pytest.fixture(scope="module")
def short_result() -> SimResult:
    sc = load_scenario("hypersonic-direct-s1")
    loop = replace(sc.loop, t_final=45.0)  # the first failure (40 s) is inside
    return sc.stamp(__import__("adaptive_ftc").simulate(loop, sc.solver))


# ------------------------------------------------------------------------------ recovery
def test_recovery_without_any_failure_in_the_run_is_empty_not_a_zip_strict_crash(short_result):
    no_fail = replace(short_result, failure_times=())
    assert no_fail.recovery() == []
    cut = replace(short_result, failure_times=(100.0,))  # a failure after the run ended
    assert cut.recovery() == []
    rows = short_result.recovery(window=2.0)
    assert [r["time"] for r in rows] == [40.0]
    expected = short_result.rms_error(40.0, 42.0)[0]
    assert rows[0]["rms_after"] == pytest.approx(expected)


def test_aftc_run_on_a_failure_free_scenario_writes_metrics_json(tmp_path, capsys):
    src = tmp_path / "free.toml"
    src.write_text('extends = "wingrock-free-1deg"\nname = "free"\nduration = 0.5\n')
    out = tmp_path / "out"
    assert main(["run", str(src), "--out", str(out), "--quiet", "--no-baselines"]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["recovery"] == [] and metrics["runs"]["adaptive"]["status"] == "completed"
    assert not [p for p in out.iterdir() if p.name.startswith(".aftc-tmp-")]


# ------------------------------------------------------------------------------ loader
def test_every_problem_of_a_file_is_reported_at_once(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(
        "duration = 'ten'\ncolour = 3\n"
        "[plant]\nmodel = 'hypersonic'\ninitial_state = ['a']\n"
        "[controller]\ndesign = 'direct'\nallocation = [1.0, 1.0]\nlam = 'x'\n"
        "[controller.regressor]\ntype = 'linear'\ninputs = ['e']\n"
        "[[failures]]\nmodel = 'stuk'\nactuator = 1\n"
        "[[failures]]\nmodel = 'stuck'\nactuator = 1.5\n"
        "[solver]\ndt = -1\n"
    )
    with pytest.raises(ScenarioError) as info:
        load_scenario(bad)
    text = str(info.value)
    assert "7 problems" in text
    for needle in (
        "unknown key 'colour'",
        "`duration`: expected a number",
        "[plant] `initial_state`: item 1",
        "[controller] `lam`",
        "[failures.1] unknown failure model 'stuk'. Did you mean 'stuck'?",
        "[failures.2] `actuator`: expected a whole number",
        "[solver] `dt`",
    ):
        assert needle in text


@pytest.mark.parametrize(
    "body, needle",
    [
        ("plant = 1", "[plant] must be a table"),
        ("failures = [1]", "[failures.1] must be a table"),
        ("[solver]\nrecord_dt = 1e-12", "record_dt"),
        ("duration = 1e9\n[solver]\nmethod = 'rk4'", "integration steps"),
        ("duration = 1e9", "shorten `duration`"),
        ("[reference]\noutputs = ['" + "-" * 992 + "t']", "nests deeper"),
        ("[reference]\noutputs = ['" + "9" * 309 + "*t']", "larger than 1e+100"),
        ("[reference]\noutputs = ['" + "*".join(["t"] * 200) + "']", "nests deeper"),
    ],
)
def test_bad_values_are_one_clear_scenario_error_fast(tmp_path, body, needle):
    f = tmp_path / "s.toml"
    f.write_text(f'extends = "hypersonic-direct-s1"\n{body}\n')
    start = time.perf_counter()
    with pytest.raises(ScenarioError) as info:
        load_scenario(f)
    assert time.perf_counter() - start < 10
    assert needle in str(info.value)


def test_derivative_growth_is_bounded():
    e = Expression("*".join(["t"] * 40), ("t",))
    with pytest.raises(ExpressionError, match="more than 20000 terms"):
        e.derivative("t").derivative("t")
    assert str(Expression("t**200", ("t",)).derivative("t")) == "200*t**199"


def test_run_size_budget_names_the_estimate_and_the_fix():
    sc = load_scenario("hypersonic-direct-s1")
    size = check_run_size(sc.loop, sc.solver)
    assert size.samples == pytest.approx(120 / 0.01 + 1 + 4)
    assert size.nbytes < MAX_RECORDED_BYTES
    with pytest.raises(ConfigurationError, match=r"record_dt.*fits"):
        check_run_size(replace(sc.loop, t_final=1e6), SolverOptions(dt=0.01, record_dt=1e-3))
    with pytest.raises(ConfigurationError, match="TiB"):
        check_run_size(sc.loop, SolverOptions(record_dt=1e-12))


def test_json_schema_is_generated_shipped_and_accepts_the_catalogue():
    jsonschema = pytest.importorskip("jsonschema")
    schema = scenario_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    shipped = json.loads((Path(__file__).parents[1] / "docs" / "scenario.schema.json").read_text())
    assert shipped == json.loads(json.dumps(schema)), "regenerate: aftc schema --out docs/..."
    validator = jsonschema.Draft202012Validator(schema)
    for name in list_scenarios():
        data = tomllib.loads((CATALOG / f"{name}.toml").read_text())
        assert not list(validator.iter_errors(data)), name
    bad = {"duration": "x", "plant": {"model": "nope"}, "controller": {}}
    assert list(validator.iter_errors(bad))


# ------------------------------------------------------------------------------ sign
def test_validate_calls_a_reversal_under_a_known_sign_design_not_compensable(tmp_path, capsys):
    body = "[[failures]]\nmodel = 'reversal'\nactuator = {a}\nonset = 2.0\n"
    for base, expected in (
        ("hypersonic-direct-s1", EXIT_NOT_COMPENSABLE),
        ("hypersonic-nussbaum-s1-pos", 0),
    ):
        f = tmp_path / f"{base}.toml"
        f.write_text(f'extends = "{base}"\nduration = 10.0\n' + body.format(a=1) + body.format(a=2))
        assert main(["validate", str(f)]) == expected
        out = capsys.readouterr().out
        assert ("sign conditions (2.16)/(4.6)" in out) == (expected != 0)


# ------------------------------------------------------------------------------ data files
def test_netcdf_round_trips_and_describes_itself(tmp_path, short_result):
    xr = pytest.importorskip("xarray")
    path = short_result.to_netcdf(tmp_path / "r.nc")
    back = SimResult.from_netcdf(path)
    for key in ("time", "states", "adaptive", "y", "e", "u_cmd", "u_applied", "gain"):
        np.testing.assert_array_equal(getattr(back, key), getattr(short_result, key))
    assert back.metrics() == short_result.metrics()
    assert back.recovery() == short_result.recovery()
    assert back.theta_slices == short_result.theta_slices
    with xr.open_dataset(path, engine="netcdf4", decode_times=False) as ds:
        assert ds.attrs["Conventions"] == "CF-1.10"
        assert ds.attrs["scenario"] == "hypersonic-direct-s1"
        assert "[controller]" in ds.attrs["scenario_file_text"]
        assert json.loads(ds.attrs["solver_settings"])["dt"] == 0.001
        assert "wall_time_s" not in ds.attrs
        for name, var in ds.variables.items():
            if name not in ("state_name", "output_name", "actuator_name", "param_name"):
                assert var.attrs.get("units") and var.attrs.get("long_name"), name
        assert "N(tau)" in ds["adaptive_gain"].attrs["long_name"]
        assert "true control gain" in ds["true_control_gain"].attrs["long_name"]


def test_identical_inputs_give_byte_identical_files(tmp_path, short_result):
    a = short_result.to_netcdf(tmp_path / "a.nc")
    b = short_result.to_netcdf(tmp_path / "b.nc")
    digest = [hashlib.sha256(p.read_bytes()).hexdigest() for p in (a, b)]
    assert digest[0] == digest[1]
    timed = short_result.to_netcdf(tmp_path / "t.nc", timing=True)
    assert SimResult.from_netcdf(timed).meta["wall_time_s"] == short_result.meta["wall_time_s"]


def test_float32_and_decimation_shrink_the_file(tmp_path, short_result):
    full = short_result.to_netcdf(tmp_path / "f.nc").stat().st_size
    small = short_result.to_netcdf(tmp_path / "s.nc", float32=True, decimate=4)
    assert small.stat().st_size < full / 4
    back = SimResult.from_netcdf(small)
    assert back.time[-1] == short_result.time[-1]
    np.testing.assert_allclose(back.e, short_result.e[_every(short_result.time.size, 4)], atol=1e-6)
    with pytest.raises(ConfigurationError, match="decimate"):
        short_result.to_netcdf(tmp_path / "x.nc", decimate=0)


def _every(n: int, k: int) -> np.ndarray:
    idx = np.arange(0, n, k)
    return idx if idx[-1] == n - 1 else np.append(idx, n - 1)


def test_from_netcdf_on_a_foreign_or_missing_file_is_a_clear_error(tmp_path):
    with pytest.raises(ConfigurationError, match="No netCDF file"):
        SimResult.from_netcdf(tmp_path / "none.nc")
    junk = tmp_path / "junk.nc"
    junk.write_text("not netcdf")
    with pytest.raises(ConfigurationError, match="not a readable netCDF4"):
        SimResult.from_netcdf(junk)


# ------------------------------------------------------------------------------ outputs
def test_failed_run_keeps_earlier_complete_results(tmp_path, monkeypatch, capsys):
    src = tmp_path / "s.toml"
    src.write_text('extends = "hypersonic-direct-s1"\nname = "s"\nduration = 0.2\n')
    out = tmp_path / "out"
    assert main(["run", str(src), "--out", str(out), "--quiet", "--no-baselines"]) == 0
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("adaptive_ftc.plots.save_figure", boom)
    assert main(["run", str(src), "--out", str(out), "--quiet", "--no-baselines"]) == 130
    after = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    assert "untouched" in capsys.readouterr().err


def test_out_naming_a_file_or_an_unwritable_folder_is_a_clear_error(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["run", "hypersonic-direct-s1", "--out", str(f)]) == EXIT_INVALID
    assert "is a file, not a folder" in capsys.readouterr().err
    if os.geteuid() != 0:  # root can write anywhere
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        assert main(["run", "hypersonic-direct-s1", "--out", str(ro / "x")]) == EXIT_INVALID


@pytest.mark.parametrize(
    "argv",
    [
        ["run", "hypersonic-direct-s1", "--dt", "nan"],
        ["run", "hypersonic-direct-s1", "--dt", "-1"],
        ["reproduce", "--jobs", "0"],
        ["run", "hypersonic-direct-s1", "--decimate", "x"],
        ["frobnicate"],
    ],
)
def test_bad_arguments_exit_2(argv, capsys):
    assert main(argv) == EXIT_INVALID


def test_help_documents_the_exit_codes(capsys):
    assert main(["--help"]) == 0
    text = capsys.readouterr().out
    for code in ("0 ", "2 ", "3 ", "4 ", "5 ", "130"):
        assert code in text


def test_sigterm_ends_aftc_run_with_130_and_keeps_results(tmp_path):
    src = tmp_path / "s.toml"
    src.write_text('extends = "hypersonic-direct-s1"\nname = "s"\nduration = 1e4\n')
    out = tmp_path / "out"
    out.mkdir()
    (out / "metrics.json").write_text("{}")
    proc = subprocess.Popen(
        [sys.executable, "-m", "adaptive_ftc.cli", "run", str(src), "--out", str(out), "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.time() + 60
    while time.time() < deadline and not any(out.glob(".aftc-tmp-*")):
        time.sleep(0.05)
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:  # a hang is a failure, never a skip (issue 27)
        proc.kill()
        proc.communicate()
        pytest.fail("aftc run hung: it did not end within 60 s of SIGTERM.")
    assert proc.returncode == 130, err
    assert (out / "metrics.json").read_text() == "{}"
    assert not list(out.glob(".aftc-tmp-*"))
