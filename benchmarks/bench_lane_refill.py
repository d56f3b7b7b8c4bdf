"""DOPRI5 lane refill (issue 29): the lanes' time and occupancy against the queue length.

The members of ``bench_peers.py`` (hypersonic-direct-s1, ``--n`` members of ``--t-final`` s,
failures drawn with ``--seed``), DOPRI5 rtol 1e-6 / atol 1e-9, records every 10 ms, through
``iter_simulate(lanes=True, jobs=1)`` on one thread with the DOPRI5 lane jobs holding
``q`` members (``lanes.QUEUE_MEMBERS``, set here for each): ``q = 8`` is one group of 8
lanes per job, as before refill (a group runs until its slowest member); larger ``q`` lets
a lane whose member ends take the next one. Interleaved over ``--rounds``; prints the CPU
time per member, its ratio to ``q = 8`` and the lanes' occupancy (the engine's counter:
the members' step attempts / the lane slots), and checks that every ``q`` gives the same
results (final states, bit for bit).

Run: ``python benchmarks/bench_lane_refill.py [--n 64] [--t-final 120] [--rounds 2]
[--queues 8,16,64]``.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _cref import rk4_scenario  # noqa: E402
from bench_batch import draw_failures  # noqa: E402

from adaptive_ftc import SolverOptions, iter_simulate  # noqa: E402
from adaptive_ftc.sim import lanes  # noqa: E402

DP = SolverOptions(method="dopri5", rtol=1e-6, atol=1e-9, record_dt=0.01)


def run(loops, q: int) -> tuple[float, float, np.ndarray]:
    """CPU seconds per member, occupancy and the final states with jobs of ``q`` members."""
    lanes.QUEUE_MEMBERS["dopri5"] = q
    before = lanes.lane_occupancy()
    t = time.process_time()
    finals = [r.states[-1].copy() for r in iter_simulate(loops, DP, jobs=1, lanes=True)]
    per = (time.process_time() - t) / len(loops)
    after = lanes.lane_occupancy()
    occ = (after.attempts - before.attempts) / max(after.slots - before.slots, 1)
    return per, occ, np.array(finals)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--n", type=int, default=64)
    ap.add_argument("--t-final", type=float, default=120.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--queues", default="8,16,64")
    args = ap.parse_args()
    queues = [int(q) for q in args.queues.split(",")]
    base = replace(rk4_scenario().loop, t_final=args.t_final)
    rng = np.random.default_rng(args.seed)
    loops = [replace(base, failures=draw_failures(rng, args.t_final)) for _ in range(args.n)]
    warnings.simplefilter("ignore")
    list(iter_simulate(loops[:2], DP, jobs=1, lanes=True))  # compile or load the lane module
    times: dict[int, list[float]] = {q: [] for q in queues}
    occ: dict[int, float] = {}
    finals: dict[int, np.ndarray] = {}
    for _ in range(args.rounds):
        for q in queues:
            per, occ[q], finals[q] = run(loops, q)
            times[q].append(per)
    print(f"{args.n} members of {args.t_final:g} s (seed {args.seed}), DOPRI5, one thread")
    ref = min(times[queues[0]])
    failed = False
    for q in queues:
        same = np.array_equal(finals[q], finals[queues[0]], equal_nan=True)
        failed |= not same
        ms = ", ".join(f"{t * 1e3:.2f}" for t in times[q])
        print(
            f"  queue {q:3d}: {ms} ms per member (best {min(times[q]) / ref:.3f}x queue "
            f"{queues[0]}), occupancy {occ[q]:.1%}, results {'equal' if same else 'DIFFER'}"
        )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
