"""Fair baselines: non-adaptive controllers to compare the adaptive designs with.

The thesis compares its designs with nothing, and "adaptation frozen at ``theta0``"
(:meth:`ClosedLoop.frozen`) is close to no control at all. :func:`fixed_gain` is the fair
non-adaptive baseline of issue 14: a controller of the *same structure* whose parameters are
those the adaptive law reached at the end of a failure-free run of the same loop (tuned on the
healthy plant), then frozen. It is what a designer would fly without adaptation.

Two more baselines replace the adaptive design by feedback linearisation
(:mod:`adaptive_ftc.controllers.nominal`), with the same targets ``lam``, ``k``, ``k0``,
``eps0``: :func:`nominal_inverse` inverts the *healthy* plant model (what a designer without
fault tolerance would fly) and :func:`oracle` inverts the model *with the true failure* of each
interval (a bound, not a fair competitor: claims never compare with it, reports show it).

Campaigns compare them under the design names ``"fixed-gain"``, ``"nominal-inverse"`` and
``"oracle"`` (a campaign's ``"oracle"`` is :func:`oracle` of the member's constraint-aware loop
with ``law_feedback``: the same designer's model and the law's own fixed feedback;
``"oracle-filtered"`` the same without that feedback, ``"oracle-plain"`` the thesis-gain one with
no command filter: :data:`adaptive_ftc.campaigns.spec.DESIGN_VARIANTS`)::

    designs = ["adaptive", "fixed-gain", "nominal-inverse", "oracle", "frozen"]

:data:`FAIR_BASELINES` names the non-oracle baselines a claim's ``baseline_ratio`` is held
against (the best of them, see :mod:`adaptive_ftc.claims`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from threading import Lock

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.engine import SolverOptions, simulate
from adaptive_ftc.sim.result import SimResult
from adaptive_ftc.sim.system import ClosedLoop

__all__ = [
    "BASELINES",
    "BASELINE_TABLE",
    "Baseline",
    "CAMPAIGN_SOLVER",
    "FAIR_BASELINES",
    "baseline_loop",
    "baseline_solver",
    "fixed_gain",
    "healthy_parameters",
    "nominal_inverse",
    "oracle",
    "run_baselines",
]

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
    # the s' filter's states (on with sdot "filtered", or "auto" on a measured loop) follow
    # the adaptive parameters and are not parameters
    n_filter = loop.plant.n_outputs if solver.sdot_for(healthy) == "filtered" else 0
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


def _inverse(
    loop: ClosedLoop, cls, label: str, *, hardware: bool = False, **settings
) -> ClosedLoop:
    if not isinstance(loop, ClosedLoop):
        raise ConfigurationError(
            f"{label}() needs a ClosedLoop (e.g. load_scenario(name).loop); "
            f"got {type(loop).__name__}."
        )
    c = loop.controller
    if hardware and "constraint_aware" not in settings:
        # the same designer's model: the same command filter, smoothing and measurement
        # filters (derived from the same loop rate k + k0/eps0), so the oracle answers
        # "how good could any controller be on this hardware"
        # (the adaptive design's model completed from the loop: its loop rate)
        settings["constraint_aware"] = c.bound(loop).constraint_aware
    if settings.pop("law_feedback", False):
        model = settings.get("constraint_aware")
        if model is not None and not model.is_ideal and c.regressors():
            # the law's own feedback design beside the inverse (OracleInverse.law)
            law = c.bound(loop)
            settings.update(law=law, constraint_aware=law.constraint_aware)
    ctrl = cls(lam=c.lam, k=c.k, k0=c.k0, eps0=c.eps0, **settings)
    name = f"{loop.name} ({ctrl.design})" if loop.name else ctrl.design
    return replace(loop, controller=ctrl, adaptive_initial=(), adapt=False, name=name)


def nominal_inverse(loop: ClosedLoop, **settings) -> ClosedLoop:
    """The nominal-inverse baseline of ``loop``: feedback linearisation with the healthy model.

    The controller of ``loop`` is replaced by :class:`~adaptive_ftc.controllers.NominalInverse`
    with the same ``lam``, ``k``, ``k0`` and ``eps0`` (so it aims at the same error dynamics
    ``s' = -k s - k0 tanh(s/eps0)``); allocation, failures, reference and initial state are
    kept. It has no adaptive state.

    Parameters
    ----------
    loop
        The closed loop (any design).
    **settings
        ``gmin`` and ``probe`` of :class:`~adaptive_ftc.controllers.NominalInverse`.

    Returns
    -------
    ClosedLoop
        Named ``"<name> (nominal-inverse)"``.

    Examples
    --------
    >>> from adaptive_ftc import load_scenario
    >>> nominal_inverse(load_scenario("hypersonic-direct-s1").loop).controller.design
    'nominal-inverse'
    """
    from adaptive_ftc.controllers.nominal import NominalInverse

    return _inverse(loop, NominalInverse, "nominal_inverse", **settings)


def oracle(loop: ClosedLoop, *, law_feedback: bool = False, **settings) -> ClosedLoop:
    """The oracle baseline of ``loop``: feedback linearisation knowing the true failure.

    As :func:`nominal_inverse`, with :class:`~adaptive_ftc.controllers.OracleInverse`: the
    model includes the failed actuators' true outputs on every interval (exact for ``a u + b``
    failures). An upper bound on what a controller of this form can achieve; not a fair
    competitor (claims never compare with it).

    Under hardware (issue 25, item 3) the oracle runs on the loop's own actuators, sampling
    and sensors, and, when the loop's design has the constraint-aware option
    (``constraint_aware``), with the same designer's model: the same command filter (rate,
    travel and bandwidth limits), the same smoothing of the robust term (``k``, ``k0``,
    ``eps0``, ``lam`` as :meth:`~adaptive_ftc.controllers.base.AdaptiveController.robust_settings`
    derives them from the same loop rate) and the same measurement filters; so its error is
    "how good could a controller that knows the failure be on this hardware" (the yardstick
    of issue 25's "2x the oracle's error"). ``constraint_aware=None`` in ``settings`` gives
    the thesis-gain oracle on the same hardware.

    ``law_feedback=True`` (session 13; the campaigns' ``oracle``) also keeps the law's own
    feedback design where the loop's design has a non-ideal constraint-aware model:
    :class:`~adaptive_ftc.controllers.OracleInverse` with ``law`` (the bound design), i.e.
    the law's whole configuration (placed PID and lead, MIMO floors, its sampled filter) and
    per-output smoothing, with the exact inverse of the failed plant where the law has its
    adaptation (:mod:`adaptive_ftc.controllers.nominal`, "The oracle of the law's
    feedback"). Without it the oracle drops every fixed feedback: behind a lag, on the wing
    rock and the spacecraft, that inverse is weaker than the law itself (docs/hardware.md).
    The default stays off, so the catalogue's oracle rows do not move.

    Examples
    --------
    >>> from adaptive_ftc import load_scenario
    >>> oracle(load_scenario("hypersonic-direct-s1").loop).name
    'hypersonic-direct-s1 (oracle)'
    """
    from adaptive_ftc.controllers.nominal import OracleInverse

    return _inverse(
        loop, OracleInverse, "oracle", hardware=True, law_feedback=law_feedback, **settings
    )


@dataclass(frozen=True)
class Baseline:
    """One baseline as the registry lists it (:data:`adaptive_ftc.registry.BASELINES`).

    ``make(loop, solver)`` builds the baseline's closed loop from the adaptive design's
    ``loop`` (``solver``: the failure-free tuning run's settings where the baseline has one);
    ``fair``: a claim's ``baseline_ratio`` may be held against it (all but the oracle).
    """

    name: str
    make: Callable[[ClosedLoop, SolverOptions | None], ClosedLoop]
    fair: bool
    summary: str


def _nominal_inverse(loop: ClosedLoop, solver: SolverOptions | None = None) -> ClosedLoop:
    return nominal_inverse(loop)


def _oracle(loop: ClosedLoop, solver: SolverOptions | None = None) -> ClosedLoop:
    return oracle(loop)


def _frozen(loop: ClosedLoop, solver: SolverOptions | None = None) -> ClosedLoop:
    return loop.frozen()


#: The baselines by name, in report order (:data:`BASELINES` lists the names).
BASELINE_TABLE: dict[str, Baseline] = {
    b.name: b
    for b in (
        Baseline("fixed-gain", fixed_gain, True, "the adaptive law's healthy end state, frozen"),
        Baseline("nominal-inverse", _nominal_inverse, True, "inverse of the healthy model"),
        Baseline("oracle", _oracle, False, "inverse of the model with the true failure"),
        Baseline("frozen", _frozen, True, "adaptation frozen at theta0"),
    )
}
#: Every baseline, in report order; ``"oracle"`` knows the true failure.
BASELINES: tuple[str, ...] = tuple(BASELINE_TABLE)
#: The baselines a controller can be fairly compared with (all but the oracle).
FAIR_BASELINES: tuple[str, ...] = tuple(n for n, b in BASELINE_TABLE.items() if b.fair)


def baseline_loop(loop: ClosedLoop, name: str, solver: SolverOptions | None = None) -> ClosedLoop:
    """The baseline ``name`` (one of :data:`BASELINES`) of ``loop``.

    ``solver`` is used by ``"fixed-gain"`` only (its failure-free tuning run).

    Raises
    ------
    ConfigurationError
        For an unknown name (the message lists :data:`BASELINES`).
    """
    baseline = BASELINE_TABLE.get(name)
    if baseline is not None:
        return baseline.make(loop, solver)
    from adaptive_ftc.errors import did_you_mean

    raise ConfigurationError(
        f"Unknown baseline {name!r}.{did_you_mean(str(name), BASELINES)} "
        f"Available: {', '.join(BASELINES)}."
    )


#: Loosest tolerances of the exact-inverse baselines (see :func:`baseline_solver`)
BASELINE_RTOL, BASELINE_ATOL = 1e-6, 1e-9


def baseline_solver(name: str, solver: SolverOptions) -> SolverOptions:
    """The integration settings of baseline ``name`` in a scenario integrated with ``solver``.

    The exact-inverse baselines impose ``s' = -k s - k0 tanh(s/eps0)``: with the thesis's small
    ``eps0`` their loops are stiff (an eigenvalue near ``-k0/eps0``), so a scenario on the
    explicit adaptive-step method runs them with the stiff Rodas5P (``"rodas5p"``). Measured
    over the catalogue's 20 exact-inverse runs of DOPRI5 scenarios (``benchmarks``-style, warm,
    same tolerances): 0.26 s in all against 1.07 s with stiffness switching (``"auto"``, used
    before) and more with DOPRI5 (spacecraft-mimo-s2's oracle: 5.5 s DOPRI5, 0.34 s auto,
    0.044 s Rodas5P); the RMS errors moved by at most 2.1e-7 of themselves.

    They are yardsticks: only their RMS tracking errors enter the claims and the report, so an
    adaptive-step method runs them at no tighter than ``rtol`` :data:`BASELINE_RTOL` and
    ``atol`` :data:`BASELINE_ATOL`. Against the scenario's own tolerances (rtol 1e-7, atol
    1e-10 on the spacecraft and manipulator), every catalogue baseline's RMS error moved by at
    most 5.2e-6 of itself (spacecraft-mimo-s1 nominal inverse), and the spacecraft oracle took
    0.36-0.48 s instead of 2.1-3.0 s (19k instead of 285k steps on s2).
    """
    if name not in ("nominal-inverse", "oracle"):
        return solver  # fixed-gain: the adaptive loop's structure and settings, unchanged
    method = "rodas5p" if solver.method == "dopri5" else solver.method
    if method == "rk4":
        return solver
    return replace(
        solver,
        method=method,
        rtol=max(solver.rtol, BASELINE_RTOL),
        # a per-state atol names the adaptive loop's states, which the baseline's loop does not
        # have: its smallest entry stands for every state
        atol=max(
            min(solver.atol) if isinstance(solver.atol, tuple) else solver.atol, BASELINE_ATOL
        ),
    )


def run_baselines(
    scenario,
    names: tuple[str, ...] = BASELINES,
    *,
    failures: bool = True,
    solver: SolverOptions | None = None,
) -> dict[str, SimResult | None]:
    """Simulate the baselines ``names`` of a scenario (what claims with ``baseline_ratio`` and
    the report compare with).

    Parameters
    ----------
    scenario
        A :class:`~adaptive_ftc.scenarios.loader.Scenario` (its loop and solver are used).
    names
        Baselines to run (default every one of :data:`BASELINES`).
    failures
        Keep the scenario's failures (default) or run the failure-free loop.
    solver
        Integration settings (default: the scenario's).

    Returns
    -------
    dict
        ``{name: SimResult}``; ``None`` for a baseline that cannot be built (a fixed-gain
        baseline whose failure-free tuning run diverged). Diverged runs are returned as they
        are (claims count them as infinitely worse).
    """
    import warnings

    solver = solver or scenario.solver
    loop = scenario.loop if failures else scenario.loop.without_failures()
    out: dict[str, SimResult | None] = {}
    for name in names:
        try:
            base = baseline_loop(loop, name, solver)
        except ConfigurationError:
            if name != "fixed-gain":
                raise
            out[name] = None
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a diverged baseline is a result
            result = simulate(base, baseline_solver(name, solver))
        if hasattr(scenario, "stamp"):
            scenario.stamp(result)
        result.meta["variant"] = name
        out[name] = result
    return out


def campaign_fixed_gain(loop: ClosedLoop) -> ClosedLoop:
    """The fixed-gain baseline of a campaign member (tuned with :data:`CAMPAIGN_SOLVER`)."""
    return fixed_gain(loop, CAMPAIGN_SOLVER)
