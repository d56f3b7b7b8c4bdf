"""MIMO direct adaptive design with actuator distribution (thesis §3.3)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import ClassVar, NamedTuple

import numpy as np

from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers import constraints
from adaptive_ftc.controllers.base import (
    AdaptiveController,
    _nonnegative,
    _positive,
    as_tuple,
)
from adaptive_ftc.controllers.laws import theta_law
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.layout import Misc

__all__ = ["MimoDirectAdaptive"]


#: the normalised loop gain of a digital law per sample: ``g T <= C_SAMPLE_NORMALISED``. The
#: sampled law sees ``s`` one sample late (``theta`` by forward Euler, ``s'`` by the sampled
#: dirty derivative), so its proportional loop is ``s[k+1] = s[k] - g T s[k-1]``, with poles
#: of modulus ``sqrt(g T)``: 0.71 at 1/2 (the shared rule's ``0.75/T`` gives 0.87; measured,
#: the manipulator at 50 Hz loses the arm after the 12 s failure with it, and tracks to
#: 2.3e-2 rad with 1/2). Since round 5 the digital law looks ahead to the sample's step
#: (:meth:`MimoDirectAdaptive.emit_control`: ``s[k+1] = (1 - g T) s[k]``); the cap is kept,
#: not remeasured.
C_SAMPLE_NORMALISED = 0.5

#: an output whose proportional loop gain ``g_i = b_i eta |Pi_i|^2`` is below ``C_RAISE w`` (``w``
#: the admitted loop rate) has its adaptation gain raised to ``eta_i = m_i eta``, ``m_i = C_RAISE
#: w / g_i`` (normalised, :meth:`MimoDirectAdaptive.normalization`: its loop gain ``g/(1 +
#: g/w)`` is then ``3w/4``), its robust slope set to ``C_SLOPE w`` (the integral corner at the
#: loop rate) and its leakage rate ``eta_i sigma_i`` to the thesis's ``eta sigma`` times ``w /
#: w0``. The thesis's spacecraft loop is an integral one (``g`` = 0.04-0.11 1/s against ``K`` =
#: 4005-20005 1/s, damped by the leakage ``eta sigma`` = 2 1/s alone); slowed to ``w`` = 4.8
#: 1/s with that leakage kept (above the 0.31 rad/s reference) it lagged the reference by
#: 9.3e-3 rad behind a 50 ms lag, and a faster loop chattered. With the proportional path at
#: the loop rate and the leakage moved down with the loop: 1.3e-3 rad and 0.33 N m of fast
#: content (spacecraft-mimo-s1, all four hardware cases of issue 25 acceptable;
#: docs/hardware.md). Chosen once on spacecraft-mimo-s1 and -s2 (with the thesis's ``k`` = 5
#: as the slope, before ``C_SLOPE``): 2 met every s1 case but left s2 at 2.5e-3 rad (its
#: target) behind the lag; 4 left s2's noise case at 2.3e-3 rad. An output whose loop gain is
#: above ``C_RAISE w`` already (the manipulator's, at zero error, 104 and 606 1/s, against
#: ``w`` = 20 behind a 50 ms lag) is unchanged.
C_RAISE = 3.0

#: the robust term's slope of a raised output: ``K_i' = min(K_i, C_SLOPE w)`` (``k_i`` lowered to
#: it where it is above): the raised loop's linear band ``l^2 + G l + G K' = 0`` (``G`` = 3w/4,
#: normalised) then has its natural frequency near ``w`` and a damping of 0.43. Measured on
#: spacecraft-mimo-s1 (error / fast content): behind a 50 ms lag (``w`` = 4.8) 1.3e-3 / 0.33 at
#: 1, 2.2e-3 / 0.20 at 0.6, 3.9e-3 / 0.15 at 1/3; at 10 Hz with a lag, travel and rate limit
#: (``w`` = 2.7) the thesis's ``k`` = 5 (1.9 w) loses the tracking (0.18 rad, 4.3 N m), 1 gives
#: 2.4e-2 / 1.5 and 0.6 5.7e-3 / 0.21; ``w^2`` over the normalised gain (1.33 w) chatters at
#: 10 Hz (3.4 N m).
C_SLOPE = 1.0


#: an output whose loop gain is at or above ``C_RAISE w`` at the operating point (zero tracking
#: error) but below it at the loop's initial state (a local basis: the manipulator's raw fuzzy
#: basis of the errors, 104 and 606 1/s at zero error against 1.8 and 10.7 at ``t0``) gets a
#: **fixed proportional feedback floor** ``u0_i += (C_FLOOR w / b_i) s_i`` beside its law, after
#: the command filter (:meth:`MimoDirectAdaptive.output_floor`): its normalised loop gain is
#: ``w`` only where ``|Pi_i|^2`` is large and falls to ``g(z)`` where the basis fades; once the
#: errors leave the basis (|e| of 1-2 rad) the command ``Pi^T theta`` is 0 and the arm is lost
#: for good. Measured on the manipulator-hardware campaign (issue 25): 309 of the 331
#: constraint-aware failures of session 10 were arms lost within the first 3 s (errors 1-2 rad
#: at 3 s, the command exactly 0 in the final window), behind lags above 20 ms with the rule's
#: ``w`` = 6-10 1/s; with the floor at ``w`` every one of them holds the arm (the floor of
#: adaptive augmentation, Lavretsky & Wise 2013, ch. 10). 1 = the loop rate; ``2 w`` on joint
#: 2 gave the same errors.
C_FLOOR = 1.0

#: the delay budget of a loop with a floor, with rate or travel limits
#: (:attr:`ConstraintAware.floor_delay`): ``w (lag + T + tau_d) <= C_FLOOR_DELAY`` (a whole
#: sample: hold and the law's sample) in place of the shared rule's ``C_DELAY_LIMITED`` with the
#: command filter's lag counted, which gave ``w`` = 6-10 1/s behind 35-50 ms and left the
#: floored arm at 0.07-0.15 rad of error (target 0.05). The floor is outside the command filter,
#: so the filter's lag is not in its path. Measured on the first 39 failing members of the
#: campaign with the loop rate forced to this budget: 0.7: 29 of 39, 0.85: 34 (and two limit
#: cycles at 20 Hz behind 41-45 ms); 0.8 kept. Without limits: the shared ``C_DELAY``.
C_FLOOR_DELAY = 0.8

#: the floor enters **before** the command filter (its rate clip, 0.9 x the rate limit, and
#: travel clip apply to it, and the compensated error sees what they hold back) where the
#: filter is not capped by the actuator's lag (``omega_f < 1/lag``: a fast filter, or one at
#: ``1/T`` that a digital law steps through), else after it (behind a slow filter the floor
#: would add the filter's lag to the actuator's, and the actuator's own lag smooths the noise
#: the floor carries). Measured on the campaign: after the filter everywhere, 11 members with
#: lags of 0.1-11 ms spent 6-43 % of the final window at a rate limit (the floor's share of the
#: measurement noise, stepping a lag-free actuator at its limit); before it where the filter
#: is fast: 8 (3 fixed, none lost: 92.8 % -> 93.4 %). ``False``: after it everywhere.
C_FLOOR_INSIDE = True


#: the outputs with a floor (:meth:`MimoDirectAdaptive.output_floor`) also get the healthy
#: model's feedforward along the reference (``Configuration.feedforward``: ``G(x_r) u_ff =
#: y_r'' - f(x_r)`` on the state on the reference, before the command filter), unless the
#: designer's model leaves it out (``ConstraintAware.model_feedforward``). The law's basis is
#: of the errors only, so without it its tracking of the reference is its loop gain there,
#: which the lags bound: 25 of the 32 manipulator-hardware failures of round 6 tracked at
#: 0.05-0.09 rad behind 32-50 ms lags; with it all 25 track (0.001-0.040 rad), none of a
#: control set of 29 succeeding members is lost. The computed-torque feedforward of the
#: desired trajectory beside an adaptive law: Sadegh & Horowitz, Int. J. Robotics Research
#: 9(3), 1990; the adaptive augmentation of a baseline, Lavretsky & Wise 2013, ch. 10. Not on
#: a raised output (no floor): member 139 lost joint 1 with it there.
C_FEEDFORWARD = True
#: ... read ahead by ``C_FEEDFORWARD_LEAD`` times the declared lags (actuator lag, half a
#: sample of hold, the command filter's ``1/omega_f``): 1-2 % less error than without the
#: lead behind 40-47 ms (members 11, 52, 144, 358)
C_FEEDFORWARD_LEAD = 1.0


class MimoGains(NamedTuple):
    """Adaptation gains of (3.37)."""

    eta: float
    sigma: float


@dataclass(frozen=True, kw_only=True)
class MimoDirectAdaptive(AdaptiveController):
    """``u0_i = Pi_i(z_i)^T theta_i`` (3.26), ``u = R^T u0`` (3.14) and (3.37):
    ``theta_i' = eta Pi_i (s_i' + k_i s_i + k0_i tanh(s_i/eps0)) - eta sigma theta_i``.

    ``regressors`` has one regressor per output; a single regressor is shared by all outputs
    (each output still has its own parameters).
    """

    design: ClassVar[str] = "mimo"
    equation: ClassVar[str] = "(3.26)-(3.29), (3.37)"

    regressor: FuzzyBasis | LinearRegressor | tuple
    eta: float = 0.001
    sigma: float = 0.01
    #: constraint-aware only, filled by :meth:`bound` from the loop (not a setting): each
    #: output's loop gain ``b_i eta |Pi_i|^2`` (:meth:`measured_loop_rate`); not compared, so
    #: ``replace(bound_design, constraint_aware=None)`` equals the thesis design
    output_gains: tuple = field(default=(), compare=False, repr=False)
    #: constraint-aware only, filled by :meth:`bound` (not a setting): each output's loop gain
    #: at the loop's initial state and its input gain ``b_i = |d s_i'/d u0_i|``
    #: (:meth:`output_floor`); not compared
    initial_gains: tuple = field(default=(), compare=False, repr=False)
    input_gains_out: tuple = field(default=(), compare=False, repr=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        _positive(type(self).__name__, eta=self.eta)
        if not isinstance(self.output_gains, tuple) or any(
            isinstance(v, bool) or not isinstance(v, (int, float)) or not v >= 0
            for v in self.output_gains
        ):
            raise ConfigurationError(
                "`output_gains` of MimoDirectAdaptive is filled by bound(loop) (a tuple of "
                f"loop gains >= 0, one per output); leave it out. Got {self.output_gains!r}."
            )
        _nonnegative(type(self).__name__, sigma=self.sigma)
        regs = self.regressor if isinstance(self.regressor, tuple) else (self.regressor,)
        if not regs or not all(isinstance(r, (FuzzyBasis, LinearRegressor)) for r in regs):
            raise ConfigurationError(
                "`regressor` of MimoDirectAdaptive must be a regressor or "
                "a tuple of regressors (one per output)."
            )

    @property
    def single_output(self) -> bool:
        return False

    def regressors_for(self, p: int) -> tuple:
        """One regressor per output."""
        regs = self.regressor if isinstance(self.regressor, tuple) else (self.regressor,)
        if len(regs) == 1:
            return regs * p
        if len(regs) != p:
            raise ConfigurationError(
                f"MimoDirectAdaptive has {len(regs)} regressors but the "
                f"plant has {p} outputs; give one per output or one for "
                "all."
            )
        return regs

    def theta_gain(self) -> float:
        return float(self.eta)

    def gains(self) -> MimoGains:
        ca = self.constraint_aware
        if ca is not None and not ca.is_ideal:
            # constraint-aware: the normalised law bounds the loop gain at every state
            # (:meth:`normalization`), so eta keeps the thesis's value
            return MimoGains(float(self.eta), float(self.sigma))
        return MimoGains(float(self.eta) * self.adaptation_scale, float(self.sigma))

    def _output_gains(self, loop, zero_error: bool) -> np.ndarray:
        """``b_i eta |Pi_i|^2`` per output at the loop's initial state, or
        (``zero_error``) with the outputs and their rates on the reference at ``t0``."""
        a = self.thesis_assembled(loop)
        y = np.array(a.y0, dtype=float)
        plant = loop.plant
        if zero_error:
            ref = np.zeros(3 * plant.n_outputs)
            a.module.reference_at(float(loop.t0), a.data.c, ref)
            for i in range(plant.n_outputs):
                y[plant.position_index[i]] = ref[3 * i]
                y[plant.velocity_index[i]] = ref[3 * i + 1]
        phi = a.regressor_values(loop.t0, y)
        G = np.asarray(plant.input_gains(loop.t0, np.asarray(loop.initial_state, float)))
        R = np.atleast_2d(np.asarray(loop.R, dtype=float))
        p = len(a.theta_slices)
        b = np.abs(np.sum(R * G, axis=1)) if G.shape == R.shape else np.ones(p)
        x = abs(float(self.theta_gain()))
        return np.array(
            [float(b[i]) * x * float(np.sum(phi[sl] ** 2)) for i, sl in enumerate(a.theta_slices)]
        )

    def measured_loop_rate(self, loop) -> tuple[float, float, float]:
        """As :meth:`AdaptiveController.measured_loop_rate`, with each output's loop gain
        the larger of its values at the initial state and at zero tracking error (the
        operating point the law is designed for: the manipulator's raw fuzzy basis has
        ``|Pi|^2`` 57x larger there, 605 1/s on joint 2 against 10.7 at ``t0``); the
        smallest gain is the smaller of the two (what ``lam`` must stay below)."""
        g0 = self._output_gains(loop, zero_error=False)
        g1 = self._output_gains(loop, zero_error=True)
        p = len(g0)
        k = as_tuple(self.k, p, "k", type(self).__name__)
        k0 = as_tuple(self.k0, p, "k0", type(self).__name__)
        rate, gain = 0.0, 0.0
        for i in range(p):
            g = max(g0[i], g1[i])
            ri = max(g, math.sqrt(g * (k[i] + k0[i] / float(self.eps0))))
            if ri > rate:
                rate, gain = ri, g
        least = float(np.min(np.minimum(g0, g1)))
        return (float(rate), float(gain), least) if rate > 0 else (self.loop_rate(), 0.0, 0.0)

    def bound(self, loop):
        """:meth:`AdaptiveController.bound`, with each output's loop gain recorded
        (``output_gains``) for the per-output smoothing of :meth:`robust_settings`."""
        out = super().bound(loop)
        if out is self or self.output_gains:
            return out
        ca = out.constraint_aware
        if ca.sample_time > 0 and ca.derivative_lag is None:
            # the digital law's own s' (derivative_filter_tau: the backward difference),
            # integrated by the sample's step it looks ahead to (emit_control), is s at the
            # sample: no lag of the s' estimate in its loop (the shared default: 2 T)
            out = replace(out, constraint_aware=replace(ca, derivative_lag=0.0))
        g0 = self._output_gains(loop, zero_error=False)
        g1 = self._output_gains(loop, zero_error=True)
        out = replace(
            out,
            output_gains=tuple(float(v) for v in np.maximum(g0, g1)),
            initial_gains=tuple(float(v) for v in g0),
            input_gains_out=tuple(float(v) for v in self._input_gains(loop)),
        )
        if out.output_floor() and C_FLOOR_DELAY > 0:
            out = replace(
                out, constraint_aware=replace(out.constraint_aware, floor_delay=C_FLOOR_DELAY)
            )
        return out

    def _input_gains(self, loop) -> np.ndarray:
        """``b_i = |d s_i'/d u0_i|`` per output: the healthy plant's input gains at the
        initial state along the allocation (ones where they cannot be formed)."""
        G = np.asarray(loop.plant.input_gains(loop.t0, np.asarray(loop.initial_state, float)))
        R = np.atleast_2d(np.asarray(loop.R, dtype=float))
        return np.abs(np.sum(R * G, axis=1)) if G.shape == R.shape else np.ones(R.shape[0])

    def robust_settings(self) -> tuple:
        """:meth:`AdaptiveController.robust_settings`, then, constraint-aware, the robust
        term's slope ``K_i' = min(K_i, C_SLOPE w)`` of each raised output
        (:meth:`output_raise`): ``k_i`` lowered to it where it is above, else reached through
        ``k0_i`` at the common ``eps0``. The raised loop's linear band, normalised loop gain
        ``G = 3w/4`` and integral corner ``K_i'``, has the poles of ``l^2 + G l + G K' = 0``:
        a natural frequency near ``w``, damping 0.43. Round 3 gave each output ``w^2 / g_i``
        with the thesis's (slow) ``g_i``: the spacecraft's roll and yaw followed the
        reference 13x better than with the fastest output's slope, but lagged it by 9.3e-3
        rad (the leakage's damping, 0.2, allowed no faster loop). Other outputs: the shared
        rule's."""
        lam, k, k0, eps0 = super().robust_settings()
        raised = self.output_raise()
        if not any(m > 1.0 for m in raised):
            return lam, k, k0, eps0
        p = len(self.output_gains)
        w = self.admitted_rate()
        owner = type(self).__name__
        k_t, k0_t = as_tuple(self.k, p, "k", owner), as_tuple(self.k0, p, "k0", owner)
        k_s, k0_s = as_tuple(k, p, "k", owner), as_tuple(k0, p, "k0", owner)
        ks, out = [], []
        for i in range(p):
            if raised[i] > 1.0:
                target = min(k_t[i] + k0_t[i] / float(self.eps0), C_SLOPE * w)
                ks.append(min(k_s[i], target))
                out.append(max(0.0, (target - ks[-1]) * float(eps0)))
            else:
                ks.append(k_s[i])
                out.append(k0_s[i])
        return lam, tuple(ks), tuple(out), eps0

    def configuration(self, b_max: float = 1.0, input_gain: float = 0.0):
        """:meth:`AdaptiveController.configuration`, then, with a raised output
        (:meth:`output_raise`) whose noise the shared rule's density bound does not admit at
        the raised gain (``max m_i w^2 n_d > C_NOISE_DENSITY``, ``n_d`` the noise density the
        law sees, :attr:`ConstraintAware.noise_density`), the prefilter of the adaptation
        signal ``q`` at ``C_PREFILTER w`` (at most ``C_EULER / T``), whether or not the
        noise's std bound is the one that binds: the raised proportional path carries ``m_i``
        times the thesis loop's noise into the command. Below that density the prefilter's
        lag costs more than it gives: on the first 20 members of the spacecraft-hardware
        campaign (attitude noise <= 1e-4 rad, continuous or 10-50 Hz, lags, travel and rate
        limits), with the prefilter wherever there is noise, 0 successes (median error 5.9e-2
        rad, 16 members above the fast-content target); with this bound, 12 (median error
        1.0e-3 rad, none above it). Not the measurement prefilter: measured on
        spacecraft-mimo-s1 with 1e-3 rad and 1e-2 rad/s of noise (150 s), ``q`` prefiltered:
        1.6e-3 rad, 1.1 N m of fast content (target 1.5); neither: 1.6e-3 rad, 4.4 N m; with
        ``C_RAISE`` = 1, the measurements alone: 2.3e-3 rad, 1.0 N m, both: the loop is lost
        (4.1e-2 rad, 8.6
        N m)."""
        cfg = self.floor_configuration(super().configuration(b_max, input_gain))
        ca = self.constraint_aware
        if ca is None or ca.is_ideal or ca.noise <= 0 or cfg.prefiltered:
            return cfg
        if ca.sample_time > 0:
            # digital: the law looks ahead to the sample's step (emit_control) with the raw
            # q; a prefiltered q would make the step and the look-ahead disagree
            return cfg
        raised = self.output_raise()
        if not any(m > 1.0 for m in raised):
            return cfg
        w = self.admitted_rate()
        if max(raised) * w * w * ca.noise_density <= constraints.C_NOISE_DENSITY:
            return cfg  # the raised path's noise density within the shared rule's bound
        om_q = constraints.C_PREFILTER * w
        if ca.sample_time > 0:
            om_q = min(om_q, constraints.C_EULER / ca.sample_time)
        return cfg._replace(omega_q=om_q)

    def output_floor(self) -> tuple[float, ...]:
        """Constraint-aware only, on a bound design: each output's fixed feedback rate
        (1/s; 0 = none): ``C_FLOOR w`` for an output whose loop gain at the operating point is
        at or above ``C_RAISE w`` (not raised, :meth:`output_raise`) but below it at the loop's
        initial state (``initial_gains``). ``()``: no such output."""
        ca = self.constraint_aware
        if ca is None or ca.is_ideal or not self.initial_gains or C_FLOOR <= 0:
            return ()
        w = self.admitted_rate()
        raised = self.output_raise()
        rates = tuple(
            C_FLOOR * w if m <= 1.0 and g0 < C_RAISE * w else 0.0
            for m, g0 in zip(raised, self.initial_gains, strict=True)
        )
        return rates if any(r > 0 for r in rates) else ()

    def floor_configuration(self, cfg):
        """``cfg`` with the per-output floor feedback of :meth:`output_floor` (gain
        ``rate_i / b_i``), before the command filter where the filter is not capped by the
        actuator's lag (``C_FLOOR_INSIDE``); with the measurement prefilter at
        ``constraints.C_FLOOR_MEASURE w`` where the rule's loop rate is above the noise's std
        bound (:meth:`ConstraintAware.floor_prefiltered_rate`); and with the healthy model's
        feedforward along the reference on the floored outputs (``C_FEEDFORWARD``), the
        reference read ahead by the declared lags."""
        rates = self.output_floor()
        if not rates:
            return cfg
        b = self.input_gains_out
        gains = tuple(r / b[i] if r > 0 and b[i] > 0 else 0.0 for i, r in enumerate(rates))
        ca = self.constraint_aware
        inside = cfg.filtered and not (ca.lag > 0 and cfg.omega_f >= 1.0 / ca.lag)
        cfg = cfg._replace(output_feedback=gains, feedback_filtered=bool(inside and C_FLOOR_INSIDE))
        if (
            ca.noise > 0
            and ca.bandwidth is None  # the rule's rate, not a designer's
            and constraints.C_FLOOR_MEASURE > 0
            and self.admitted_rate() > constraints.C_NOISE / ca.noise
        ):
            # above the noise's std bound (ConstraintAware.omega_max): the law sees its
            # measurements through the prefilter at C_FLOOR_MEASURE w
            om = constraints.C_FLOOR_MEASURE * self.admitted_rate()
            if ca.sample_time > 0:
                om = min(om, constraints.C_EULER / ca.sample_time)
            cfg = cfg._replace(omega_m=om)
        if not C_FEEDFORWARD or not ca.model_feedforward:
            return cfg
        lead = ca.lag + 0.5 * ca.sample_time
        if cfg.filtered:
            lead += 1.0 / cfg.omega_f
        return cfg._replace(feedforward=C_FEEDFORWARD_LEAD * lead)

    def admitted_rate(self) -> float:
        """The loop rate ``w`` the designer's model admits (:meth:`ConstraintAware.omega_max`
        of the measured loop rate); constraint-aware only."""
        ca = self.constraint_aware
        if ca is None:
            raise ConfigurationError(
                "admitted_rate() of MimoDirectAdaptive needs `constraint_aware`; give the "
                "design a ConstraintAware (the designer's model of the hardware)."
            )
        w0 = ca.loop_rate if ca.loop_rate is not None else self.loop_rate()
        w, _ = ca.omega_max(w0, ca.b_max if ca.b_max is not None else 1.0)
        return float(w)

    def output_raise(self) -> tuple[float, ...]:
        """Constraint-aware only, on a bound design (:meth:`bound`): each output's factor
        ``m_i = max(1, C_RAISE w / g_i)`` on its adaptation gain (``C_RAISE``); ``()`` for the
        thesis law, an ideal model or an unbound design."""
        ca = self.constraint_aware
        if ca is None or ca.is_ideal or not self.output_gains:
            return ()
        w = self.admitted_rate()
        return tuple(max(1.0, C_RAISE * w / g) if g > 0 else 1.0 for g in self.output_gains)

    def output_adaptation(self) -> tuple[tuple[float, float], ...]:
        """Constraint-aware only, on a bound design: each output's ``(eta_i, sigma_i)``: the
        thesis's where its loop gain is at the admitted rate, else ``eta_i = m_i eta`` and a
        leakage rate ``eta_i sigma_i = eta sigma w / w0`` (moved down with the loop, as the
        shared rule's scaled ``gamma`` moves it on a SISO loop); ``()`` where no output is
        raised (the law then reads the design's own ``eta`` and ``sigma``)."""
        raised = self.output_raise()
        ca = self.constraint_aware
        if ca is None or not any(m > 1.0 for m in raised):
            return ()
        w0 = ca.loop_rate if ca.loop_rate is not None else self.loop_rate()
        slow = min(1.0, self.admitted_rate() / w0)
        eta, sigma = float(self.eta), float(self.sigma)
        return tuple((eta * m, sigma * slow / m) if m > 1.0 else (eta, sigma) for m in raised)

    def normalization(self, loop) -> tuple[float, ...]:
        """Constraint-aware only: ``c_i`` of the normalised law of each output, ``theta_i' =
        eta_i Pi_i q_i / (1 + c_i |Pi_i|^2)`` with ``c_i = eta_i b_i / w`` (``eta_i`` the
        thesis's gain, or a raised output's, :meth:`output_adaptation`; ``b_i = |d s_i'/d
        u0_i|`` of the healthy plant at its initial state, ``w`` the
        loop rate the hardware admits, :meth:`ConstraintAware.omega_max`): the proportional
        loop gain ``g/(1 + g/w)``, ``g = b_i eta |Pi_i(z)|^2``, stays below ``w`` at every
        state, not only at the initial one (the manipulator's raw fuzzy basis: ``|Pi|^2`` is
        57x larger at zero error than at its initial state), and is unchanged where it is far
        below ``w`` (the normalised gradient law, Ioannou & Sun 1996, §4.3.4 and §8.5).
        ``()``: none (the thesis law, an ideal model). A digital law's ``w`` is at most
        ``C_SAMPLE_NORMALISED / T``."""
        ca = self.constraint_aware
        if ca is None or ca.is_ideal:
            return ()
        ctrl = self.bound(loop)
        ca = ctrl.constraint_aware
        R = np.atleast_2d(np.asarray(loop.R, dtype=float))
        b_max = float(np.abs(R).max()) if R.size else 1.0
        w0 = ca.loop_rate if ca.loop_rate is not None else ctrl.loop_rate()
        w, _ = ca.omega_max(w0, ca.b_max if ca.b_max is not None else b_max)
        G = np.asarray(loop.plant.input_gains(loop.t0, np.asarray(loop.initial_state, float)))
        p = R.shape[0]
        b = np.abs(np.sum(R * G, axis=1)) if G.shape == R.shape else np.ones(p)
        if ca.sample_time > 0:
            w = min(w, C_SAMPLE_NORMALISED / ca.sample_time)
        etas = [e for e, _ in ctrl.output_adaptation()] or [float(self.eta)] * len(b)
        return tuple(float(etas[i] * bi / w) for i, bi in enumerate(b))

    def derivative_filter_tau(self, loop) -> float | None:
        """Constraint-aware, digital: the ``s'`` filter at the sample time, i.e. the backward
        difference ``(s[k] - s[k-1]) / T`` (forward Euler of the dirty derivative with
        ``tau = T`` has its pole at 0), which the law's step integrates back to ``s[k]``: with
        the look-ahead of :meth:`emit_control` its proportional path sees ``s`` at the
        sample, not through the solver's default ``2 T`` filter (one more sample of lag:
        measured on the spacecraft-hardware members at 10 Hz, e.g. member 1, 9.6e-3 rad
        against 3.3e-3). ``None`` (the solver's default) otherwise."""
        ca = self.constraint_aware
        if ca is None or ca.is_ideal or not float(loop.sample_time) > 0:
            return None
        return float(loop.sample_time)

    def sampled_configuration(self, cfg, g):
        """Digital (:meth:`sampled_lookahead`): the command filter hands on its value after
        the sample's step, ``u0 = uf + T uf'`` (``Configuration.step``), not ``uf``: the same
        filter one sample earlier (at ``omega_f T = 1`` its output is the limited command of
        the same sample)."""
        if not self.sampled_lookahead(g) or not cfg.filtered:
            return cfg
        return cfg._replace(step=float(g.loop.sample_time))

    def sampled_lookahead(self, g) -> bool:
        """Constraint-aware, digital (``g.loop.sample_time > 0``, ``s'`` from the dirty-
        derivative filter): the command is computed from the estimates the sample's law
        step gives (:meth:`emit_control`)."""
        ca = self.constraint_aware
        return (
            ca is not None
            and not ca.is_ideal
            and float(g.loop.sample_time) > 0
            and g.sdot == "filtered"
            and bool(self.normalization(g.loop))
        )

    def emit_control(self, g, blocks, extra_at: int) -> list[str]:
        """Constraint-aware, digital (:meth:`sampled_lookahead`): ``u0_i = Pi_i^T (theta_i +
        T theta_i')``, the estimates after the forward-Euler step that the sample computes,
        instead of before it. The sampled law otherwise sees ``s`` one sample late (``theta``
        at sample ``k`` integrates ``q`` up to ``k - 1``) and, through the integrated ``s'``
        of the dirty-derivative filter, a further filter lag; with the step taken first, its
        proportional path sees ``s`` at the sample. ``theta_i'`` here is the law of
        :meth:`emit_adapt` without the compensated error (whose filter needs the command
        itself); its ``s'`` is a copy of the loop's ``s'`` filter (states ``s_lookahead_i``,
        started at ``s(t0)`` like it). Not while the adaptation is frozen."""
        if not self.sampled_lookahead(g):
            return []
        g.use("normaliser", normaliser)  # robust_q: one of the loop's laws already
        g.use("lookahead", lookahead)
        norm = self.normalization(g.loop)
        adaptation = self.bound(g.loop).output_adaptation()
        c0 = len(g.consts)
        g.consts.append(float(g.loop.sample_time))
        g.consts.extend(norm)
        a0 = len(g.consts)
        for eta_i, sigma_i in adaptation:
            g.consts.extend((eta_i, sigma_i))
        p, nx = len(blocks), g.nx
        g.adaptive_names += [f"s_lookahead{i + 1}" for i in range(p)]
        g.y0_extra.extend([0.0] * p)  # assemble starts them at s(t0)
        lines = ["    # constraint-aware, digital: u0 from the estimates after the sample's step"]
        for r, (o, at, size) in enumerate(blocks):
            eta, sigma = "D.gains.eta", "D.gains.sigma"
            if adaptation:
                eta, sigma = f"c[{a0 + 2 * r}]", f"c[{a0 + 2 * r + 1}]"
            s = f"sig[{nx + 2 * p + r}]"
            lines += [
                f"    sd = ({s} - Y[{extra_at + r}]) / c[FTAU]",
                f"    dY[{extra_at + r}] = sd",
                "    if c[ADAPT] != 0.0:",
                f"        u0[{r}] += c[{c0}] * lookahead(phi, Y, robust_q(sd, {s}, c[K + {r}],"
                f" c[K0 + {r}], c[EPS0]), {eta}, {sigma}, normaliser(phi, c[{c0 + 1 + r}],"
                f" {o}, {size}), {o}, {at}, {size})",
            ]
        return lines

    def emit_adapt(self, g, blocks, extra_at: int) -> list[str]:
        g.use("theta_law", theta_law)
        norm = self.normalization(g.loop)
        if not norm:
            return [
                "    # adaptive laws (3.37), one per output",
                f"    misc[{int(Misc.GAIN)}] = 1.0",
                *self.theta_laws(blocks, "D.gains.eta", "D.gains.sigma", "1.0"),
            ]
        g.use("normaliser", normaliser)
        c0 = len(g.consts)
        g.consts.extend(norm)
        adaptation = self.bound(g.loop).output_adaptation()
        a0 = len(g.consts)
        for eta_i, sigma_i in adaptation:
            g.consts.extend((eta_i, sigma_i))
        lines = [
            "    # adaptive laws (3.37), one per output, normalised (constraint-aware)",
            f"    misc[{int(Misc.GAIN)}] = 1.0",
        ]
        for r, (o, at, size) in enumerate(blocks):
            gain = f"normaliser(phi, c[{c0 + r}], {o}, {size})"
            eta, sigma = "D.gains.eta", "D.gains.sigma"
            if adaptation:  # each output's own (raised) gain and leakage
                eta, sigma = f"c[{a0 + 2 * r}]", f"c[{a0 + 2 * r + 1}]"
            lines.append(
                f"    theta_law(dY, Y, phi, q[{r}], {eta}, {sigma}, {gain}, {o}, {at}, {size})"
            )
        return lines


def lookahead(phi, Y, q, gamma, sigma, gain, off, at, size):
    """``Pi^T theta'`` of :func:`~adaptive_ftc.controllers.laws.theta_law` (``theta' = gamma
    g Pi q - gamma sigma theta``): what one step of the law adds to ``u0 = Pi^T theta``
    (:meth:`MimoDirectAdaptive.emit_control`)."""
    acc = 0.0
    for l in range(size):
        acc += phi[off + l] * (gamma * gain * phi[off + l] * q - gamma * sigma * Y[at + l])
    return acc


def normaliser(phi, c, off, size):
    """``1 / (1 + c |Pi|^2)``: the normalisation of the constraint-aware MIMO law
    (:meth:`MimoDirectAdaptive.normalization`)."""
    acc = 0.0
    for l in range(size):
        acc += phi[off + l] * phi[off + l]
    return 1.0 / (1.0 + c * acc)
