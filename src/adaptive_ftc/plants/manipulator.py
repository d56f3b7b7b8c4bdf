"""Two-link manipulator with two concurrent actuators per joint (thesis (3.60)-(3.65))."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from adaptive_ftc import _codes as kernel
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.plants.base import Plant, require_finite

__all__ = ["TwoLinkManipulator"]


@dataclass(frozen=True, kw_only=True)
class TwoLinkManipulator(Plant):
    """Planar two-link arm, no gravity, joint torques ``tau = R u^f`` with ``R = [[1,1,0,0],
    [0,0,1,1]]`` (eq. (3.62)): ``M(q) q'' + C(q, q') q' = tau``.

    ``M11 = a1 + 2 a3 cos q2 + 2 a4 sin q2``, ``M12 = a2 + a3 cos q2 + a4 sin q2``, ``M22 = a2``,
    ``h = a3 sin q2 - a4 cos q2``, ``C = [[-h q2', -h(q1' + q2')], [h q1', 0]]`` (the printed
    ``h(q1 + q2)`` is a typo). The parameters are the classic arm of the thesis's ref. [109].
    """

    name: ClassVar[str] = "manipulator"
    kind: ClassVar[int] = kernel.PLANT_MANIPULATOR
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

    def parameter_vector(self) -> np.ndarray:
        return np.array(self.inertia_constants(), dtype=float)
