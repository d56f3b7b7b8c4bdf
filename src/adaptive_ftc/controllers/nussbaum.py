"""Nussbaum-gain design for unknown control direction and non-affine failures (thesis §4.3)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers import constraints
from adaptive_ftc.controllers.base import AdaptiveController, _nonnegative, _positive
from adaptive_ftc.controllers.laws import theta_law
from adaptive_ftc.expressions import Expression
from adaptive_ftc.sim.layout import Misc

__all__ = ["NussbaumAdaptive", "NUSSBAUM_FUNCTIONS"]

#: Common Nussbaum-type functions (4.15)-(4.16); any expression of ``tau`` may be used.
NUSSBAUM_FUNCTIONS = {
    "tau2cos": "tau**2*cos(tau)",
    "tau2sin": "tau**2*sin(tau)",
    "exp_tau2_cos": "exp(tau**2)*cos(tau)",
}


class NussbaumGains(NamedTuple):
    """Adaptation gains of (4.25)-(4.26)."""

    alpha0: float
    alpha1: float
    sigma: float


def tau_law(q, alpha1):
    """Eq. (4.26): ``tau' = alpha1 q^2``."""
    return alpha1 * q * q


@dataclass(frozen=True, kw_only=True)
class NussbaumAdaptive(AdaptiveController):
    """``u0 = Pi^T theta`` (4.17) with (4.25)-(4.27):
    ``theta' = alpha0 N(tau) Pi q - alpha0 sigma theta``, ``tau' = alpha1 q^2``,
    ``q = s' + k s + k0 tanh(s/eps0)``, ``N(tau) = tau^2 cos(tau)`` by default.

    ``nussbaum`` is an expression of ``tau`` or one of :data:`NUSSBAUM_FUNCTIONS`.
    """

    design: ClassVar[str] = "nussbaum"
    equation: ClassVar[str] = "(4.17), (4.25)-(4.27)"
    #: its own rule for the noise in its regressor (:meth:`configuration`,
    #: ``constraints.adaptation_regressor_rule``, with ``tau``'s prefilter): the shared
    #: regressor prefilter is not taken (``ConstraintAware.regressor_prefilter``)
    regressor_noise_rule: ClassVar[bool] = True

    regressor: FuzzyBasis | LinearRegressor
    alpha0: float = 5.0
    alpha1: float = 0.01
    sigma: float = 0.01
    tau0: float = 1.0
    nussbaum: str = "tau2cos"

    def __post_init__(self) -> None:
        super().__post_init__()
        _positive(type(self).__name__, alpha0=self.alpha0, alpha1=self.alpha1)
        _nonnegative(type(self).__name__, sigma=self.sigma)
        self.nussbaum_expression()

    def nussbaum_expression(self) -> Expression:
        """The Nussbaum function as an expression of ``tau``."""
        text = NUSSBAUM_FUNCTIONS.get(self.nussbaum, self.nussbaum)
        return Expression(text, ("tau",), context="`nussbaum` of NussbaumAdaptive")

    def theta_gain(self) -> float:
        """``alpha0 |N(tau0)|``: the law's gain at the initial ``tau``."""
        return float(self.alpha0) * abs(float(self.nussbaum_expression()(tau=float(self.tau0))))

    def configuration(
        self, b_max: float = 1.0, input_gain: float = 0.0
    ) -> constraints.Configuration:
        """The shared rule's configuration and, under noise above the density bound, the
        adaptation's regressor of prefiltered measurements
        (:func:`~adaptive_ftc.controllers.constraints.adaptation_regressor_rule`: the noise
        of ``Pi`` and of ``q`` is correlated, and ``theta`` drifts with it)."""
        cfg = super().configuration(b_max, input_gain)
        ca = self.constraint_aware
        if ca is None or cfg == constraints.IDENTITY or ca.noise <= 0:
            return cfg
        w0 = ca.loop_rate if ca.loop_rate is not None else self.loop_rate()
        w, _ = ca.omega_max(w0, ca.b_max if ca.b_max is not None else b_max)
        return constraints.adaptation_regressor_rule(cfg, ca, w)

    def tau_prefilter(self) -> float:
        """Bandwidth (rad/s) of the prefilter of ``q`` in the law of ``tau`` (``inf``: none):
        ``C_PREFILTER w`` (at most ``C_EULER / T``) where the noise rule applies
        (:meth:`configuration`). ``tau' = alpha1 q^2`` integrates the noise's power: with the
        measured ``q`` the noise case's ``tau`` drifts from 1 to 1.19 in 120 s (``N(tau)``
        down 12 %, towards its sign change at ``pi/2``), at the thesis's ``alpha1`` to 5.4
        and the loop is lost at 49 s; with the prefiltered ``q`` it stays below 1.01."""
        ca = self.constraint_aware
        if ca is None or ca.is_ideal or ca.noise <= 0:
            return math.inf
        if not self.configuration().adaptation_regressor_filtered:
            return math.inf
        w0 = ca.loop_rate if ca.loop_rate is not None else self.loop_rate()
        w, _ = ca.omega_max(w0, ca.b_max if ca.b_max is not None else 1.0)
        omega = constraints.C_PREFILTER * w
        if ca.sample_time > 0:
            omega = min(omega, constraints.C_EULER / ca.sample_time)
        return omega

    def gain_cap(self) -> float:
        """Largest ``|N(tau)|`` the law of ``theta`` uses (``inf``: none): ``|N(tau0)|`` where
        the noise rule applies (:meth:`tau_prefilter` finite), the gain the constraint-aware
        scale ``r`` is sized for (:meth:`theta_gain`: the loop gain ``alpha0 r |N(tau0)| b
        |Pi|^2`` at most the admitted loop rate ``w``).

        Why: after a direction search ``|N(tau)|`` is wherever ``tau`` stopped, not
        ``|N(tau0)|``: hypersonic-nussbaum-s1-neg with 1 % noise ends its search at ``tau`` =
        2.58, ``N`` = -5.6, 10.4x the designed gain, and the loop runs 10x past ``w`` (14.9
        1/s): 62 % of the command's fast content was at 10-30 Hz, the measurement noise the
        loop tracked (fast content 8.4e-2 rad; capped 1.5e-2, the positive-signed run's
        1.1e-2). Capped, ``N`` keeps its sign change (the direction search) but not its
        growth: a sign-switching search at the designed gain, not a Nussbaum function in the
        strict sense (its running mean stays bounded), so §4.3's Nussbaum lemma does not cover
        this option; it relies on the declared bound ``b_max`` on the control gain's
        magnitude, which the scale ``r`` assumes already (docs/hardware.md, "§4.3 Nussbaum")."""
        if not math.isfinite(self.tau_prefilter()):
            return math.inf
        cap = abs(float(self.nussbaum_expression()(tau=float(self.tau0))))
        return cap if cap > 0 else math.inf  # N(tau0) = 0: the scale has nothing to size

    def gains(self) -> NussbaumGains:
        """``(alpha0, alpha1, sigma)`` as the compiled law uses them: the thesis's, or, under a
        constraint-aware model that slows the law by ``r``, ``r alpha0`` and ``r alpha1``;
        where ``tau`` sees the prefiltered ``q`` (:meth:`tau_prefilter`), the thesis's
        ``alpha1``: ``tau`` is not in the loop's linear band, and the direction search must
        outrun the wrong-signed loop (hypersonic-nussbaum-s1-neg with noise diverged at 0.9 s
        with ``r alpha1``)."""
        r = self.adaptation_scale  # 1 for the thesis law
        a1 = float(self.alpha1) * (1.0 if math.isfinite(self.tau_prefilter()) else r)
        return NussbaumGains(float(self.alpha0) * r, a1, float(self.sigma))

    def emit_adapt(self, g, blocks, extra_at: int) -> list[str]:
        g.adaptive_names.append("tau")
        g.y0_extra.append(float(self.tau0))
        text = g.constant_block(self.nussbaum_expression().node, {"tau": "tau"})
        g.defs.append(
            "@inl\ndef nussbaum(tau, c):\n"
            '    """The Nussbaum function N(tau) (4.15); its numbers are in c."""\n'
            f"    return {text}"
        )
        g.use("theta_law", theta_law)
        g.use("tau_law", tau_law)
        lines = [
            "    # adaptive laws (4.25)-(4.27)",
            f"    gain = nussbaum(Y[{extra_at}], c)",
            f"    misc[{int(Misc.GAIN)}] = gain",
            f"    dY[{extra_at}] = tau_law(q[0], D.gains.alpha1)",
        ]
        omega = self.tau_prefilter()
        if math.isfinite(omega):  # constraint-aware, noise: tau sees q prefiltered
            g.adaptive_names.append("tau_q_prefilter")
            g.y0_extra.append(0.0)
            at = len(g.consts)
            g.consts.append(omega)
            qf = extra_at + 1
            lines[-1:] = [
                f"    dY[{qf}] = c[{at}] * (q[0] - Y[{qf}])  # constraint-aware: prefiltered q",
                f"    dY[{extra_at}] = tau_law(Y[{qf}], D.gains.alpha1)",
            ]
        cap = self.gain_cap()
        if math.isfinite(cap):
            cat = len(g.consts)
            g.consts.append(cap)
            lines[1:2] = [
                f"    gain = nussbaum(Y[{extra_at}], c)",
                f"    gain = min(max(gain, -c[{cat}]), c[{cat}])  # |N(tau0)| at most",
            ]
        return [*lines, *self.theta_laws(blocks, "D.gains.alpha0", "D.gains.sigma", "gain")]
