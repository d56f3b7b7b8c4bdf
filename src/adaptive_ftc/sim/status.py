"""How a run ended: a :class:`RunStatus` with a :class:`StatusReason` attached.

The engine decides the status from what it observed (a state over the bound, a non-finite
expression, a step size that underflowed, ...) and records the facts in a reason; the message a
user reads is built from the reason (:func:`describe`), never parsed back from text.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

__all__ = ["RunStatus", "SimulationInterrupted", "StatusReason", "describe", "short"]


class RunStatus(StrEnum):
    """How a simulation ended (a ``str``: ``result.status == "diverged"`` keeps working and
    files store the plain value).

    ``completed``: the run reached ``t_final``. ``diverged``: a state left the divergence bound or
    the plant's envelope. ``nonfinite``: an expression of the scenario (a failure pattern, a
    reference or its derivative) or a signal became NaN/inf. ``step_underflow``: an adaptive-step
    method needed a step below what the tolerances allow (the loop is stiff for that method).
    ``singular``: a plant equation became non-finite at finite states and inputs (a division by
    zero). ``interrupted``: Ctrl-C. ``invalid``: the run was refused before it started (campaign
    members whose drawn settings are invalid).
    """

    COMPLETED = "completed"
    DIVERGED = "diverged"
    NONFINITE = "nonfinite"
    STEP_UNDERFLOW = "step_underflow"
    SINGULAR = "singular"
    INTERRUPTED = "interrupted"
    INVALID = "invalid"

    def __repr__(self) -> str:
        # shown as the plain value, as before the enum: ``[r.status for r in runs]`` prints
        # ``['completed', 'diverged']``
        return repr(self.value)


@dataclass(frozen=True, kw_only=True)
class StatusReason:
    """The facts behind a status (every field optional; what applies to the status is set).

    Attributes
    ----------
    time
        When it happened (s): the stop time, or the first time the expression was non-finite.
    signal
        The state or signal concerned (``"alpha"``, ``"theta_3"``, ``"u_cmd[1]"``).
    value
        Its value then (``nan``/``inf`` for a non-finite one).
    bound
        The bound it left (the divergence bound or the plant's envelope).
    expression
        The text of the expression that became non-finite (or of the singular plant equation).
    source
        What the expression belongs to (``"the stuck failure of actuator 2"``, ``"the
        reference of output alpha"``, ``"the equation of q' of plant 'p'"``).
    advice
        What to try (the stiffness advice appears on ``step_underflow`` only).
    method
        The integration method of the run.
    detail
        Anything else the solver said.
    envelope
        ``diverged``: the bound is the plant's envelope (else the divergence bound).
    states
        ``singular``: the plant states then (``"x = 1, v = 0"``).
    step_limit
        ``step_underflow``: the step count limit when that, not the step size, stopped it.
    """

    time: float | None = None
    signal: str = ""
    value: float | None = None
    bound: float | None = None
    expression: str = ""
    source: str = ""
    advice: str = ""
    method: str = ""
    detail: str = ""
    envelope: bool = False
    states: str = ""
    step_limit: int | None = None


class SimulationInterrupted(KeyboardInterrupt):
    """Ctrl-C (or SIGTERM in ``aftc``) stopped :func:`~adaptive_ftc.simulate`; ``.result`` holds
    the partial :class:`~adaptive_ftc.SimResult` (status ``interrupted``, the samples before the
    interrupt). A subclass of :class:`KeyboardInterrupt`, so a script that does not catch it
    stops as on any Ctrl-C."""

    def __init__(self, result=None, message: str = "simulation interrupted") -> None:
        super().__init__(message)
        self.result = result

    def __reduce__(self):  # pickled with its result (a worker process's interrupt)
        return (type(self), (self.result, str(self)))


def _num(v: float | None) -> str:
    if v is None:
        return "?"
    if not math.isfinite(v):
        return str(v)
    return f"{v:.4g}"


def short(status: RunStatus | str, reason: StatusReason | None) -> str:
    """A few words for a table cell: ``"nonfinite at t = 5 s ('sqrt(5-t)')"``."""
    status = RunStatus(status)
    if status is RunStatus.COMPLETED or reason is None:
        return str(status)
    text = str(status)
    if reason.time is not None:
        text += f" at t = {reason.time:.4g} s"
    what = f"'{reason.expression}'" if reason.expression else reason.signal
    return f"{text} ({what})" if what else text


def describe(status: RunStatus | str, reason: StatusReason | None, label: str = "") -> str:
    """The message of a run that ended with ``status`` for ``reason`` (``""`` when completed).

    ``label``: how the run is named (``"'hypersonic-direct-s1'"``).
    """
    status = RunStatus(status)
    if status is RunStatus.COMPLETED:
        return ""
    r = reason or StatusReason()
    who = f"Simulation {label}" if label else "Simulation"
    at = f"t = {r.time:.6g} s" if r.time is not None else "an unknown time"
    keep = "The result keeps the samples before that time."
    if status is RunStatus.INTERRUPTED:
        return f"Interrupted at {at}; the result keeps the samples before that time."
    if status is RunStatus.INVALID:
        return f"{who} was not run: {r.detail or 'its settings are invalid'}."
    if status is RunStatus.DIVERGED:
        if r.envelope:
            text = (
                f"{who} diverged at {at}: signal '{r.signal}' = {_num(r.value)} left the plant's "
                f"envelope |{r.signal}| <= {_num(r.bound)} (a physically meaningless value: a "
                f"wrong control direction, or gains too high). {keep}"
            )
        else:
            text = (
                f"{who} diverged at {at}: signal '{r.signal}' = {_num(r.value)} exceeded the "
                f"divergence bound {r.bound:g}. {keep} Check the gains and failure values, or "
                "raise `divergence_bound` if such values are meaningful."
                if r.bound is not None
                else f"{who} diverged at {at}: signal '{r.signal}'. {keep}"
            )
    elif status is RunStatus.NONFINITE:
        if r.expression:
            text = (
                f"{who} stopped at {at}: the expression '{r.expression}' of {r.source} is "
                f"non-finite or unbounded there ({_num(r.value)}). {keep} Fix the expression "
                "so that it is finite over the whole run (e.g. keep the argument of sqrt/log in "
                "its domain, no division by zero)."
            )
        else:
            text = (
                f"{who} stopped at {at}: signal '{r.signal}' became non-finite "
                f"({_num(r.value)}). {keep} Check the gains (a too high adaptation gain), "
                "the failure values and the initial state."
            )
    elif status is RunStatus.SINGULAR:
        text = (
            f"{who} stopped at {at}: {r.source or 'a plant equation'}"
            + (f" ('{r.expression}')" if r.expression else "")
            + f" is non-finite or unbounded ({_num(r.value)}) at finite states and inputs"
            + (f" ({r.states})" if r.states else "")
            + f": the equation is singular there (a division by zero). {keep} Check the "
            "initial state, the failures and the gains, or the equation's domain."
        )
    elif r.step_limit is not None:  # STEP_UNDERFLOW at the step count limit
        text = (
            f"{who} stopped at {at}: the '{r.method}' method reached its limit of "
            f"{r.step_limit:,} steps. {keep}"
        )
    else:  # STEP_UNDERFLOW
        text = (
            f"{who} stopped at {at}: the '{r.method}' step size fell below what the tolerances "
            f"allow. {keep}"
        )
    if r.advice:
        text += f" {r.advice}"
    if r.detail:
        text += f" (solver: {r.detail})"
    return text
