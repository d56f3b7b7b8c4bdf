"""When do SIMD lanes repay their lane module? (issue 29: the ``lanes="auto"`` policy).

For each workload (the members of ``bench_campaign.py``'s campaign: hypersonic-direct-s1 with
its drawn failures, 120 s), on one thread, interleaved over ``--rounds``:

- ``rk4``: :func:`simulate_many`'s default solver (RK4 dt 1e-3, records every 10 ms), full
  signals;
- ``dopri5``: the base scenario's solver (DOPRI5 rtol 1e-6 / atol 1e-9, records every 10 ms),
  full signals;
- ``campaign``: the campaign's solver (DOPRI5, records every 1 ms) with ``lean_signals``, as
  the campaign runner asks;
- ``rk4-lean``: a campaign of an RK4 scenario (RK4 dt 1e-3, records every 1 ms, lean).

It measures the CPU time per member one at a time (``lanes=False``) and in full lane groups
(``lanes=True``), hence the saving per member and the lane / single ratio ``r`` (a lane group
of ``n < 8`` members costs about what 8 cost: it pays when ``n > 8 r``); then, per method,
the lane module's cold compile (an empty cache folder for the lane module only: the loop
modules are warm, as in a campaign on a machine that has run the scenario) and its load from
that cache in a fresh process (numba's cache and the once-per-process self-check). The
break-even counts are compile (or load) time over the saving per member.

Run: ``python benchmarks/bench_lane_break_even.py [--members 32] [--rounds 2]``
(``--no-compile`` skips the compile and load measurements, ``--compile-only`` the others).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_campaign import spec_data  # noqa: E402

from adaptive_ftc import SolverOptions  # noqa: E402
from adaptive_ftc.campaigns import draw_member, load_campaign  # noqa: E402
from adaptive_ftc.errors import DivergenceWarning  # noqa: E402
from adaptive_ftc.sim import codegen  # noqa: E402
from adaptive_ftc.sim.batch import iter_simulate  # noqa: E402
from adaptive_ftc.sim.engine import CompiledLoop  # noqa: E402


def workloads(n: int) -> dict:
    """name -> (loops, solver, lean)."""
    spec = load_campaign(spec_data(n))
    loops = [draw_member(spec, i).design_loop("adaptive") for i in range(n)]
    base = spec.base.solver
    return {
        "rk4": (loops, SolverOptions(), False),
        "dopri5": (loops, replace(base, record_dt=0.01), False),
        "campaign": (loops, spec.solver, True),
        "rk4-lean": (loops, SolverOptions(record_dt=spec.solver.record_dt), True),
    }


def cpu_per_member(loops, solver, lean: bool, lanes: bool) -> float:
    t = time.process_time()
    for _ in iter_simulate(loops, solver, jobs=1, lanes=lanes, lean_signals=lean):
        pass
    return (time.process_time() - t) / len(loops)


def first_group_seconds(loops, solver, folder: str) -> float:
    """CPU seconds of the first lane group of ``loops`` with the lane module's cache in
    ``folder`` (compile or load), less a warm group's; with the lean signals' pass (a
    campaign compiles it too)."""
    from adaptive_ftc.sim.lanes import LANE_WIDTH, integrate_lanes

    built = [CompiledLoop.build(loop, solver) for loop in loops[:LANE_WIDTH]]
    own = codegen.cache_dir
    codegen.cache_dir = lambda: Path(folder)  # type: ignore[assignment]
    try:
        t = time.process_time()
        integrate_lanes(built, lean=True)
        first = time.process_time() - t
    finally:
        codegen.cache_dir = own  # type: ignore[assignment]
    t = time.process_time()
    integrate_lanes(built, lean=True)
    return first - (time.process_time() - t)


def child(method: str, folder: str) -> None:
    """In a fresh process: the first lane group's extra seconds (compile or load)."""
    warnings.simplefilter("ignore", DivergenceWarning)
    loops, solver, _ = workloads(8)["rk4" if method == "rk4" else "dopri5"]
    for loop in loops:  # the loop modules: loaded before the lane module is timed
        CompiledLoop.build(loop, solver)
    print(json.dumps({"seconds": first_group_seconds(loops, solver, folder)}))


def fresh(method: str, folder: str) -> float:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    out = subprocess.run(
        [sys.executable, __file__, "--child", method, folder],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    return float(json.loads(out.stdout.strip().splitlines()[-1])["seconds"])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--members", type=int, default=32)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--no-compile", action="store_true")
    ap.add_argument("--compile-only", action="store_true")
    ap.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(*args.child)
        return 0
    warnings.simplefilter("ignore", DivergenceWarning)
    print(f"load before: {os.getloadavg()[0]:.2f}")
    n = args.members - args.members % 8 or 8  # full lane groups
    saving = {}
    for name, (loops, solver, lean) in () if args.compile_only else workloads(n).items():
        cpu_per_member(loops[:8], solver, lean, True)  # compile or load both paths first
        cpu_per_member(loops[:8], solver, lean, False)
        single, lanes = [], []
        for _ in range(args.rounds):
            single.append(cpu_per_member(loops, solver, lean, False))
            lanes.append(cpu_per_member(loops, solver, lean, True))
        s, ln = min(single), min(lanes)
        saving[name] = s - ln
        print(
            f"{name:9s} {n} members: one at a time {s * 1e3:6.1f} ms CPU per member, lanes "
            f"{ln * 1e3:6.1f} ms: r = {ln / s:.3f} (a partial group pays from {8 * ln / s:.1f} "
            f"members), saving {saving[name] * 1e3:5.1f} ms per member"
        )
    if not args.no_compile:
        for method, names in (("rk4", ["rk4", "rk4-lean"]), ("dopri5", ["dopri5", "campaign"])):
            with tempfile.TemporaryDirectory(prefix="aftc-lane-cache-") as tmp:
                cold = fresh(method, tmp)
                warm = fresh(method, tmp)
            print(
                f"{method}: lane module cold compile {cold:5.1f} s CPU, load from cache "
                f"{warm:4.2f} s CPU"
            )
            for name in names if saving else ():
                if saving[name] > 0:
                    print(
                        f"  {name}: break-even {cold / saving[name]:7.0f} members to repay the "
                        f"compile, {warm / saving[name]:5.0f} the load"
                    )
                else:
                    print(f"  {name}: lanes save nothing: no break-even")
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
