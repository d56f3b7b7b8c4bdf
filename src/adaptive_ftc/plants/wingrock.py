"""Wing-rock roll dynamics with three aileron segments (thesis eqs. (2.98)-(2.102))."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.plants.base import Plant, require_finite

__all__ = ["WingRock", "WingRockParams", "dynamics"]


class WingRockParams(NamedTuple):
    """Numbers of eq. (2.101); ``b`` holds one gain per aileron."""

    a0: float
    a1: float
    a2: float
    a3: float
    a4: float
    b: tuple


def dynamics(t, x, uf, p, xdot):
    """Eq. (2.101): ``phi'' = -a0 phi - a1 phi' - a2|phi'|phi' - a3 phi^3 - a4 phi^2 phi'
    + sum_j b_j u^f_j``."""
    ph = x[0]
    pd = x[1]
    acc = -p.a0 * ph - p.a1 * pd - p.a2 * abs(pd) * pd - p.a3 * ph * ph * ph - p.a4 * ph * ph * pd
    for j in range(uf.size):
        acc += p.b[j] * uf[j]
    xdot[0] = pd
    xdot[1] = acc


@dataclass(frozen=True, kw_only=True)
class WingRock(Plant):
    """Wing rock of an 80-degree delta wing at 32.5 degrees angle of attack, eq. (2.101).

    ``phi'' = -a0 phi - a1 phi' - a2|phi'|phi' - a3 phi^3 - a4 phi^2 phi' + sum_j b_j u^f_j``.

    The defaults are the thesis's dimensional coefficients with its typos resolved (SPEC §6):
    ``a3 = +785.2666`` multiplies ``phi^3`` (from (2.96)-(2.98), ``a3 = 0.00623/t_s^2 > 0``),
    and ``b1 = -149.1759`` (printed "-0.149.1759"). The aileron gains ``b_j`` are negative, as
    printed: a positive deflection rolls the wing negative. See ``docs/sign-convention.md``.
    """

    name: ClassVar[str] = "wingrock"
    units: ClassVar[tuple[str, ...]] = ("rad", "rad s-1")
    actuator_units: ClassVar[str] = "rad"
    equations = staticmethod(dynamics)
    envelope: ClassVar[tuple[float, ...]] = (3.141592653589793, float("inf"))  # |phi| <= 180 deg
    state_names: ClassVar[tuple[str, ...]] = ("phi", "phi_dot")
    output_names: ClassVar[tuple[str, ...]] = ("phi",)
    position_index: ClassVar[tuple[int, ...]] = (0,)
    velocity_index: ClassVar[tuple[int, ...]] = (1,)

    a0: float = 922.6568
    a1: float = -11.0201
    a2: float = 0.5388
    a3: float = 785.2666
    a4: float = 14.8722
    b: tuple[float, ...] = (-149.1759, -111.8819, -111.8819)

    def __post_init__(self) -> None:
        if len(self.b) < 1:
            raise ConfigurationError("`b` of WingRock needs at least one aileron gain.")
        require_finite(
            "WingRock", a0=self.a0, a1=self.a1, a2=self.a2, a3=self.a3, a4=self.a4, b=self.b
        )

    @property
    def n_actuators(self) -> int:
        return len(self.b)

    @property
    def actuator_names(self) -> tuple[str, ...]:
        return tuple(f"delta_a{j + 1}" for j in range(len(self.b)))

    def parameter_values(self) -> WingRockParams:
        return WingRockParams(
            self.a0, self.a1, self.a2, self.a3, self.a4, tuple(float(v) for v in self.b)
        )
