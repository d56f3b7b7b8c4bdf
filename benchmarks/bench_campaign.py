"""Campaign throughput (issue 13): a seeded campaign of hypersonic-direct-s1 (120 s runs).

Run: ``python benchmarks/bench_campaign.py [--runs 1000] [--jobs 2] [--no-dask] [--no-c]``,
or ``python benchmarks/bench_campaign.py --runs 200 --against OLD/src [--against ...]
[--rounds 2]``.

Times, in the same process:

1. ``run_campaign`` on ``--jobs`` threads, including drawing the members, the compensability
   verdicts, the metrics rows and writing the Parquet parts and ``results.parquet`` (the summary
   page is timed apart);
2. the plain C reference (``benchmarks/_cref.py``, ``c/hypersonic_loop.c``) on the same drawn
   runs on ``--jobs`` pthreads; prints the ratio campaign / C against the target >= 0.9;
3. the same campaign on a Dask ``LocalCluster`` (``--jobs`` worker processes, 1 thread each);
   prints the overhead against local threads (target <= 15 %), cluster start-up excluded.

Beside the campaign it times bare ``simulate_many`` on the same loops, at the base scenario's
solver (records every 10 ms) and at the campaign's (every 1 ms: a campaign that judges the
control activity records finely enough not to alias the chatter, ``CampaignSpec.solver``), and
prints the campaign's throughput against both, and against the baseline recorded in issue 29
(main at ed96ddc, 200 runs, load ~1: campaign 6.86 s, bare simulate_many 2.20 s) normalised by
the bare simulate_many of this run (the machine is shared: absolute times move with its load).

Failures are drawn from the models the C reference implements (loss of effectiveness, bias,
stuck, affine; numeric, abrupt).

``--against SRC`` (repeatable): only the campaign line, for this checkout and each other
checkout's ``src`` (e.g. a ``git worktree`` of the session-9 code), each in a fresh process,
interleaved over ``--rounds`` rounds (the machine is shared: its load moves between rounds);
prints each one's best and median runs/s and CPU time per run (every thread of the process:
the work done, less sensitive to the load than the wall time) and this checkout's ratio to
each, best against best.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from adaptive_ftc.campaigns import draw_member, load_campaign, run_campaign, run_chunk
from adaptive_ftc.campaigns.summary import write_summary

TARGET_C = 0.9
TARGET_DASK = 0.15
#: issue 29's recorded baseline (main at ed96ddc, --runs 200 --no-dask): campaign and bare
#: simulate_many (base solver) seconds; the campaign reached 2.20 / 6.86 = 0.32 of bare
BASELINE_29 = (6.86, 2.20)
TARGET_29 = 2.0


def spec_data(runs: int) -> dict:
    return {
        "name": "bench-hypersonic",
        "base": "hypersonic-direct-s1",
        "designs": ["adaptive"],
        "runs": runs,
        "seed": 12345,
        "chunk_size": 50,
        "success": {"rms_error_final": 8.7e-4, "final_window": 20.0},
        "failures": {
            "count": {"integers": [1, 2]},
            "onset": {"uniform": [10.0, 100.0]},
            "recovery_probability": 0.2,
            "duration": {"uniform": [5.0, 30.0]},
            "models": {
                "loss_of_effectiveness": {"effectiveness": {"uniform": [0.1, 0.9]}},
                "bias": {"bias": {"uniform": [-0.3, 0.3]}},
                "stuck": {"value": {"uniform": [-0.2, 0.2]}},
                "affine": {
                    "effectiveness": {"uniform": [0.5, 1.0]},
                    "bias": {"uniform": [-0.2, 0.2]},
                },
            },
        },
        "ranges": {"initial_state": [{"uniform": [0.0, 0.05]}]},
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-dask", action="store_true")
    ap.add_argument("--no-c", action="store_true")
    ap.add_argument("--against", action="append", default=[], metavar="SRC")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        sys.stdout.write(json.dumps(_campaign_only(args.runs, args.jobs)) + "\n")
        return 0
    if args.against:
        return _compare_checkouts(args)
    spec = load_campaign(spec_data(args.runs))
    small = load_campaign({**spec_data(2), "chunk_size": 2})
    run_chunk(small, 0, jobs=1)  # compile or load the cached kernel
    print(f"campaign of hypersonic-direct-s1, {args.runs} runs x 120 s, {args.jobs} threads")
    with tempfile.TemporaryDirectory(prefix="aftc-bench-campaign-") as tmp:
        t = time.perf_counter()
        run = run_campaign(spec, Path(tmp) / "local", jobs=args.jobs, progress=False, summary=False)
        t_local = time.perf_counter() - t
        t = time.perf_counter()
        write_summary(spec, run.out)
        t_summary = time.perf_counter() - t
        rate = args.runs / t_local
        print(f"  campaign (threads, incl. Parquet table): {t_local:8.2f} s  {rate:8.2f} runs/s")
        print(f"  summary page and figures:                {t_summary:8.2f} s")
        _compare_simulate_many(spec, args, t_local)
        if not args.no_c:
            _compare_c(spec, args, rate)
        if not args.no_dask:
            _compare_dask(spec, args, Path(tmp), t_local)
    return 0


def _campaign_only(runs: int, jobs: int) -> dict:
    """The campaign line alone in this process (whichever ``adaptive_ftc`` it imports): wall
    and CPU seconds (all threads) of ``run_campaign``, compiled code loaded first."""
    import adaptive_ftc

    spec = load_campaign(spec_data(runs))
    run_chunk(load_campaign({**spec_data(2), "chunk_size": 2}), 0, jobs=1)
    with tempfile.TemporaryDirectory(prefix="aftc-bench-campaign-") as tmp:
        t, c = time.perf_counter(), time.process_time()
        run_campaign(spec, Path(tmp) / "c", jobs=jobs, progress=False, summary=False)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
    return {"wall": wall, "cpu": cpu, "load": os.getloadavg()[0], "at": adaptive_ftc.__file__}


def _compare_checkouts(args) -> int:
    """This checkout against each ``--against`` checkout, interleaved, fresh processes."""
    here = str(Path(__file__).resolve().parents[1] / "src")
    trees = [here, *(str(Path(a).resolve()) for a in args.against)]
    got: dict[str, list[dict]] = {t: [] for t in trees}
    print(
        f"campaign of hypersonic-direct-s1, {args.runs} runs x 120 s, {args.jobs} threads; "
        f"{len(trees)} checkouts interleaved over {args.rounds} rounds"
    )
    for r in range(args.rounds):
        for tree in trees:
            env = {**os.environ, "PYTHONPATH": tree}
            cmd = [sys.executable, __file__, "--child", "--runs", str(args.runs)]
            cmd += ["--jobs", str(args.jobs)]
            proc = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
            if proc.returncode != 0:
                print(proc.stderr, file=sys.stderr)
                return 1
            res = json.loads(proc.stdout.strip().splitlines()[-1])
            got[tree].append(res)
            print(
                f"  round {r + 1}: {tree}: {args.runs / res['wall']:7.2f} runs/s, "
                f"{1000 * res['cpu'] / args.runs:6.1f} ms CPU a run (load {res['load']:.1f})"
            )

    def best(tree: str) -> tuple[float, float]:
        rates = sorted(args.runs / g["wall"] for g in got[tree])
        cpus = sorted(1000 * g["cpu"] / args.runs for g in got[tree])
        return rates[-1], cpus[0]

    b_rate, b_cpu = best(here)
    for tree in trees:
        rate, cpu = best(tree)
        median = statistics.median(args.runs / g["wall"] for g in got[tree])
        print(
            f"  {tree}: best {rate:.2f} runs/s (median {median:.2f}), best {cpu:.1f} ms CPU a run"
        )
    for tree in trees[1:]:
        rate, cpu = best(tree)
        print(
            f"  this checkout / {tree}: throughput {b_rate / rate:.2f}x (best wall), "
            f"{cpu / b_cpu:.2f}x (best CPU per run; issue 29's target >= {TARGET_29:g}x)"
        )
    return 0


def _compare_simulate_many(spec, args, t_local: float) -> None:
    """The same runs through bare simulate_many (no drawing, table or files): what the
    campaign machinery itself costs; at the base's solver (issue 29's reference) and at the
    campaign's (the same records: the integration's own floor)."""
    import warnings

    from adaptive_ftc import simulate_many
    from adaptive_ftc.errors import DivergenceWarning

    loops = [draw_member(spec, i).loop for i in range(spec.runs)]

    def bare(solver) -> float:
        t = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DivergenceWarning)
            for k in range(0, len(loops), spec.chunk_size):
                simulate_many(loops[k : k + spec.chunk_size], solver, jobs=args.jobs)
        return time.perf_counter() - t

    t_bare = bare(spec.base.solver)
    print(
        f"  bare simulate_many, same loops:          {t_bare:8.2f} s  "
        f"(campaign overhead {t_local / t_bare - 1.0:+.1%})"
    )
    print(
        f"  throughput vs bare simulate_many:        {t_bare / t_local:8.3f}  "
        f"(records every {spec.base.solver.record_dt:g} s; campaign every "
        f"{spec.solver.record_dt:g} s)"
    )
    if spec.solver != spec.base.solver:
        # streamed and dropped (iter_simulate): simulate_many would hold a chunk's 1 ms records
        from adaptive_ftc import iter_simulate

        t = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DivergenceWarning)
            for _ in iter_simulate(loops, spec.solver, jobs=args.jobs):
                pass
        t_same = time.perf_counter() - t
        print(
            f"  bare iter_simulate, campaign's records:  {t_same:8.2f} s  "
            f"(throughput vs it {t_same / t_local:.3f}: the integration's floor)"
        )
    base_campaign, base_bare = BASELINE_29
    gain = (t_bare / t_local) / (base_bare / base_campaign)
    verdict = "MET" if gain >= TARGET_29 else "NOT MET"
    print(
        f"  vs issue 29 baseline (normalised):       {gain:8.2f}x  (campaign/bare "
        f"{t_bare / t_local:.3f} now, {base_bare / base_campaign:.3f} at ed96ddc; absolute "
        f"{args.runs / t_local:.1f} vs {200 / base_campaign:.1f} runs/s; target >= "
        f"{TARGET_29:g}x: {verdict})"
    )


def _compare_c(spec, args, rate: float) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    try:
        from _cref import CReferenceError, build, failure_records, run_batch
    except ImportError:
        print("  C reference: benchmarks/_cref.py not found; absolute throughput only")
        return
    try:
        exe = build()
        runs = []
        for i in range(spec.runs):
            m = draw_member(spec, i)
            runs.append((m.loop.initial_state[:2], failure_records(m.failures)))
        t_c, _ = run_batch(
            exe,
            runs,
            threads=args.jobs,
            t_final=spec.t_final,
            dt=spec.base.solver.dt,
            record_dt=spec.base.solver.record_dt,
        )
    except CReferenceError as exc:
        print(f"  C reference unavailable ({exc}); absolute throughput only")
        return
    c_rate = spec.runs / t_c
    ratio = rate / c_rate
    verdict = "MET" if ratio >= TARGET_C else "NOT MET"
    print(f"  plain C loop, same runs, {args.jobs} pthreads:  {t_c:8.2f} s  {c_rate:8.2f} runs/s")
    print(
        f"  ratio campaign / C:                      {ratio:8.3f}  (target >= {TARGET_C}: "
        f"{verdict})"
    )


def _compare_dask(spec, args, tmp: Path, t_local: float) -> None:
    try:
        from distributed import LocalCluster
    except ImportError:
        print("  Dask: distributed not installed (pip install 'adaptive-ftc[distributed]')")
        return
    t = time.perf_counter()
    with LocalCluster(
        n_workers=args.jobs, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        t_start = time.perf_counter() - t
        from distributed import Client

        with Client(cluster) as client:  # warm each worker (kernel cache load)
            small = load_campaign({**spec_data(2), "chunk_size": 1})
            client.gather([client.submit(run_chunk, small, c, 1, pure=False) for c in (0, 1)])
            t = time.perf_counter()
            run_campaign(spec, tmp / "dask", scheduler=client, progress=False, summary=False)
            t_dask = time.perf_counter() - t
    overhead = t_dask / t_local - 1.0
    verdict = "MET" if overhead <= TARGET_DASK else "NOT MET"
    print(
        f"  Dask LocalCluster ({args.jobs} processes):       {t_dask:8.2f} s  "
        f"(cluster start {t_start:.1f} s, not counted)"
    )
    print(
        f"  Dask overhead vs local threads:          {overhead:+8.1%}  (target <= "
        f"{TARGET_DASK:.0%}: {verdict})"
    )


if __name__ == "__main__":
    sys.exit(main())
