"""Single run of hypersonic-direct-s1 against a plain C implementation of the same closed loop.

Run: ``python benchmarks/bench_engine.py [--repeat N]``. Builds ``benchmarks/c/hypersonic_loop.c``
with the system C compiler (``cc -O3 -march=native``) into a temporary directory, checks that the
C and ``Scenario.run()`` trajectories agree (alpha at every recorded time to 1e-9 rad), then times,
interleaved in one process:

- the whole run: ``Scenario.run()`` (integration, recording, signals, the SimResult) against the
  C program doing integration, recording and the same recorded signals;
- the integration alone (with state recording, without signals) on both sides.

Prints min and median of each and the ratios Python / C against the targets of issue 10
(whole run <= 1.3x, integration alone <= 1.2x). Exit status 1 if the trajectories disagree.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time

import numpy as np
from _cref import CReferenceError, build, rk4_scenario, run_single


def _python_integration_only(loop, solver):
    """Integrate ``loop`` without building the SimResult (issue 10's "integration alone")."""
    from adaptive_ftc.sim.engine import integrate_only

    return integrate_only(loop, solver)


SCENARIO = "hypersonic-direct-s1"
TARGET_WHOLE = 1.3
TARGET_INTEGRATION = 1.2
TOLERANCE = 1e-9


def check_agreement(exe, sc) -> float:
    """Largest |alpha_C - alpha_Python| over the recorded times of one whole run (printed)."""
    c = run_single(
        exe, mode="whole", t_final=sc.loop.t_final, dt=sc.solver.dt, record_dt=sc.solver.record_dt
    )
    r = sc.run()
    if c.time.shape != r.time.shape or np.max(np.abs(c.time - r.time)) > 1e-12:
        print(f"record grids differ: C {c.time.size} samples, Python {r.time.size}")
        return math.inf
    d_alpha = float(np.max(np.abs(c.states[:, 0] - r.states[:, 0])))
    d_state = float(np.max(np.abs(c.states - np.hstack([r.states, r.adaptive]))))
    d_e = float(np.max(np.abs(c.signal("e") - r.e[:, 0])))
    d_u = float(np.max(np.abs(c.signals[:, 11:13] - r.u_applied)))
    print(
        f"agreement C vs Scenario.run() over {r.time.size} recorded times "
        f"(status C {c.status}, Python {r.status!r}):"
    )
    print(
        f"  max |alpha| diff {d_alpha:.2e} rad (required <= {TOLERANCE:g}), all 27 states "
        f"{d_state:.2e}, e {d_e:.2e}, u_applied {d_u:.2e}"
    )
    return d_alpha


def _stats(xs: list[float]) -> tuple[float, float]:
    return min(xs), statistics.median(xs)


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--repeat", type=int, default=15, help="interleaved repetitions (default 15)")
    args = ap.parse_args()
    try:
        exe = build()
    except CReferenceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    sc = rk4_scenario(SCENARIO)
    loop, solver = sc.loop, sc.solver
    t0 = time.perf_counter()
    sc.run()  # compile or load the cached engine
    _python_integration_only(loop, solver)
    warm = time.perf_counter() - t0
    print(
        f"{SCENARIO}: {loop.t_final:g} s simulated, RK4 dt = {solver.dt:g}, "
        f"record_dt = {solver.record_dt:g}; first Python calls (compile or cache load) "
        f"{warm:.2f} s"
    )
    d_alpha = check_agreement(exe, sc)
    ok = d_alpha <= TOLERANCE
    common = dict(t_final=loop.t_final, dt=solver.dt, record_dt=solver.record_dt, read=False)
    times: dict[str, list[float]] = {"c_whole": [], "py_whole": [], "c_int": [], "py_int": []}
    for _ in range(args.repeat):
        # the C process runs twice and keeps the second (warm) time
        times["c_whole"].append(run_single(exe, mode="whole", repeat=2, **common).elapsed[-1])
        t = time.perf_counter()
        sc.run()
        times["py_whole"].append(time.perf_counter() - t)
        times["c_int"].append(run_single(exe, mode="integrate", repeat=2, **common).elapsed[-1])
        t = time.perf_counter()
        _python_integration_only(loop, solver)
        times["py_int"].append(time.perf_counter() - t)
    print(f"timings over {args.repeat} interleaved repetitions (min / median, seconds):")
    rows = (("whole run", "whole", TARGET_WHOLE), ("integration alone", "int", TARGET_INTEGRATION))
    for label, key, target in rows:
        cmin, cmed = _stats(times[f"c_{key}"])
        pmin, pmed = _stats(times[f"py_{key}"])
        rmin, rmed = pmin / cmin, pmed / cmed
        verdict = "MET" if rmin <= target else "NOT MET"
        print(
            f"  {label:18s} C {cmin:.4f} / {cmed:.4f}   Python {pmin:.4f} / {pmed:.4f}   "
            f"ratio {rmin:.2f} / {rmed:.2f} (target <= {target}: {verdict})"
        )
    if not ok:
        print(f"FAILED: the C and Python trajectories differ by {d_alpha:.2e} rad > {TOLERANCE:g}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
