"""Time hypersonic-direct-s1 (120 s simulated) on the fast and the accurate path.

Run: ``python benchmarks/bench_hypersonic.py [--repeat N]``. The compiled kernel is warmed up
(and cached on disk) before timing. Target for the fast path: under 0.2 s per run on the
2-core reference machine (issue 2). Prints wall times, the ratio between the paths and their
agreement.
"""

from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import replace

import numpy as np

from adaptive_ftc import SolverOptions, load_scenario, simulate, simulate_many

TARGET_FAST_S = 0.2


def best_of(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    sc = load_scenario("hypersonic-direct-s1")
    fast_opts = replace(sc.solver, method="rk4", dt=1e-3)
    acc_opts = SolverOptions(method="accurate", record_dt=sc.solver.record_dt)
    t0 = time.perf_counter()
    fast = simulate(sc.loop, fast_opts)  # compiles or loads the cached kernel
    warm = time.perf_counter() - t0
    acc = simulate(sc.loop, acc_opts)
    t_fast = best_of(lambda: simulate(sc.loop, fast_opts), args.repeat)
    t_acc = best_of(lambda: simulate(sc.loop, acc_opts), max(1, args.repeat // 2))
    loops = [replace(sc.loop, initial_state=(a, 0.0)) for a in np.linspace(0, 0.05, 8)]
    t_batch = best_of(lambda: simulate_many(loops, fast_opts), 1)
    diff = float(np.max(np.abs(fast.states - acc.states)))
    print("hypersonic-direct-s1, 120 s simulated")
    print(f"  first call (compile or cache load): {warm:8.3f} s")
    print(f"  fast path  (RK4, dt = 1e-3):        {t_fast:8.3f} s per run "
          f"(target < {TARGET_FAST_S} s: {'MET' if t_fast < TARGET_FAST_S else 'NOT MET'})")
    print(f"  accurate path (LSODA, rtol 1e-8):   {t_acc:8.3f} s per run")
    print(f"  ratio accurate / fast:              {t_acc / t_fast:8.1f}")
    print(f"  8 runs in parallel (threads):       {t_batch:8.3f} s "
          f"({t_batch / 8:.3f} s per run)")
    print(f"  max |fast - accurate| over states:  {diff:8.2e}")
    print(f"  median kernel wall time recorded:   "
          f"{statistics.median([fast.meta['wall_time_s'], acc.meta['wall_time_s']]):.3f} s")


if __name__ == "__main__":
    main()
