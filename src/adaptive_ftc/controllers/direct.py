"""Direct adaptive design for non-parameterised failures (thesis §2.3)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers.base import AdaptiveController, _nonnegative, _positive
from adaptive_ftc.controllers.laws import theta_law
from adaptive_ftc.sim.layout import Misc

__all__ = ["DirectAdaptive"]


class DirectGains(NamedTuple):
    """Adaptation gains of (2.29)."""

    gamma: float
    sigma: float


@dataclass(frozen=True, kw_only=True)
class DirectAdaptive(AdaptiveController):
    """``u0 = Pi(z)^T theta`` (2.22) with ``theta' = gamma Pi (s' + k s + k0 tanh(s/eps0))
    - gamma sigma theta`` (2.29), actuated proportionally ``u_j = b_j u0`` (2.10).

    ``sigma`` is not given by the thesis for §2.3; the default 0.01 is documented in the
    README and was checked on both hypersonic scenarios.
    """

    design: ClassVar[str] = "direct"
    equation: ClassVar[str] = "(2.22), (2.29)"

    regressor: FuzzyBasis | LinearRegressor
    gamma: float = 5.0
    sigma: float = 0.01

    def __post_init__(self) -> None:
        super().__post_init__()
        _positive(type(self).__name__, gamma=self.gamma)
        _nonnegative(type(self).__name__, sigma=self.sigma)

    def theta_gain(self) -> float:
        return float(self.gamma)

    def gains(self) -> DirectGains:
        return DirectGains(float(self.gamma) * self.adaptation_scale, float(self.sigma))

    def emit_adapt(self, g, blocks, extra_at: int) -> list[str]:
        g.use("theta_law", theta_law)
        return [
            "    # adaptive law (2.29)",
            f"    misc[{int(Misc.GAIN)}] = 1.0",
            *self.theta_laws(blocks, "D.gains.gamma", "D.gains.sigma", "1.0"),
        ]
