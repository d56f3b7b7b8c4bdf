"""Shared pieces of the thesis's adaptive designs."""

from __future__ import annotations

import math
from abc import ABC
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers import constraints
from adaptive_ftc.controllers.constraints import ConstraintAware
from adaptive_ftc.errors import ConfigurationError

__all__ = ["AdaptiveController", "as_tuple"]

Regressor = FuzzyBasis | LinearRegressor


def as_tuple(value, n: int, name: str, owner: str) -> tuple[float, ...]:
    """Broadcast a scalar or a length-``n`` sequence to a tuple of ``n`` floats."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return (float(value),) * n
    try:
        out = tuple(float(v) for v in value)
    except TypeError:
        raise ConfigurationError(
            f"`{name}` of {owner} must be a number or a list of {n} numbers; got {value!r}."
        ) from None
    if len(out) != n:
        raise ConfigurationError(
            f"`{name}` of {owner} needs {n} values (one per output); got {len(out)}."
        )
    return out


def _positive(owner: str, **values: float | tuple[float, ...]) -> None:
    for key, v in values.items():
        vals = v if isinstance(v, tuple) else (v,)
        for x in vals:
            if (
                isinstance(x, bool)
                or not isinstance(x, (int, float))
                or not math.isfinite(x)
                or x <= 0
            ):
                raise ConfigurationError(f"`{key}` of {owner} must be positive; got {v!r}.")


def _nonnegative(owner: str, **values: float) -> None:
    for key, v in values.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
            raise ConfigurationError(f"`{key}` of {owner} must be >= 0; got {v!r}.")


@dataclass(frozen=True, kw_only=True)
class AdaptiveController(ABC):
    """Common settings: filtered error ``s = e' + lambda e`` (2.18) and robust term
    ``k s + k0 tanh(s/eps0)`` (2.20). ``lam``, ``k`` and ``k0`` may be given per output.

    ``constraint_aware``: the designer's model of the hardware
    (:class:`~adaptive_ftc.controllers.constraints.ConstraintAware`); with it the design runs
    its constraint-aware version (scaled gains, command filter, anti-windup, prefilter,
    projection: see :mod:`adaptive_ftc.controllers.constraints`). ``None`` (default) is the
    thesis law, and ``dataclasses.replace(design, constraint_aware=None)`` gives it back.
    """

    design: ClassVar[str]
    equation: ClassVar[str]
    #: the design has its own rule for the noise in its regressor (§4.3), so the rule does not
    #: give it the shared regressor prefilter (``ConstraintAware.regressor_prefilter``)
    regressor_noise_rule: ClassVar[bool] = False
    #: the design estimates its input gain (§4.4's ``rho``), so its loop gain moves along the
    #: run whatever bound the rule puts on the estimate: the rule does not give it the shared
    #: regressor prefilter (measured to lose §4.4's failed loop, docs/hardware.md round 11)
    estimates_input_gain: ClassVar[bool] = False

    lam: float | tuple[float, ...] = 1.0
    k: float | tuple[float, ...] = 1.0
    k0: float | tuple[float, ...] = 1.0
    eps0: float = 0.01
    theta0: float = 0.0
    constraint_aware: ConstraintAware | None = None

    def __post_init__(self) -> None:
        owner = type(self).__name__
        if self.constraint_aware is not None and not isinstance(
            self.constraint_aware, ConstraintAware
        ):
            raise ConfigurationError(
                f"`constraint_aware` of {owner} must be a ConstraintAware (the designer's "
                f"model of the hardware) or None; got {self.constraint_aware!r}."
            )
        for key in ("lam", "k"):
            v = getattr(self, key)
            _positive(owner, **{key: tuple(v) if not isinstance(v, (int, float)) else v})
        v = self.k0
        vals = (v,) if isinstance(v, (int, float)) else tuple(v)
        for x in vals:
            _nonnegative(owner, k0=x)
        _positive(owner, eps0=self.eps0)
        if (
            isinstance(self.theta0, bool)
            or not isinstance(self.theta0, (int, float))
            or not math.isfinite(self.theta0)
        ):
            raise ConfigurationError(
                f"`theta0` of {owner} must be a finite number; got {self.theta0!r}."
            )

    def regressors(self) -> tuple[Regressor, ...]:
        """The regressor of each output's control channel."""
        return (self.regressor,)  # type: ignore[attr-defined]

    def regressors_for(self, p: int) -> tuple[Regressor, ...]:
        """The regressors for a plant with ``p`` outputs (one common channel by default)."""
        return self.regressors()

    # ------------------------------------------------------------------ constraint-aware
    def loop_rate(self) -> float:
        """``w0 = k + k0/eps0``: the rate at which the law's linear band integrates ``s``
        (the largest over the outputs)."""
        k = (self.k,) if isinstance(self.k, (int, float)) else tuple(self.k)
        k0 = (self.k0,) if isinstance(self.k0, (int, float)) else tuple(self.k0)
        k = k * len(k0) if len(k) == 1 else k
        k0 = k0 * len(k) if len(k0) == 1 else k0
        return max(float(a) + float(b) / float(self.eps0) for a, b in zip(k, k0, strict=True))

    def configuration(
        self, b_max: float = 1.0, input_gain: float = 0.0
    ) -> constraints.Configuration:
        """The constraint-aware configuration (the identity without ``constraint_aware``);
        ``input_gain``: the loop's nominal ``|d s'/d u0|`` (:meth:`nominal_input_gain`)."""
        ca = self.constraint_aware
        if ca is None:
            return constraints.IDENTITY
        lam = self.lam if isinstance(self.lam, (int, float)) else min(self.lam)
        return ca.configure(
            w0=ca.loop_rate if ca.loop_rate is not None else self.loop_rate(),
            b_max=ca.b_max if ca.b_max is not None else b_max,
            lam=float(lam),
            input_gain=input_gain,
            slope=self.loop_rate() if self.single_output else None,
            adaptive=bool(self.regressors()),
        )

    def theta_gain(self) -> float:
        """The gain of ``Pi q`` in the law of ``theta`` at the initial state (``gamma`` of
        (2.29)); the loop gain of the law is this times ``|Pi|^2`` and the input gain."""
        raise NotImplementedError

    def thesis_assembled(self, loop):
        """``loop`` with this design's thesis law on ideal, continuous hardware and fresh
        adaptive states, assembled: where the constraint-aware rules measure the regressor and
        the loop gain as the loop computes them."""
        from adaptive_ftc.sim.compose import assemble

        thesis = replace(
            loop,
            controller=replace(self, constraint_aware=None),
            actuators=None,
            sensors=None,
            sample_time=0.0,
            adaptive_initial=(),
            adapt=True,
        )
        return assemble(thesis)

    def measured_loop_rate(self, loop) -> tuple[float, float, float]:
        """The law's loop rate on ``loop`` (1/s): in the linear band ``u0`` moves by ``x |Pi|^2
        (s + (k + k0/eps0) int s)`` per unit of the filtered error (``x`` =
        :meth:`theta_gain`), and ``s' = -b u0 + ...`` with ``b = |d s'/d u0|``
        (:meth:`nominal_input_gain`), so the law's poles satisfy ``l^2 + g l + g K = 0``
        with ``g = b x |Pi(z0)|^2``, ``K = k + k0/eps0``: the rate is ``max(g, sqrt(g K))``,
        the largest over the outputs, with ``Pi`` at the loop's initial state. Returns
        ``(rate, g)`` of that output and the smallest ``g``. Designs without a regressor (the
        baselines): ``(k + k0/eps0, 0, 0)``."""
        regs = self.regressors_for(loop.plant.n_outputs)
        if not regs:
            return self.loop_rate(), 0.0, 0.0
        a = self.thesis_assembled(loop)
        phi = a.regressor_values(loop.t0, a.y0)
        G = np.asarray(loop.plant.input_gains(loop.t0, np.asarray(loop.initial_state, float)))
        R = np.atleast_2d(np.asarray(loop.R, dtype=float))
        b = np.abs(np.sum(R * G, axis=1)) if G.shape == R.shape else np.ones(len(regs))
        p = len(regs)
        k = as_tuple(self.k, p, "k", type(self).__name__)
        k0 = as_tuple(self.k0, p, "k0", type(self).__name__)
        x = abs(float(self.theta_gain()))
        extra = self.compensator_gain(loop)
        rate, gain, least = 0.0, 0.0, math.inf
        for i, sl in enumerate(a.theta_slices):
            bi = float(b[i] if len(b) == len(a.theta_slices) else np.max(b))
            g = bi * x * float(np.sum(phi[sl] ** 2))
            if extra:
                g = bi * (x * float(np.sum(phi[sl] ** 2)) + extra)
            least = min(least, g)
            ri = max(g, math.sqrt(g * (k[i] + k0[i] / float(self.eps0))))
            if ri > rate:
                rate, gain = ri, g
        return (rate, gain, least) if rate > 0 else (self.loop_rate(), 0.0, 0.0)

    def compensator_gain(self, loop) -> float:
        """The rate (per unit of ``q``, before the input gain) at which the design's
        compensator moves ``u0`` at ``t0``, beside ``theta``'s ``x |Pi|^2``: 0; §2.4's
        ``u_f = -sum_j kappa_j^T varpi_j(t)`` overrides it."""
        return 0.0

    def bound(self, loop):
        """The design with its designer's model completed from ``loop`` (what the compiled
        loop uses): the measured loop rate, the allocation's largest gain and the nominal
        input gain where the model leaves them ``None``. Without the option, or with an ideal
        model, the design itself."""
        ca = self.constraint_aware
        if ca is None or ca.is_ideal:
            return self
        updates = {}
        if ca.b_max is None:
            R = np.asarray(loop.R, dtype=float)
            updates["b_max"] = float(np.abs(R).max()) if R.size and np.abs(R).max() > 0 else 1.0
        if ca.input_gain is None:
            updates["input_gain"] = self.nominal_input_gain(loop)
        if ca.unstable_rate is None:
            updates["unstable_rate"] = self.open_loop_unstable_rate(loop)
        if ca.open_loop is None and self.single_output:
            updates["open_loop"] = self.open_loop_rows(loop)
        if ca.loop_rate is None:
            updates["loop_rate"], gain, least = self.measured_loop_rate(loop)
            if ca.loop_gain is None and gain > 0:
                updates["loop_gain"] = gain
            if ca.min_loop_gain is None and least > 0:
                updates["min_loop_gain"] = least
        if ca.per_actuator is None:
            # a single-output law with a fixed allocation shapes its command filter by each
            # actuator's own limits (session 13, ConstraintAware.per_actuator), but where the
            # placed feedback is (the wing rock: its loop was sized with the filter it has)
            done = replace(ca, **updates)
            updates["per_actuator"] = bool(
                self.single_output
                and loop.allocator is None
                and done.limited
                and not done.fast_unstable(float(done.b_max or 1.0))
            )
        if ca.decimation is None and ca.noise > 0 and ca.whole_readings >= 2:
            # the decimation filter (session 14, ConstraintAware.decimation) where the noise
            # is what lowers the rule's loop rate (elsewhere it would add its delay for
            # nothing) and the loop's sensors give the model's readings per sample; only on
            # single-output laws with a fixed allocation and no placed feedback, where it was
            # measured: the wing rock's placed PID (sized without the filter's delay) lost
            # 3 of the wingrock-hardware campaign's 500 members with it (210, 343, 370 at
            # 100 Hz: limit cycle or 20x the error), and the MIMO laws were not measured
            done = replace(ca, **updates, bandwidth=None, decimation=False)
            validated = (
                self.single_output
                and loop.allocator is None
                and not done.fast_unstable(float(done.b_max or 1.0))
            )
            w0, b_max = float(done.loop_rate or self.loop_rate()), float(done.b_max or 1.0)
            noisy = done.omega_max(w0, b_max)[0]
            quiet = replace(done, noise=0.0).omega_max(w0, b_max)[0]
            sensors = loop.sensors
            given = sensors is not None and math.isclose(
                float(loop.sample_time) * float(sensors.rate), ca.whole_readings, rel_tol=1e-9
            )
            updates["decimation"] = bool(validated and given and noisy < quiet * (1.0 - 1e-9))
        if ca.gain_growth is None:
            # last: §4.4's bound of rho depends on the configuration the rest completes
            done = replace(self, constraint_aware=replace(ca, **updates))
            updates["gain_growth"] = done.loop_gain_growth()
        if ca.regressor_prefilter is None:
            # (session 15) the regressor's prefilter (ConstraintAware.regressor_prefilter)
            # where the rule takes the decimation filter (the noise sets the loop rate), on
            # a law whose loop gain does not grow along the run (not §4.4: its failed loop,
            # lightly damped at this rate, is lost with the filter's phase), without a noise
            # rule of its own for the regressor (not §4.3) and whose delay budget admits the
            # filter's delay
            done = replace(ca, **updates)
            take = False
            own = self.regressor_noise_rule
            if ca.decimation is None and done.decimation and self.regressors() and not own:
                w0, b_max = float(done.loop_rate or self.loop_rate()), float(done.b_max or 1.0)
                w = done.omega_max(w0, b_max)[0]
                # not on a law that estimates its input gain (§4.4): its gain_growth is 1
                # where the rule gives it the error's integral (rho bounded by |rho0|, round
                # 11b) but its failed loop still is lost with the filter's phase
                growth = float(done.gain_growth or 1.0)
                take = (
                    not self.estimates_input_gain
                    and growth == 1.0
                    and done.regressor_prefilter_fits(w)
                )
            updates["regressor_prefilter"] = bool(take)
        return replace(self, constraint_aware=replace(ca, **updates))

    @staticmethod
    def _plant_jacobian(loop) -> np.ndarray:
        """The plant's Jacobian ``d x'/d x`` at the loop's initial state with zero command
        (central differences of the plant's derivative)."""
        plant = loop.plant
        x0 = np.asarray(loop.initial_state, dtype=float)
        u = np.zeros(plant.n_actuators)
        n = x0.size
        jac = np.zeros((n, n))
        for i in range(n):
            h = 1e-6 * max(1.0, abs(float(x0[i])))
            xp, xm = x0.copy(), x0.copy()
            xp[i] += h
            xm[i] -= h
            fp = np.asarray(plant.derivative(loop.t0, xp, u), dtype=float)
            fm = np.asarray(plant.derivative(loop.t0, xm, u), dtype=float)
            jac[:, i] = (fp - fm) / (2.0 * h)
        return jac

    @classmethod
    def open_loop_rows(cls, loop) -> tuple[float, float] | None:
        """``(d y''/d y, d y''/d y')`` of the first output at the loop's initial state with
        zero command (the plant linearised as ``y'' = a y + c y' + ...``; the wing rock at 1
        deg: ``-(a0 + 3 a3 phi0^2)``, ``-(a1 + a4 phi0^2)``), the designer's linear model of
        the placed feedback (:func:`~adaptive_ftc.controllers.constraints.placed_feedback`);
        ``None`` where the plant has no position/velocity pair for it."""
        plant = loop.plant
        pos = getattr(plant, "position_index", ())
        vel = getattr(plant, "velocity_index", ())
        if not pos or not vel:
            return None
        jac = cls._plant_jacobian(loop)
        a, c = float(jac[vel[0], pos[0]]), float(jac[vel[0], vel[0]])
        return (a, c) if math.isfinite(a) and math.isfinite(c) else None

    @classmethod
    def open_loop_unstable_rate(cls, loop) -> float:
        """The modulus of the plant's fastest unstable open-loop mode at the loop's initial
        state with zero command (the largest ``|lambda|`` over the eigenvalues of the
        linearised plant with a positive real part; 0 where there is none), by central
        differences of the plant's derivative: the wing rock's 5.5 +- 29.9j gives 30.4 1/s,
        the hypersonic short period 0.75 1/s."""
        jac = cls._plant_jacobian(loop)
        if not np.all(np.isfinite(jac)):
            return 0.0
        ev = np.linalg.eigvals(jac)
        unstable = np.abs(ev[ev.real > 1e-9])
        return float(unstable.max()) if unstable.size else 0.0

    def derivative_filter_tau(self, loop) -> float | None:
        """The time constant (s) of the ``s'`` filter this design asks for on ``loop``
        (``SolverOptions.filter_tau_for``, where the solver leaves ``filter_tau`` unset);
        ``None``: the solver's default. The constraint-aware MIMO law overrides it."""
        return None

    def loop_gain_growth(self) -> float:
        """The factor by which the law's loop gain can grow along the run over the one at
        ``t0`` (``ConstraintAware.gain_growth``): 1; §4.4 overrides it."""
        return 1.0

    @staticmethod
    def nominal_input_gain(loop) -> float:
        """The healthy loop's ``|d s_i'/d u0_i| = |sum_j R_ij dy_i''/du_j|`` at the initial
        state (the largest over the outputs): the gain of the compensated-error filter."""
        G = np.asarray(loop.plant.input_gains(loop.t0, np.asarray(loop.initial_state, dtype=float)))
        R = np.atleast_2d(np.asarray(loop.R, dtype=float))
        if G.shape != R.shape:
            return 0.0
        return float(np.max(np.abs(np.sum(R * G, axis=1))))

    @property
    def adaptation_scale(self) -> float:
        """Factor on every adaptation gain of ``theta`` (1 for the thesis law)."""
        return self.configuration().scale

    def robust_settings(self) -> tuple:
        """``(lam, k, k0, eps0)`` as the compiled law uses them: the thesis's, or
        ``(f lam, r k, W k0, W eps0 / r_K)`` with the constraint-aware bandwidth scale ``r``,
        error-filter factor ``f``, boundary-layer widening ``W`` and slope scale ``r_K``."""
        cfg = self.configuration()
        r, f, w, rk = cfg.scale, cfg.lam_factor, cfg.widen, cfg.slope_scale
        if r == 1.0 and f == 1.0 and w == 1.0 and rk == 1.0:
            return self.lam, self.k, self.k0, self.eps0

        def times(v, x):
            return v * x if isinstance(v, (int, float)) else tuple(e * x for e in v)

        return times(self.lam, f), times(self.k, r), times(self.k0, w), self.eps0 * w / rk

    @property
    def keeps_fixed_feedback(self) -> bool:
        """Whether the generated loop keeps the configuration's fixed feedback (placed PID
        and lead): an adaptive design does; a baseline's own law (the inverse) has none beside
        it, unless it stands in for a law's adaptation (the oracle with ``law``)."""
        return bool(self.regressors())

    def compiled_configuration(self, g) -> constraints.Configuration:
        """The configuration the generated loop ``g`` implements (before
        :meth:`sampled_configuration`): :meth:`configuration` with the allocation's largest
        gain and the loop's nominal input gain, its fixed feedback dropped where the design
        does not keep it (:attr:`keeps_fixed_feedback`)."""
        b_max = float(abs(np.asarray(g.loop.R)).max()) if np.size(g.loop.R) else 1.0
        gain = 0.0
        ca = self.constraint_aware
        if ca is not None and ca.input_gain is None and not ca.is_ideal:
            gain = self.nominal_input_gain(g.loop)
        cfg = self.configuration(b_max, gain)  # compose calls this on the bound design
        if (cfg.feedback or cfg.feedback_e or cfg.feedback_i) and not self.keeps_fixed_feedback:
            # a baseline's own law (the oracle) has no fixed feedback beside it
            cfg = cfg._replace(feedback=0.0, feedback_e=0.0, feedback_i=0.0, feedback_lead=())
        return cfg

    def emit_constraint_aware(self, g, blocks, at: int):
        """Generated lines of the constraint-aware parts (``constraints.emit``): nothing for
        the thesis law or an ideal designer's model."""
        cfg = self.compiled_configuration(g)
        if cfg == constraints.IDENTITY:
            return [], [], [], []
        cfg = self.sampled_configuration(cfg, g)
        return constraints.emit(cfg, g, blocks, at, self.single_output, self.hedge_direction(g))

    def sampled_configuration(self, cfg: constraints.Configuration, g):
        """``cfg`` as the generated loop ``g`` implements it (a digital law may hand on its
        command filter's value after the sample's step); the design's own: ``cfg``."""
        return cfg

    def hedge_direction(self, g) -> str:
        """The sign of the input gain the compensated-error filter assumes, as generated code:
        ``""`` (positive: the designs whose control direction is known)."""
        return ""

    # ------------------------------------------------------------------ code generation
    def code_label(self) -> str:
        """The design as the generated module's header names it: designs that differ only in
        their numbers (see :class:`~adaptive_ftc.controllers.nominal.OracleInverse`) share one
        label, hence one compiled structure."""
        return f"{self.design!r} {self.equation}"

    def gains(self) -> tuple:
        """The design's adaptation gains as a NamedTuple (numbers of the compiled loop)."""
        raise NotImplementedError

    def emit_control(self, g, blocks, extra_at: int) -> list[str]:
        """Generated lines run after ``u0 = Pi^T theta`` (a compensator, if the design has one).

        ``blocks`` lists ``(phi offset, state index, size)`` of each theta block; the design's
        own states start at ``extra_at`` (declare them with ``g.adaptive_names`` and
        ``g.y0_extra``).
        """
        return []

    def emit_adapt(self, g, blocks, extra_at: int) -> list[str]:
        """Generated lines of the adaptive laws (write ``dY`` of every adaptive state)."""
        raise NotImplementedError

    @staticmethod
    def theta_laws(blocks, gamma: str, sigma: str, gain: str) -> list[str]:
        """Calls of :func:`~adaptive_ftc.controllers.laws.theta_law`, one per theta block."""
        return [
            f"    theta_law(dY, Y, phi, q[{r}], {gamma}, {sigma}, {gain}, {o}, {at}, {size})"
            for r, (o, at, size) in enumerate(blocks)
        ]

    @property
    def single_output(self) -> bool:
        """True for the chapter 2 and 4 designs (one common signal ``u0``)."""
        return True
