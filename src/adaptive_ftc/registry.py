"""What the library knows by name, in one place, and the checks every entry passes.

The tables are declared where their parts live, as literal dicts (nothing registers itself
when a module is imported): :data:`PLANTS` in :mod:`adaptive_ftc.plants`, :data:`DESIGNS` in
:mod:`adaptive_ftc.controllers`, :data:`FAILURE_MODELS` in :mod:`adaptive_ftc.faults`,
:data:`BASELINES` in :mod:`adaptive_ftc.baselines` and :data:`SOLVERS` in
:mod:`adaptive_ftc.sim.engine`. This module gathers them as read-only views, which the scenario
loader, the campaigns and the command line read; adding a part is one module and one line in
its package's table.

Like Gymnasium's ``check_env``, :func:`check_plant`, :func:`check_design` and
:func:`check_failure_model` call a part on sample inputs and raise one
:class:`~adaptive_ftc.errors.ConfigurationError` listing every problem they find; the test
suite runs them over everything registered (``tests/test_registry.py``).

Examples
--------
>>> from adaptive_ftc.registry import FAILURE_MODELS, check_failure_model
>>> check_failure_model(FAILURE_MODELS["loss_of_effectiveness"](actuator=1, effectiveness=0.4))
>>> sorted(PLANTS)[:2]
['equations', 'hypersonic']
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

import numpy as np

from adaptive_ftc import baselines as _baselines
from adaptive_ftc.controllers import DESIGNS as _DESIGNS
from adaptive_ftc.controllers.base import AdaptiveController
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.faults import FAILURE_MODELS as _FAILURE_MODELS
from adaptive_ftc.faults import Failure
from adaptive_ftc.plants import PLANTS as _PLANTS
from adaptive_ftc.plants import Plant
from adaptive_ftc.plants.custom import check_plant as _check_equations
from adaptive_ftc.sim import engine as _engine
from adaptive_ftc.sim import solvers as _solvers
from adaptive_ftc.sim.system import ClosedLoop

__all__ = [
    "BASELINES",
    "DESIGNS",
    "FAILURE_MODELS",
    "PLANTS",
    "SOLVERS",
    "check_design",
    "check_failure_model",
    "check_plant",
]

#: Plants by the name used in scenario files (``[plant] model = ...``).
PLANTS: Mapping[str, type[Plant]] = MappingProxyType(_PLANTS)
#: Designs by the name used in scenario files (``[controller] design = ...``).
DESIGNS: Mapping[str, type[AdaptiveController]] = MappingProxyType(_DESIGNS)
#: Failure models by the name used in scenario files (``[[failures]] model = ...``).
FAILURE_MODELS: Mapping[str, type[Failure]] = MappingProxyType(_FAILURE_MODELS)
#: Baselines by name, in report order (:class:`~adaptive_ftc.baselines.Baseline`).
BASELINES: Mapping[str, _baselines.Baseline] = MappingProxyType(_baselines.BASELINE_TABLE)
#: Integration methods by the name ``SolverOptions.method`` takes (the registry of
#: :mod:`adaptive_ftc.sim.solvers`, which has each method's kind and summary).
SOLVERS: tuple[str, ...] = tuple(_solvers.names())


def _raise(what: str, problems: list[str]) -> None:
    if problems:
        lines = "\n".join(f"- {p}" for p in problems)
        raise ConfigurationError(f"{what} fails its checks ({len(problems)}):\n{lines}")


def _frozen_dataclass(obj: Any, problems: list[str]) -> None:
    """A part is a frozen dataclass (configuration validated at construction, varied with
    ``dataclasses.replace``)."""
    params = getattr(type(obj), "__dataclass_params__", None)
    if params is None or not params.frozen:
        problems.append("it must be a frozen dataclass (@dataclass(frozen=True, kw_only=True)).")
        return
    try:
        if dataclasses.replace(obj) != obj:
            problems.append("dataclasses.replace(part) does not give an equal part.")
    except Exception as exc:  # noqa: BLE001 - reported, not raised
        problems.append(f"dataclasses.replace(part) fails: {type(exc).__name__}: {exc}.")


def _class_name(obj: Any, attr: str, problems: list[str]) -> None:
    value = getattr(type(obj), attr, None)
    if not isinstance(value, str) or not value:
        problems.append(f"its class must name itself: a non-empty class attribute `{attr}`.")


def _require(obj: Any, cls: type, check: str, example: str) -> None:
    """``check``'s argument must be a ``cls`` instance (a ConfigurationError naming ``obj``
    and giving ``example``)."""
    if not isinstance(obj, cls):
        article = "an" if cls.__name__[0] in "AEIOU" else "a"
        raise ConfigurationError(
            f"{check} needs {article} {cls.__name__} instance (e.g. {example}); got {obj!r}."
        )


def _part_problems(obj: Any, *names: str) -> list[str]:
    """The problems of a part's class: each of ``names`` a non-empty class attribute, and a
    frozen dataclass."""
    problems: list[str] = []
    for attr in names:
        _class_name(obj, attr, problems)
    _frozen_dataclass(obj, problems)
    return problems


def check_plant(plant: Plant) -> None:
    """Check a plant: what every design assumes of its equations, and how it is built.

    Runs :func:`adaptive_ftc.plants.check_plant` (equations at sample states and inputs: a
    finite ``dx/dt`` for every state, inputs not modified, outputs of relative degree 2 driven
    by some actuator), then checks that the plant is a frozen dataclass with a ``name``, that
    its numbers are named (``parameter_values()`` a ``NamedTuple``) and that its equations
    give the same ``dx/dt`` twice.

    Raises
    ------
    ConfigurationError
        Listing every problem, naming the plant.
    """
    _require(plant, Plant, "check_plant", "WingRock()")
    problems: list[str] = []
    try:
        _check_equations(plant)
    except ConfigurationError as exc:
        problems.append(str(exc))
    _class_name(plant, "name", problems)
    _frozen_dataclass(plant, problems)
    values = plant.parameter_values()
    named = isinstance(values, tuple) and hasattr(values, "_fields")
    if not (named or isinstance(values, np.ndarray)):  # an array: user-named parameters
        problems.append(
            "parameter_values() must return a typing.NamedTuple (numbers travel as named "
            f"data) or, for parameters the user names, a float array; got {type(values).__name__}."
        )
    rng = np.random.default_rng(1)
    x = rng.uniform(-0.5, 0.5, plant.n_states)
    u = rng.uniform(-0.5, 0.5, plant.n_actuators)
    try:
        first, second = plant.evaluate(0.1, x.copy(), u.copy()), plant.evaluate(0.1, x, u)
        if not np.array_equal(first, second, equal_nan=True):
            problems.append("its equations give a different dx/dt for the same t, x and u.")
    except Exception:  # noqa: BLE001, S110 - reported by the equations check above
        pass
    _raise(f"Plant '{getattr(plant, 'name', type(plant).__name__)}'", problems)


def check_failure_model(failure: Failure) -> None:
    """Check a failure model on sample commands, times and states.

    Checks that the model is a frozen dataclass naming itself (``model``), that its failed
    output is a valid expression giving finite values for commands in [-1, 1] over its
    active window, that it is inactive before its onset and active from it, that its jump
    times are ordered and start at the onset, and that its :meth:`~Failure.severity` is in
    [0, 1] or ``nan``.

    Raises
    ------
    ConfigurationError
        Listing every problem, naming the failure.
    """
    _require(failure, Failure, "check_failure_model", "Stuck(actuator=1, onset=5.0)")
    problems = _part_problems(failure, "model")
    before = copy.deepcopy(failure)
    try:
        expr = failure.expression(("t", "u"), strict=False)
        t0, t1 = float(failure.onset), min(failure.end, float(failure.onset) + 10.0)
        t = np.linspace(t0, t1 if math.isfinite(t1) else t0 + 10.0, 7)[:, None]
        u = np.linspace(-1.0, 1.0, 5)[None, :]
        env = {v: np.zeros_like(t * u) for v in expr.variables if v not in ("t", "u")}
        y = np.broadcast_to(expr(t=t, u=u, **env), (7, 5))
        if not np.all(np.isfinite(y)):
            problems.append(
                f"its failed output {str(expr)!r} is not finite for commands in [-1, 1] over "
                "its active window."
            )
    except Exception as exc:  # noqa: BLE001 - reported, not raised
        problems.append(f"its failed output cannot be evaluated: {type(exc).__name__}: {exc}.")
    onset = float(failure.onset)
    if onset > 0 and failure.active(onset * 0.5):
        problems.append(f"it is active before its onset ({onset:g} s).")
    if not failure.active(onset):
        problems.append(f"it is not active at its onset ({onset:g} s).")
    jumps = tuple(failure.jump_times)
    if not jumps or jumps[0] != onset or list(jumps) != sorted(jumps):
        problems.append(f"its jump times {jumps} must start at the onset and be ordered.")
    for scales in (None, {f.name: 1.0 for f in dataclasses.fields(failure)}):
        sev = failure.severity(scales)
        if not (isinstance(sev, float) and (math.isnan(sev) or 0.0 <= sev <= 1.0)):
            problems.append(f"severity({scales}) must be a float in [0, 1] or nan; got {sev!r}.")
    if failure != before:
        problems.append("calling it changed the failure.")
    _raise(f"Failure model {type(failure).__name__}(actuator={failure.actuator})", problems)


def check_design(
    design: AdaptiveController,
    loop: ClosedLoop,
    solver: _engine.SolverOptions | None = None,
    *,
    duration: float = 0.2,
) -> None:
    """Check a design on a closed loop: its settings, and a short run of ``loop`` with it.

    Checks that the design is a frozen dataclass naming itself (``design``, ``equation``),
    that its numbers are named (``gains()`` a ``NamedTuple`` of finite numbers) and that its
    loop rate is finite and positive; then simulates ``loop`` with the design for
    ``duration`` seconds twice (``solver``, default compiled RK4 with ``dt = 1e-3``): the runs must
    complete with finite signals, give bit-identical results, and leave the design unchanged.

    Raises
    ------
    ConfigurationError
        Listing every problem, naming the design.
    """
    _require(design, AdaptiveController, "check_design", "a scenario's loop.controller")
    problems = _part_problems(design, "design", "equation")
    gains = design.gains()
    flat = np.asarray(
        [v for g in gains for v in (g if isinstance(g, tuple) else (g,))], dtype=float
    )
    if not (isinstance(gains, tuple) and hasattr(gains, "_fields")):
        problems.append(f"gains() must return a typing.NamedTuple; got {type(gains).__name__}.")
    elif not np.all(np.isfinite(flat)):
        problems.append(f"gains() must be finite numbers; got {gains}.")
    rate = design.loop_rate()
    if not (math.isfinite(rate) and rate > 0):
        problems.append(f"loop_rate() must be finite and positive; got {rate!r}.")
    before = copy.deepcopy(design)
    short = dataclasses.replace(loop, controller=design, t_final=min(loop.t_final, duration))
    solver = solver or _engine.SolverOptions(method="rk4", dt=1e-3)
    try:
        runs = [_engine.simulate(short, solver) for _ in range(2)]
    except Exception as exc:  # noqa: BLE001 - reported, not raised
        problems.append(f"its loop cannot run: {type(exc).__name__}: {exc}.")
    else:
        first, second = runs
        if first.status != "completed":
            problems.append(
                f"its loop does not complete {duration:g} s: {first.message.rstrip('.')}."
            )
        signals = (first.states, first.u_cmd, first.adaptive)
        if not all(np.all(np.isfinite(s)) for s in signals):
            problems.append("its loop gives non-finite states, commands or adaptive states.")
        same = all(
            np.array_equal(a, b)
            for a, b in zip(signals, (second.states, second.u_cmd, second.adaptive), strict=True)
        )
        if not same:
            problems.append("two runs of the same loop differ (the design is not deterministic).")
    if design != before:
        problems.append("running its loop changed the design.")
    _raise(f"Design {type(design).__name__} ('{getattr(design, 'design', '?')}')", problems)
