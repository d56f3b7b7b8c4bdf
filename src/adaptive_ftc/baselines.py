"""Fair baselines: non-adaptive controllers to compare the adaptive designs with.

The thesis compares its designs with nothing, and "adaptation frozen at ``theta0``"
(:meth:`ClosedLoop.frozen`) is close to no control at all. :func:`fixed_gain` is the fair
non-adaptive baseline of issue 14: a controller of the *same structure* whose parameters are
those the adaptive law reached at the end of a failure-free run of the same loop (tuned on the
healthy plant), then frozen. It is what a designer would fly without adaptation.

Campaigns can compare it under the design name ``"fixed-gain"``::

    designs = ["adaptive", "fixed-gain", "frozen"]
"""

from __future__ import annotations

from dataclasses import replace
from threading import Lock

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.engine import SolverOptions, simulate
from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["CAMPAIGN_SOLVER", "fixed_gain", "healthy_parameters"]

#: Solver of the failure-free tuning run when a campaign asks for ``"fixed-gain"`` (a campaign
#: design variant receives only the loop): adaptive-step DOPRI5/RODASP, so stiff loops work too.
CAMPAIGN_SOLVER = SolverOptions(method="auto", record_dt=0.1)

_CACHE: dict[tuple[ClosedLoop, SolverOptions], tuple[float, ...]] = {}
_CACHE_LIMIT = 256
_LOCK = Lock()


def healthy_parameters(loop: ClosedLoop, solver: SolverOptions | None = None) -> tuple[float, ...]:
    """Every adaptive state at the end of a failure-free, adapting run of ``loop``.

    The run is ``loop.without_failures()`` with adaptation on, from the loop's own initial
    adaptive states, over the same duration and reference: the adaptive law (e.g. (2.29)) acts
    as the tuning procedure on the healthy plant. Results are cached per (healthy loop, solver).

    Parameters
    ----------
    loop
        The closed loop (its failures are ignored).
    solver
        Integration settings (default :class:`SolverOptions`; ``sdot`` filter states are not
        adaptive parameters and are left out).

    Returns
    -------
    tuple of float
        In the order of ``SimResult.adaptive_names`` (what ``ClosedLoop.adaptive_initial``
        takes).

    Raises
    ------
    ConfigurationError
        When the failure-free run does not complete (no healthy tuning exists to freeze).
    """
    if not isinstance(loop, ClosedLoop):
        raise ConfigurationError(
            f"fixed_gain() needs a ClosedLoop (e.g. load_scenario(name).loop); "
            f"got {type(loop).__name__}."
        )
    solver = solver or SolverOptions()
    if not isinstance(solver, SolverOptions):
        raise ConfigurationError(f"`solver` must be a SolverOptions; got {solver!r}.")
    healthy = replace(loop.without_failures(), adapt=True)
    key = (healthy, solver)
    with _LOCK:
        hit = _CACHE.get(key)
    if hit is not None:
        return hit
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a diverged tuning run is reported below
        result = simulate(healthy, solver)
    if result.status != "completed":
        raise ConfigurationError(
            f"The failure-free tuning run of {loop.name or 'the loop'} did not complete "
            f"({result.message}); a fixed-gain baseline needs a healthy adaptive run to freeze. "
            "Fix the loop's gains or initial state, or pass a stiffer solver "
            "(SolverOptions(method='auto'))."
        )
    n_filter = loop.plant.n_outputs if solver.sdot == "filtered" else 0
    final = result.adaptive[-1, : result.adaptive.shape[1] - n_filter]
    if not np.all(np.isfinite(final)):  # pragma: no cover - a completed run is finite
        raise ConfigurationError("The failure-free tuning run ended with non-finite parameters.")
    params = tuple(float(v) for v in final)
    with _LOCK:
        if len(_CACHE) >= _CACHE_LIMIT:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = params
    return params


def fixed_gain(loop: ClosedLoop, solver: SolverOptions | None = None) -> ClosedLoop:
    """The fixed-gain baseline of ``loop``: same controller structure, parameters tuned on
    the healthy plant and frozen.

    ``replace(loop, adapt=False, adaptive_initial=healthy_parameters(loop, solver))``: the
    failures of ``loop`` are kept, so the returned loop shows how the tuned, non-adaptive
    controller copes with them.

    Parameters
    ----------
    loop
        The closed loop (any design; its failures are kept).
    solver
        Settings of the failure-free tuning run (default :class:`SolverOptions`); use the
        solver you will simulate with.

    Returns
    -------
    ClosedLoop
        Named ``"<name> (fixed-gain)"``.

    Examples
    --------
    >>> from adaptive_ftc import load_scenario, simulate
    >>> sc = load_scenario("hypersonic-direct-s1")
    >>> baseline = fixed_gain(sc.loop, sc.solver)
    >>> baseline.adapt, len(baseline.adaptive_initial)
    (False, 25)
    """
    params = healthy_parameters(loop, solver)
    name = f"{loop.name} (fixed-gain)" if loop.name else "fixed-gain"
    return replace(loop, adapt=False, adaptive_initial=params, name=name)


def _campaign_fixed_gain(loop: ClosedLoop) -> ClosedLoop:
    return fixed_gain(loop, CAMPAIGN_SOLVER)


def _register() -> None:
    from adaptive_ftc.campaigns.spec import register_design

    register_design("fixed-gain", _campaign_fixed_gain)


_register()
