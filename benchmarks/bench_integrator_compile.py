"""CPU time of compiling one shared integrator alone, in fresh processes with empty caches.

Run: ``python benchmarks/bench_integrator_compile.py [--method dopri5] [--rounds 4]
[--against /work/main/src]``.

Each round starts a new interpreter per checkout (this one's ``src`` and each ``--against``
``src``, interleaved round by round) with new, empty temporary caches
(``ADAPTIVE_FTC_CACHE_DIR``, ``NUMBA_CACHE_DIR``), fills numba's typing and lowering registries
(as ``aftc run`` does before it forks its compile child), then compiles
``integrate_<method>`` for the argument types ``hypersonic-direct-s1`` passes
(``precompile.shared_signatures``) and reports the CPU seconds of that compile alone: the
compile child's main work on a first ``aftc run`` (sim/precompile.py), without the
interpreter's start, the imports and the rest of the command, so the differences of a change
to the integrators' template show above the noise of a shared machine. Prints each
checkout's best and median and the ratio of the medians; the load average at the start and
the end. CPU time, not wall: on a shared machine a process waiting for a core uses none.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

#: this checkout's package, the one timed (``--against`` adds another)
HERE = Path(__file__).resolve().parents[1] / "src"

_CHILD = """
import sys, time
from dataclasses import replace
from adaptive_ftc.scenarios.loader import load_scenario
from adaptive_ftc.sim import precompile
from adaptive_ftc.sim.compose import integrators
from numba.core.registry import cpu_target

method = sys.argv[1]
sc = load_scenario("hypersonic-direct-s1")
solver = replace(sc.solver, method=method)
sig = dict(precompile.shared_signatures(sc.loop, solver))[f"integrate_{method}"]
disp = getattr(integrators(), f"integrate_{method}")
cpu_target.typing_context.refresh()
cpu_target.target_context.refresh()
c0 = time.process_time()
disp.compile(sig)
print("CPU", time.process_time() - c0)
"""


def compile_cpu(src: Path, method: str) -> float:
    """CPU seconds of compiling ``integrate_<method>`` in a fresh process on ``src``."""
    with tempfile.TemporaryDirectory(prefix="aftc-bench-integrator-") as tmp:
        env = dict(os.environ)
        env["PYTHONPATH"] = str(src)
        env["ADAPTIVE_FTC_CACHE_DIR"] = str(Path(tmp) / "loops")
        env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba")
        env.pop("NUMBA_DISABLE_JIT", None)
        out = subprocess.run(
            [sys.executable, "-c", _CHILD, method],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    return float(out.split("CPU ", 1)[1].split()[0])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="dopri5", help="dopri5, rodasp, rodas5p, auto or rk4")
    ap.add_argument("--rounds", type=int, default=4, help="interleaved rounds (default 4)")
    ap.add_argument(
        "--against", action="append", default=[], help="another checkout's src to compare"
    )
    args = ap.parse_args(argv)
    srcs = [HERE, *(Path(a).resolve() for a in args.against)]
    times: dict[Path, list[float]] = {s: [] for s in srcs}
    load0 = os.getloadavg()[0]
    for _ in range(args.rounds):
        for src in srcs:
            times[src].append(compile_cpu(src, args.method))
    load1 = os.getloadavg()[0]
    print(
        f"integrate_{args.method} compiled alone, {args.rounds} interleaved round(s), a fresh "
        f"process and empty caches each; load average {load0:.1f} at the start, {load1:.1f} "
        "at the end"
    )
    for src, ts in times.items():
        print(
            f"  [{src}] best {min(ts):.2f} s CPU, median {statistics.median(ts):.2f} s "
            f"(all: {' '.join(f'{t:.2f}' for t in ts)})"
        )
    base = statistics.median(times[HERE])
    for src in srcs[1:]:
        print(f"  this / [{src}]: {base / statistics.median(times[src]):.2f} (medians)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
