"""Export closed loops and plants to python-control (optional dependency ``control``).

Install with ``pip install "adaptive-ftc[control]"``::

    import control
    from adaptive_ftc import load_scenario
    from adaptive_ftc.interop import to_control, control_initial_state

    loop = load_scenario("hypersonic-direct-s1").loop
    sys = to_control(loop)                       # no inputs, outputs = plant outputs
    resp = control.input_output_response(sys, [0, 1, 2], initial_state=control_initial_state(loop))

Failure times: the exported closed loop chooses the failure phase (the interval of fixed
failure pattern, see :attr:`adaptive_ftc.sim.compose.Assembled.breakpoints`) from ``t``, so its
right-hand side jumps at every failure onset and recovery. python-control integrates with
:func:`scipy.integrate.solve_ivp`, which has no jump handling: an adaptive step across a jump is
rejected repeatedly and the step lands *somewhere* near it. For results that match
:func:`adaptive_ftc.simulate`, integrate each interval on its own (the states are continuous at
the jumps), which is what :func:`piecewise_response` does.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.plants.base import Plant
from adaptive_ftc.sim.layout import Misc
from adaptive_ftc.sim.system import ClosedLoop

__all__ = [
    "control_initial_state",
    "disturbance_input_names",
    "piecewise_response",
    "plant_to_control",
    "reference_input_names",
    "to_control",
]


def _control():
    try:
        import control
    except ImportError:  # pragma: no cover - exercised only without the extra
        raise ConfigurationError(
            "python-control is not installed: the interop module needs it. Install it with "
            '`pip install "adaptive-ftc[control]"` (or `pip install control`).'
        ) from None
    return control


def _assembled(loop: ClosedLoop, sdot: str, filter_tau: float):
    if not isinstance(loop, ClosedLoop):
        raise ConfigurationError(
            f"to_control() needs a ClosedLoop (e.g. load_scenario(name).loop); "
            f"got {type(loop).__name__}."
        )
    if loop.sample_time > 0 or (loop.sensors is not None and loop.sensors.has_noise):
        raise ConfigurationError(
            f"Loop '{loop.name}' has a digital controller or sampled sensor noise: its state "
            "jumps at every sample, which python-control's continuous-time systems cannot "
            "express. Export the loop without `sample_time` and sensor noise."
        )
    from adaptive_ftc.sim.compose import assemble

    return assemble(loop, sdot=sdot, filter_tau=filter_tau)


def _label(name: str) -> str:
    return str(name).replace(" ", "_") or "adaptive_ftc"


_INPUTS = ("reference", "disturbance")


def reference_input_names(loop: ClosedLoop) -> list[str]:
    """Input names of the reference of ``to_control(loop, inputs=("reference",))``: per output
    ``y``, ``yd_<y>``, ``yd_<y>_dot``, ``yd_<y>_ddot`` (the designs use y_d and its first two
    derivatives, thesis (2.18)-(2.22))."""
    return [f"yd_{y}{suffix}" for y in loop.plant.output_names for suffix in ("", "_dot", "_ddot")]


def disturbance_input_names(loop: ClosedLoop) -> list[str]:
    """Input names of the disturbance of ``to_control(loop, inputs=("disturbance",))``: one
    per output ``y``, ``d_<y>``, added to the derivative of that output's velocity state."""
    return [f"d_{y}" for y in loop.plant.output_names]


def to_control(
    loop: ClosedLoop,
    *,
    sdot: str = "exact",
    filter_tau: float = 0.01,
    name: str | None = None,
    inputs: tuple[str, ...] | list[str] = (),
):
    """The closed loop as a :class:`control.NonlinearIOSystem`.

    States are the plant states followed by every adaptive state (in the order of
    ``SimResult.adaptive_names``; with ``sdot="filtered"`` the s-filter states come last), then
    the actuator positions of a loop with actuator dynamics; its outputs are the plant outputs
    ``y`` (thesis (2.1)/(3.1)). The failure phase is chosen from ``t``: phase ``k`` on
    ``[breakpoints[k], breakpoints[k+1])``.

    By default the system has no inputs: the reference ``y_d(t)`` of the loop's ``reference``
    expressions and the failure schedule are part of it. ``inputs`` opens it for
    :func:`control.interconnect`:

    ``"reference"``
        the reference becomes inputs (:func:`reference_input_names`): per output ``y``, the
        value ``yd_<y>`` and its first two derivatives ``yd_<y>_dot``, ``yd_<y>_ddot``, which
        the designs use; the loop's own reference expressions are then ignored. Feed them
        from a source system (e.g. a :class:`control.NonlinearIOSystem` with no inputs).
    ``"disturbance"``
        one input ``d_<y>`` per output, added to the derivative of that output's velocity
        state (``plant.velocity_index``): an unmeasured generalised force or moment per unit
        inertia, which the controller does not see.

    Parameters
    ----------
    loop
        The closed loop.
    sdot, filter_tau
        How ``s'`` is obtained, as in :class:`~adaptive_ftc.SolverOptions`.
    name
        System name (default: the loop's name).

    Returns
    -------
    control.NonlinearIOSystem
        Integrate it from :func:`control_initial_state`; across failure times use
        :func:`piecewise_response` (python-control has no jump handling).
    """
    ct = _control()
    chosen = tuple(inputs)
    bad = [i for i in chosen if i not in _INPUTS]
    if bad or len(set(chosen)) != len(chosen):
        raise ConfigurationError(
            f"to_control(inputs=...) takes 'reference' and/or 'disturbance', each once; got "
            f"{list(chosen)!r}."
        )
    asm = _assembled(loop, sdot, filter_tau)
    bps = np.asarray(asm.breakpoints, dtype=float)
    last = bps.size - 2
    rhs, data = asm.module.rhs, asm.data
    work = asm.work()
    ny = asm.y0.size
    pos = list(loop.plant.position_index)
    vel = list(loop.plant.velocity_index)
    ref = asm.layout.work["ref"]
    ref_valid = asm.layout.misc(Misc.REF_VALID)
    use_ref = "reference" in chosen
    use_dist = "disturbance" in chosen
    n_ref = 3 * len(pos) if use_ref else 0
    input_names = (reference_input_names(loop) if use_ref else []) + (
        disturbance_input_names(loop) if use_dist else []
    )

    def phase_of(t: float) -> int:
        return int(min(max(int(np.searchsorted(bps, t, side="right")) - 1, 0), last))

    def updfcn(t, x, u, params):
        dy = np.zeros(ny)
        t = float(t)
        x = np.ascontiguousarray(x, dtype=float)
        ph = phase_of(t)
        if use_ref:
            # the compiled rhs keeps the reference of the last time in work[ref] and skips
            # computing it again at the same t (Misc.REF_VALID, Misc.REF_TIME): one call
            # fills the per-time values (e.g. the estimation design's basis), then the
            # reference is replaced by the inputs and the derivative computed with them
            work[ref_valid] = 0.0
            rhs(t, x, ph, data, work, dy)
            work[ref.start : ref.start + n_ref] = np.asarray(u, dtype=float)[:n_ref]
        rhs(t, x, ph, data, work, dy)
        if use_dist:
            d = np.asarray(u, dtype=float)[n_ref:]
            for i, k in enumerate(vel):
                dy[k] += d[i]
        return dy

    def outfcn(t, x, u, params):
        return np.asarray(x, dtype=float)[pos]

    states = [*loop.plant.state_names, *asm.adaptive_names, *asm.extra_names]
    sys = ct.NonlinearIOSystem(
        updfcn,
        outfcn,
        inputs=input_names or 0,
        outputs=list(loop.plant.output_names),
        states=states,
        name=_label(name if name is not None else loop.name),
    )
    return sys


def control_initial_state(
    loop: ClosedLoop, *, sdot: str = "exact", filter_tau: float = 0.01
) -> np.ndarray:
    """Initial state of :func:`to_control`'s system (plant, adaptive and filter states)."""
    return _assembled(loop, sdot, filter_tau).y0.copy()


def plant_to_control(plant: Plant, *, name: str | None = None):
    """The plant alone as a :class:`control.NonlinearIOSystem`.

    Inputs are the actuators' *applied* outputs ``u^f`` (after any failure), states the plant
    states and outputs the controlled outputs; the update function is
    :meth:`Plant.derivative`.
    """
    ct = _control()
    if not isinstance(plant, Plant):
        raise ConfigurationError(
            f"plant_to_control() needs a Plant (e.g. load_scenario(name).loop.plant); "
            f"got {type(plant).__name__}."
        )
    pos = list(plant.position_index)

    def updfcn(t, x, u, params):
        return plant.derivative(float(t), np.asarray(x, dtype=float), np.asarray(u, dtype=float))

    def outfcn(t, x, u, params):
        return np.asarray(x, dtype=float)[pos]

    return ct.NonlinearIOSystem(
        updfcn,
        outfcn,
        inputs=list(plant.actuator_names),
        outputs=list(plant.output_names),
        states=list(plant.state_names),
        name=_label(name if name is not None else plant.name),
    )


def piecewise_response(
    loop: ClosedLoop,
    timepts: Any,
    *,
    sdot: str = "exact",
    filter_tau: float = 0.01,
    solve_ivp_method: str = "RK45",
    solve_ivp_kwargs: dict | None = None,
):
    """:func:`control.input_output_response` of :func:`to_control`, one interval of fixed
    failure pattern at a time (restarted from the end state of the previous one).

    Parameters
    ----------
    loop
        The closed loop.
    timepts
        Increasing times (within ``[t0, t_final]``) at which to return the response.
    solve_ivp_method, solve_ivp_kwargs
        python-control's solver (a :func:`scipy.integrate.solve_ivp` method) and its options
        (e.g. ``{"rtol": 1e-9, "atol": 1e-12}``).

    Returns
    -------
    control.TimeResponseData
        Time, outputs and states at ``timepts``.
    """
    ct = _control()
    sys = to_control(loop, sdot=sdot, filter_tau=filter_tau)
    x = control_initial_state(loop, sdot=sdot, filter_tau=filter_tau)
    T = np.asarray(timepts, dtype=float)
    if T.ndim != 1 or T.size < 2 or np.any(np.diff(T) <= 0):
        raise ConfigurationError("`timepts` must be at least two increasing times.")
    if T[0] < loop.t0 or T[-1] > loop.t_final:
        raise ConfigurationError(
            f"`timepts` must lie within the loop's [t0, t_final] = [{loop.t0:g}, "
            f"{loop.t_final:g}] s; got [{T[0]:g}, {T[-1]:g}]."
        )
    bps = np.asarray(_assembled(loop, sdot, filter_tau).breakpoints, dtype=float)
    kw = dict(solve_ivp_kwargs or {})
    kw.setdefault("method", solve_ivp_method)
    X = np.full((x.size, T.size), np.nan)
    t_start = float(T[0])
    if t_start > bps[0]:  # advance to the first requested time
        x = _advance(ct, sys, bps, float(bps[0]), t_start, x, kw)
    for k in range(bps.size - 1):
        a, b = max(float(bps[k]), t_start), float(bps[k + 1])
        if b <= a:
            continue
        last = k == bps.size - 2
        sel = (T >= a) & ((T <= b) if last else (T < b))
        pts = np.unique(np.concatenate([[a], T[sel], [b]]))
        resp = ct.input_output_response(sys, pts, initial_state=x, solve_ivp_kwargs=kw)
        if not resp.success:
            raise ConfigurationError(
                f"python-control's solver failed on [{a:g}, {b:g}] s: {resp.message}. Try "
                "looser tolerances or a stiff method (solve_ivp_method='LSODA' or 'Radau')."
            )
        idx = np.searchsorted(pts, T[sel])
        X[:, sel] = resp.states[:, idx]
        x = resp.states[:, -1].copy()
        if b >= T[-1]:
            break
    Y = X[list(loop.plant.position_index), :]
    return ct.TimeResponseData(
        T,
        Y,
        states=X,
        output_labels=list(loop.plant.output_names),
        state_labels=list(sys.state_labels),
        sysname=sys.name,
        issiso=False,
    )


def _advance(ct, sys, bps, t_from, t_to, x, kwargs):
    for k in range(bps.size - 1):
        a, b = max(float(bps[k]), t_from), min(float(bps[k + 1]), t_to)
        if b > a:
            r = ct.input_output_response(sys, [a, b], initial_state=x, solve_ivp_kwargs=kwargs)
            x = r.states[:, -1].copy()
    return x
