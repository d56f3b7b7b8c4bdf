"""Why a run stopped early: from what the integrator saw to a :class:`RunStatus` and its reason.

The compiled integrators return a code (1: a state non-finite, over the divergence bound or
outside the plant's envelope; 2: the step size underflowed; 3: interrupted), the stop time, the
index of the offending state and leave the state at the stop after the last record. A step-size
underflow is also what a non-finite right-hand side looks like to an adaptive-step method (every
step is rejected), so before calling a run stiff this module looks for the cause: an expression
of the scenario (reference, its derivatives, a failure pattern) that is non-finite near the stop
time, or a right-hand side that is non-finite at the stop state (a plant equation dividing by
zero: ``singular``; an adaptive law or the control signal: ``nonfinite``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from adaptive_ftc.sim.status import RunStatus, StatusReason

if TYPE_CHECKING:  # pragma: no cover
    from collections.abc import Callable

    from adaptive_ftc.faults import Failure
    from adaptive_ftc.sim.compose import Assembled
    from adaptive_ftc.sim.engine import SolverOptions
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["stop_outcome"]

STIFF_ADVICE = (
    "The loop may be too stiff for this method: try method = 'rodasp' or 'auto', or looser "
    "rtol/atol."
)

#: A value this large (or the divergence bound, if larger) counts as a pole: an adaptive step
#: stops just short of where ``1/(t - 3)`` is infinite, and sees a huge finite value there.
POLE = 1e10


def stop_outcome(
    loop: ClosedLoop,
    asm: Assembled,
    solver: SolverOptions,
    *,
    code: int,
    t_stop: float,
    bad: int,
    y_stop: np.ndarray | None,
    t_prev: float,
    y_prev: np.ndarray | None,
) -> tuple[RunStatus, StatusReason]:
    """The status and reason of a run the integrator stopped with ``code`` at ``t_stop``.

    ``bad``: the state it named (code 1); ``y_stop``: the state at the stop (``None``: not
    known); ``t_prev``, ``y_prev``: the last recorded sample before it (``y_prev`` ``None``: no
    sample).
    """
    method = str(solver.compiled_method or solver.method)
    if code == 3:
        return RunStatus.INTERRUPTED, StatusReason(time=t_stop, method=method)
    value = None
    if code == 1 and y_stop is not None and 0 <= bad < y_stop.size:
        value = float(y_stop[bad])
    finite_stop = y_stop is not None and bool(np.all(np.isfinite(y_stop)))
    label = _state_label(loop, asm, bad)
    bound = float(solver.divergence_bound)
    env = tuple(getattr(loop.plant, "envelope", ()) or ())
    if (
        code == 1
        and value is not None
        and math.isfinite(value)
        and abs(value) < bound
        and bad < min(len(env), asm.n_x)
    ):  # a plant state outside the plant's envelope: a real divergence
        return RunStatus.DIVERGED, StatusReason(
            time=t_stop, signal=label, value=value, bound=float(env[bad]), envelope=True,
            method=method,
        )  # fmt: skip
    # an expression of the scenario non-finite near the stop: the cause, whatever the code
    pole = max(bound, POLE)
    found = _nonfinite_expression(
        loop, asm, t_prev, t_stop, y_stop if finite_stop else y_prev, pole
    )
    if found is not None:
        return RunStatus.NONFINITE, found
    # the right-hand side at the last finite state
    y_rhs, t_rhs = (y_stop, t_stop) if finite_stop else (y_prev, t_prev)
    if y_rhs is not None:
        # a step-size underflow at a plant derivative past the bound: a singular equation
        huge = pole if code == 2 else math.inf
        stopped = _nonfinite_rhs(loop, asm, t_rhs, t_stop, y_rhs, method, huge)
        if stopped is not None:
            return stopped
    if code == 1:
        if value is not None and math.isfinite(value):
            return RunStatus.DIVERGED, StatusReason(
                time=t_stop, signal=label, value=value, bound=bound, method=method
            )
        return RunStatus.NONFINITE, StatusReason(
            time=t_stop, signal=label, value=value if value is not None else math.nan,
            method=method,
        )  # fmt: skip
    return RunStatus.STEP_UNDERFLOW, StatusReason(time=t_stop, method=method, advice=STIFF_ADVICE)


def _state_label(loop: ClosedLoop, asm: Assembled, index: int) -> str:
    names = list(loop.plant.state_names) + list(asm.adaptive_names) + list(asm.extra_names)
    return names[index] if 0 <= index < len(names) else f"state {index}"


def _probe_times(t_lo: float, t_stop: float) -> np.ndarray:
    """Times to look at: a grid from the last sample to the stop, just past the stop (an
    adaptive step stops short of where the right-hand side becomes non-finite) and the round
    numbers near it (where ``1/(t - 3)`` is infinite)."""
    scale = max(1.0, abs(t_stop))
    ahead = t_stop + scale * np.array([1e-14, 1e-12, 1e-10, 1e-8, 1e-6, 1e-5, 1e-4, 1e-3])
    times = [np.linspace(min(t_lo, t_stop), t_stop, 65), ahead]
    hi = t_stop + 1e-3 * scale
    rounded = [round(t_stop, k) for k in range(13)]
    times.append(np.array([t for t in rounded if min(t_lo, t_stop) <= t <= hi]))
    return np.unique(np.concatenate(times))


def _candidates(loop: ClosedLoop):
    """``(source, text, expression, active)`` of every expression of ``loop`` that varies."""
    from adaptive_ftc.expressions import Expression

    out = []
    for i, text in enumerate(loop.reference):
        name = loop.plant.output_names[i]
        e = Expression(str(text), ("t",), context=f"reference of output '{name}'")
        if e.is_constant:
            continue
        d1 = e.derivative("t")
        always = _always
        out.append((f"the reference of output '{name}'", str(text), e, always))
        out.append(
            (f"the reference of output '{name}' (its derivative {d1})", str(text), d1, always)
        )
        d2 = d1.derivative("t")
        out.append(
            (
                f"the reference of output '{name}' (its second derivative {d2})",
                str(text),
                d2,
                always,
            )
        )
    aliases = tuple(loop.plant.aliases())
    variables = ("t", "u", *aliases)
    for f in loop.failures.failures:
        e = f.expression(variables)
        if e.is_constant:
            continue
        kind = type(f).__name__
        out.append(
            (
                f"the {kind} failure of actuator {f.actuator} (onset {f.onset:g} s)",
                _unwrap(f.pattern()),
                e,
                _acting(f),
            )
        )
    return out


def _unwrap(text: str) -> str:
    """``text`` without one pair of parentheses around all of it (``"(sqrt(5-t))"``)."""
    text = text.strip()
    if not (text.startswith("(") and text.endswith(")")):
        return text
    depth = 0
    for k, ch in enumerate(text):
        depth += ch == "("
        depth -= ch == ")"
        if depth == 0 and k < len(text) - 1:
            return text  # "(a) + (b)": the first pair closes before the end
    return text[1:-1]


def _always(t: float) -> bool:
    return True


def _acting(f: Failure) -> Callable[[float], bool]:
    """Whether ``f`` acts at ``t`` (from its onset to its end)."""
    return lambda t: f.onset <= t < f.end


def _env(loop: ClosedLoop, asm: Assembled, t: float, y: np.ndarray | None, actuator: int):
    env: dict[str, float] = {"t": float(t), "u": 0.0}
    if y is not None:
        for name, i in loop.plant.aliases().items():
            env[name] = float(y[i])
        u = _commands(loop, asm, t, y)
        if u is not None and 0 <= actuator - 1 < u.size and math.isfinite(u[actuator - 1]):
            env["u"] = float(u[actuator - 1])
    return env


def _phase(asm: Assembled, t: float) -> int:
    bps = np.asarray(asm.breakpoints, dtype=float)
    return int(np.clip(np.searchsorted(bps, t, side="right") - 1, 0, max(bps.size - 2, 0)))


def _signals_row(loop: ClosedLoop, asm: Assembled, t: float, y: np.ndarray) -> np.ndarray | None:
    from adaptive_ftc.sim.result import signal_block

    out = signal_block(loop, 1)
    try:
        with np.errstate(all="ignore"):
            asm.signals(
                np.array([float(t)]),
                np.ascontiguousarray(y, dtype=float)[None, :],
                np.array([_phase(asm, t)], dtype=np.int64),
                out,
            )
    except Exception:  # noqa: BLE001 - a diagnosis never hides the run's own outcome
        return None
    return out[0]


def _commands(loop: ClosedLoop, asm: Assembled, t: float, y: np.ndarray):
    row = _signals_row(loop, asm, t, y)
    if row is None:
        return None
    return row[asm.layout.records["u_cmd"]]


def _value(expr, env: dict[str, float]) -> float:
    try:
        with np.errstate(all="ignore"):
            v = expr(**{k: env[k] for k in expr.used})
        return float(np.asarray(v, dtype=float).reshape(-1)[0])
    except (OverflowError, ZeroDivisionError, ValueError):
        return math.nan


def _nonfinite_expression(
    loop: ClosedLoop,
    asm: Assembled,
    t_lo: float,
    t_stop: float,
    y: np.ndarray | None,
    bound: float,
) -> StatusReason | None:
    """The first expression of ``loop`` that is non-finite (or at least ``bound`` in size: a
    pole an adaptive step stops just short of) near ``t_stop``, and when it first was
    (``None``: every expression is finite there)."""
    try:
        cands = _candidates(loop)
    except Exception:  # noqa: BLE001 - e.g. a derivative too large to take
        return None
    if not cands:
        return None
    times = _probe_times(t_lo, t_stop)
    envs: dict[tuple[int, float, bool], dict] = {}
    prev = None
    for t in times:
        for source, text, e, active in cands:
            if not active(t):
                continue
            actuator = _actuator_of(source)
            of_t = not (e.used - {"t"})  # expressions of t alone need no state
            key = (actuator, float(t), of_t)
            env = envs.get(key)
            if env is None:
                env = _env(loop, asm, t, None if of_t else y, actuator)
                envs[key] = env
            v = _value(e, env)
            if not abs(v) < bound:
                t_first = _first_time(e, env, prev, float(t), active, bound)
                return StatusReason(
                    time=t_first, expression=text, source=source, value=v,
                )  # fmt: skip
        prev = float(t)
    return None


def _actuator_of(source: str) -> int:
    if " of actuator " in source:
        return int(source.split(" of actuator ")[1].split()[0])
    return 0


def _first_time(e, env: dict, t_ok: float | None, t_bad: float, active, bound: float) -> float:
    """Bisect between a time where ``e`` is finite (below ``bound``) and one where it is not."""
    if t_ok is None:
        return t_bad
    env = dict(env)
    env["t"] = t_ok
    if not abs(_value(e, env)) < bound:
        return t_bad
    lo, hi = t_ok, t_bad
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        env["t"] = mid
        if active(mid) and not abs(_value(e, env)) < bound:
            hi = mid
        else:
            lo = mid
    return hi


def _nonfinite_rhs(
    loop: ClosedLoop,
    asm: Assembled,
    t_state: float,
    t_stop: float,
    y: np.ndarray,
    method: str,
    huge: float = math.inf,
) -> tuple[RunStatus, StatusReason] | None:
    """A non-finite closed-loop derivative at state ``y`` from ``t_state`` to just past
    ``t_stop``: ``singular`` when it is a plant equation at finite states and inputs, else
    ``nonfinite`` naming the derivative. A plant derivative of ``huge`` or more counts as
    non-finite (an adaptive step stops just short of the pole of ``1/(x - 2)``)."""
    scale = max(1.0, abs(t_stop))
    times = np.unique(
        np.concatenate(
            [[t_state, t_stop], t_stop + scale * np.array([1e-14, 1e-12, 1e-10, 1e-8, 1e-6])]
        )
    )
    y = np.ascontiguousarray(y, dtype=float)
    for t in times:
        try:
            with np.errstate(all="ignore"):
                dy = asm.derivative(float(t), y, _phase(asm, float(t)))
        except Exception:  # noqa: BLE001 - a diagnosis never hides the run's own outcome
            return None
        off = ~np.isfinite(dy)
        n = loop.plant.n_states
        off[:n] |= np.abs(dy[:n]) >= huge
        if not off.any():
            continue
        i = int(np.argmax(off))
        row = _signals_row(loop, asm, float(t), y)
        m = loop.plant.n_actuators
        rec = asm.layout.records  # the commands, then the applied outputs
        u_cols = slice(rec["u_cmd"].start, rec["u_applied"].stop)
        u = row[u_cols] if row is not None else np.full(2 * m, math.nan)
        if i < n and np.all(np.isfinite(y)) and np.all(np.isfinite(u)):
            state = loop.plant.state_names[i]
            dyn = getattr(loop.plant, "dynamics", None)
            text = str(dyn.get(state, "")) if isinstance(dyn, dict) else ""
            shown = ", ".join(f"{s} = {y[k]:.6g}" for k, s in enumerate(loop.plant.state_names))
            return RunStatus.SINGULAR, StatusReason(
                time=float(t), signal=state, value=float(dy[i]), expression=text,
                source=f"the equation of {state}' of plant '{loop.plant.name}'",
                states=shown, method=method,
            )  # fmt: skip
        if row is not None and not np.all(np.isfinite(u)):
            j = int(np.argmax(~np.isfinite(u)))
            which = "u_cmd" if j < m else "u_applied"
            name = loop.plant.actuator_names[j % m]
            return RunStatus.NONFINITE, StatusReason(
                time=float(t), signal=f"{which}[{name}]", value=float(u[j]), method=method
            )
        return RunStatus.NONFINITE, StatusReason(
            time=float(t), signal=f"d{_state_label(loop, asm, i)}/dt", value=float(dy[i]),
            method=method,
        )  # fmt: skip
    return None
