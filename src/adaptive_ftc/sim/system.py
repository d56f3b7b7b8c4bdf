"""The closed loop: plant + adaptive controller + allocation + reference + failure schedule."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from adaptive_ftc.controllers.base import AdaptiveController
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.faults.models import Failure
from adaptive_ftc.faults.schedule import (
    CompensabilityReport,
    FailureSchedule,
    check_compensability,
)
from adaptive_ftc.hardware import Actuators, Sensors
from adaptive_ftc.plants.base import Plant

__all__ = ["KNOWN_SIGN_DESIGNS", "ClosedLoop", "signal_names"]

#: Designs that assume a known control direction (sign conditions (2.16)/(4.6) apply).
KNOWN_SIGN_DESIGNS = ("direct", "estimation", "mimo")


def signal_names(plant: Plant) -> dict[str, int]:
    """Controller signals a regressor may use on ``plant``'s loop (states and their aliases,
    ``e``, ``edot``, ``s`` per output), with their index in the signal vector."""
    n, p = plant.n_states, plant.n_outputs
    names = dict(plant.aliases())
    for i in range(p):
        for j, stem in enumerate(("e", "edot", "s")):
            names[f"{stem}{i + 1}"] = n + j * p + i
            if p == 1:
                names[stem] = n + j * p + i
    return names


def _input_gains(plant: Plant) -> np.ndarray | None:
    """The plant's ``(outputs, actuators)`` input gains at the zero state, measured from its
    own equations (any plant, user plants included); else its declared per-actuator gains
    (``actuator_gains`` or ``b``); else ``None`` (all 1)."""
    shape = (plant.n_outputs, plant.n_actuators)
    try:
        G = np.asarray(plant.input_gains(), dtype=float)
        if G.shape == shape and np.all(np.isfinite(G)):
            return G
    except Exception:  # noqa: BLE001 - a plant whose equations cannot run in Python
        pass
    for attr in ("actuator_gains", "b"):
        value = getattr(plant, attr, None)
        try:
            gains = np.asarray([float(v) for v in value], dtype=np.float64)  # type: ignore[union-attr]
        except (TypeError, ValueError):
            continue
        if gains.shape == (plant.n_actuators,) and np.all(np.isfinite(gains)):
            return gains
    return None


@dataclass(frozen=True, kw_only=True)
class ClosedLoop:
    """Everything that defines one simulation run (the *what*; the *how* is in
    :class:`~adaptive_ftc.sim.engine.SolverOptions`).

    Parameters
    ----------
    plant
        The plant.
    controller
        The adaptive design.
    allocation
        Actuation matrix ``R`` (p x m) of ``u = R^T u0`` (3.14); for a single-output plant a
        flat list of proportional gains ``b_j`` (2.10) is accepted.
    reference
        Desired output ``y_d(t)`` per output, as expressions of ``t`` (their first two
        derivatives are taken symbolically).
    initial_state
        Initial plant state; when shorter than the plant state, the remaining states start at 0.
    failures
        A :class:`FailureSchedule` or a sequence of failures.
    t_final
        Duration in seconds.
    adapt
        ``False`` freezes every adaptive parameter at its initial value (non-adaptive baseline).
    name
        Label carried into the result.
    adaptive_initial
        Initial values of every adaptive state (theta, then the design's own states, in the
        order of ``SimResult.adaptive_names``); empty: ``theta0`` and the design's defaults.
        With ``adapt=False`` this gives a fixed-gain controller (e.g. the parameters reached
        at the end of a failure-free run).
    actuators
        Actuator dynamics (:class:`~adaptive_ftc.hardware.Actuators`: lag, rate and position
        limits); ``None``: the thesis's ideal actuators.
    sensors
        Measurement noise and bias (:class:`~adaptive_ftc.hardware.Sensors`); ``None``: the
        controller sees the exact state.
    sample_time
        Period (s) of a digital, sample-and-hold controller; 0: continuous-time controller.
    dormant_failures
        Failures compiled into the loop that never act (set by :meth:`without_failures`): the
        failure-free run of a scenario shares the compiled code of the failing one, so it
        costs no compilation of its own.
    allocator
        How the virtual control becomes actuator commands (:mod:`adaptive_ftc.allocation`):
        ``None`` (default) is the thesis's fixed ``u = R^T u0``; a ``PseudoInverse``,
        ``WeightedLeastSquares`` or ``AdaptiveAllocation`` distributes ``v = R R^T u0``
        through the effectiveness matrix it believes.
    annunciations
        Failures a detector reports to the allocator
        (:class:`~adaptive_ftc.allocation.inloop.Annunciation`: actuator, onset, recovery,
        detection delay); the others are silent, known only to the plant.
    """

    plant: Plant
    controller: AdaptiveController
    allocation: tuple = ()
    reference: tuple = ("0",)
    initial_state: tuple = ()
    failures: FailureSchedule | tuple = ()
    t_final: float = 10.0
    adapt: bool = True
    name: str = ""
    t0: float = field(default=0.0)
    adaptive_initial: tuple = ()
    actuators: Actuators | None = None
    sensors: Sensors | None = None
    sample_time: float = 0.0
    dormant_failures: tuple = ()
    allocator: object = None
    annunciations: tuple = ()

    def __post_init__(self) -> None:
        plant = self.plant
        if not isinstance(plant, Plant):
            raise ConfigurationError(f"`plant` must be a Plant; got {plant!r}.")
        if not isinstance(self.controller, AdaptiveController):
            raise ConfigurationError(
                f"`controller` must be an adaptive design; got {self.controller!r}."
            )
        if not type(plant).__module__.startswith("adaptive_ftc."):
            from adaptive_ftc.plants.custom import check_plant

            check_plant(plant)  # a user's Plant subclass: check what the designs assume
        p, m, n = plant.n_outputs, plant.n_actuators, plant.n_states
        R = np.asarray(self.allocation, dtype=float) if len(self.allocation) else np.zeros(0)
        if R.ndim == 1 and p == 1:
            R = R[None, :]
        if R.shape != (p, m):
            raise ConfigurationError(
                f"`allocation` must be a {p}x{m} matrix R for plant '{plant.name}' "
                f"({p} output(s), {m} actuators)"
                + (f" or a list of {m} proportional gains" if p == 1 else "")
                + f"; got shape {R.shape}."
            )
        if not np.all(np.isfinite(R)):
            raise ConfigurationError("`allocation` must contain finite numbers.")
        object.__setattr__(self, "allocation", tuple(tuple(float(v) for v in row) for row in R))
        ref = self.reference
        if isinstance(ref, (str, int, float)):
            ref = (ref,)
        ref = tuple(ref)
        if len(ref) != p:
            raise ConfigurationError(
                f"`reference` needs one expression per output of plant '{plant.name}' "
                f"({', '.join(plant.output_names)}); got {len(ref)}."
            )
        object.__setattr__(self, "reference", ref)
        x0 = tuple(float(v) for v in self.initial_state)
        if len(x0) > n:
            raise ConfigurationError(
                f"`initial_state` has {len(x0)} values but plant '{plant.name}' has {n} states "
                f"({', '.join(plant.state_names)})."
            )
        if not all(math.isfinite(v) for v in x0):
            raise ConfigurationError("`initial_state` must contain finite numbers.")
        object.__setattr__(self, "initial_state", x0 + (0.0,) * (n - len(x0)))
        dormant = tuple(self.dormant_failures)
        if not all(isinstance(f, Failure) and 1 <= f.actuator <= m for f in dormant):
            raise ConfigurationError(
                f"`dormant_failures` must be failures of plant '{plant.name}'s {m} actuators."
            )
        object.__setattr__(self, "dormant_failures", dormant)
        fails = self.failures
        if not isinstance(fails, FailureSchedule):
            if isinstance(fails, Failure):
                fails = (fails,)
            fails = FailureSchedule(tuple(fails), m)
        elif fails.n_actuators != m:
            raise ConfigurationError(
                f"The failure schedule is for {fails.n_actuators} "
                f"actuators but plant '{plant.name}' has {m}."
            )
        object.__setattr__(self, "failures", fails)
        try:
            init = tuple(float(v) for v in self.adaptive_initial)
        except (TypeError, ValueError):
            raise ConfigurationError(
                f"`adaptive_initial` must be a list of numbers; got {self.adaptive_initial!r}."
            ) from None
        if not all(math.isfinite(v) for v in init):
            raise ConfigurationError("`adaptive_initial` must contain finite numbers.")
        object.__setattr__(self, "adaptive_initial", init)
        if not (
            isinstance(self.t_final, (int, float))
            and math.isfinite(self.t_final)
            and self.t_final > self.t0
        ):
            raise ConfigurationError(
                f"`t_final` must be a finite time after t0 = {self.t0}; got {self.t_final!r}."
            )
        if self.actuators is not None:
            if not isinstance(self.actuators, Actuators):
                raise ConfigurationError(
                    "`actuators` must be an adaptive_ftc.hardware.Actuators; got "
                    f"{self.actuators!r}."
                )
            self.actuators.table(m)  # checks every value against the plant's actuators
        if self.sensors is not None:
            if not isinstance(self.sensors, Sensors):
                raise ConfigurationError(
                    f"`sensors` must be an adaptive_ftc.hardware.Sensors; got {self.sensors!r}."
                )
            self.sensors.per_state(plant.aliases(), n)  # checks the state names
        ts = self.sample_time
        if (
            isinstance(ts, bool)
            or not isinstance(ts, (int, float))
            or not math.isfinite(ts)
            or ts < 0
            or (ts > 0 and ts > self.t_final - self.t0)
        ):
            raise ConfigurationError(
                f"`sample_time` must be 0 (continuous controller) or a period in seconds shorter "
                f"than the run ({self.t_final - self.t0:g} s); got {ts!r}."
            )
        object.__setattr__(self, "sample_time", float(ts))
        if ts > 0 and self.actuators is not None and self.actuators.has_delay:
            for j, d in enumerate(self.actuators.delays(m)):
                k = round(d / ts)
                if abs(d - k * ts) > 1e-9 * max(1.0, d):
                    raise ConfigurationError(
                        f"The input delay of actuator {j + 1} ({d:g} s) is not a whole number "
                        f"of the controller's samples ({ts:g} s): a digital controller delays "
                        f"its held command by whole samples. Set `delay` to "
                        f"{math.floor(d / ts) * ts:g} or {math.ceil(d / ts) * ts:g} s."
                    )
        if self.controller.single_output and p != 1:
            raise ConfigurationError(
                f"Design '{self.controller.design}' is single-output but plant '{plant.name}' "
                f"has {p} outputs; use the 'mimo' design."
            )
        if self.allocator is not None or self.annunciations:
            from adaptive_ftc.allocation.inloop import check_allocator

            alloc, anns = check_allocator(self.allocator, self.R, m, self.annunciations)
            object.__setattr__(self, "allocator", alloc)
            object.__setattr__(self, "annunciations", anns)

    @property
    def has_actuator_dynamics(self) -> bool:
        """Whether the actuators have states (declared dynamics or a dynamics failure)."""
        return self.actuators is not None or any(
            hasattr(f, "dynamics") for f in self.failures.failures
        )

    @property
    def measured_with_noise(self) -> bool:
        """Whether the controller sees noisy measurements or runs sampled (then the honest
        ``s'`` is the filtered one)."""
        return self.sample_time > 0 or (self.sensors is not None and self.sensors.has_noise)

    @property
    def R(self) -> np.ndarray:
        """The actuation matrix as an array."""
        return np.asarray(self.allocation, dtype=float)

    @property
    def known_sign(self) -> bool:
        """Whether the design assumes a known control direction (``direct``, ``estimation``,
        ``mimo`` while adapting): the sign conditions (2.16)/(4.6) then apply."""
        return self.adapt and self.controller.design in KNOWN_SIGN_DESIGNS

    def compensability(self, *, design: bool = False) -> CompensabilityReport:
        """Rank condition (3.6) on every interval of fixed failure pattern; ``design=True``
        adds the design's own conditions: for a known-sign design the sign conditions
        (2.16)/(4.6), for the healthy plant and on every interval, weighted by the plant's
        input gains (:meth:`~adaptive_ftc.plants.base.Plant.input_gains`)."""
        known_sign = design and self.known_sign
        return check_compensability(
            self.failures,
            self.R,
            self.t_final,
            state_names=tuple(self.plant.aliases()),
            t0=self.t0,
            known_sign=known_sign,
            gains=_input_gains(self.plant) if known_sign else None,
        )

    def without_failures(self) -> ClosedLoop:
        """The same loop with healthy actuators (failure-free reference run)."""
        from dataclasses import replace

        return replace(
            self,
            failures=FailureSchedule((), self.plant.n_actuators),
            dormant_failures=self.dormant_failures + tuple(self.failures.failures),
            annunciations=(),
            name=f"{self.name} (failure-free)" if self.name else "failure-free",
        )

    def frozen(self) -> ClosedLoop:
        """The same loop with adaptation switched off (non-adaptive baseline)."""
        from dataclasses import replace

        return replace(self, adapt=False, name=f"{self.name} (frozen)" if self.name else "frozen")

    def signal_names(self) -> dict[str, int]:
        """Controller signals a regressor may use, with their index in the signal vector."""
        return signal_names(self.plant)

    def describe_failures(self) -> list[str]:
        """One line per failure, in time order, for reports."""
        out = []
        for f in sorted(self.failures.failures, key=lambda f: (f.onset, f.actuator)):
            rec = f" until {f.recovery:g} s" if f.recovery is not None else ""
            out.append(
                f"t={f.onset:g} s{rec}: {self.plant.actuator_names[f.actuator - 1]} "
                f"-> {f.pattern()}"
            )
        return out
