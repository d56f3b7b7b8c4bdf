"""Wall time of `aftc reproduce` on an empty cache (a fresh install) and on a warm one.

Run: ``python benchmarks/bench_reproduce.py [--formats png] [--repeat 1]``.

Each round runs, in fresh processes and with fresh temporary folders:

- ``aftc reproduce`` with an empty loop cache and an empty numba cache (``ADAPTIVE_FTC_CACHE_DIR``
  and ``NUMBA_CACHE_DIR`` both new): every loop structure, failure pattern, control-gain module
  and shared integrator compiles;
- the same command again on those caches (warm);
- ``python -c "import adaptive_ftc"`` against ``python -c "pass"`` (the import's own cost).

Absolute times drift with the machine's load, so the script also times the plain C loop of
``hypersonic-direct-s1`` (``benchmarks/c``, built with the system C compiler) in the same
session and prints every time in units of that C run as well: a reference measured in the same
run. Prints the times against issue 10's targets (warm <= 15 s, cold <= 30 s, import <= 0.3 s);
``--formats png`` is the measurement of the targets (PDF figures add about 3 s). Needs about a
minute per round on the 2-core machine.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _cref import CReferenceError, build, run_single

TARGET_WARM = 15.0
TARGET_COLD = 30.0
TARGET_IMPORT = 0.3


def _timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU seconds (children included) of ``cmd``; raises if it fails."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{done.stdout[-2000:]}{done.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def reproduce_round(formats: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """(cold wall, cold CPU), (warm wall, warm CPU) of one round in fresh caches."""
    with tempfile.TemporaryDirectory(prefix="aftc-bench-reproduce-") as tmp:
        env = dict(os.environ)
        env["ADAPTIVE_FTC_CACHE_DIR"] = str(Path(tmp) / "loops")
        env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba")
        aftc = [sys.executable, "-m", "adaptive_ftc.cli", "reproduce", "--formats", formats]
        cold = _timed([*aftc, "--out", str(Path(tmp) / "cold"), "--quiet"], env)
        warm = _timed([*aftc, "--out", str(Path(tmp) / "warm"), "--quiet"], env)
    return cold, warm


def import_time(repeat: int = 5) -> float:
    """Best wall time of ``import adaptive_ftc`` minus that of an empty interpreter start."""
    env = dict(os.environ)

    def best(code: str) -> float:
        return min(_timed([sys.executable, "-c", code], env)[0] for _ in range(repeat))

    return max(0.0, best("import adaptive_ftc") - best("pass"))


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--formats", default="png", help="figure formats (default png)")
    ap.add_argument("--repeat", type=int, default=1, help="cold + warm rounds (default 1)")
    args = ap.parse_args()
    if args.repeat < 1:
        print("error: --repeat must be positive", file=sys.stderr)
        return 2
    try:
        exe = build()
        c_run = min(run_single(exe, mode="whole", repeat=5, read=False).elapsed)
    except CReferenceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    colds, warms = [], []
    for _ in range(args.repeat):
        cold, warm = reproduce_round(args.formats)
        colds.append(cold)
        warms.append(warm)
    imp = import_time()

    def row(what: str, runs: list[tuple[float, float]], target: float) -> None:
        walls = [w for w, _ in runs]
        best, med = min(walls), statistics.median(walls)
        cpu = min(c for _, c in runs)
        verdict = "MET" if best <= target else "NOT MET"
        print(
            f"  {what:5s} {best:6.1f} s / {med:6.1f} s wall (min / median), {cpu:6.1f} s CPU; "
            f"{best / c_run:7.0f} C runs; target <= {target:g} s: {verdict}"
        )

    print(
        f"aftc reproduce --formats {args.formats}, {args.repeat} round(s); reference: the C "
        f"loop of hypersonic-direct-s1, whole run, {c_run * 1e3:.1f} ms (best of 5)"
    )
    row("cold", colds, TARGET_COLD)
    row("warm", warms, TARGET_WARM)
    verdict = "MET" if imp <= TARGET_IMPORT else "NOT MET"
    print(
        f"  import adaptive_ftc {imp:.3f} s ({imp / c_run:.1f} C runs; target <= "
        f"{TARGET_IMPORT:g} s: {verdict})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
