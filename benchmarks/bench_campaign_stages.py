"""Where a campaign member's CPU time goes (issue 29, session 13): bench_campaign.py's campaign
(hypersonic-direct-s1, 120 s, DOPRI5 rtol 1e-6 / atol 1e-9, records every 1 ms, lean signals)
run chunk by chunk through ``run_chunk``, each stage timed with the CPU clock of the thread
that runs it (``time.thread_time``), per member:

- ``lanes``: ``integrate_lanes`` (the lane group's integration and, with lean signals, its
  signals' pass), of which ``lean pass`` is the lane module's ``lean_pass`` alone;
- ``single``: a member run one at a time (``CompiledLoop.integrate``: a chunk's last few
  members, or every member when lanes are off);
- ``finish``: ``finish_run`` (the ``SimResult`` of the records; a member run one at a time
  computes its signals there: ``signals``);
- ``row``: ``outcome`` (the results-table row: metrics, recovery, activity);
- ``main``: the calling thread (drawing the members, building their loops, the lane groups'
  bookkeeping, the rows' assembly).

Run: ``python benchmarks/bench_campaign_stages.py [--runs 150] [--jobs 1] [--lanes auto|off]``.
The first chunk warms up (compiles or loads); the rest are timed. Timing wrappers are
installed on the module attributes, so the numbers include a few microseconds of wrapping.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_campaign import spec_data  # noqa: E402

from adaptive_ftc.campaigns import load_campaign, run_chunk, runner  # noqa: E402
from adaptive_ftc.errors import DivergenceWarning  # noqa: E402
from adaptive_ftc.sim import engine, lanes  # noqa: E402

SPENT: dict[str, float] = defaultdict(float)


def _timed(owner, name: str, key: str) -> None:
    inner = getattr(owner, name)

    def timed(*args, **kw):
        t = time.thread_time()
        try:
            return inner(*args, **kw)
        finally:
            SPENT[key] += time.thread_time() - t

    setattr(owner, name, timed)


class _Module:
    """A lane module whose ``lean_pass`` is timed (the other attributes as they are)."""

    def __init__(self, module) -> None:
        self._module = module

    def __getattr__(self, name: str):
        attr = getattr(self._module, name)
        if name != "lean_pass":
            return attr

        def timed(*args):
            t = time.thread_time()
            try:
                return attr(*args)
            finally:
                SPENT["lean pass"] += time.thread_time() - t

        return timed


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=150)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--lanes", choices=("auto", "off"), default="auto")
    args = ap.parse_args()
    spec = load_campaign(spec_data(args.runs))
    use = "auto" if args.lanes == "auto" else False
    run_chunk(spec, 0, jobs=args.jobs, lanes=use)  # warm-up: compile or load
    _timed(lanes, "integrate_lanes", "lanes")
    _timed(engine.CompiledLoop, "integrate", "single")
    _timed(engine, "finish_run", "finish")
    _timed(runner, "outcome", "row")
    signals = engine.CompiledLoop.recorded

    def recorded(self, run, *, lean=False):
        t = time.thread_time()
        try:
            return signals(self, run, lean=lean)
        finally:
            if run.lean_signals is None:
                SPENT["signals"] += time.thread_time() - t

    engine.CompiledLoop.recorded = recorded  # type: ignore[method-assign]
    lean_signals = lanes._lean_signals
    lanes._lean_signals = lambda module, *a: lean_signals(_Module(module), *a)
    n = 0
    cpu, main_cpu = time.process_time(), time.thread_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        for c in range(1, spec.n_chunks):
            n += len(run_chunk(spec, c, jobs=args.jobs, lanes=use))
    cpu, main_cpu = time.process_time() - cpu, time.thread_time() - main_cpu
    SPENT["main"] = main_cpu
    print(
        f"{n} members of bench_campaign.py's campaign, {args.jobs} thread(s), lanes "
        f"{args.lanes}: {1000 * cpu / n:.1f} ms CPU per member (process)"
    )
    for key in ("lanes", "lean pass", "single", "signals", "finish", "row", "main"):
        print(f"  {key:10s} {1000 * SPENT[key] / n:7.2f} ms per member")
    return 0


if __name__ == "__main__":
    sys.exit(main())
