"""Wall time of `aftc reproduce` on an empty cache (a fresh install) and on a warm one.

Run: ``python benchmarks/bench_reproduce.py [--formats png] [--repeat 1] [--against SRC]
[--warm-only]``.

Each round runs, in fresh processes and with fresh temporary folders:

- ``aftc reproduce`` with an empty loop cache and an empty numba cache (``ADAPTIVE_FTC_CACHE_DIR``
  and ``NUMBA_CACHE_DIR`` both new): every loop structure, failure pattern, control-gain module
  and shared integrator compiles;
- the same command again on those caches (warm);
- ``python -c "import adaptive_ftc"`` against ``python -c "pass"`` (the import's own cost).

Absolute times drift with the machine's load, so the script also times the plain C loop of
``hypersonic-direct-s1`` (``benchmarks/c``, built with the system C compiler) in the same
session and prints every time in units of that C run as well: a reference measured in the same
run. Prints the times against issue 29's targets (warm <= 10 s, cold <= 20 s, import <= 0.2 s;
issue 10's were 15 s, 30 s and 0.3 s); ``--formats png`` is the measurement of the targets (PDF
figures add about 3 s). Needs about two minutes per round on the 2-core machine.

``--against SRC`` (e.g. ``/work/main/src``) times another checkout's package in the same
session, interleaved round by round with this one (this checkout's ``src``, then ``SRC``, each
with its own fresh caches), and prints this checkout's times over the other's: on a shared,
noisy machine only times measured side by side compare. The load average (``uptime``) is
printed beside every round. ``--warm-only`` skips the cold runs and times one run per round
on the environment's own caches (run it once before, or after a reproduction of each tree).
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

TARGET_WARM = 10.0
TARGET_COLD = 20.0
TARGET_IMPORT = 0.2
HERE_SRC = Path(__file__).resolve().parents[1] / "src"


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


def _load() -> str:
    return "load " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def reproduce_round(
    formats: str, src: Path | None = None, warm_only: bool = False
) -> tuple[tuple[float, float] | None, tuple[float, float]]:
    """(cold wall, cold CPU), (warm wall, warm CPU) of one round in fresh caches, importing the
    package from ``src`` when given (``PYTHONPATH``). ``warm_only``: one run on the
    environment's own caches (warm after any earlier run of the same loops), no cold run."""
    with tempfile.TemporaryDirectory(prefix="aftc-bench-reproduce-") as tmp:
        env = dict(os.environ)
        if src is not None:
            env["PYTHONPATH"] = str(src)
        aftc = [sys.executable, "-m", "adaptive_ftc.cli", "reproduce", "--formats", formats]
        if warm_only:
            return None, _timed([*aftc, "--out", str(Path(tmp) / "warm"), "--quiet"], env)
        env["ADAPTIVE_FTC_CACHE_DIR"] = str(Path(tmp) / "loops")
        env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba")
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
    ap.add_argument(
        "--against",
        type=Path,
        default=None,
        help="another checkout's src folder, timed in the same session, interleaved",
    )
    ap.add_argument(
        "--warm-only",
        action="store_true",
        help="warm runs only, on the environment's own loop and numba caches (no cold run)",
    )
    args = ap.parse_args()
    if args.repeat < 1:
        print("error: --repeat must be positive", file=sys.stderr)
        return 2
    if args.against is not None and not (args.against / "adaptive_ftc").is_dir():
        print(
            f"error: --against {args.against}: no adaptive_ftc package there; give the src "
            "folder of a checkout (e.g. /work/main/src)",
            file=sys.stderr,
        )
        return 2
    try:
        exe = build()
        c_run = min(run_single(exe, mode="whole", repeat=5, read=False).elapsed)
    except CReferenceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    trees: dict[str, Path | None] = {"this": None}
    if args.against is not None:
        trees = {"this": HERE_SRC, "against": args.against}
    colds: dict[str, list[tuple[float, float]]] = {k: [] for k in trees}
    warms: dict[str, list[tuple[float, float]]] = {k: [] for k in trees}
    for i in range(args.repeat):
        for label, src in trees.items():
            before = _load()
            cold, warm = reproduce_round(args.formats, src, args.warm_only)
            if cold is not None:
                colds[label].append(cold)
            warms[label].append(warm)
            cold_text = f"cold {cold[0]:.1f} s / {cold[1]:.1f} s CPU, " if cold else ""
            print(
                f"  round {i + 1} {label:7s} {cold_text}warm {warm[0]:.1f} s / {warm[1]:.1f} s "
                f"CPU ({before}; after: {_load()})",
                flush=True,
            )
    imp = import_time()

    def row(what: str, runs: list[tuple[float, float]], target: float) -> None:
        if not runs:
            return
        walls = [w for w, _ in runs]
        best, med = min(walls), statistics.median(walls)
        cpu = min(c for _, c in runs)
        verdict = "MET" if best <= target else "NOT MET"
        print(
            f"  {what:13s} {best:6.1f} s / {med:6.1f} s wall (min / median), {cpu:6.1f} s CPU; "
            f"{best / c_run:7.0f} C runs; target <= {target:g} s: {verdict}"
        )

    print(
        f"aftc reproduce --formats {args.formats}, {args.repeat} round(s); reference: the C "
        f"loop of hypersonic-direct-s1, whole run, {c_run * 1e3:.1f} ms (best of 5)"
    )
    if args.against is not None:
        print(f"  this = {HERE_SRC}, against = {args.against}")
    for label in trees:
        row(f"cold {label}", colds[label], TARGET_COLD)
        row(f"warm {label}", warms[label], TARGET_WARM)
    if args.against is not None:
        for what, runs in (("cold", colds), ("warm", warms)):
            if runs["this"] and runs["against"]:
                wall = min(w for w, _ in runs["this"]) / min(w for w, _ in runs["against"])
                cpu = min(c for _, c in runs["this"]) / min(c for _, c in runs["against"])
                print(f"  {what}: this / against = {wall:.2f}x wall, {cpu:.2f}x CPU (best runs)")
    verdict = "MET" if imp <= TARGET_IMPORT else "NOT MET"
    print(
        f"  import adaptive_ftc {imp:.3f} s ({imp / c_run:.1f} C runs; target <= "
        f"{TARGET_IMPORT:g} s: {verdict})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
