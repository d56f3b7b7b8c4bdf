"""Data that says what it is (issue 28): reproduction files at full precision and rate whose
recomputed metrics equal metrics.csv, CF-clean netCDF (IOOS compliance-checker, cf-units), one
unit style, units in the campaign Parquet schema."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from adaptive_ftc import FlexibleSpacecraft, load_scenario
from adaptive_ftc._units import SQRT_KG_M, display, per_second, state_unit, udunits
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.result import SimResult

xr = pytest.importorskip("xarray")

#: one single-output scenario and the MIMO spacecraft (18 states, modal coordinates in sqrt(kg) m)
NAMES = ["hypersonic-direct-s1", "spacecraft-mimo-s1"]

#: metrics.csv columns recomputed from a data file
METRICS = [
    "t_end",
    "rms_error",
    "max_error",
    "final_window_s",
    "rms_error_final",
    "max_error_final",
    "peak_command",
    "peak_applied",
    "fast_rms_max",
    "tv_per_s_max",
    "peak_rate_max",
    "peak_to_peak_max",
]


@pytest.fixture(scope="module")
def quick_reproduction(tmp_path_factory):
    from adaptive_ftc.reproduce import run_reproduction

    out = tmp_path_factory.mktemp("repro") / "r"
    summary = run_reproduction(
        out, quick=True, names=NAMES, jobs=1, progress=False, formats=("png",), dpi=40
    )
    with open(out / "metrics.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    return out, summary, rows


@pytest.fixture(scope="module")
def short_result() -> SimResult:
    from dataclasses import replace

    from adaptive_ftc import simulate

    sc = load_scenario("hypersonic-direct-s1")
    return sc.stamp(simulate(replace(sc.loop, t_final=3.0), sc.solver))


@pytest.fixture(scope="module")
def spacecraft_file(quick_reproduction):
    return quick_reproduction[0] / "data" / "spacecraft-mimo-s1.nc"


def _data_file(out, row):
    suffix = "" if row["variant"] == "adaptive" else f"_{row['variant']}"
    return out / "data" / f"{row['scenario']}{suffix}.nc"


# ---------------------------------------------------------------------- full precision, full rate
def test_metrics_recomputed_from_the_files_equal_metrics_csv(quick_reproduction):
    out, summary, rows = quick_reproduction
    assert summary["data_precision"] == "float64" and summary["data_decimation"] == 1
    checked = 0
    for row in rows:
        if row["status"] == "error":
            continue
        path = _data_file(out, row)
        # from the raw arrays, without SimResult: what a user of xarray would compute
        with xr.open_dataset(path, engine="netcdf4", decode_times=False) as ds:
            assert ds.attrs["precision"] == "float64" and ds.attrs["decimation"] == 1
            assert ds["u_cmd"].dtype == np.float64 and ds["time"].dtype == np.float64
            e, u_cmd, u_app = ds["e"].values, ds["u_cmd"].values, ds["u_applied"].values
            raw = {
                "t_end": float(ds["time"].values[-1]),
                "rms_error": float(np.sqrt(np.mean(e**2))),
                "max_error": float(np.max(np.abs(e))),
                "peak_command": float(np.max(np.abs(u_cmd))),
                "peak_applied": float(np.max(np.abs(u_app))),
            }
        for key, value in raw.items():
            assert value == pytest.approx(float(row[key]), rel=1e-13, abs=0), (path.name, key)
        # every metric, through SimResult.from_netcdf
        back = SimResult.from_netcdf(path).metrics()
        for key in METRICS:
            want, got = float(row[key]), float(back[key])
            assert (math.isnan(want) and math.isnan(got)) or got == pytest.approx(
                want, rel=1e-13, abs=0
            ), (path.name, key)
        checked += 1
    assert checked >= 6  # both scenarios, with their baselines


def test_report_states_what_the_data_files_hold(quick_reproduction):
    out, _, _ = quick_reproduction
    page = (out / "report.html").read_text("utf-8")
    assert "double precision, every recorded sample" in page


def test_float32_and_decimation_are_a_recorded_choice(tmp_path):
    from adaptive_ftc.reproduce import _data_note, _simulate_task

    rec = _simulate_task("hypersonic-direct-s1", "frozen", True, str(tmp_path), True, 3)
    assert rec["error"] == ""
    path = tmp_path / "data" / "hypersonic-direct-s1_frozen.nc"
    with xr.open_dataset(path, engine="netcdf4", decode_times=False) as ds:
        assert ds.attrs["precision"] == "float32" and ds.attrs["decimation"] == 3
        assert "float32=True, decimate=3" in ds.attrs["history"]
        assert ds["u_cmd"].dtype == np.float32
        assert ds.sizes["time"] == len(range(0, rec["result"].time.size, 3)) + 1
    note = _data_note(True, 3)
    assert "single precision" in note and "one recorded sample in 3" in note
    assert "differ from metrics.csv" in note


def test_reproduce_cli_passes_the_data_options(monkeypatch, tmp_path):
    from adaptive_ftc import reproduce
    from adaptive_ftc.cli import main

    seen = {}

    def fake(out, **kwargs):
        seen.update(kwargs)
        return {
            "n_scenarios": 0,
            "n_runs": 0,
            "n_claims": 0,
            "n_pass": 0,
            "n_fail": 0,
            "n_not_evaluated": 0,
            "n_not_reproduced": 0,
            "n_finding": 0,
            "n_errors": 0,
            "wall_time_s": 0.0,
            "report": tmp_path / "report.html",
            "out_dir": tmp_path,
        }

    monkeypatch.setattr(reproduce, "run_reproduction", fake)
    main(["reproduce", "--out", str(tmp_path / "o"), "--quiet", "--float32", "--decimate", "4"])
    assert seen["float32"] is True and seen["decimate"] == 4
    main(["reproduce", "--out", str(tmp_path / "o"), "--quiet"])
    assert seen["float32"] is False and seen["decimate"] == 1


def test_a_bad_decimation_is_refused_before_any_run(tmp_path):
    from adaptive_ftc.reproduce import run_reproduction

    with pytest.raises(ConfigurationError, match="decimate"):
        run_reproduction(tmp_path / "r", names=["hypersonic-direct-s1"], decimate=0)


# ---------------------------------------------------------------------- CF
def _failing(path):
    """(name, priority, messages) of every failing check of the CF 1.10 suite, and the checks
    that raised."""
    from compliance_checker.runner import CheckSuite

    suite = CheckSuite()
    suite.load_all_available_checkers()
    ds = suite.load_dataset(str(path))
    groups = suite.run_all(ds, ["cf:1.10"], skip_checks=[])
    results, crashed = groups["cf:1.10"]
    failing = []
    for r in results:
        value = r.value
        ok = value if isinstance(value, bool) else value[0] >= value[1]
        if not ok:
            failing.append((r.name, r.weight, tuple(r.msgs)))
    return failing, crashed


@pytest.mark.parametrize("name", NAMES)
def test_files_pass_the_compliance_checker_cf_suite(quick_reproduction, name):
    """IOOS compliance-checker, suite cf:1.10: no failing high-priority check (errors) and no
    check that crashes; the one medium-priority note left is the recommended dimension order
    (time before output/actuator/param, kept: it is the order of SimResult's arrays)."""
    pytest.importorskip("compliance_checker")
    from compliance_checker.base import BaseCheck

    failing, crashed = _failing(quick_reproduction[0] / "data" / f"{name}.nc")
    assert not crashed, crashed
    assert [f for f in failing if f[1] >= BaseCheck.HIGH] == []
    assert {f[0] for f in failing if f[1] == BaseCheck.MEDIUM} <= {"§2.4 Dimensions"}


def test_the_old_layout_fails_the_checker(short_result, tmp_path):
    """The checks above can fail: a file in the layout before issue 28 (time in plain 's',
    string-valued dimension coordinates) has errors."""
    pytest.importorskip("compliance_checker")
    from compliance_checker.base import BaseCheck

    failing, _ = _failing(_old_layout(short_result, tmp_path / "old.nc"))
    assert [f for f in failing if f[1] >= BaseCheck.HIGH]


def test_every_units_attribute_parses_with_cf_units(quick_reproduction):
    cf_units = pytest.importorskip("cf_units")
    out, _, rows = quick_reproduction
    for row in rows:
        with xr.open_dataset(_data_file(out, row), engine="netcdf4", decode_times=False) as ds:
            assert ds.attrs["Conventions"] == "CF-1.10" and ds.attrs["history"]
            for name, var in ds.variables.items():
                if var.dtype.kind in "OSU":  # labels
                    assert var.dims[0] not in ds.coords or name != var.dims[0], name
                    continue
                assert "units" in var.attrs or "units_note" in var.attrs, name
                if "units" in var.attrs:
                    unit = cf_units.Unit(var.attrs["units"])
                    assert not unit.is_unknown(), (name, var.attrs["units"])
                    assert "/" not in var.attrs["units"], name  # one style: UDUNITS
            # numeric dimensions: no string-valued dimension coordinate
            for dim in ds.dims:
                assert dim not in ds.variables or ds[dim].dtype.kind not in "OSU", dim
            assert ds["time"].attrs["units"].startswith("seconds since ")


def test_second_derivative_units_and_the_spacecraft_modal_states(spacecraft_file):
    with xr.open_dataset(spacecraft_file, engine="netcdf4", decode_times=False) as ds:
        assert ds["sdot"].attrs["units"] == "rad s-2"
        assert ds["s"].attrs["units"] == "rad s-1"
        assert ds["state_h1"].attrs["units"] == "N m s"
        for k in (1, 2, 3):
            for var, shown in ((f"state_eta{k}", "√kg·m"), (f"state_eta{k}_dot", "√kg·m/s")):
                attrs = ds[var].attrs
                # UDUNITS cannot write sqrt(kg): no 'units' (cf-units would read 'kg0.5 m' as
                # 0.5 m), the unit stated in units_note, as in the figures
                assert "units" not in attrs and attrs["units_note"].startswith(shown), var
    meta = {"plant": "spacecraft"}
    i = FlexibleSpacecraft.state_names.index("eta1")
    assert FlexibleSpacecraft.units[i] == SQRT_KG_M
    assert state_unit(meta, "eta1") == display(FlexibleSpacecraft.units[i]) == "√kg·m"
    assert state_unit(meta, "eta1_dot") == "√kg·m/s"


def test_units_module_speaks_one_style():
    cf_units = pytest.importorskip("cf_units")
    assert udunits("rad/s") == "rad s-1" == per_second("rad")
    assert udunits("rad s-1 s-1") == per_second("rad s-1") == "rad s-2"
    assert per_second("N m s") == "N m" and per_second("1") == "s-1"
    assert udunits("m/s^2") == "m s-2" == udunits("m/s**2") and udunits("kg·m2/s") == "kg m2 s-1"
    assert display("rad s-2") == "rad/s²" and display("N m s") == "N·m·s"
    from adaptive_ftc import plants

    for cls in [getattr(plants, n) for n in plants.__all__]:
        for unit in tuple(getattr(cls, "units", ()) or ()) + (getattr(cls, "actuator_units", ""),):
            if not isinstance(unit, str) or not unit or "sqrt(" in unit:
                continue
            assert udunits(unit) == unit, (cls.__name__, unit)
            assert not cf_units.Unit(unit).is_unknown()


# ---------------------------------------------------------------------- old files
def _old_layout(result: SimResult, path):
    """Write ``result`` as the files before issue 28 were: string dimension coordinates, time
    in 's' with standard_name time."""
    ds = result.to_xarray().drop_vars("state_index")
    ds = ds.assign_coords(
        {dim: ds[f"{dim}_name"].values for dim in ("state", "output", "actuator", "param")}
    ).drop_vars([f"{d}_name" for d in ("state", "output", "actuator", "param")])
    ds["time"].attrs = {"standard_name": "time", "long_name": "time", "units": "s", "axis": "T"}
    ds.to_netcdf(path, engine="netcdf4")
    return path


def test_files_in_the_old_layout_still_load(short_result, tmp_path):
    back = SimResult.from_netcdf(_old_layout(short_result, tmp_path / "old.nc"))
    assert back.state_names == short_result.state_names
    assert back.output_names == short_result.output_names
    assert back.adaptive_names == short_result.adaptive_names
    np.testing.assert_array_equal(back.time, short_result.time)
    assert back.metrics() == short_result.metrics()


def test_new_files_round_trip_with_labels(short_result, tmp_path):
    path = short_result.to_netcdf(tmp_path / "r.nc")
    with xr.open_dataset(path, engine="netcdf4", decode_times=False) as ds:
        by_name = ds.swap_dims(output="output_name").sel(output_name="alpha")
        np.testing.assert_array_equal(by_name["e"].values, short_result.e[:, 0])
    back = SimResult.from_netcdf(path)
    assert back.actuator_names == short_result.actuator_names
    assert back.metrics() == short_result.metrics()


# ---------------------------------------------------------------------- campaign Parquet
def test_campaign_parquet_fields_carry_units(tmp_path):
    pytest.importorskip("pyarrow")
    cf_units = pytest.importorskip("cf_units")
    import pyarrow.parquet as pq

    from adaptive_ftc.campaigns import load_campaign
    from adaptive_ftc.campaigns.store import column_units, to_table, write_part

    spec = load_campaign(
        {
            "name": "units",
            "base": "hypersonic-direct-s1",
            "designs": ["adaptive"],
            "runs": 2,
            "seed": 1,
            "chunk_size": 2,
            "duration": 2.0,
            "success": {"rms_error_final": 0.01, "final_window": 0.5},
            "failures": {
                "count": 1,
                "onset": {"uniform": [0.5, 1.0]},
                "models": {"stuck": {"value": {"uniform": [-0.1, 0.1]}}},
            },
            "hardware": {
                "lag": {"uniform": [0.01, 0.05]},
                "rate_limit": {"uniform": [1.0, 5.0]},
                "noise": {"alpha": {"uniform": [0.0, 1e-3]}},
            },
            "ranges": {"initial_state": [{"uniform": [0.0, 0.04]}]},
        }
    )
    path = write_part(to_table([{"index": 0, "design": "adaptive"}], spec), tmp_path, 0)
    schema = pq.read_schema(path)
    units = {
        f.name: f.metadata[b"units"].decode()
        for f in schema
        if f.metadata and b"units" in f.metadata
    }
    assert units == column_units(spec)
    assert units["rms_error"] == "rad" and units["peak_command"] == "rad"
    assert units["hw_rate_limit"] == "rad s-1" == units["peak_rate_max"]
    assert units["hw_lag"] == "s" == units["f1_onset"] == units["divergence_time"]
    assert units["x0_alpha"] == "rad" and units["noise_alpha"] == "rad"
    assert "status" not in units and "success" not in units
    for unit in units.values():
        assert not cf_units.Unit(unit).is_unknown()
