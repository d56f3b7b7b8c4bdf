"""Shared test helpers."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def load_script(name: str):
    """The module of ``scripts/<name>.py`` (registered in ``sys.modules`` under ``name``
    first: a script's dataclasses look their module up), loaded once per process."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def assert_close(actual, expected, *, atol: float, rtol: float = 0.0, what: str = "") -> None:
    """The one closeness check of the suite, with an explicit absolute tolerance."""
    np.testing.assert_allclose(actual, expected, atol=atol, rtol=rtol, err_msg=what)


def combination_2(
    scenario: str,
    *,
    t1: float,
    t2: float,
    t_final: float,
    noise: float = 1e-4,
    seed: int = 0,
    **model,
):
    """``scenario`` (a hypersonic one, two failures) under issue 25's second combination (lag
    50 ms, rate 2 rad/s, travel ±0.5 rad, 50 Hz, noise ``noise`` on alpha and 10x on q from a
    1 kHz sensor), its failures moved to ``t1`` and ``t2``; the designer's model from the
    hardware (the ``s'`` filter's own time constant ``T``, as scripts/hardware_cases.py; ``model``
    overrides its fields). Returns ``(loop, solver)``: RK4 at 1 ms, recorded at 1 ms."""
    from dataclasses import replace

    from adaptive_ftc.controllers.constraints import ConstraintAware
    from adaptive_ftc.hardware import Actuators, Sensors
    from adaptive_ftc.scenarios.loader import load_scenario

    lag, rate, travel, T = 0.05, 2.0, 0.5, 0.02
    sc = load_scenario(scenario)
    first, second = sc.loop.failures.failures
    failures = replace(
        sc.loop.failures, failures=(replace(first, onset=t1), replace(second, onset=t2))
    )
    loop = replace(
        sc.loop,
        actuators=Actuators(tau=lag, rate=rate, lower=-travel, upper=travel),
        sensors=Sensors(noise=(noise, 10 * noise), rate=1000.0, seed=seed),
        sample_time=T,
        t_final=t_final,
        failures=failures,
    )
    solver = replace(sc.solver, method="rk4", dt=1e-3, filter_tau=T, record_dt=1e-3)
    ca = ConstraintAware.from_loop(loop, derivative_lag=T, **model)
    return replace(loop, controller=replace(loop.controller, constraint_aware=ca)), solver
