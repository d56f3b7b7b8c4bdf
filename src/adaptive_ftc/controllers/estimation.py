"""Failure estimation and compensation design for parameterised failures (thesis §2.4)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import ClassVar, NamedTuple

import numpy as np

from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers.base import AdaptiveController, _nonnegative, _positive
from adaptive_ftc.controllers.constraints import capped_gain
from adaptive_ftc.controllers.laws import kappa_law, theta_law
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.expressions import Expression
from adaptive_ftc.sim.layout import Misc

__all__ = ["FailureEstimation"]


class EstimationGains(NamedTuple):
    """Adaptation gains of (2.72)-(2.73)."""

    eta1: float
    eta2: float
    sigma: float


@dataclass(frozen=True, kw_only=True)
class FailureEstimation(AdaptiveController):
    """``u0 = Pi^T theta - sum_j kappa_j^T varpi_j(t)`` (2.62) with laws (2.72)-(2.73):

    ``theta' = eta1 Pi q - eta1 sigma theta``, ``kappa_j' = -eta2 varpi_j q - eta2 sigma kappa_j``,
    ``q = s' + k s + k0 tanh(s/eps0)``. The compensation term ``u_f = -sum_j kappa_j^T varpi_j``
    is recorded as a fault indicator.

    ``basis`` gives the known failure basis ``varpi_j(t)`` of each actuator as expressions of
    ``t``; one tuple per actuator, or a single tuple used for every actuator. The thesis does
    not state it for the wing-rock runs; the catalogue uses ``("1", "sin(5*t)", "cos(5*t)")`` for
    every aileron (see the notes of ``wingrock-estimation-s1``). With the same basis for every
    actuator the ``kappa_j`` stay equal.
    """

    design: ClassVar[str] = "estimation"
    equation: ClassVar[str] = "(2.62), (2.72), (2.73)"

    regressor: FuzzyBasis | LinearRegressor
    eta1: float = 20.0
    eta2: float = 20.0
    sigma: float = 0.1
    kappa0: float = 0.0
    basis: tuple = field(default=("1",))

    def __post_init__(self) -> None:
        super().__post_init__()
        _positive(type(self).__name__, eta1=self.eta1, eta2=self.eta2)
        _nonnegative(type(self).__name__, sigma=self.sigma)
        if not self.basis:
            raise ConfigurationError("`basis` of FailureEstimation needs at least one function.")

    def basis_for(self, n_actuators: int) -> tuple[tuple[str, ...], ...]:
        """The basis functions of each actuator."""
        b = self.basis
        if all(isinstance(v, (str, int, float)) for v in b):
            return tuple(tuple(str(v) for v in b) for _ in range(n_actuators))
        if len(b) != n_actuators:
            raise ConfigurationError(
                f"`basis` of FailureEstimation gives {len(b)} lists but the plant has "
                f"{n_actuators} actuators; give one list per actuator or one list for all."
            )
        out = tuple(tuple(str(v) for v in bj) for bj in b)
        if any(not bj for bj in out):
            raise ConfigurationError("Each actuator's `basis` needs at least one function.")
        return out

    def theta_gain(self) -> float:
        return float(self.eta1)

    def compensator_gain(self, loop) -> float:
        """``eta2 sum_j |varpi_j(t0)|^2``: ``kappa_j' = -eta2 varpi_j q`` moves the compensator
        ``u_f = -sum_j kappa_j^T varpi_j`` by this per unit of ``q``, a proportional path of
        the law beside ``theta``'s (wing rock: 634 x 20 x 3 x 2 = 76100 1/s against 12700 for
        ``theta``; the rule left it out and the 50 Hz law diverged within 0.12 s). Counted
        only on a plant with a fast unstable mode (:meth:`ConstraintAware.fast_unstable`, the
        wing rock); 0 elsewhere (hypersonic-estimation-s1 behind a 50 ms lag was acceptable
        without it, 1.6e-4 rad, and is not with it, 1.4e-2)."""
        ca = self.constraint_aware
        if ca is None or ca.is_ideal:
            return 0.0
        if ca.unstable_rate is None:
            ca = replace(ca, unstable_rate=self.open_loop_unstable_rate(loop))
        R = np.asarray(loop.R, dtype=float)
        b_max = ca.b_max or (float(np.abs(R).max()) if R.size and np.abs(R).max() > 0 else 1.0)
        if not ca.fast_unstable(b_max):
            return 0.0
        t0 = float(loop.t0)
        total = 0.0
        for bj in self.basis_for(loop.plant.n_actuators):
            for text in bj:
                v = Expression(text, ("t",), context="basis function")(t=t0)
                total += float(v) ** 2
        return float(self.eta2) * total

    def gains(self) -> EstimationGains:
        r = self.adaptation_scale  # 1 for the thesis law
        return EstimationGains(float(self.eta1) * r, float(self.eta2) * r, float(self.sigma))

    def emit_control(self, g, blocks, extra_at: int) -> list[str]:
        basis = self.basis_for(g.m)
        lines = [
            "@inl",
            "def basis(t, c, w):",
            '    """Known failure basis varpi_j(t) of every actuator, flattened (2.62)."""',
        ]
        i = 0
        for j, bj in enumerate(basis):
            for l, text in enumerate(bj):
                e = Expression(text, ("t",), context=f"basis function {l + 1} of actuator {j + 1}")
                text = g.constant_block(e.node, {"t": "t"})
                lines.append(f"    w[{i}] = {text}  # actuator {j + 1}, function {l + 1}")
                g.adaptive_names.append(f"kappa{j + 1}_{l + 1}")
                g.y0_extra.append(float(self.kappa0))
                i += 1
        g.defs.append("\n".join(lines))
        g.n_w = i
        g.per_time.append("basis(t, c, wb)  # varpi(t), once per t (wb holds nothing else)")
        return [
            "    # compensator u_f = -sum_j kappa_j^T varpi_j(t) (2.62); wb = varpi(t)",
            "    comp = 0.0",
            f"    for l in range({i}):",
            f"        comp -= Y[{extra_at} + l] * wb[l]",
            f"    misc[{int(Misc.UF_COMP)}] = comp",
            "    u0[0] += comp",
        ]

    def regressor_cap(self, loop) -> float:
        """Constraint-aware only, on a plant with a fast unstable mode
        (:meth:`ConstraintAware.fast_unstable`, the wing rock): the bound on ``|Pi|^2`` above
        which ``theta``'s law is normalised
        (:func:`~adaptive_ftc.controllers.constraints.capped_gain`), ``|Pi(z0)|^2`` at the
        loop's initial state; 0: none (the thesis law, an ideal model, other plants)."""
        ca = self.constraint_aware
        if ca is None or ca.is_ideal or not ca.fast_unstable(ca.b_max or 1.0):
            return 0.0
        a = self.thesis_assembled(loop)
        phi = a.regressor_values(loop.t0, a.y0)
        return float(sum(np.sum(phi[sl] ** 2) for sl in a.theta_slices))

    def emit_adapt(self, g, blocks, extra_at: int) -> list[str]:
        g.use("theta_law", theta_law)
        g.use("kappa_law", kappa_law)
        cap = self.regressor_cap(g.loop)
        if cap > 0:
            # constraint-aware: the linear regressor's |Pi|^2 grows with the error squared,
            # and with it the slowed law's loop gain (the 50 Hz law diverged at 0.57 s)
            g.use("capped_gain", capped_gain)
            g.consts.append(cap)
            at = len(g.consts) - 1
            laws = [
                f"    theta_law(dY, Y, phi, q[0], D.gains.eta1, D.gains.sigma,"
                f" capped_gain(phi, c[{at}], {o}, {size}), {o}, {a}, {size})"
                for o, a, size in blocks
            ]
        else:
            laws = self.theta_laws(blocks, "D.gains.eta1", "D.gains.sigma", "1.0")
        return [
            "    # adaptive laws (2.72)-(2.73)",
            f"    misc[{int(Misc.GAIN)}] = 1.0",
            *laws,
            f"    kappa_law(dY, Y, wb, q[0], D.gains.eta2, D.gains.sigma, 0, {extra_at}, {g.n_w})",
        ]
