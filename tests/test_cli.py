"""The aftc command: list, validate, run; errors are one clear line, never a traceback."""

from __future__ import annotations

import json

from adaptive_ftc.cli import main


def test_list_shows_every_scenario_with_its_figures(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "hypersonic-direct-s1" in out and "2.1, 2.2" in out


def test_validate_reports_compensability(capsys):
    assert main(["validate", "hypersonic-direct-s2"]) == 0
    out = capsys.readouterr().out
    assert "[70 s, 100 s): compensable" in out


def test_bad_scenario_is_a_clear_error_and_keeps_earlier_results(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    keep = out / "metrics.json"
    keep.write_text("{}")
    bad = tmp_path / "bad.toml"
    bad.write_text('duration = 1.0\n[plant]\nmodel = "wingrok"\n')
    assert main(["run", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "Did you mean 'wingrock'" in err
    assert "Traceback" not in err
    assert keep.read_text() == "{}"


def test_run_writes_data_figures_and_metrics(tmp_path, capsys):
    src = tmp_path / "short.toml"
    src.write_text(
        'extends = "hypersonic-direct-s1"\nname = "short"\nfigures = ["2.1"]\nduration = 45.0\n'
    )
    out = tmp_path / "o"
    assert main(["run", str(src), "--out", str(out), "--quiet", "--csv"]) == 0
    assert (out / "data" / "short.nc").is_file()
    assert (out / "data" / "short_frozen.nc").is_file()
    assert (out / "data" / "short_failure_free.csv").is_file()
    pngs = sorted(p.name for p in (out / "figures").glob("*.png"))
    assert pngs, "no figures written"
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["runs"]["adaptive"]["status"] == "completed"
    assert "short: completed" in capsys.readouterr().out


def test_reproduce_refuses_an_unknown_figure_format_before_running(tmp_path, capsys):
    assert main(["reproduce", "--out", str(tmp_path / "r"), "--formats", "png,gif"]) == 2
    assert "gif" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()
