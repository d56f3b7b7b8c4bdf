"""Wall time of a first `aftc run hypersonic-direct-s1` after install: empty caches, fresh process.

Run: ``python benchmarks/bench_first_run.py [--repeat 1] [--scenario hypersonic-direct-s1]``.

Each round, in a fresh process with new, empty temporary caches (``ADAPTIVE_FTC_CACHE_DIR``
and ``NUMBA_CACHE_DIR``), runs ``aftc run SCENARIO`` (cold: every part of the
loop compiles), then the same command again on those caches (warm: loaded from disk). The
difference is what the first run costs over any later one. This is the number
docs/installation.md ("First run") quotes; every other page links there.

Absolute times drift with the machine's load, so the script also times the plain C loop of
``hypersonic-direct-s1`` (``benchmarks/c``, built with the system C compiler) in the same
session and prints each time in units of that C run: a reference measured in the same run.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

from _cref import CReferenceError, build, run_single
from bench_reproduce import _timed


def first_run_round(scenario: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """(cold wall, cold CPU), (warm wall, warm CPU) of ``aftc run`` in fresh caches."""
    with tempfile.TemporaryDirectory(prefix="aftc-bench-first-run-") as tmp:
        env = dict(os.environ)
        env["ADAPTIVE_FTC_CACHE_DIR"] = str(Path(tmp) / "loops")
        env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba")
        aftc = [sys.executable, "-m", "adaptive_ftc.cli", "run", scenario]
        cold = _timed([*aftc, "--out", str(Path(tmp) / "cold")], env)
        warm = _timed([*aftc, "--out", str(Path(tmp) / "warm")], env)
    return cold, warm


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--scenario", default="hypersonic-direct-s1", help="catalogue scenario")
    ap.add_argument("--repeat", type=int, default=1, help="cold + warm rounds (default 1)")
    args = ap.parse_args()
    if args.repeat < 1:
        print("error: --repeat must be positive, e.g. --repeat 3", file=sys.stderr)
        return 2
    try:
        exe = build()
        c_run = min(run_single(exe, mode="whole", repeat=5, read=False).elapsed)
    except CReferenceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    rounds = [first_run_round(args.scenario) for _ in range(args.repeat)]
    print(
        f"aftc run {args.scenario}, {args.repeat} round(s), fresh process and "
        f"empty caches per cold run; reference: the C loop of hypersonic-direct-s1, whole run, "
        f"{c_run * 1e3:.1f} ms (best of 5), measured in this session"
    )
    for what, runs in (("cold", [r[0] for r in rounds]), ("warm", [r[1] for r in rounds])):
        walls = [w for w, _ in runs]
        best, med = min(walls), statistics.median(walls)
        cpu = min(c for _, c in runs)
        print(
            f"  {what:5s} {best:6.1f} s / {med:6.1f} s wall (min / median), {cpu:6.1f} s CPU; "
            f"{best / c_run:7.0f} C runs"
        )
    extra = statistics.median(c[0] - w[0] for c, w in rounds)
    print(f"  first-run cost (cold - warm, median): {extra:.1f} s ({extra / c_run:.0f} C runs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
