"""Two-link manipulator with two concurrent actuators per joint (thesis (3.60)-(3.65))."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.plants.base import Plant, require_finite

__all__ = ["ManipulatorParams", "TwoLinkManipulator", "dynamics"]


class ManipulatorParams(NamedTuple):
    """Inertia constants ``(a1, a2, a3, a4)`` of eq. (3.64)."""

    a1: float
    a2: float
    a3: float
    a4: float


def dynamics(t, x, uf, p, xdot):
    """Eqs. (3.60)-(3.65): ``M(q) q'' + C(q, q') q' = R u^f`` with ``R = [[1,1,0,0],[0,0,1,1]]``,
    solved for ``q''`` by Cramer's rule."""
    q2 = x[2]
    qd1 = x[1]
    qd2 = x[3]
    c = math.cos(q2)
    s = math.sin(q2)
    m11 = p.a1 + 2.0 * p.a3 * c + 2.0 * p.a4 * s
    m12 = p.a2 + p.a3 * c + p.a4 * s
    m22 = p.a2
    h = p.a3 * s - p.a4 * c
    tau1 = uf[0] + uf[1]
    tau2 = uf[2] + uf[3]
    r1 = tau1 - (-h * qd2 * qd1 - h * (qd1 + qd2) * qd2)
    r2 = tau2 - (h * qd1 * qd1)
    det = m11 * m22 - m12 * m12
    xdot[0] = qd1
    xdot[1] = (m22 * r1 - m12 * r2) / det
    xdot[2] = qd2
    xdot[3] = (-m12 * r1 + m11 * r2) / det


@dataclass(frozen=True, kw_only=True)
class TwoLinkManipulator(Plant):
    """Planar two-link arm, no gravity, joint torques ``tau = R u^f`` with ``R = [[1,1,0,0],
    [0,0,1,1]]`` (eq. (3.62)): ``M(q) q'' + C(q, q') q' = tau``.

    ``M11 = a1 + 2 a3 cos q2 + 2 a4 sin q2``, ``M12 = a2 + a3 cos q2 + a4 sin q2``, ``M22 = a2``,
    ``h = a3 sin q2 - a4 cos q2``, ``C = [[-h q2', -h(q1' + q2')], [h q1', 0]]`` (the printed
    ``h(q1 + q2)`` is a typo). The parameters are the classic arm of the thesis's ref. [109].
    """

    name: ClassVar[str] = "manipulator"
    units: ClassVar[tuple[str, ...]] = ("rad", "rad s-1", "rad", "rad s-1")
    actuator_units: ClassVar[str] = "N m"
    equations = staticmethod(dynamics)
    state_names: ClassVar[tuple[str, ...]] = ("q1", "q1_dot", "q2", "q2_dot")
    output_names: ClassVar[tuple[str, ...]] = ("q1", "q2")
    position_index: ClassVar[tuple[int, ...]] = (0, 2)
    velocity_index: ClassVar[tuple[int, ...]] = (1, 3)

    m1: float = 1.0
    l1: float = 1.0
    me: float = 2.0
    delta_e_deg: float = 30.0
    I1: float = 0.12
    lc1: float = 0.5
    Ie: float = 0.25
    lce: float = 0.6

    def __post_init__(self) -> None:
        require_finite(
            "TwoLinkManipulator",
            m1=self.m1,
            l1=self.l1,
            me=self.me,
            delta_e_deg=self.delta_e_deg,
            I1=self.I1,
            lc1=self.lc1,
            Ie=self.Ie,
            lce=self.lce,
        )
        for key in ("m1", "l1", "me", "I1", "Ie", "lce"):
            if getattr(self, key) <= 0:
                raise ConfigurationError(
                    f"`{key}` of TwoLinkManipulator must be positive; got {getattr(self, key)}."
                )

    @property
    def n_actuators(self) -> int:
        return 4

    @property
    def actuator_names(self) -> tuple[str, ...]:
        return ("tau11", "tau12", "tau21", "tau22")

    def inertia_constants(self) -> tuple[float, float, float, float]:
        """``(a1, a2, a3, a4)`` of eq. (3.64)."""
        de = math.radians(self.delta_e_deg)
        a1 = (
            self.I1 + self.m1 * self.lc1**2 + self.Ie + self.me * self.lce**2 + self.me * self.l1**2
        )
        a2 = self.Ie + self.me * self.lce**2
        a3 = self.me * self.l1 * self.lce * math.cos(de)
        a4 = self.me * self.l1 * self.lce * math.sin(de)
        return a1, a2, a3, a4

    def parameter_values(self) -> ManipulatorParams:
        return ManipulatorParams(*self.inertia_constants())
