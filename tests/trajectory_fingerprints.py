"""Fingerprints of every catalogue trajectory (shared by scripts/trajectory_hashes.py and
tests/test_trajectory_hashes.py)."""

from __future__ import annotations

import dataclasses
import hashlib
import platform
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "data" / "trajectory_hashes.json"

#: the arrays of a SimResult that make up its trajectory
FIELDS = (
    "time", "states", "adaptive", "y", "yd", "e", "s", "sdot", "u0", "u_cmd", "u_applied",
    "u_f", "gain", "control_gain",
)  # fmt: skip
#: simulated seconds of each baseline's run (they cost several times a design's run)
BASELINE_SPAN = 5.0


def _host() -> str:
    from llvmlite import binding

    return f"{platform.machine()}-{binding.get_host_cpu_name()}"


def fingerprint(result) -> dict:
    h = hashlib.sha256()
    sums = {}
    for name in FIELDS:
        a = np.ascontiguousarray(np.asarray(getattr(result, name), dtype=np.float64))
        h.update(name.encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
        finite = np.where(np.isfinite(a), a, 0.0)
        sums[name] = [float(finite.sum()), float(np.abs(finite).sum())]
    return {
        "sha256": h.hexdigest(),
        "status": str(result.status),
        "n": int(len(result.time)),
        "sums": sums,
        "final_state": [float(v) for v in np.asarray(result.states)[-1]],
    }


def runs():
    """(key, thunk) of every run fingerprinted."""
    from adaptive_ftc import list_scenarios, load_scenario
    from adaptive_ftc.baselines import baseline_loop, baseline_solver
    from adaptive_ftc.reproduce import thesis_law_loop
    from adaptive_ftc.sim.engine import simulate

    for name in list_scenarios():
        sc = load_scenario(name)
        yield name, (lambda sc=sc: sc.run())
        if getattr(sc.loop.controller, "constraint_aware", None) is not None:
            yield (
                f"{name}/thesis_law",
                (lambda sc=sc: simulate(thesis_law_loop(sc.loop), sc.solver)),
            )
        short = dataclasses.replace(
            sc.loop, t_final=min(sc.loop.t_final, sc.loop.t0 + BASELINE_SPAN)
        )
        for b in ("fixed-gain", "nominal-inverse", "oracle"):

            def thunk(short=short, b=b, sc=sc):
                return simulate(baseline_loop(short, b, sc.solver), baseline_solver(b, sc.solver))

            yield f"{name}/{b}", thunk


def fingerprints() -> dict:
    out = {}
    for key, thunk in runs():
        try:
            out[key] = fingerprint(thunk())
        except Exception as exc:  # a baseline a scenario refuses: its refusal is the fingerprint
            out[key] = {"error": type(exc).__name__}
    return {"host": _host(), "runs": out}


def compare(stored: dict, now: dict, rtol: float = 1e-9) -> list[str]:
    """Runs that changed. Bit-identical (same SHA-256) is required on the host that recorded the
    file; elsewhere (another CPU may fuse or vectorise differently) the summaries must agree to
    ``rtol`` relative to each array's scale."""
    exact = stored["host"] == now["host"]
    problems = []
    for key in sorted(set(stored["runs"]) | set(now["runs"])):
        a, b = stored["runs"].get(key), now["runs"].get(key)
        if a is None or b is None:
            problems.append(f"{key}: {'new run' if a is None else 'run missing'}")
            continue
        if "error" in a or "error" in b:
            if a != b:
                problems.append(f"{key}: {a} -> {b}")
            continue
        if a["status"] != b["status"] or a["n"] != b["n"]:
            problems.append(
                f"{key}: status/length {a['status']}/{a['n']} -> {b['status']}/{b['n']}"
            )
        elif exact and a["sha256"] != b["sha256"]:
            worst = max(
                (abs(x - y) / max(s, 1e-300), f)
                for f in a["sums"]
                for (x, s), (y, _) in [(a["sums"][f], b["sums"][f])]
            )
            problems.append(
                f"{key}: not bit-identical (largest summary change {worst[0]:.1e} in {worst[1]})"
            )
        elif not exact:
            for f in a["sums"]:
                (x, s), (y, _) = a["sums"][f], b["sums"][f]
                if abs(x - y) > rtol * max(s, 1e-300):
                    problems.append(f"{key}: {f} sum {x!r} -> {y!r}")
                    break
    return problems
