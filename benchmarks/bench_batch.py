"""Batch throughput: many random failure scenarios of hypersonic-direct-s1, Python vs C threads.

Run: ``python benchmarks/bench_batch.py [--n 1000] [--jobs 2] [--seed 0] [--repeat 1]
[--api iter|many] [--chunk 100]``.

Draws ``n`` runs from a seeded numpy Generator: each run fails one or both elevators, each with
a loss of effectiveness, a bias, a stuck surface or a loss of effectiveness with bias (numeric
values, random onset, sometimes a recovery; at most one elevator stuck at a time, so every run
stays compensable). The same drawn numbers go to ``iter_simulate(loops, jobs=--jobs)`` (results
streamed in input order, each consumed and dropped, so memory stays bounded: a 120 s SimResult
holds about 4 MB) and to the C reference (``c/hypersonic_loop.c`` on ``--jobs`` pthreads, whole
runs with recording and signals); final states of every run are compared. Rounds are
interleaved (C, Python, C, ...); prints runs per second (min / median over rounds) and the ratio
Python / C against the target of issue 10 (>= 0.9). ``--api many`` measures ``simulate_many``
on chunks of ``--chunk`` runs instead (the way to bound memory before ``iter_simulate``: both
threads wait at the end of each chunk for its last run).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from dataclasses import replace

import numpy as np
from _cref import N_STATE, CReferenceError, build, failure_records, rk4_scenario, run_batch

from adaptive_ftc import iter_simulate, simulate_many
from adaptive_ftc.faults import Affine, Bias, LossOfEffectiveness, Stuck

SCENARIO = "hypersonic-direct-s1"
TARGET = 0.9
TOLERANCE = 1e-9


def draw_failures(rng: np.random.Generator, t_final: float) -> tuple:
    """Random failures on one or both elevators (numeric, abrupt, compensable)."""
    which = ((1,), (2,), (1, 2))[rng.integers(3)]
    stuck_used = False
    out = []
    for act in which:
        kinds = ("loe", "bias", "affine") if stuck_used else ("loe", "bias", "stuck", "affine")
        kind = kinds[rng.integers(len(kinds))]
        onset = float(np.round(rng.uniform(5.0, 0.9 * t_final), 3))
        recovery = None
        if rng.random() < 0.3:
            rec = float(np.round(onset + rng.uniform(2.0, 30.0), 3))
            recovery = rec if rec < t_final else None
        common = dict(actuator=act, onset=onset, recovery=recovery)
        if kind == "loe":
            out.append(LossOfEffectiveness(effectiveness=float(rng.uniform(0.1, 1.0)), **common))
        elif kind == "bias":
            out.append(Bias(bias=float(rng.uniform(-0.1, 0.1)), **common))
        elif kind == "stuck":
            stuck_used = True
            out.append(Stuck(value=float(rng.uniform(-0.1, 0.1)), **common))
        else:
            out.append(
                Affine(
                    effectiveness=float(rng.uniform(0.1, 1.0)),
                    bias=float(rng.uniform(-0.1, 0.1)),
                    **common,
                )
            )
    return tuple(out)


def _row(rows: np.ndarray, i: int, r) -> None:
    rows[i, 0] = 0.0 if r.status == "completed" else 1.0
    rows[i, 1] = r.time.size
    rows[i, 2:] = np.concatenate([r.states[-1], r.adaptive[-1]])


def python_batch(loops, solver, jobs: int, api: str, chunk: int) -> tuple[float, np.ndarray]:
    """Wall time of ``iter_simulate`` (``api="iter"``) or of ``simulate_many`` on chunks
    (``"many"``) over ``loops``, and rows [status, n, final state]."""
    rows = np.zeros((len(loops), 2 + N_STATE))
    t = time.perf_counter()
    if api == "iter":
        for i, r in enumerate(iter_simulate(loops, solver, jobs=jobs)):
            _row(rows, i, r)
    else:
        for start in range(0, len(loops), chunk):
            results = simulate_many(loops[start : start + chunk], solver, jobs=jobs)
            for i, r in enumerate(results, start):
                _row(rows, i, r)
            del results
    return time.perf_counter() - t, rows


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--n", type=int, default=1000, help="runs per batch (default 1000)")
    ap.add_argument("--jobs", type=int, default=2, help="threads on both sides (default 2)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the failure draws (default 0)")
    ap.add_argument("--repeat", type=int, default=1, help="interleaved rounds (default 1)")
    ap.add_argument(
        "--api",
        choices=("iter", "many"),
        default="iter",
        help="iter_simulate over all runs (default) or simulate_many on chunks",
    )
    ap.add_argument("--chunk", type=int, default=100, help="runs per simulate_many call (many)")
    args = ap.parse_args()
    if min(args.n, args.jobs, args.repeat, args.chunk) < 1:
        print("error: --n, --jobs, --repeat and --chunk must be positive", file=sys.stderr)
        return 2
    try:
        exe = build()
    except CReferenceError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    sc = rk4_scenario(SCENARIO)
    loop, solver = sc.loop, sc.solver
    rng = np.random.default_rng(args.seed)
    loops, runs = [], []
    for _ in range(args.n):
        failures = draw_failures(rng, loop.t_final)
        loops.append(replace(loop, failures=failures))
        runs.append((loop.initial_state, failure_records(failures)))
    warnings.simplefilter("ignore")  # diverged runs (if any) are compared, not reported
    simulate_many(loops[:2], solver, jobs=args.jobs)  # compile or load the cached engine
    common = dict(threads=args.jobs, t_final=loop.t_final, dt=solver.dt, record_dt=solver.record_dt)
    c_times, py_times = [], []
    c_rows = py_rows = None
    c_times.append(run_batch(exe, runs, **common)[0])
    for _ in range(args.repeat):
        t_py, py_rows = python_batch(loops, solver, args.jobs, args.api, args.chunk)
        py_times.append(t_py)
        t_c, c_rows = run_batch(exe, runs, **common)
        c_times.append(t_c)
    status_ok = bool(np.all(c_rows[:, :2] == py_rows[:, :2]))
    scale = np.maximum(1.0, np.abs(py_rows[:, 2:]))
    diff = float(np.max(np.abs(c_rows[:, 2:] - py_rows[:, 2:]) / scale))
    n_div = int(py_rows[:, 0].sum())
    how = "iter_simulate" if args.api == "iter" else f"simulate_many on {args.chunk}-run chunks"
    print(
        f"{SCENARIO}: {args.n} random failure scenarios (seed {args.seed}), "
        f"{loop.t_final:g} s each, RK4 dt = {solver.dt:g}, {args.jobs} threads, {how}; "
        f"{n_div} diverged"
    )
    print(
        f"  agreement: statuses and sample counts {'equal' if status_ok else 'DIFFER'}, "
        f"max |final state| diff (relative above 1) {diff:.2e} (required <= {TOLERANCE:g})"
    )
    c_rate = [args.n / t for t in c_times]
    py_rate = [args.n / t for t in py_times]
    c_best, c_med = max(c_rate), statistics.median(c_rate)
    py_best, py_med = max(py_rate), statistics.median(py_rate)
    ratio_best, ratio_med = py_best / c_best, py_med / c_med
    verdict = "MET" if ratio_best >= TARGET else "NOT MET"
    print(
        f"  runs per second (best / median): C {c_best:.1f} / {c_med:.1f} over "
        f"{len(c_times)} rounds, Python {py_best:.1f} / {py_med:.1f} over {len(py_times)}"
    )
    print(
        f"  throughput Python / C: {ratio_best:.2f} / {ratio_med:.2f} "
        f"(target >= {TARGET}: {verdict}); C is {1 / ratio_best:.2f}x faster"
    )
    if not (status_ok and diff <= TOLERANCE):
        print("FAILED: the C and Python batches disagree")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
