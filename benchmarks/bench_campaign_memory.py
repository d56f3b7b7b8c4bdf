"""Campaign memory against the number of members (issue 29, "streaming campaigns").

Run: ``python benchmarks/bench_campaign_memory.py [--runs 500] [--factor 4] [--duration 2]
[--jobs 2] [--no-summary] [--single]``.

Runs the same seeded campaign of hypersonic-direct-s1 (the bench_campaign.py spec with runs
shortened to ``--duration`` seconds and failure times inside it) with N = ``--runs`` and
``factor`` x N members, each in a fresh process, and prints per N:

* peak RSS after the chunks (the streaming part: simulate, reduce each run to its metrics
  row, write one Parquet part per chunk) and after ``results.parquet`` and the summary page;
* throughput (runs/s) of the first and last quarter of the chunks: flat when nothing grows;
* throughput (runs/s) per tenth of the chunks (deciles): flat when nothing slows down;
* the RSS ratio factor-N / N (target: flat, <= 1.10 for the chunks) and the peak RSS of a
  100,000-member campaign extrapolated linearly from the two.

``--single``: one campaign of N members only (e.g. ``--runs 100000 --single``: the issue's
100,000 members measured, not extrapolated); its peak RSS against the target of 1 GB.

Absolute numbers depend on the machine and its load; the ratios are the point.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_RATIO = 1.10
TARGET_RSS_MIB = 1024.0  # issue 29: 100,000 members with peak RSS <= 1 GB
MB = 1024.0  # ru_maxrss is in KiB on Linux


def spec_data(runs: int, duration: float) -> dict:
    from bench_campaign import spec_data as base

    data = base(runs)
    data["duration"] = duration
    fail = data["failures"]
    fail["onset"] = {"uniform": [0.1 * duration, 0.6 * duration]}
    fail["duration"] = {"uniform": [0.05 * duration, 0.3 * duration]}
    data["success"] = {**data["success"], "final_window": 0.25 * duration}
    return data


def child(runs: int, duration: float, jobs: int, summary: bool) -> dict:
    """One campaign in this process: peak RSS (MiB) and per-chunk timestamps."""
    from adaptive_ftc.campaigns import load_campaign, run_campaign, run_chunk, store

    spec = load_campaign(spec_data(runs, duration))
    run_chunk(load_campaign({**spec_data(2, duration), "chunk_size": 2}), 0, jobs=1)  # compile
    rss_ready = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / MB
    stamps: list[float] = []
    write_part = store.write_part

    def timed_write_part(table, out, chunk):
        path = write_part(table, out, chunk)
        stamps.append(time.perf_counter())
        return path

    store.write_part = timed_write_part  # the runner calls store.write_part once per chunk
    with tempfile.TemporaryDirectory(prefix="aftc-bench-campaign-memory-") as tmp:
        t0 = time.perf_counter()
        run_campaign(spec, Path(tmp) / "c", jobs=jobs, progress=False, summary=False)
        rss_chunks = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / MB
        t_chunks = time.perf_counter() - t0
        if summary:
            from adaptive_ftc.campaigns.summary import write_summary

            write_summary(spec, Path(tmp) / "c")
        rss_all = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / MB
        t_all = time.perf_counter() - t0
    return {
        "runs": runs,
        "chunk_size": spec.chunk_size,
        "rss_ready": rss_ready,
        "rss_chunks": rss_chunks,
        "rss_all": rss_all,
        "t_chunks": t_chunks,
        "t_all": t_all,
        "stamps": [s - t0 for s in stamps],
    }


def _quarter_rates(stamps: list[float], chunk: int) -> tuple[float, float]:
    n = len(stamps)
    q = max(1, n // 4)
    first = stamps[q - 1]
    last = stamps[-1] - stamps[n - q - 1] if n > q else stamps[-1]
    return q * chunk / first, q * chunk / last


def _decile_rates(stamps: list[float], chunk: int, runs: int) -> list[float]:
    """Runs/s over each tenth of the chunks (by chunk count; the last chunk may be short)."""
    n = len(stamps)
    if n < 10:
        return []
    rates = []
    edges = [round(k * n / 10) for k in range(11)]
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        t_a = stamps[a - 1] if a > 0 else 0.0
        done = min(b * chunk, runs) - a * chunk
        rates.append(done / max(stamps[b - 1] - t_a, 1e-9))
    return rates


def _print_run(r: dict) -> None:
    first, last = _quarter_rates(r["stamps"], r["chunk_size"])
    print(
        f"  N={r['runs']:6d}: peak RSS {r['rss_ready']:6.0f} MiB compiled, "
        f"{r['rss_chunks']:6.0f} MiB after the chunks, {r['rss_all']:6.0f} MiB with the "
        f"summary; {r['runs'] / r['t_chunks']:7.1f} runs/s (first quarter {first:.1f}, "
        f"last quarter {last:.1f}); chunks {r['t_chunks']:.0f} s, with the summary "
        f"{r['t_all']:.0f} s"
    )
    deciles = _decile_rates(r["stamps"], r["chunk_size"], r["runs"])
    if deciles:
        print("    runs/s per tenth of the chunks: " + " ".join(f"{v:.1f}" for v in deciles))


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--runs", type=int, default=500, help="N (default 500)")
    ap.add_argument("--factor", type=int, default=4, help="the second campaign has factor*N")
    ap.add_argument("--duration", type=float, default=2.0, help="seconds per run (default 2)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-summary", action="store_true", help="chunks and results only")
    ap.add_argument("--single", action="store_true", help="one campaign of N members only")
    ap.add_argument("--child", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child is not None:
        sys.stdout.write(
            json.dumps(child(args.child, args.duration, args.jobs, not args.no_summary)) + "\n"
        )
        return 0
    if args.runs < 8 or (args.factor < 2 and not args.single):
        print("error: use --runs >= 8 and --factor >= 2, e.g. --runs 500 --factor 4")
        return 2
    out = []
    for n in (args.runs,) if args.single else (args.runs, args.factor * args.runs):
        cmd = [sys.executable, __file__, "--child", str(n), "--duration", str(args.duration)]
        cmd += ["--jobs", str(args.jobs)] + (["--no-summary"] if args.no_summary else [])
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            print(proc.stderr, file=sys.stderr)
            return 1
        out.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    print(
        f"campaign of hypersonic-direct-s1, {args.duration:g} s runs, {args.jobs} threads, "
        f"chunks of {out[0]['chunk_size']}; fresh process per N"
    )
    for r in out:
        _print_run(r)
    if args.single:
        peak = max(out[0]["rss_chunks"], out[0]["rss_all"])
        verdict = "MET" if peak <= TARGET_RSS_MIB else "NOT MET"
        print(f"  peak RSS {peak:.0f} MiB (target <= {TARGET_RSS_MIB:.0f} MiB: {verdict})")
        return 0
    a, b = out
    ratio = b["rss_chunks"] / a["rss_chunks"]
    ratio_all = b["rss_all"] / a["rss_all"]
    verdict = "MET" if ratio <= TARGET_RATIO else "NOT MET"
    print(
        f"  RSS ratio {b['runs']}/{a['runs']} members: chunks {ratio:.3f}, with summary "
        f"{ratio_all:.3f} (target <= {TARGET_RATIO}: {verdict})"
    )
    for what, key in (("chunks", "rss_chunks"), ("with summary", "rss_all")):
        # linear in the members between the two campaigns: an upper bound where the growth
        # levels off (bounded memos fill up over the first few thousand members)
        slope = max(0.0, b[key] - a[key]) / (b["runs"] - a["runs"])
        at = b[key] + slope * (100_000 - b["runs"])
        print(
            f"  {what}: {slope * 1024:.2f} KiB per member -> 100,000 members: about "
            f"{at:.0f} MiB peak (linear extrapolation)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
