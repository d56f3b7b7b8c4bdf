"""Non-adaptive baselines: the nominal inverse and the oracle (issue 14, "fair baselines").

Both are feedback linearisation along the allocation ``u = R^T u0`` (3.14). Per output ``i``
the model gives the output acceleration

    ``y_i'' = f_i(x) + sum_k G_ik(x) u0_k``

(``y_i'' = x'[vel_i]``), and the control ``u0`` solves ``G u0 = v - f`` for the target

    ``v_i = y_di'' + lambda_i e_i' + k_i s_i + k0_i tanh(s_i / eps0)``

with ``e = y_d - y`` and ``s = e' + lambda e`` (2.18). With an exact model the closed loop then
obeys ``s_i' = -k_i s_i - k0_i tanh(s_i / eps0)`` (``q = 0`` in the notation of the adaptive
laws), so ``s_i -> 0`` exponentially and ``e_i' = -lambda_i e_i + s_i``: with ``k0 = 0`` the
error is ``e(t) = e0 exp(-lambda t) + s0 (exp(-k t) - exp(-lambda t)) / (lambda - k)``.
The targets and gains (``lam``, ``k``, ``k0``, ``eps0``) are those of the adaptive designs,
so a baseline built from an adaptive loop aims at the same error dynamics.

:class:`NominalInverse` (design ``"nominal-inverse"``)
    takes ``f`` and ``G`` from the *healthy* plant model: the plant's own ``dynamics`` at
    ``u = 0`` and at ``u = probe R_k`` (row ``k`` of ``R``), ``G_ik = (y_i''(probe R_k) -
    f_i) / probe``. It knows nothing of the failures, which act on the applied outputs as in
    every loop; it is what a designer without fault tolerance would fly.
:class:`OracleInverse` (design ``"oracle"``)
    evaluates the same two model calls through the failure functions of the current interval
    (``failure(instance(ph, j, D), t, x, u_j, D)``; a healthy actuator passes ``u_j``), so ``f``
    includes the stuck/bias outputs and ``G`` the lost effectiveness: exact for the failures
    ``a u + b`` (loss, stuck, bias, affine, reversal, incipient) of plants affine in ``u``. It
    is the best any controller of this form could do and is not a fair competitor: reports
    show it, claims never compare with it.

**The oracle of the law's feedback** (``OracleInverse(law=...)``; issue 25, item 3, session
13). Under hardware the constraint-aware laws are not only adaptation: beside ``Pi^T theta``
they carry a fixed feedback sized for the hardware (:mod:`adaptive_ftc.controllers.constraints`:
the wing rock's PID placed on the linearised plant behind the lag, with its lead; the MIMO
law's floor ``u0_i += (w / b_i) s_i`` and its per-output smoothing), and an inverse that
cancels the whole plant through a 30-50 ms lag (the wing rock's ``-922.7 phi``) loses what
that feedback holds. With ``law`` the oracle keeps the law's configuration whole (command
filter, placed PID and lead, floors, measurement prefilters, its sampled implementation) and
its robust-term smoothing, and its inverse stands where the law's adaptation stands: on an
output with a fixed feedback the target is the designer's linear model along the error,

    ``v_i = y_di'' - a_i e_i - c_i e_i'``

(``y'' = a y + c y' + b u0``: the placed PID's model, :attr:`ConstraintAware.open_loop`;
``a = c = 0`` for the MIMO floor, sized as ``s' = -w s`` on the nominal input gain), so that
the inverse cancels the rest of the true (failed) plant, ``f(x) - a y - c y'``, and supplies
the reference feedforward of that model, while the law's fixed feedback, added where the law
adds it (before or after the command filter), sets the error dynamics it was placed for (with
the healthy input gain: ``e'' = a e + c e' - b u_fb``); the other outputs keep ``v`` above
with the law's smoothing. The law's nominal feedforward along the reference is left out (the
inverse is the exact one) but for its lead: where the law reads it ahead by the declared lags
(the MIMO floors, ``mimo.C_FEEDFORWARD_LEAD``), the oracle adds ``u_ff(t + lead) - u_ff(t)``
(the law's feedforward lines at the lead and at zero), so that the inverse's reference part is
not delivered late behind the lags (without it, the manipulator-hardware oracle's median error
was 3.5e-2 rad on the first 20 members, with it 6.7e-3). Without a fixed feedback (the
hypersonic loops) it is the inverse with the law's smoothing. Measured on the first 100
members of the hardware campaigns (docs/hardware.md, "The oracle with the law's feedback
design"): wing rock 99 % (the inverse alone: 6 %), spacecraft 99 % (0 %), manipulator 78 %
(65 %), hypersonic bit-identical to the inverse alone (99 %).

**The oracle's compensated error** (session 15; :meth:`OracleInverse.compensated_outputs`,
``C_ORACLE_COMPENSATED``). The law's adaptation sees the compensated error ``s - xi``, where
``xi`` is the part of ``s`` that its limited command filter caused (``constraints.hedged_q``;
Farrell et al. 2009, pseudo-control hedging, Johnson & Calise 2003): its robust term, in its
adaptation signal, acts on ``s - xi``. The oracle's robust term stands in the target instead,
and acted on ``s`` (the law's hedge states stop with the adaptation the oracle does not have).
On the manipulator-hardware members whose law raises joint 1 (the robust term) and floors
joint 2, the initial errors (0.5 and 0.75 rad) ask the exact inverse for more than the command
filter's rate limit gives: the command swings between the filter's travel at its rate limit
(about 1 Hz) and the errors stay at 0.2-0.6 rad for good, with or without the failure, the
noise or the actuator's lag (member 24 on ideal hardware with the law's filter: 0.31 rad; the
filter's rate limit removed: 1.7e-3). 88 of the campaign oracle's 90 failures of session 14
were such members (95 members have this configuration). With a limited, hedged command filter
and a floor, the oracle's raised outputs now aim at ``k_i (s_i - xi_i) + k0_i tanh((s_i -
xi_i) / eps0)``, with ``xi = G zeta`` of the oracle's exact (failed) ``G`` and ``zeta_k' = -w_h
zeta_k + (u0c_k - u0r_k)`` per command (``u0c`` into the law's filter, ``u0r = uf + uf'/w_f``
what it delivers, ``w_h`` the law's decay rate): the pseudo-control deficit that the oracle's
own model gives, not the law's one nominal input gain (11.7, joint 2's, where joint 1's is
2.0: with it the oracle lost the arm on members 4 and 12). The ``xi'`` term of the law's
``hedged_q`` is left out (it needs the command itself). That robust term then goes into
``u0_i`` through the output's own input gain, ``u0_i += (k_i (s_i - xi_i) + k0_i tanh((s_i -
xi_i) / eps0)) / G_ii`` (``C_ORACLE_OWN_GAIN``), after the exact inverse of the rest of the
target (``y_d'' + lambda e' - f``): where the law's adaptive command ``Pi_i^T theta_i``
stands, its coupling into the floored joint left to that joint's floor, as the law leaves
it. Decoupled through the whole inverse, the raised joint's noisy target (its robust slope
``w`` on the measured ``s``) was applied through ``(G^-1)_11 G_11 = M11 M22 / det M``, about
4.4 times the torque (on ideal motors, noise only, member 187 at 100 Hz: per-sample steps of
motor 1's command of 0.56 N m, against 0.19-0.24 through ``G_11`` and the law's 0.10-0.11):
20 campaign members that the law holds failed on it (18 on activity, 2 lost the arm). And
the term runs at the law's proportional loop gain on that output, not at its robust slope
(``C_ORACLE_PROPORTIONAL``, :meth:`OracleInverse.proportional_scale`): the law's robust slope
``w`` on a raised output is the integral corner of its adaptation, its proportional gain the
normalised ``m g / (1 + m g / w)`` = ``3w/4``; the oracle, which needs no integral, takes the
proportional one (member 187: per-sample steps 0.13 N m against 0.19). With all three, the
manipulator-hardware oracle succeeds on 492 of 500 members (session 14: 410;
docs/hardware.md, session 15). Every other loop's generated code is unchanged.

Every catalogue plant is affine in ``u``, so ``G`` is exact up to rounding. For a plant (or
failure) that is not, ``G`` is the forward-difference slope at ``u0 = 0`` over ``probe``: the
local linearisation there, not at the current command.

Guard: ``G`` is factorised by Gaussian elimination with partial pivoting; a pivot smaller than
``gmin`` in magnitude is replaced by ``gmin`` with its sign (``+gmin`` for an exact zero), so
that ``|u0|`` stays bounded by ``|v - f| / gmin`` (single output: ``g`` is replaced by
``copysign(gmin, g)`` when ``|g| < gmin``). Neither design has an adaptive state.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

from adaptive_ftc.controllers._solve import solve_guarded
from adaptive_ftc.controllers.base import AdaptiveController, _positive
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.layout import Misc

__all__ = [
    "C_ORACLE_COMPENSATED",
    "C_ORACLE_OWN_GAIN",
    "C_ORACLE_PROPORTIONAL",
    "NominalInverse",
    "OracleInverse",
    "solve_guarded",
]

#: (session 15) the oracle of a law with a MIMO floor and a limited, hedged command filter
#: puts the robust term of its raised outputs on the compensated error ``s - xi``, as the law
#: puts its own (:meth:`OracleInverse.compensated_outputs`; the module docstring). ``False``:
#: the session-13 oracle (the robust term on ``s``).
C_ORACLE_COMPENSATED = True
#: (session 15) ... and adds that robust term to ``u0_i`` through the output's own input gain,
#: ``u0_i += (k_i (s_i - xi_i) + k0_i tanh((s_i - xi_i)/eps0)) / G_ii``, after the exact
#: inverse of the rest of the target, where the law's adaptive command ``Pi_i^T theta_i``
#: stands, instead of decoupling it through the whole inverse (which applied the raised
#: joint's noisy target through ``M11 M22 / det M``, about 4.4 times the torque; the module
#: docstring). ``False``: in the target.
C_ORACLE_OWN_GAIN = True
#: (session 15) ... at the law's *proportional* loop gain on that output, not at its robust
#: slope: the term is scaled by ``min(1, G_i / K_i)``, ``G_i = m_i g_i / (1 + m_i g_i / w)``
#: the law's normalised loop gain at its operating point (``3w/4`` on a raised output,
#: ``mimo.C_RAISE``) and ``K_i = k_i + k0_i / eps0`` its robust slope, which in the law is the
#: integral corner of its adaptation (``mimo.C_SLOPE``), not a proportional gain
#: (:meth:`OracleInverse.proportional_scale`). ``False``: the robust slope.
C_ORACLE_PROPORTIONAL = True
#: the generator's attribute holding the constant slot of the first ``zeta`` state between
#: :meth:`OracleInverse.emit_control` and :meth:`OracleInverse.emit_constraint_aware`
_ZETA_SLOT = "_oracle_zeta_slot"


class NominalGains(NamedTuple):
    """Numbers of the inverse: the pivot floor, the probe step of the model slope and whether
    the model sees the true failures (1.0, the oracle) or healthy actuators (0.0): a number,
    so the nominal inverse and the oracle of a loop share one compiled structure."""

    gmin: float
    probe: float
    oracle: float


@dataclass(frozen=True, kw_only=True)
class NominalInverse(AdaptiveController):
    """Feedback linearisation with the healthy model, no adaptation (module docstring).

    ``u0`` solves ``G u0 = y_d'' + lambda e' + k s + k0 tanh(s/eps0) - f`` with ``f``, ``G``
    from the plant's dynamics along ``u = R^T u0``; the closed loop with an exact model obeys
    ``s' = -k s - k0 tanh(s/eps0)``. Works for any number of outputs.

    Parameters
    ----------
    lam, k, k0, eps0
        As in the adaptive designs: filtered error (2.18) and robust term (2.20).
    gmin
        Smallest pivot magnitude of ``G`` (units of ``y''`` per unit ``u0``); smaller pivots
        are replaced by ``gmin`` with their sign.
    probe
        Step in ``u0`` of the forward difference giving ``G`` (exact for plants affine in
        ``u``; the local slope at ``u0 = 0`` otherwise).
    """

    design: ClassVar[str] = "nominal-inverse"
    equation: ClassVar[str] = "feedback linearisation with the healthy model (baseline)"
    oracle: ClassVar[bool] = False

    gmin: float = 1e-6
    probe: float = 1e-3

    def __post_init__(self) -> None:
        super().__post_init__()
        _positive(type(self).__name__, gmin=self.gmin, probe=self.probe)

    @property
    def single_output(self) -> bool:
        return False

    def regressors(self) -> tuple:
        return ()

    def regressors_for(self, p: int) -> tuple:
        return ()

    def gains(self) -> NominalGains:
        return NominalGains(float(self.gmin), float(self.probe), 1.0 if self.oracle else 0.0)

    def feedback_model(self, g) -> tuple[tuple[float, float] | None, ...]:
        """Per output, the linear model on which a kept fixed feedback sets the error dynamics
        (:meth:`OracleInverse.feedback_model`); ``None``: the target keeps the robust term
        (every output of the nominal inverse)."""
        return (None,) * g.p

    def emit_control(self, g, blocks, extra_at: int) -> list[str]:
        nx, p, m = g.nx, g.p, g.m
        plant = g.loop.plant
        vel = plant.velocity_index
        g.use("nominal_solve", solve_guarded)
        g.n_w = max(g.n_w, p * p + 2 * p)
        f_at = p * p + p  # wb: [G (p*p, row-major) | v (p) | f (p)]
        v_at = p * p
        # the oracle goes through the failure functions of the current interval; the model at
        # zero command (kk = -1) and along each output's allocation row share one call site:
        # numba pastes the plant's equations once per site (spacecraft: rhs compile 2.9 s ->
        # 2.3 s)
        what = "the healthy model, or the failed actuators' true outputs (oracle)"
        lines = [
            f"    misc[{int(Misc.GAIN)}] = 1.0  # the recorded gain: 1 for a design without one",
            f"    # u0 from y'' = f + G u0 along u = R^T u0, with {what} (controllers/nominal.py)",
            f"    xs = sig[0:{nx}]",
            f"    for kk in range(-1, {p}):",
            f"        for j in range({m}):",
            f"            a = 0.0 if kk < 0 else c[RMAT + kk * {m} + j] * D.gains.probe",
            "            k = instance(ph, j, D) if D.gains.oracle != 0.0 else -1",
            "            uf[j] = a if k < 0 else failure(k, t, xs, a, D)",
            "        plant_dynamics(t, xs, uf, plant_params(D), xdot)",
            "        if kk < 0:  # f, the model's y'' at zero command",
            *[f"            wb[{f_at + i}] = xdot[{vel[i]}]" for i in range(p)],
            "        else:  # column kk of G",
            *[
                f"            wb[{i * p} + kk] = (xdot[{vel[i]}] - wb[{f_at + i}]) / D.gains.probe"
                for i in range(p)
            ],
            "    # target y'' = y_d'' + lambda e' + k s + k0 tanh(s/eps0), so that with an exact",
            "    # model s' = -k s - k0 tanh(s/eps0)",
        ]
        models = self.feedback_model(g)
        lines += self.compensation_lines(g)
        for i in range(p):
            e, ed, s = f"sig[{nx + i}]", f"sig[{nx + p + i}]", f"sig[{nx + 2 * p + i}]"
            if models[i] is not None:
                # the oracle of a law with a placed feedback (OracleInverse.law): the target is
                # the designer's linear model along the error, y'' = y_d'' - a e - c e', so that
                # the law's fixed feedback (added after the command filter) sets the error
                # dynamics it was placed for; the inverse cancels the rest of the true plant
                g.consts.extend(models[i])
                a, cc = f"c[{len(g.consts) - 2}]", f"c[{len(g.consts) - 1}]"
                lines.append(
                    f"    wb[{v_at + i}] = (ref[{3 * i + 2}] - {a} * {e} - {cc} * {ed})"
                    f" - wb[{f_at + i}]"
                )
                continue
            lines.append(
                f"    wb[{v_at + i}] = (ref[{3 * i + 2}] + c[LAM + {i}] * {ed} + "
                f"{self.target_robust_term(g, i, s)}) - wb[{f_at + i}]"
            )
        lines.append(f"    nominal_solve(wb, 0, {p}, D.gains.gmin, u0)")
        return lines + self.after_solve_lines(g)

    def target_robust_term(self, g, i: int, s: str) -> str:
        """The robust term of output ``i``'s target, ``k s + k0 tanh(s/eps0)``
        (:meth:`OracleInverse.target_robust_term`)."""
        return f"c[K + {i}] * {s} + c[K0 + {i}] * math.tanh({s} / c[EPS0])"

    def after_solve_lines(self, g) -> list[str]:
        """Lines after ``u0`` is solved: none here (:meth:`OracleInverse.after_solve_lines`)."""
        return []

    def compensation_lines(self, g) -> list[str]:
        """Lines run once ``G`` is formed (``wb[0:p*p]``, row-major), before the targets:
        none here (:meth:`OracleInverse.compensation_lines`)."""
        return []

    def emit_adapt(self, g, blocks, extra_at: int) -> list[str]:
        return []


@dataclass(frozen=True, kw_only=True)
class OracleInverse(NominalInverse):
    """:class:`NominalInverse` that knows the true failure of the current interval: the model
    calls go through the loop's failure functions, so ``f`` and ``G`` include the failed
    actuators' outputs (exact for ``a u + b`` failures of a plant affine in ``u``). A bound on
    what a controller of this form can achieve, not a fair competitor.

    ``law``: the constraint-aware design (bound to its loop, :meth:`AdaptiveController.bound`)
    whose **own feedback design** the oracle keeps (issue 25, item 3; the module docstring,
    "The oracle of the law's feedback"; what the campaigns' ``oracle`` runs): its
    configuration whole (command filter, placed PID and lead, per-output floors, measurement
    prefilters, as ``constraints.emit`` generates them for the law; not its nominal
    feedforward, which the exact inverse replaces), its smoothing of the robust term
    (:meth:`~AdaptiveController.robust_settings`, per output on the MIMO law) and its sampled
    implementation; the exact inverse of the known (failed) plant stands where the law's
    adaptive term ``Pi^T theta`` stands. ``None`` (default): the inverse alone, with the
    filters of its own ``constraint_aware`` model."""

    design: ClassVar[str] = "oracle"
    equation: ClassVar[str] = "feedback linearisation knowing the true failure (oracle baseline)"
    oracle: ClassVar[bool] = True

    law: AdaptiveController | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        law = self.law
        if law is None:
            return
        if (
            not isinstance(law, AdaptiveController)
            or isinstance(law, NominalInverse)
            or law.constraint_aware is None
        ):
            raise ConfigurationError(
                "`law` of OracleInverse must be an adaptive design with its constraint-aware "
                "option (the law whose feedback design the oracle keeps, bound to its loop: "
                f"design.bound(loop)); got {law!r}. Leave `law` out for the plain inverse."
            )

    @property
    def keeps_fixed_feedback(self) -> bool:
        return self.law is not None

    def configuration(self, b_max: float = 1.0, input_gain: float = 0.0):
        if self.law is None:
            return super().configuration(b_max, input_gain)
        return self.law.configuration(b_max, input_gain)

    def compiled_configuration(self, g):
        """The law's configuration (:attr:`law`) without its nominal feedforward, which the
        inverse replaces by the exact one (it knows the plant); the plain oracle's own
        otherwise (:meth:`AdaptiveController.compiled_configuration`)."""
        cfg = super().compiled_configuration(g)
        if self.law is not None and cfg.feedforward >= 0:
            cfg = cfg._replace(feedforward=-1.0)
        return cfg

    def robust_settings(self) -> tuple:
        if self.law is None:
            return super().robust_settings()
        return self.law.robust_settings()

    def sampled_configuration(self, cfg, g):
        if self.law is None:
            return super().sampled_configuration(cfg, g)
        return self.law.sampled_configuration(cfg, g)

    def derivative_filter_tau(self, loop) -> float | None:
        if self.law is None:
            return super().derivative_filter_tau(loop)
        return self.law.derivative_filter_tau(loop)

    def bound(self, loop):
        if self.law is None:
            return super().bound(loop)
        return self  # the law is bound already (its model completed from its own loop)

    def emit_control(self, g, blocks, extra_at: int) -> list[str]:
        """:meth:`NominalInverse.emit_control`, then, with a :attr:`law` whose nominal
        feedforward is read ahead by the declared lags (``Configuration.feedforward``, the
        MIMO law's floored outputs), the same lead on the inverse's reference part: ``u0 +=
        u_ff(t + lead) - u_ff(t)`` (the law's feedforward lines, ``constraints.emit``, at the
        lead and at zero), so that the cancellation of the reference's feedforward is not
        delivered late behind the lags, as the law's is not."""
        lines = super().emit_control(g, blocks, extra_at)
        if self.law is None:
            return lines
        cfg = AdaptiveController.compiled_configuration(self, g)
        if cfg.feedforward < 0:
            return lines
        from adaptive_ftc.controllers.constraints import _feedforward_lines

        lines += ["    # the oracle's lead correction of the reference feedforward"]
        lines += _feedforward_lines(cfg, g)
        return lines + _feedforward_lines(cfg._replace(feedforward=0.0), g, sign=-1.0)

    def feedback_model(self, g) -> tuple[tuple[float, float] | None, ...]:
        """Per output, the designer's linear model ``y'' = a y + c y' + b u0`` on which the
        law's fixed feedback sets the error dynamics, as ``(a, c)``, or ``None`` for an output
        without one (its target keeps the law's robust term): the placed PID of a
        single-output law (``Configuration.feedback``, ``feedback_e``, ``feedback_i``; the
        model's ``open_loop`` rows, zeros where it has none) and the MIMO law's floor
        (``Configuration.output_feedback``: ``(0, 0)``, the loop ``s' = -w s`` it was sized
        for on the nominal input gain). All ``None`` without :attr:`law`."""
        p = g.p
        if self.law is None:
            return super().feedback_model(g)
        cfg = self.compiled_configuration(g)
        if cfg.feedback or cfg.feedback_e or cfg.feedback_i:
            model = self.law.constraint_aware
            rows = model.open_loop if model is not None else None
            a, c = (float(rows[0]), float(rows[1])) if rows is not None else (0.0, 0.0)
            return ((a, c),) * p
        floor = tuple(cfg.output_feedback) or (0.0,) * p
        return tuple((0.0, 0.0) if f > 0 else None for f in floor)

    def compensated_outputs(self, g) -> tuple[int, ...]:
        """The outputs whose robust term acts on the **compensated error** ``s_i - xi_i``
        (session 15; the module docstring, "The oracle's compensated error"): with a
        :attr:`law` whose command filter is limited and hedged (``Configuration.hedge``) and
        that has a MIMO floor (``output_feedback``), every output whose target keeps the
        robust term (:meth:`feedback_model` ``None``: the raised outputs beside the floored
        ones). ``()`` otherwise (no change to the generated loop)."""
        if self.law is None or not C_ORACLE_COMPENSATED:
            return ()
        cfg = self.compiled_configuration(g)
        if not (cfg.filtered and cfg.hedge > 0 and any(f > 0 for f in cfg.output_feedback)):
            return ()
        models = self.feedback_model(g)
        return tuple(i for i in range(g.p) if models[i] is None)

    def compensation_lines(self, g) -> list[str]:
        """With :meth:`compensated_outputs`: ``xi_i = sum_k G_ik zeta_k`` of the oracle's
        exact (failed) ``G`` and the states ``zeta`` (:meth:`emit_constraint_aware`), whose
        first index is a constant that :meth:`emit_constraint_aware` fills in once the
        constraint-aware states are placed."""
        outs = self.compensated_outputs(g)
        if not outs:
            return []
        p = g.p
        slot = len(g.consts)
        g.consts.append(-1.0)  # the first zeta state, set by emit_constraint_aware
        setattr(g, _ZETA_SLOT, slot)
        z = f"int(c[{slot}])"
        lines = ["    # the oracle's compensated error xi = G zeta (zeta: the held-back command)"]
        for i in outs:
            terms = " + ".join(f"wb[{i * p + k}] * Y[{z} + {k}]" for k in range(p))
            lines.append(f"    xih{i} = {terms}")
            if C_ORACLE_OWN_GAIN:
                gii = f"wb[{i * p + i}]"
                lines.append(f"    gii{i} = {gii} if abs({gii}) > D.gains.gmin else D.gains.gmin")
        return lines

    def target_robust_term(self, g, i: int, s: str) -> str:
        """The robust term of a compensated output acts on ``s_i - xi_i``
        (``C_ORACLE_COMPENSATED``), and leaves the target for ``u0_i`` (``C_ORACLE_OWN_GAIN``,
        :meth:`after_solve_lines`); the others' as :class:`NominalInverse`'s."""
        if i not in self.compensated_outputs(g):
            return super().target_robust_term(g, i, s)
        if C_ORACLE_OWN_GAIN:
            return "0.0"  # in u0_i after the solve (after_solve_lines)
        return super().target_robust_term(g, i, f"({s} - xih{i})")

    def after_solve_lines(self, g) -> list[str]:
        """``u0_i += (k_i (s_i - xi_i) + k0_i tanh((s_i - xi_i)/eps0)) / G_ii`` per
        compensated output (``C_ORACLE_OWN_GAIN``; ``G_ii`` of the oracle's exact ``G``, kept
        before the solve, at least ``gmin``)."""
        outs = self.compensated_outputs(g)
        if not outs or not C_ORACLE_OWN_GAIN:
            return []
        nx, p = g.nx, g.p
        scale = self.proportional_scale(p)
        lines = []
        for i in outs:
            sc = f"(sig[{nx + 2 * p + i}] - xih{i})"
            term = super().target_robust_term(g, i, sc)
            if scale[i] != 1.0:
                g.consts.append(float(scale[i]))
                term = f"c[{len(g.consts) - 1}] * ({term})"
            lines.append(f"    u0[{i}] += ({term}) / gii{i}")
        return lines

    def proportional_scale(self, p: int) -> tuple[float, ...]:
        """Per output, ``min(1, G_i / K_i)`` (``C_ORACLE_PROPORTIONAL``): the law's normalised
        loop gain at its operating point, ``G_i = m_i g_i / (1 + m_i g_i / w)`` (its loop gain
        ``g_i`` at zero error, raised by ``m_i``, :meth:`MimoDirectAdaptive.output_raise`),
        over its robust slope ``K_i = k_i + k0_i / eps0`` (its integral corner); ``p`` ones where
        the law has no such gains (not a bound MIMO law) or without ``C_ORACLE_PROPORTIONAL``."""
        from adaptive_ftc.controllers.mimo import MimoDirectAdaptive

        law = self.law
        if not isinstance(law, MimoDirectAdaptive) or not C_ORACLE_PROPORTIONAL:
            return (1.0,) * p
        gains = tuple(law.output_gains)
        if len(gains) != p:
            return (1.0,) * p
        raised = law.output_raise() or (1.0,) * p
        w = law.admitted_rate()
        _, k, k0, eps0 = law.robust_settings()
        k = k if isinstance(k, tuple) else (k,) * p
        k0 = k0 if isinstance(k0, tuple) else (k0,) * p
        out = []
        for i in range(p):
            mg = raised[i] * gains[i]
            slope = float(k[i]) + float(k0[i]) / float(eps0)
            proportional = mg / (1.0 + mg / w) if w > 0 else 0.0
            out.append(min(1.0, proportional / slope) if slope > 0 and proportional > 0 else 1.0)
        return tuple(out)

    def emit_constraint_aware(self, g, blocks, at: int):
        """The law's constraint-aware lines (:meth:`AdaptiveController.emit_constraint_aware`),
        then, with :meth:`compensated_outputs`, the states ``zeta`` (one per output, after the
        law's; they run while the oracle's adaptation, which it does not have, is "frozen")
        with ``zeta_k' = -w_h zeta_k + (u0c_k - u0r_k)``: ``u0c`` the command into the law's
        filter, ``u0r = uf + uf' / w_f`` what the filter delivers (the law's own hedge, with
        its decay rate ``w_h``, ``Configuration.omega_h``)."""
        n0 = len(g.y0_extra)
        control, pre, post, measure = super().emit_constraint_aware(g, blocks, at)
        slot = getattr(g, _ZETA_SLOT, None)
        if slot is None:
            return control, pre, post, measure
        filters: dict[int, int] = {}
        for ln in control:
            hit = re.match(r"\s*dY\[(\d+)\] = command_filter\(uc(\d+),", ln)
            if hit:
                filters[int(hit.group(2))] = int(hit.group(1))
        p = g.p
        if sorted(filters) != list(range(p)):  # pragma: no cover - emit's own lines changed
            raise ConfigurationError(
                "OracleInverse: the compensated error needs the law's command filter per "
                f"output (constraints.emit); found {sorted(filters)} of {p} outputs. Build the "
                "oracle without `law` (baselines.oracle(loop)) meanwhile."
            )
        z0 = at + len(g.y0_extra) - n0
        g.consts[slot] = float(z0)
        g.adaptive_names += [f"oracle_hedge{k + 1}" for k in range(p)]
        g.y0_extra.extend([0.0] * p)
        g.free_running += p
        cfg = self.sampled_configuration(self.compiled_configuration(g), g)
        c0 = len(g.consts)
        g.consts.extend([float(cfg.omega_f), float(cfg.omega_h)])
        wf, wh = f"c[{c0}]", f"c[{c0 + 1}]"
        control = [
            *control,
            "    # the oracle's compensated error: zeta' = -w_h zeta + u0c - the filter's u0",
            *[
                f"    dY[{z0 + k}] = -{wh} * Y[{z0 + k}] + (uc{k} - (Y[{f}] + dY[{f}] / {wf}))"
                for k, f in sorted(filters.items())
            ],
        ]
        return control, pre, post, measure

    def code_label(self) -> str:
        return NominalInverse.code_label(NominalInverse())  # the same code, other numbers
