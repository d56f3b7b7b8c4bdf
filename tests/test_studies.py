"""Robustness sweeps (adaptive_ftc.studies): truths the sweep must respect."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from adaptive_ftc import load_scenario, simulate
from adaptive_ftc.cli import main
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.studies import break_points, robustness_sweep
from adaptive_ftc.study_plots import plot_robustness

SC = "hypersonic-direct-s1"


@pytest.fixture(scope="module")
def noise_table():
    return robustness_sweep(SC, "noise", [0.0, 1e-4], seeds=(0, 1), duration=10.0, window=5.0)


def test_zero_noise_is_the_ideal_run_exactly(noise_table):
    sc = load_scenario(SC)
    ideal = simulate(replace(sc.loop, t_final=10.0), sc.solver)
    expected = float(np.max(ideal.rms_error(5.0, 10.0)))
    zero = noise_table[noise_table["value"] == 0.0]
    assert list(zero["rms_error"]) == [expected, expected]  # bit for bit, both seeds
    assert (zero["ratio_to_ideal"] == 1.0).all()
    assert (zero["status"] == "completed").all() and not zero["broken"].any()
    # the default threshold is the scenario's tracking claim (1 % of pi/36)
    assert noise_table["threshold"].iloc[0] == pytest.approx(8.7e-4)


def test_same_seed_same_table_and_seeds_differ(noise_table):
    again = robustness_sweep(SC, "noise", [0.0, 1e-4], seeds=(0, 1), duration=10.0, window=5.0)
    pd.testing.assert_frame_equal(noise_table, again)
    noisy = noise_table[noise_table["value"] == 1e-4]
    a, b = noisy["rms_error"]
    assert a != b  # two seeds, two noise realisations
    assert (noisy["rms_error"] > noisy["ideal_rms_error"]).all()  # noise costs accuracy


def test_lag_sweep_grows_with_the_lag_and_matches_a_direct_run():
    from adaptive_ftc.hardware import Actuators

    t = robustness_sweep(SC, "lag", [0.05, 0.01], duration=10.0, window=5.0, threshold=1e-4)
    assert list(t["seed"]) == [-1, -1]  # deterministic knob: one run per value
    sc = load_scenario(SC)
    direct = simulate(replace(sc.loop, t_final=10.0, actuators=Actuators(tau=0.05)), sc.solver)
    assert t["rms_error"].iloc[0] == float(np.max(direct.rms_error(5.0, 10.0)))
    assert t["rms_error"].iloc[0] > t["rms_error"].iloc[1]  # a slower actuator tracks worse
    assert list(t["broken"]) == list(t["rms_error"] > 1e-4)


def _synthetic(knob, values, broken, status=None):
    n = len(values)
    return pd.DataFrame(
        {
            "scenario": "s",
            "knob": knob,
            "value": values,
            "unit": "",
            "broken": broken,
            "status": status or ["completed"] * n,
        }
    )


def test_break_point_on_synthetic_tables():
    # noise: harsher upward; a broken value below a good one does not count (not "for good")
    t = _synthetic("noise", [1e-5, 1e-4, 1e-3, 1e-2], [True, False, True, True])
    bp = break_points(t).iloc[0]
    assert (bp["break_point"], bp["last_ok"], bp["how"]) == (1e-3, 1e-4, "error > threshold")
    # controller rate: harsher downward, input order irrelevant
    st = ["completed", "diverged", "completed"]
    t = _synthetic("controller_rate", [1000.0, 100.0, 200.0], [False, True, False], st)
    bp = break_points(t).iloc[0]
    assert (bp["break_point"], bp["last_ok"], bp["how"]) == (100.0, 200.0, "diverged")
    # never breaks / always broken
    assert math.isnan(break_points(_synthetic("lag", [0.1, 0.2], [False] * 2))["break_point"][0])
    every = break_points(_synthetic("rate_limit", [50.0, 5.0], [True] * 2)).iloc[0]
    assert every["break_point"] == 50.0 and math.isnan(every["last_ok"])
    # one broken seed breaks the value
    t = _synthetic("noise", [1e-4, 1e-4, 1e-3], [False, True, True])
    assert break_points(t)["break_point"][0] == 1e-4


def test_bad_arguments_are_clear_errors():
    with pytest.raises(ConfigurationError, match="Did you mean 'noise'"):
        robustness_sweep(SC, "nois", [1e-4])
    with pytest.raises(ConfigurationError, match="controller_rate.*> 0"):
        robustness_sweep(SC, "controller_rate", [0.0])
    with pytest.raises(ConfigurationError, match="window"):
        robustness_sweep(SC, "lag", [0.01], duration=5.0, window=20.0)
    with pytest.raises(ConfigurationError, match="columns missing"):
        break_points(pd.DataFrame({"value": [1.0]}))


def _fake_study(scenarios, **_):
    rows = []
    for scen, bad_from in zip(scenarios, (1e-3, 1e-4), strict=False):
        for v in (1e-5, 1e-4, 1e-3):
            broken = v >= bad_from
            rows.append(
                {
                    "scenario": scen,
                    "knob": "noise",
                    "value": v,
                    "unit": "rad",
                    "seed": 0,
                    "status": "diverged" if broken else "completed",
                    "rms_error": math.nan if broken else v,
                    "threshold": 8.7e-4,
                    "broken": broken,
                }
            )
    return pd.DataFrame(rows)


def test_figure_marks_break_points():
    fig = plot_robustness(_fake_study(["a-x", "a-y"]))
    ax = fig.axes[0]
    marks = [ln for ln in ax.get_lines() if ln.get_gid() == "break-point"]
    assert sorted(ln.get_xdata()[0] for ln in marks) == [1e-4, 1e-3]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert any(ln.get_gid() == "diverged" for ln in ax.get_lines())


def test_cli_writes_the_table_figure_and_break_points(tmp_path, monkeypatch, capsys):
    from adaptive_ftc import studies

    monkeypatch.setattr(studies, "robustness_study", _fake_study)
    out = tmp_path / "study"
    assert main(["study", "robustness", "--out", str(out), "--quick", "--quiet"]) == 0
    for name in ("robustness.csv", "break_points.csv", "robustness.png", "robustness.pdf"):
        assert (out / name).stat().st_size > 0
    bps = pd.read_csv(out / "break_points.csv")
    assert list(bps["break_point"]) == [1e-3, 1e-4]
    assert "hypersonic-direct-s1" in capsys.readouterr().out
