"""Campaign throughput with the lane engine (issue 29, stages 2 and 3, and the default):
bench_campaign.py's campaign (hypersonic-direct-s1, 120 s runs, the base scenario's DOPRI5
rtol 1e-6 / atol 1e-9) run by ``run_campaign`` with its members one at a time
(``lanes=False``) and with its default, ``lanes="auto"`` (the lane module compiled or loaded
in the warm-up, so "auto" runs the members in SIMD lanes: lane groups of 8, a chunk's last
few members one at a time), interleaved, in the same process. The campaign passes
``lean_signals=True``, so the lane groups take the lanes' own signals pass (stage 3); the
bench counts the lane groups that did.

Run: ``python benchmarks/bench_campaign_lanes.py [--runs 200] [--jobs 1] [--rounds 2]``.

Prints per round the wall and CPU time of each and their ratio, checks that both results
tables are equal (every metric of every member). The first lane group of a structure compiles
its lane module (timed apart, "cold" only when the cache is empty).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_campaign import spec_data  # noqa: E402

import adaptive_ftc.sim.lanes as lane_engine  # noqa: E402
from adaptive_ftc.campaigns import load_campaign, run_campaign  # noqa: E402
from adaptive_ftc.campaigns.store import read_results  # noqa: E402
from adaptive_ftc.errors import DivergenceWarning  # noqa: E402

LEAN_GROUPS = [0, 0]  # lane groups run, and those with the lanes' lean signals pass
_integrate_lanes = lane_engine.integrate_lanes


def _counted(compiled, *args, **kw):
    LEAN_GROUPS[0] += 1
    LEAN_GROUPS[1] += bool(kw.get("lean"))
    return _integrate_lanes(compiled, *args, **kw)


lane_engine.integrate_lanes = _counted  # batch._run_group looks it up there on each call


def timed(spec, out: Path, jobs: int, lanes: bool | str) -> tuple[float, float]:
    """Wall and CPU seconds of one run_campaign (summary page not written)."""
    wall, cpu = time.perf_counter(), time.process_time()
    run_campaign(spec, out, jobs=jobs, progress=False, summary=False, lanes=lanes)
    return time.perf_counter() - wall, time.process_time() - cpu


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    warnings.simplefilter("ignore", DivergenceWarning)
    spec = load_campaign(spec_data(args.runs))
    small = load_campaign({**spec_data(2), "chunk_size": 2})
    print(
        f"campaign of hypersonic-direct-s1, {args.runs} runs x 120 s, method "
        f"{spec.solver.method} rtol {spec.solver.rtol:g}, {args.jobs} thread(s)"
    )
    with tempfile.TemporaryDirectory(prefix="aftc-bench-lanes-") as tmp:
        root = Path(tmp)
        t = time.perf_counter()
        timed(small, root / "warm0", 1, False)  # compile or load the loop modules
        print(f"  warm-up, members one at a time:  {time.perf_counter() - t:7.2f} s")
        t = time.perf_counter()
        timed(small, root / "warm1", 1, True)  # compile or load the lane module
        print(f"  warm-up, lane module:            {time.perf_counter() - t:7.2f} s")
        for k in range(args.rounds):
            w0, c0 = timed(spec, root / f"single{k}", args.jobs, False)
            w1, c1 = timed(spec, root / f"lanes{k}", args.jobs, "auto")
            print(
                f"  round {k}: one at a time {w0:6.2f} s wall {c0:6.2f} s CPU; lanes {w1:6.2f} s "
                f"wall {c1:6.2f} s CPU; lanes / one at a time: wall {w1 / w0:.3f}, "
                f"CPU {c1 / c0:.3f}"
            )
        print(f"  lane groups: {LEAN_GROUPS[0]}, with the lanes' lean signals: {LEAN_GROUPS[1]}")
        a = read_results(root / "single0")
        b = read_results(root / "lanes0")
        timing = [c for c in a.columns if "wall" in c]  # the runs' own timings differ
        print(f"  columns: {list(a.columns)}")
        same = a.drop(columns=timing).equals(b.drop(columns=timing))
        print(f"  results tables equal (every column but {timing}): {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
