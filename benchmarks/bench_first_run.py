"""Wall time of `aftc run hypersonic-direct-s1` end to end, first run after install (empty caches)
and warm, each against its issue-29 target.

Run: ``python benchmarks/bench_first_run.py [--repeat 1] [--scenario hypersonic-direct-s1]
[--against /work/main/src]``.

Each round, in a fresh process with new, empty temporary caches (``ADAPTIVE_FTC_CACHE_DIR``
and ``NUMBA_CACHE_DIR``), runs ``aftc run SCENARIO`` (cold: every part of the
loop compiles), then the same command again on those caches (warm: loaded from disk), then
the warm command with ``--no-figures`` (what the figures cost). The difference of cold and warm
is what the first run costs over any later one. This is the number docs/installation.md
("First run") quotes; every other page links there.

Targets (issue 29, a quiet 2-core machine): warm <= 1.5 s, cold <= 5 s, end to end.

Absolute times drift with the machine's load, so the script also measures, in the same
session, two references and prints each time in units of them: the start-up of the
interpreter (``python -c pass``, best of 5) and the plain C loop of ``hypersonic-direct-s1``
(``benchmarks/c``, built with the system C compiler). The load average is printed at the start
and the end; on a loaded machine compare the CPU times (a process waiting for a core uses none).

``--against SRC`` also times the same commands with ``PYTHONPATH=SRC`` (another checkout's
``src``, e.g. the main branch's), interleaved with this one's round by round, and prints the
ratio of the two: a before/after comparison from one session.

Byte code: with ``PYTHONDONTWRITEBYTECODE`` set (as on a development machine), every run would
compile the package's source again, which an installed package never does; the script then
lets the runs write byte code under a private ``PYTHONPYCACHEPREFIX`` (primed by one untimed
run) and says so.
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

#: this checkout's package, the one timed (``--against`` adds another)
HERE = Path(__file__).resolve().parents[1] / "src"
#: issue 29's targets, seconds end to end on a quiet 2-core machine
TARGETS = {"cold": 5.0, "warm": 1.5}


def first_run_round(
    scenario: str, env: dict[str, str], bare: bool
) -> dict[str, tuple[float, float]]:
    """(wall, CPU) of the cold, warm and (``bare``) warm ``--no-figures`` run in fresh
    caches."""
    with tempfile.TemporaryDirectory(prefix="aftc-bench-first-run-") as tmp:
        env = dict(env)
        env["ADAPTIVE_FTC_CACHE_DIR"] = str(Path(tmp) / "loops")
        env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba")
        aftc = [sys.executable, "-m", "adaptive_ftc.cli", "run", scenario, "--quiet", "--out"]
        times = {
            "cold": _timed([*aftc, str(Path(tmp) / "cold")], env),
            "warm": _timed([*aftc, str(Path(tmp) / "warm")], env),
        }
        if bare:
            times["warm, no figures"] = _timed(
                [*aftc, str(Path(tmp) / "bare"), "--no-figures"], env
            )
        return times


def _has_no_figures(env: dict[str, str]) -> bool:
    """Whether that checkout's ``aftc run`` has ``--no-figures`` (older ones draw always)."""
    import subprocess

    cmd = [sys.executable, "-m", "adaptive_ftc.cli", "run", "--help"]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    return "--no-figures" in done.stdout


def _env(src: str | None, pycache: Path | None) -> dict[str, str]:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = src
    if pycache is not None:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(pycache)
    return env


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--scenario", default="hypersonic-direct-s1", help="catalogue scenario")
    ap.add_argument("--repeat", type=int, default=1, help="cold + warm rounds (default 1)")
    ap.add_argument(
        "--against",
        metavar="SRC",
        help="also time another checkout's src folder (PYTHONPATH=SRC), interleaved",
    )
    args = ap.parse_args()
    if args.repeat < 1:
        print("error: --repeat must be positive, e.g. --repeat 3", file=sys.stderr)
        return 2
    if args.against and not (Path(args.against) / "adaptive_ftc" / "__init__.py").is_file():
        print(
            f"error: --against {args.against}: no adaptive_ftc package there; give a "
            "checkout's src folder, e.g. --against ../main/src",
            file=sys.stderr,
        )
        return 2
    load_start = os.getloadavg()[0]
    try:
        exe = build()
        c_run = min(run_single(exe, mode="whole", repeat=5, read=False).elapsed)
    except CReferenceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="aftc-bench-pyc-") as pyc:
        bytecode = Path(pyc) if os.environ.get("PYTHONDONTWRITEBYTECODE") else None
        trees = {"this": _env(str(HERE), bytecode)}
        if args.against:
            trees["against"] = _env(args.against, bytecode)
        start = min(_timed([sys.executable, "-c", "pass"], trees["this"])[0] for _ in range(5))
        for env in trees.values():  # byte code (and default caches) primed, not timed
            with tempfile.TemporaryDirectory(prefix="aftc-bench-prime-") as tmp:
                _timed([sys.executable, "-m", "adaptive_ftc.cli", "run", args.scenario,
                        "--quiet", "--out", tmp], env)  # fmt: skip
        rounds: dict[str, list[dict[str, tuple[float, float]]]] = {k: [] for k in trees}
        bare = {name: _has_no_figures(env) for name, env in trees.items()}
        for _ in range(args.repeat):
            for name, env in trees.items():  # interleaved: the same load for both
                rounds[name].append(first_run_round(args.scenario, env, bare[name]))
    print(
        f"aftc run {args.scenario}, {args.repeat} round(s), a fresh process each, empty caches "
        f"per cold run; load average {load_start:.1f} at the start, "
        f"{os.getloadavg()[0]:.1f} at the end"
        + (
            " (byte code written under a private prefix: PYTHONDONTWRITEBYTECODE is set)"
            if bytecode
            else ""
        )  # fmt: skip
    )
    print(
        f"references measured in this session: interpreter start-up (python -c pass) "
        f"{start * 1e3:.0f} ms; the C loop of hypersonic-direct-s1, whole run, "
        f"{c_run * 1e3:.1f} ms (best of 5)"
    )
    best: dict[tuple[str, str], float] = {}
    for name, runs in rounds.items():
        label = f" [{HERE if name == 'this' else args.against}]"
        for what in runs[0]:
            walls = [r[what][0] for r in runs]
            low, med = min(walls), statistics.median(walls)
            cpu = min(r[what][1] for r in runs)
            best[name, what] = low
            target = TARGETS.get(what)
            verdict = (
                f"target <= {target:g} s: {'MET' if low <= target else 'NOT MET'}"
                + (" (CPU within it)" if low > target and cpu <= target else "")
                if target
                else ""
            )
            print(
                f"  {what:16s}{label} {low:6.2f} s / {med:6.2f} s wall (min / median), "
                f"{cpu:6.2f} s CPU; {low / start:5.1f} start-ups, {low / c_run:5.0f} C runs; "
                f"{verdict}"
            )
        extra = statistics.median(r["cold"][0] - r["warm"][0] for r in runs)
        print(f"  first-run cost{label} (cold - warm, median): {extra:.1f} s")
    if args.against:
        for what in rounds["this"][0]:
            if ("against", what) not in best:
                continue
            print(
                f"  {what}: this / against = {best['this', what] / best['against', what]:.2f} "
                "(best walls)"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
