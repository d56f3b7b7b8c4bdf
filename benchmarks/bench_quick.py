"""Wall time of `aftc reproduce --quick` against a warm full `aftc reproduce`, in one session.

Run: ``python benchmarks/bench_quick.py [--repeat 1] [--formats png,pdf] [NAME ...]``.

Both commands run in fresh processes with the same loop and numba caches (the user's, or
``ADAPTIVE_FTC_CACHE_DIR`` / ``NUMBA_CACHE_DIR`` if set) and fresh temporary output folders.
Each is run once first (warm-up: whatever is not compiled yet compiles there), then ``repeat``
times more, alternating full and quick so that the machine's load drifts over both alike. The
script prints both times and their ratio quick / full against issue 28's target (<= 1/4), and
checks that the quick run judged every claim the full one did with the same verdicts (apart
from the thesis law's companion verdicts, which quick mode leaves out and lists). The full run
uses the command's default formats (PNG and PDF) unless ``--formats`` says otherwise. About
three minutes a round on the shared 2-core machine.
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import sys
import tempfile
from pathlib import Path

from bench_reproduce import _timed

TARGET_RATIO = 0.25


def _verdicts(out: Path) -> dict[tuple[str, str, str], str]:
    """``(scenario, kind, text) -> verdict`` of the scenario's own claims (run adaptive)."""
    with (out / "claims.csv").open(encoding="utf-8") as fh:
        return {
            (r["scenario"], r["kind"], r["text"]): r["verdict"]
            for r in csv.DictReader(fh)
            if r["run"] == "adaptive"
        }


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("names", nargs="*", help="scenarios (default: the whole catalogue)")
    ap.add_argument("--repeat", type=int, default=1, help="timed rounds after the warm-up")
    ap.add_argument("--formats", default=None, help="figure formats of the full run")
    ap.add_argument("--jobs", type=int, default=None, help="parallel processes (both runs)")
    args = ap.parse_args()
    if args.repeat < 1:
        print("error: --repeat must be positive", file=sys.stderr)
        return 2
    env = dict(os.environ)
    base = [sys.executable, "-m", "adaptive_ftc.cli", "reproduce", *args.names, "--quiet"]
    if args.jobs:
        base += ["--jobs", str(args.jobs)]
    full_cmd = base + (["--formats", args.formats] if args.formats else [])
    quick_cmd = [*base, "--quick"]
    fulls: list[float] = []
    quicks: list[float] = []
    with tempfile.TemporaryDirectory(prefix="aftc-bench-quick-") as tmp:
        for i in range(args.repeat + 1):
            full_out, quick_out = Path(tmp) / f"full{i}", Path(tmp) / f"quick{i}"
            full = _timed([*full_cmd, "--out", str(full_out)], env)[0]
            quick = _timed([*quick_cmd, "--out", str(quick_out)], env)[0]
            if i:  # the first round warms the caches
                fulls.append(full)
                quicks.append(quick)
            what = "warm-up" if not i else f"round {i}"
            print(f"  {what}: full {full:.1f} s, quick {quick:.1f} s", flush=True)
        same = _verdicts(full_out) == _verdicts(quick_out)
    f, q = statistics.median(fulls), statistics.median(quicks)
    ratio = q / f
    verdict = "MET" if ratio <= TARGET_RATIO else "NOT MET"
    print(
        f"aftc reproduce{' ' + ' '.join(args.names) if args.names else ''}: warm full "
        f"{f:.1f} s, --quick {q:.1f} s (median of {args.repeat}); quick / full = {ratio:.2f} "
        f"(target <= {TARGET_RATIO:g}: {verdict}); verdicts of the scenarios' claims "
        f"{'identical' if same else 'DIFFER'}"
    )
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
