"""How much the exact-inverse baselines' RMS tracking error moves under their yardstick tolerances.

For every catalogue scenario with an oracle or nominal-inverse baseline, run the baseline at
the scenario's own tolerances and at the ones :func:`adaptive_ftc.baselines.baseline_solver`
chooses (no tighter than rtol 1e-6, atol 1e-9), and print both wall times and the largest
relative change of the RMS tracking error over the run.

Run: ``python scripts/baseline_tolerance.py``
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from adaptive_ftc import load_scenario
from adaptive_ftc.baselines import baseline_loop, baseline_solver
from adaptive_ftc.reproduce import _variants
from adaptive_ftc.scenarios.loader import list_scenarios
from adaptive_ftc.sim.engine import simulate


def rms(r) -> np.ndarray:
    return np.sqrt(np.mean((r.y - r.yd) ** 2, axis=0))


def timed(loop, solver):
    simulate(loop, solver)  # compile or load first
    start = time.perf_counter()
    result = simulate(loop, solver)
    return result, time.perf_counter() - start


def main() -> None:
    worst = 0.0
    for name in list_scenarios():
        sc = load_scenario(name)
        for variant in ("oracle", "nominal-inverse"):
            if variant not in _variants(sc):
                continue
            loop = baseline_loop(sc.loop, variant, sc.solver)
            chosen = baseline_solver(variant, sc.solver)
            own = replace(chosen, rtol=sc.solver.rtol, atol=sc.solver.atol)
            if own == chosen:
                continue
            a, ta = timed(loop, own)
            b, tb = timed(loop, chosen)
            moved = float(np.max(np.abs(rms(b) / rms(a) - 1)))
            worst = max(worst, moved)
            print(
                f"{name:28s} {variant:16s} rtol {own.rtol:g} -> {chosen.rtol:g}: "
                f"{ta:6.2f} s -> {tb:5.2f} s, RMS moved by {moved:.1e} of itself"
            )
    print(f"largest relative change of a baseline's RMS error: {worst:.1e}")


if __name__ == "__main__":
    main()
