"""Control-direction estimation without a Nussbaum function (thesis §4.4)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar, NamedTuple

from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers import constraints
from adaptive_ftc.controllers.base import AdaptiveController, _nonnegative, _positive
from adaptive_ftc.controllers.laws import theta_law
from adaptive_ftc.sim.layout import Misc

__all__ = ["SignEstimation"]


class SignGains(NamedTuple):
    """Adaptation gains of (4.54)-(4.55)."""

    alpha0: float
    sigma0: float
    alpha1: float
    sigma1: float


def rho_law(u0, q, rho, alpha1, sigma1):
    """Eq. (4.55): ``rho' = -alpha1 u0 q - alpha1 sigma1 rho``."""
    return -alpha1 * u0 * q - alpha1 * sigma1 * rho


@dataclass(frozen=True, kw_only=True)
class SignEstimation(AdaptiveController):
    """``u0 = Pi^T theta`` (4.47) with (4.54)-(4.55):
    ``theta' = alpha0 rho Pi q - alpha0 sigma0 theta``,
    ``rho' = -alpha1 u0 q - alpha1 sigma1 rho`` (the printed ``sigma1 theta`` is read as
    ``sigma1 rho``, SPEC §5), ``q = s' + k s + k0 tanh(s/eps0)``.
    """

    design: ClassVar[str] = "sign"
    equation: ClassVar[str] = "(4.47), (4.54), (4.55)"
    #: ``rho`` estimates the input gain: no shared regressor prefilter
    #: (``AdaptiveController.estimates_input_gain``)
    estimates_input_gain: ClassVar[bool] = True

    regressor: FuzzyBasis | LinearRegressor
    alpha0: float = 5.0
    alpha1: float = 10.0
    sigma0: float = 0.01
    sigma1: float = 0.01
    rho0: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        _positive(type(self).__name__, alpha0=self.alpha0, alpha1=self.alpha1)
        _nonnegative(type(self).__name__, sigma0=self.sigma0, sigma1=self.sigma1)

    def rho_bound(self) -> float:
        """The projection bound of ``rho`` (``inf``: none): ``RHO_FACTOR |rho0|`` under a
        non-ideal constraint-aware model (:data:`~adaptive_ftc.controllers.constraints.
        RHO_FACTOR`; ``rho0 = 0``: none), so that the loop gain ``alpha0 |rho| |Pi|^2 b``
        the rule sizes the law for (:meth:`loop_gain_growth`) is a bound along the run;
        ``RHO_FACTOR_INTEGRAL |rho0|`` (``|rho0|``) where the rule gives the law the error's
        integral (:meth:`integral_surface`; session 15)."""
        ca = self.constraint_aware
        if ca is None or ca.is_ideal or float(self.rho0) == 0.0:
            return math.inf
        factor = constraints.RHO_FACTOR
        if self.integral_surface():
            factor = constraints.RHO_FACTOR_INTEGRAL
        return factor * abs(float(self.rho0))

    def integral_surface(self) -> bool:
        """The rule gives this law the error's integral (``Configuration.error_integral``:
        the delay budget of a discrete limiter with per-actuator travel sets the loop rate;
        :data:`~adaptive_ftc.controllers.constraints.C_INTEGRAL`), which does not depend on
        the bound of ``rho`` (asked with ``gain_growth`` 1). Meaningful on the bound design
        (:meth:`bound`), whose model carries the measured loop rate and the allocation."""
        ca = self.constraint_aware
        if ca is None or ca.is_ideal:
            return False
        probe = replace(self, constraint_aware=replace(ca, gain_growth=1.0))
        return AdaptiveController.configuration(probe).error_integral > 0

    def configuration(
        self, b_max: float = 1.0, input_gain: float = 0.0
    ) -> constraints.Configuration:
        """The rule's configuration; where it carries the error's integral ``k_I``, ``lam``
        raised by :func:`~adaptive_ftc.controllers.constraints.integral_damping` (the surface
        ``p^2 + lam p + k_I``'s zero pair damped at ``C_INTEGRAL_ZETA``, at most
        ``C_INTEGRAL_LAM_MAX`` times the thesis's ``lam``). Session 15, round 11b; §2.3 keeps
        the thesis's ``lam`` (round 12: the damping does not widen its band)."""
        cfg = super().configuration(b_max, input_gain)
        ca = self.constraint_aware
        lam = self.lam if isinstance(self.lam, (int, float)) else min(self.lam)
        least = ca.min_loop_gain if ca is not None else None
        return constraints.integral_damping(cfg, float(lam), least)

    def theta_gain(self) -> float:
        """``alpha0 |rho0|``: the law's gain at the initial ``rho``."""
        return float(self.alpha0) * abs(float(self.rho0))

    def loop_gain_growth(self) -> float:
        """The loop gain ``alpha0 |rho| |Pi|^2 b`` grows with ``|rho|``: with a bounded ``rho``
        (:meth:`rho_bound`) at most ``bound / |rho0|`` times the one at ``t0``."""
        bound = self.rho_bound()
        return bound / abs(float(self.rho0)) if math.isfinite(bound) else 1.0

    def hedge_direction(self, g) -> str:
        """The compensated-error filter hedges along the estimated direction, the sign of
        ``rho`` (the loop's measured ``|d s'/d u0|`` has no sign, and the direction is what this
        design does not know): with the positive sign a negative-direction plant's hedging
        was positive feedback (hypersonic-sign-s2-rho0neg at 2 rad/s diverged at 1.0 s)."""
        return f"math.copysign(1.0, Y[{g.nx + g.adaptive_names.index('rho')}])"

    def gains(self) -> SignGains:
        """``(alpha0, sigma0, alpha1, sigma1)`` as the compiled law uses them: the thesis's, or,
        under a constraint-aware model that slows the law by ``r`` (``adaptation_scale``),
        ``r alpha0`` and ``r^2 alpha1``: the direction estimate ``r`` times slower than
        ``theta`` (see :data:`~adaptive_ftc.controllers.constraints.RHO_FACTOR`)."""
        r = self.adaptation_scale  # 1 for the thesis law
        return SignGains(
            float(self.alpha0) * r,
            float(self.sigma0),
            float(self.alpha1) * r * r,
            float(self.sigma1),
        )

    def emit_adapt(self, g, blocks, extra_at: int) -> list[str]:
        g.adaptive_names.append("rho")
        g.y0_extra.append(float(self.rho0))
        g.use("theta_law", theta_law)
        g.use("rho_law", rho_law)
        lines = [
            "    # adaptive laws (4.54)-(4.55)",
            f"    rho = Y[{extra_at}]",
            f"    misc[{int(Misc.GAIN)}] = rho",
            f"    dY[{extra_at}] = rho_law(u0[0], q[0], rho, D.gains.alpha1, D.gains.sigma1)",
        ]
        bound = self.rho_bound()
        if math.isfinite(bound):  # constraint-aware: rho projected on |rho| <= bound
            g.use("project_interval", constraints.project_interval)
            at = len(g.consts)
            g.consts.append(bound)
            lines.append(f"    dY[{extra_at}] = project_interval(dY[{extra_at}], rho, c[{at}])")
        return [*lines, *self.theta_laws(blocks, "D.gains.alpha0", "D.gains.sigma0", "rho")]
