"""Record the catalogue's trajectories, or compare today's with a recording (engine regressions).

Issue 10 requires that every catalogue trajectory, on the same method and step, agrees with the
one recorded before an engine change to 1e-9 of its signal scale. Record before the change,
compare after it::

    python benchmarks/trajectories.py record  DIR     # one .npz per catalogue scenario
    python benchmarks/trajectories.py compare DIR     # exit status 1 above --tolerance

Per scenario and recorded array (plant states, adaptive states, control gain, s, commanded and
applied outputs) the error is ``max_t |new - old| / scale`` with ``scale = max(max_t |old|,
1e-12)``, the worst over the array's columns. ``compare`` runs each scenario on the solver
settings stored in its recording, so a catalogue that changed its method still compares like
with like. ``--only NAME`` restricts both commands.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

from adaptive_ftc import SolverOptions, list_scenarios, load_scenario

FIELDS = ("time", "states", "adaptive", "control_gain", "s", "u_cmd", "u_applied")


def _runs(only: list[str] | None, folder: Path | None = None):
    """Run every scenario; with ``folder``, on the solver settings recorded there (a scenario
    whose catalogue solver changed since is compared on the method and step it was recorded
    with)."""
    for name in only or list_scenarios():
        sc = load_scenario(name)
        solver = sc.solver
        path = folder / f"{name}.npz" if folder is not None else None
        if path is not None and path.exists():
            with np.load(path) as old:
                if "solver" in old:
                    solver = SolverOptions(**json.loads(str(old["solver"])))
        t0 = time.perf_counter()
        r = sc.run(solver=solver)
        yield name, r, time.perf_counter() - t0, solver


def record(folder: Path, only) -> int:
    folder.mkdir(parents=True, exist_ok=True)
    for name, r, wall, solver in _runs(only):
        settings = json.dumps(dataclasses.asdict(solver))
        np.savez(folder / f"{name}.npz", solver=settings, **{k: getattr(r, k) for k in FIELDS})
        print(f"{name:42s} {r.status:10s} {r.time.size:7d} samples  {wall:6.2f} s")
    return 0


def compare(folder: Path, only, tolerance: float) -> int:
    worst_all = 0.0
    failed = []
    for name, r, wall, _ in _runs(only, folder):
        path = folder / f"{name}.npz"
        if not path.exists():
            print(f"{name:42s} no recording in {folder}")
            continue
        old = np.load(path)
        worst, where = 0.0, ""
        for k in FIELDS:
            a, b = np.asarray(old[k], float), np.asarray(getattr(r, k), float)
            if a.shape != b.shape:
                worst, where = np.inf, f"{k} shape {a.shape} -> {b.shape}"
                break
            if a.size == 0:
                continue
            a2, b2 = a.reshape(a.shape[0], -1), b.reshape(b.shape[0], -1)
            scale = np.maximum(np.max(np.abs(a2), axis=0), 1e-12)
            err = float(np.max(np.max(np.abs(b2 - a2), axis=0) / scale))
            if not err <= worst:
                worst, where = err, k
        worst_all = max(worst_all, worst)
        if not worst <= tolerance:
            failed.append(name)
        print(f"{name:42s} worst {worst:9.2e} ({where or '-'})  {wall:6.2f} s")
    print(f"worst over all: {worst_all:.2e} (tolerance {tolerance:g}); {len(failed)} above")
    return 1 if failed else 0


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("command", choices=("record", "compare"))
    ap.add_argument("folder", type=Path)
    ap.add_argument("--only", nargs="*", help="scenario names (default: the whole catalogue)")
    ap.add_argument("--tolerance", type=float, default=1e-9)
    args = ap.parse_args()
    if args.command == "record":
        return record(args.folder, args.only)
    return compare(args.folder, args.only, args.tolerance)


if __name__ == "__main__":
    sys.exit(main())
