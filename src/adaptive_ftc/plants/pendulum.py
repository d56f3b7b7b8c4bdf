"""Damped pendulum driven by three redundant motors (not in the thesis: a plant to carry the
designs beyond it)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.plants.base import Plant, require_finite

__all__ = ["Pendulum", "PendulumParams", "dynamics"]


class PendulumParams(NamedTuple):
    """Numbers of the pendulum: gravity over length, damping, inertia and motor gains."""

    g_over_l: float
    damping: float
    inertia: float
    gains: tuple


def dynamics(t, x, uf, p, xdot):
    """``theta' = omega``, ``J omega' = -J (g/l) sin(theta) - c omega + sum_j k_j u^f_j``."""
    theta = x[0]
    omega = x[1]
    torque = 0.0
    for j in range(uf.size):
        torque += p.gains[j] * uf[j]
    xdot[0] = omega
    xdot[1] = -p.g_over_l * math.sin(theta) + (torque - p.damping * omega) / p.inertia


@dataclass(frozen=True, kw_only=True)
class Pendulum(Plant):
    """A pendulum (angle ``theta`` from the downward vertical) with redundant motors.

    ``J omega' = -J (g/l) sin(theta) - c omega + sum_j k_j u^f_j``: relative degree 2 with a
    known control direction when every ``k_j`` has the same sign (flip one to try the
    unknown-direction designs of chapter 4).

    Examples
    --------
    >>> Pendulum().derivative(0.0, [0.0, 0.0], [1.0, 0.0, 0.0]).round(3).tolist()
    [0.0, 10.0]
    """

    name: ClassVar[str] = "pendulum"
    state_names: ClassVar[tuple[str, ...]] = ("theta", "omega")
    output_names: ClassVar[tuple[str, ...]] = ("theta",)
    position_index: ClassVar[tuple[int, ...]] = (0,)
    velocity_index: ClassVar[tuple[int, ...]] = (1,)
    units: ClassVar[tuple[str, ...]] = ("rad", "rad s-1")
    actuator_units: ClassVar[str] = "N m"
    equations = staticmethod(dynamics)

    g_over_l: float = 9.81
    damping: float = 0.05
    inertia: float = 0.1
    gains: tuple[float, ...] = (1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        require_finite(
            "Pendulum",
            g_over_l=self.g_over_l,
            damping=self.damping,
            inertia=self.inertia,
            gains=self.gains,
        )
        if not self.inertia > 0:
            raise ConfigurationError(f"`inertia` of Pendulum must be positive; got {self.inertia}.")
        if len(self.gains) < 1:
            raise ConfigurationError("`gains` of Pendulum needs at least one motor gain.")

    @property
    def n_actuators(self) -> int:
        return len(self.gains)

    @property
    def actuator_names(self) -> tuple[str, ...]:
        return tuple(f"motor{j + 1}" for j in range(len(self.gains)))

    def parameter_values(self) -> PendulumParams:
        return PendulumParams(
            float(self.g_over_l),
            float(self.damping),
            float(self.inertia),
            tuple(float(g) for g in self.gains),
        )
