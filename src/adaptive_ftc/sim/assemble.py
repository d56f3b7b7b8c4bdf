"""Turn a :class:`ClosedLoop` into the flat arrays the compiled kernel runs on."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers import (
    FailureEstimation,
    MimoDirectAdaptive,
    NussbaumAdaptive,
    SignEstimation,
)
from adaptive_ftc.errors import ConfigurationError, did_you_mean
from adaptive_ftc.scenarios.expressions import OP, Expression
from adaptive_ftc.sim import kernel as K
from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["Assembled", "assemble"]


@dataclass(frozen=True)
class Assembled:
    """A closed loop compiled for the kernel, with the names of its state entries."""

    model: tuple
    y0: np.ndarray
    breakpoints: tuple[float, ...]
    adaptive_names: tuple[str, ...]
    theta_slices: tuple[slice, ...]
    n_x: int


class _Programs:
    def __init__(self) -> None:
        self.ops: list[int] = []
        self.vals: list[float] = []
        self.start: list[int] = [0]

    def add(self, expr: Expression, slots: dict) -> int:
        ops, vals = expr.program(slots)
        self.ops += ops
        self.vals += vals
        self.start.append(len(self.ops))
        return len(self.start) - 2


def _slots(loop: ClosedLoop) -> dict[str, tuple[int, float]]:
    slots = {"t": (OP["t"], 0.0), "u": (OP["u"], 0.0)}
    for name, idx in loop.plant.aliases().items():
        slots[name] = (OP["x"], float(idx))
    return slots


def _resolve_inputs(reg, names: dict[str, int], where: str) -> list[int]:
    out = []
    for name in reg.inputs:
        if name not in names:
            raise ConfigurationError(
                f"Unknown regressor input '{name}' in {where}.{did_you_mean(name, names)} "
                f"Available signals: {', '.join(names)}."
            )
        out.append(names[name])
    return out


def assemble(
    loop: ClosedLoop, *, sdot: str = "exact", filter_tau: float = 0.01, bound: float = 1e8
) -> Assembled:
    """Compile ``loop`` into the kernel's model tuple and initial closed-loop state."""
    plant, ctrl = loop.plant, loop.controller
    n, m, p = plant.n_states, plant.n_actuators, plant.n_outputs
    progs = _Programs()
    slots = _slots(loop)
    variables = tuple(slots)
    # references and their symbolic derivatives
    ref = np.zeros((p, 3), dtype=np.int64)
    for i, r in enumerate(loop.reference):
        e = Expression(r, ("t",), context=f"reference of output '{plant.output_names[i]}'")
        for d in range(3):
            ref[i, d] = progs.add(e, slots)
            e = e.derivative("t")
    # failure programs per interval of fixed pattern
    bps = loop.failures.breakpoints(loop.t0, loop.t_final)
    nph = len(bps) - 1
    phase = -np.ones((nph, m), dtype=np.int64)
    dphase = -np.ones((nph, m), dtype=np.int64)
    cache: dict[int, tuple[int, int]] = {}
    for k in range(nph):
        mid = 0.5 * (bps[k] + bps[k + 1])
        for j, f in enumerate(loop.failures.active(mid)):
            if f is None:
                continue
            if id(f) not in cache:
                ctx = f"{type(f).__name__} on actuator {f.actuator} (onset {f.onset:g} s)"
                e = f.expression(variables, context=ctx)
                cache[id(f)] = (progs.add(e, slots), progs.add(e.derivative("u"), slots))
            phase[k, j], dphase[k, j] = cache[id(f)]
    # regressors
    names = loop.signal_names()
    regs = ctrl.regressors_for(p) if isinstance(ctrl, MimoDirectAdaptive) else ctrl.regressors()
    nreg = len(regs)
    maxin = max(len(r.inputs) for r in regs)
    maxmf = max(
        [max(len(c) for c in r.centers) for r in regs if isinstance(r, FuzzyBasis)], default=1
    )
    rkind = np.zeros(nreg, dtype=np.int64)
    rin = np.zeros((nreg, max(maxin, 1)), dtype=np.int64)
    rnin = np.zeros(nreg, dtype=np.int64)
    rnmf = np.ones((nreg, max(maxin, 1)), dtype=np.int64)
    rc = np.zeros((nreg, max(maxin, 1), maxmf))
    ra = np.zeros((nreg, max(maxin, 1), maxmf))
    rsize = np.zeros(nreg, dtype=np.int64)
    roff = np.zeros(nreg, dtype=np.int64)
    off = 0
    theta_slices = []
    for r, reg in enumerate(regs):
        idx = _resolve_inputs(reg, names, f"the regressor of design '{ctrl.design}'")
        rnin[r] = len(idx)
        rin[r, : len(idx)] = idx
        if isinstance(reg, LinearRegressor):
            rkind[r] = K.REG_LINEAR_BIAS if reg.bias else K.REG_LINEAR
        else:
            rkind[r] = K.REG_FUZZY_NORMALISED if reg.normalised else K.REG_FUZZY_RAW
            for i, c in enumerate(reg.centers):
                rnmf[r, i] = len(c)
                rc[r, i, : len(c)] = c
                ra[r, i, : len(c)] = 1.0 / (2.0 * reg.width**2)
        rsize[r] = reg.size
        roff[r] = off
        theta_slices.append(slice(off, off + reg.size))
        off += reg.size
    ntheta = off
    if nreg != (p if isinstance(ctrl, MimoDirectAdaptive) else 1):  # pragma: no cover
        raise ConfigurationError("internal: regressor count does not match the design")
    # adaptive state layout: theta, then design extras, then sdot filter states
    anames = []
    if nreg == 1:
        anames += [f"theta_{l + 1}" for l in range(ntheta)]
    else:
        for r, reg in enumerate(regs):
            anames += [f"theta{r + 1}_{l + 1}" for l in range(reg.size)]
    y0_extra: list[float] = []
    ints = np.zeros(K.N_INTS, dtype=np.int64)
    flts = np.zeros(K.N_FLTS)
    bprog = -np.ones((m, 1), dtype=np.int64)
    bn = np.zeros(m, dtype=np.int64)
    boff = np.zeros(m, dtype=np.int64)
    cursor = n + ntheta
    gamma2 = sigma2 = 0.0
    if isinstance(ctrl, FailureEstimation):
        basis = ctrl.basis_for(m)
        bprog = -np.ones((m, max(len(b) for b in basis)), dtype=np.int64)
        for j, bj in enumerate(basis):
            bn[j] = len(bj)
            boff[j] = cursor
            for l, text in enumerate(bj):
                e = Expression(text, ("t",), context=f"basis function {l + 1} of actuator {j + 1}")
                bprog[j, l] = progs.add(e, slots)
                anames.append(f"kappa{j + 1}_{l + 1}")
                y0_extra.append(ctrl.kappa0)
            cursor += len(bj)
        gamma, sigma, gamma2, sigma2 = ctrl.eta1, ctrl.sigma, ctrl.eta2, ctrl.sigma
    elif isinstance(ctrl, NussbaumAdaptive):
        ints[K.I_TAU] = cursor
        ints[K.I_NUSS] = progs.add(ctrl.nussbaum_expression(), {"tau": (OP["t"], 0.0)})
        anames.append("tau")
        y0_extra.append(ctrl.tau0)
        cursor += 1
        gamma, sigma, gamma2 = ctrl.alpha0, ctrl.sigma, ctrl.alpha1
    elif isinstance(ctrl, SignEstimation):
        ints[K.I_RHO] = cursor
        anames.append("rho")
        y0_extra.append(ctrl.rho0)
        cursor += 1
        gamma, sigma, gamma2, sigma2 = ctrl.alpha0, ctrl.sigma0, ctrl.alpha1, ctrl.sigma1
    elif isinstance(ctrl, MimoDirectAdaptive):
        gamma, sigma = ctrl.eta, ctrl.sigma
    else:
        gamma, sigma = ctrl.gamma, ctrl.sigma  # type: ignore[attr-defined]
    if sdot not in ("exact", "filtered"):
        raise ConfigurationError(f"`sdot` must be 'exact' or 'filtered'; got {sdot!r}.")
    ints[K.I_FILT] = cursor
    if sdot == "filtered":
        if not filter_tau > 0:
            raise ConfigurationError(f"`filter_tau` must be positive; got {filter_tau}.")
        anames += [f"s_filter{i + 1}" for i in range(p)]
        cursor += p
    ny = cursor
    lam = np.array(_per_output(ctrl.lam, p, "lam"))
    k = np.array(_per_output(ctrl.k, p, "k"))
    k0 = np.array(_per_output(ctrl.k0, p, "k0"))
    ints[K.I_PLANT] = plant.kind
    ints[K.I_NX] = n
    ints[K.I_M] = m
    ints[K.I_P] = p
    ints[K.I_CTRL] = ctrl.kind
    ints[K.I_NTHETA] = ntheta
    ints[K.I_NY] = ny
    ints[K.I_SDOT] = 0 if sdot == "exact" else 1
    ints[K.I_ADAPT] = 1 if loop.adapt else 0
    ints[K.I_NSIG] = n + 3 * p
    ints[K.I_NREG] = nreg
    flts[K.X_EPS0] = ctrl.eps0
    flts[K.X_GAMMA] = gamma
    flts[K.X_SIGMA] = sigma
    flts[K.X_GAMMA2] = gamma2
    flts[K.X_SIGMA2] = sigma2
    flts[K.X_FTAU] = filter_tau
    flts[K.X_BOUND] = bound
    model = (
        ints,
        flts,
        np.ascontiguousarray(plant.parameter_vector(), dtype=float),
        np.array(plant.position_index, dtype=np.int64),
        np.array(plant.velocity_index, dtype=np.int64),
        np.ascontiguousarray(loop.R),
        np.array(progs.ops, dtype=np.int64),
        np.array(progs.vals, dtype=float),
        np.array(progs.start, dtype=np.int64),
        ref,
        phase,
        dphase,
        rkind,
        rin,
        rnin,
        rnmf,
        rc,
        ra,
        rsize,
        roff,
        lam,
        k,
        k0,
        bprog,
        bn,
        boff,
    )
    y0 = np.zeros(ny)
    y0[:n] = loop.initial_state
    y0[n : n + ntheta] = ctrl.theta0
    y0[n + ntheta : n + ntheta + len(y0_extra)] = y0_extra
    if sdot == "filtered":  # start the filter at s(0) so the estimated sdot starts at 0
        stack = np.zeros(64)
        x0 = y0[:n]
        for i in range(p):
            ps = model[K.F_PSTART]
            vals = [
                K.eval_program(
                    model[K.F_OPS],
                    model[K.F_VALS],
                    ps[ref[i, d]],
                    ps[ref[i, d] + 1],
                    loop.t0,
                    x0,
                    0.0,
                    stack,
                )
                for d in range(2)
            ]
            e = vals[0] - x0[plant.position_index[i]]
            ed = vals[1] - x0[plant.velocity_index[i]]
            y0[ints[K.I_FILT] + i] = ed + lam[i] * e
    return Assembled(model, y0, bps, tuple(anames), tuple(theta_slices), n)


def _per_output(value, p: int, name: str) -> tuple[float, ...]:
    if isinstance(value, (int, float)):
        return (float(value),) * p
    vals = tuple(float(v) for v in value)
    if len(vals) == 1:
        return vals * p
    if len(vals) != p:
        raise ConfigurationError(f"`{name}` needs one value per output ({p}); got {len(vals)}.")
    return vals
