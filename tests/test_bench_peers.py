"""The peer benchmark's CI mode (issue 29): ``benchmarks/bench_peers.py --small`` runs every
available engine on three members of the hypersonic loop, with no timing assertions. What it
must show: every batch member equal to its single run, and the C loop and scipy agreeing with
the project's single runs."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"


@pytest.fixture(scope="module")
def output() -> str:
    env = {**os.environ, "PYTHONPATH": str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "bench_peers.py"), "--small"],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


def _diffs(text: str, engine: str) -> list[float]:
    pattern = rf"^\s+{re.escape(engine)}\s+.*max diff (\S+)$"
    return [float(m) for m in re.findall(pattern, text, flags=re.MULTILINE)]


def test_every_batch_member_equals_its_single_run(output):
    diffs = _diffs(output, "batch")
    assert len(diffs) == 2, output  # RK4 and Dopri5
    assert diffs == [0.0, 0.0]


def test_every_lane_member_equals_its_single_run(output):
    """The lane engine (sim/lanes.py: RK4 and DOPRI5) reproduces each member's single run."""
    assert _diffs(output, "lanes") == [0.0, 0.0]
    (vec,) = _diffs(output, "lanes-vec")  # stage 1b: call-free exp and tanh
    assert vec <= 1e-10


def test_c_and_scipy_agree_with_the_single_runs(output):
    c = _diffs(output, "C")
    if not c:
        assert "C: skipped" in output, output
    else:
        assert c[0] <= 1e-9  # the same RK4 steps (tests/test_cref.py holds it to 1e-9)
    (scipy,) = _diffs(output, "scipy RK45")
    assert scipy <= 1e-6  # another adaptive method at the same tolerances


def test_per_core_times_and_the_jax_peers_status_are_reported(output):
    assert output.count("ms per member per core") >= 3
    assert re.search(r"^\s+JAX peers: (skipped|run)", output, flags=re.MULTILINE), output


def test_the_jax_peers_agree_with_the_single_runs_when_installed(output):
    """JAX RK4 runs this project's step grid (agreement to rounding); diffrax's Dopri5 its own
    step control (agreement to the tolerance). Skipped where jax is not installed (CI)."""
    if "JAX peers: skipped" in output:
        pytest.skip("jax and diffrax are not installed (pip install 'adaptive-ftc[bench]')")
    (rk4,) = _diffs(output, "JAX RK4")
    (dopri,) = _diffs(output, "diffrax")
    assert rk4 <= 1e-12
    assert dopri <= 1e-6
