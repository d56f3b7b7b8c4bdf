"""Fair-baseline study: adaptive vs fixed-gain vs frozen-at-theta0 on the hypersonic scenarios.

For every chapter-2 and chapter-4 hypersonic catalogue scenario, prints the RMS tracking error
over the last 20 s of

* ``adaptive``: the scenario as the thesis runs it;
* ``fixed-gain``: :func:`adaptive_ftc.fixed_gain` (same controller structure, parameters reached
  at the end of a failure-free adaptive run, frozen), with the scenario's failures;
* ``frozen``: adaptation frozen at ``theta0`` (:meth:`ClosedLoop.frozen`), with the failures;

and the same three on the failure-free loop (``healthy`` columns), where the fixed-gain
controller runs with exactly the parameters the adaptive law ended with.

Usage::

    python scripts/baseline_study.py            # all hypersonic chapter-2/4 scenarios
    python scripts/baseline_study.py hypersonic-direct-s1 --window 20
"""

from __future__ import annotations

import argparse
import sys
import warnings

import numpy as np

from adaptive_ftc import fixed_gain, list_scenarios, load_scenario, simulate
from adaptive_ftc.errors import ConfigurationError


def _rms(loop, solver, window: float) -> tuple[float, str]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = simulate(loop, solver)
    if r.status != "completed":
        return float("inf"), r.status
    return float(np.max(r.rms_error(loop.t_final - window, loop.t_final))), r.status


def _hypersonic_scenarios() -> list[str]:
    names = []
    for name in list_scenarios():
        sc = load_scenario(name)
        tags = set(getattr(sc, "tags", ()) or ())
        if "hypersonic" in tags and tags & {"chapter2", "chapter4"}:
            names.append(name)
    return names


def study(name: str, window: float) -> dict[str, float]:
    sc = load_scenario(name)
    loop, solver = sc.loop, sc.solver
    healthy = loop.without_failures()
    row: dict[str, float] = {}
    row["adaptive"], _ = _rms(loop, solver, window)
    try:
        row["fixed"], _ = _rms(fixed_gain(loop, solver), solver, window)
        row["h_fixed"], _ = _rms(fixed_gain(healthy, solver), solver, window)
    except ConfigurationError:
        row["fixed"] = row["h_fixed"] = float("nan")
    row["frozen"], _ = _rms(loop.frozen(), solver, window)
    row["h_adaptive"], _ = _rms(healthy, solver, window)
    row["h_frozen"], _ = _rms(healthy.frozen(), solver, window)
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenarios", nargs="*", help="scenario names (default: every hypersonic one)")
    ap.add_argument("--window", type=float, default=20.0, help="final window in seconds")
    args = ap.parse_args(argv)
    names = args.scenarios or _hypersonic_scenarios()
    head = (
        f"{'scenario':32s} {'adaptive':>9s} {'fixed-gain':>10s} {'frozen':>9s} "
        f"{'fixed/adapt':>11s} {'frozen/fixed':>12s} | healthy: {'adaptive':>9s} "
        f"{'fixed-gain':>10s} {'frozen':>9s}"
    )
    print(f"RMS tracking error (rad) over the last {args.window:g} s; inf = diverged")
    print(head)
    print("-" * len(head))
    for name in names:
        r = study(name, args.window)
        print(
            f"{name:32s} {r['adaptive']:9.2e} {r['fixed']:10.2e} {r['frozen']:9.2e} "
            f"{r['fixed'] / r['adaptive']:11.2e} {r['frozen'] / r['fixed']:12.2e} | "
            f"{'':9s}{r['h_adaptive']:9.2e} {r['h_fixed']:10.2e} {r['h_frozen']:9.2e}",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
