"""Time to first result (issue 29): ``import adaptive_ftc``, ``aftc --help`` and an argument
error import nothing heavy. Checked by the modules a fresh interpreter holds afterwards (not by
timing: the machine may be loaded); benchmarks/bench_cli_latency.py gives the times."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

#: Packages that cost tenths of a second each to import (the compiler, scipy, plotting, tables)
HEAVY = (
    "numba",
    "llvmlite",
    "scipy",
    "matplotlib",
    "pandas",
    "pyarrow",
    "xarray",
    "netCDF4",
    "numpy",
)

_PROBE = """
import json, sys
{code}
heavy = sorted({{m.split(".")[0] for m in sys.modules}} & set({heavy!r}))
sys.stdout.write("\\nHEAVY=" + json.dumps(heavy))
"""

_CLI = """
from adaptive_ftc.cli import main
code = main({argv!r})
assert code == {expect}, code
"""


def _heavy_after(code: str) -> list[str]:
    env = {**os.environ, "PYTHONPATH": str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run(
        [sys.executable, "-c", _PROBE.format(code=code, heavy=HEAVY)],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.rpartition("HEAVY=")[2])


def test_import_adaptive_ftc_imports_nothing_heavy():
    assert _heavy_after("import adaptive_ftc") == []


@pytest.mark.parametrize(
    ("argv", "expect"),
    [
        (["--help"], 0),
        (["--version"], 0),
        (["run", "--help"], 0),  # the solver methods, from the registry (sim is lazy)
        (["campaign", "--help"], 0),
        (["export", "--help"], 0),
        (["run"], 2),  # missing scenario: an argument error
        (["run", "hypersonic-direct-s1", "--dt", "-1"], 2),
        (["reproduce", "--jobs", "0"], 2),
    ],
)
def test_help_and_argument_errors_import_nothing_heavy(argv, expect):
    assert _heavy_after(_CLI.format(argv=argv, expect=expect)) == []


def test_a_bad_method_is_checked_against_the_registry():
    """The method choices are read lazily but still checked: an unknown method is an
    argument error that lists the registry's methods."""
    from adaptive_ftc.cli import main
    from adaptive_ftc.registry import SOLVERS

    proc = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from adaptive_ftc.cli import main; "
            "sys.exit(main(['run', 'x', '--method', 'nope']))",
        ],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(SRC)},
        timeout=120,
    )
    assert proc.returncode == 2
    assert "invalid choice: 'nope'" in proc.stderr
    assert all(repr(m) in proc.stderr for m in SOLVERS)
    assert main(["run", "--help"]) == 0


def test_public_names_resolve_lazily_and_are_cached():
    import adaptive_ftc

    for name in adaptive_ftc.__all__:
        value = getattr(adaptive_ftc, name)
        assert name in vars(adaptive_ftc), name  # cached after the first use
        if name != "__version__":
            assert value is getattr(sys.modules[adaptive_ftc._LAZY[name]], name)
    assert set(dir(adaptive_ftc)) >= set(adaptive_ftc.__all__)
    assert adaptive_ftc.plots is sys.modules["adaptive_ftc.plots"]  # a submodule on demand
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        _ = adaptive_ftc.nonexistent


def test_subpackages_resolve_lazily():
    import adaptive_ftc.campaigns as campaigns
    import adaptive_ftc.export as export

    for pkg in (campaigns, export):
        for name in pkg.__all__:
            assert getattr(pkg, name) is getattr(sys.modules[pkg._LAZY[name]], name)
        with pytest.raises(AttributeError):
            _ = pkg.nonexistent


def test_study_help_lists_the_default_scenarios(capsys, monkeypatch):
    """``aftc study --help`` fills in its defaults from the studies module when printed."""
    monkeypatch.setenv("COLUMNS", "1000")  # no line wrapping inside a name
    from adaptive_ftc import studies
    from adaptive_ftc.cli import main

    assert main(["study", "--help"]) == 0
    out = capsys.readouterr().out
    assert "delay-margin default: " + ", ".join(studies.DELAY_SCENARIOS) + ")" in out
    assert "(repeatable; default: " + ", ".join(studies.STUDY_SCENARIOS) + ")" in out
