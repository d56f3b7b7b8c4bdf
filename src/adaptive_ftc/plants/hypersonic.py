"""Hypersonic aircraft angle-of-attack dynamics with elevator segments (thesis eq. (2.50))."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.plants.base import Plant, require_finite

__all__ = ["HypersonicAngleOfAttack", "HypersonicParams", "dynamics"]


class HypersonicParams(NamedTuple):
    """Numbers of eq. (2.50)."""

    scale: float
    k_alpha: float
    a2: float
    a1: float
    a0: float
    k_q: float
    q2: float
    q1: float
    q0: float
    k_elevator: float


def dynamics(t, x, uf, p, xdot):
    """Eq. (2.50): ``alpha' = q``, ``q' = c [k_a(a2 a^2 + a1 a + a0) + k_q q (q2 a^2 + q1 a + q0)
    + k_e (sum_j u^f_j - a)]``; every elevator segment acts with unit gain."""
    a = x[0]
    q = x[1]
    usum = 0.0
    for j in range(uf.size):
        usum += uf[j]
    xdot[0] = q
    xdot[1] = p.scale * (
        p.k_alpha * (p.a2 * a * a + p.a1 * a + p.a0)
        + p.k_q * q * (p.q2 * a * a + p.q1 * a + p.q0)
        + p.k_elevator * (usum - a)
    )


@dataclass(frozen=True, kw_only=True)
class HypersonicAngleOfAttack(Plant):
    """Fast (alpha, q) dynamics of a hypersonic aircraft, eq. (2.50).

    ``alpha' = q``,
    ``q' = c [k_a(-6565 a^2 + 6875 a - 1) + k_q q(-6.83 a^2 + 0.303 a - 0.23)
    + k_e(sum_j u^f_j - a)]`` with ``c = 113.5891``, ``k_a = 5.33e-6``, ``k_q = 0.0026``,
    ``k_e = 0.0292``. Each elevator segment contributes its applied deflection with unit gain;
    the proportional gains ``b_j`` of the thesis belong to the controller's allocation.

    Examples
    --------
    >>> plant = HypersonicAngleOfAttack()
    >>> plant.derivative(0.0, [0.0, 0.0], [0.0, 0.0]).round(6).tolist()
    [0.0, -0.000605]
    """

    name: ClassVar[str] = "hypersonic"
    units: ClassVar[tuple[str, ...]] = ("rad", "rad s-1")
    actuator_units: ClassVar[str] = "rad"
    equations = staticmethod(dynamics)
    envelope: ClassVar[tuple[float, ...]] = (1.5707963267948966, float("inf"))  # |alpha| <= 90 deg
    state_names: ClassVar[tuple[str, ...]] = ("alpha", "q")
    output_names: ClassVar[tuple[str, ...]] = ("alpha",)
    position_index: ClassVar[tuple[int, ...]] = (0,)
    velocity_index: ClassVar[tuple[int, ...]] = (1,)

    elevators: int = 2
    scale: float = 113.5891
    k_alpha: float = 5.33e-6
    alpha_poly: tuple[float, float, float] = (-6565.0, 6875.0, -1.0)
    k_q: float = 0.0026
    q_poly: tuple[float, float, float] = (-6.83, 0.303, -0.23)
    k_elevator: float = 0.0292

    def __post_init__(self) -> None:
        if not isinstance(self.elevators, int) or self.elevators < 1:
            raise ConfigurationError(
                f"`elevators` of HypersonicAngleOfAttack must be a positive integer; "
                f"got {self.elevators!r}."
            )
        require_finite(
            "HypersonicAngleOfAttack",
            scale=self.scale,
            k_alpha=self.k_alpha,
            alpha_poly=self.alpha_poly,
            k_q=self.k_q,
            q_poly=self.q_poly,
            k_elevator=self.k_elevator,
        )

    @property
    def n_actuators(self) -> int:
        return self.elevators

    @property
    def actuator_names(self) -> tuple[str, ...]:
        return tuple(f"delta_e{j + 1}" for j in range(self.elevators))

    def parameter_values(self) -> HypersonicParams:
        return HypersonicParams(
            self.scale, self.k_alpha, *self.alpha_poly, self.k_q, *self.q_poly, self.k_elevator
        )
