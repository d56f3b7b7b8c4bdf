"""The lane engine (issue 29, stage 1): ``W`` members of one loop structure per compiled call.

A campaign runs many members of one closed loop that differ only in numbers (failures and their
times, gains, initial states). Here ``W = 8`` of them advance together in one generated, compiled
kernel written in struct-of-arrays form: every quantity is a *row* of ``W`` lanes and every
statement a loop over the lanes, all rows in ONE buffer ``B[row * W + w]`` at constant offsets,
so that LLVM's SLP vectoriser turns the right-hand side into vector instructions across members
(``benchmarks/lanes_prototype.py`` measured the form; docs/performance.md, "Lane engine").

What a lane computes is its member's own single run, bit for bit: the same fixed-step RK4
(:func:`~adaptive_ftc.sim.engine.simulate` with ``method="rk4"``), on the member's own break
times and step sizes (lanes advance in lockstep of *step count*, each on its own step; a lane
that has finished idles with a zero step until its group is done), or the same DOPRI5
(``method="dopri5"``, stage 2, ``templates/lanes_dopri5.py``: lanes advance in lockstep of
step *attempts*, each with its own step size, error control, accept or reject, break times
and dense-output records; a group runs a queue of members, a lane whose member ends taking
the next one: lane refill), the same operations in the same order, libm's ``exp``, ``tanh``,
``sin``, ``cos`` (scalar calls per lane, under strict IEEE arithmetic), its own records,
divergence check and status (a diverging lane stops at its own record; the others go on).

Eligible loops (:func:`ineligible` says why a loop is not): fixed-step RK4 or DOPRI5 with the
exact ``s'``; the built-in hypersonic plant (2.50) and plants written as equations (the plants with
a lane form of their dynamics, :data:`LANE_PLANTS`); the direct design (2.22), (2.29) without
the constraint-aware option; one fuzzy basis (raw or normalised, any grid) or linear
regressor; ideal actuators (no actuator table), no sensors, a continuous controller, the fixed
allocation ``u = R^T u0``; and failures that are affine in ``u`` (loss of effectiveness,
bias, stuck at a number, affine, reversal; abrupt or incipient), each member with its own
onsets and recoveries. Everything else runs as today, one member at a time.

One module per (structure, ``W``), generated from the loop's own module (the reference's text,
the places of the numbers in ``D.c``) and cached on disk like the loop modules. Every number is
read from each member's :class:`~adaptive_ftc.sim.compose.LoopData` into the lane's rows, so
members may differ in any number of the loop. The kernel compiles with LLVM's SLP vectoriser
switched on for its own compilation only (:func:`at_lane_level`; numba leaves it off by default).

With ``lean=True`` (stage 3: a campaign's ``lean_signals``), :func:`integrate_lanes` also runs
the lanes' own signals' pass over the records (the module's ``commands`` and ``lean_pass``: the
tracking error, commands and applied commands of every record of every lane, bit for bit each
member's lean single run's), so the records are not gone over one member at a time.

``lanes="auto"``, the default of ``iter_simulate``, ``simulate_many`` and campaigns, runs
members here where it pays (:func:`auto_uses_lanes`: the lane module compiled already, or
enough members of the structure to repay compiling it; lane groups full enough,
:data:`AUTO_GROUP_MIN`; RK4 only with records 10 or more steps apart), with the same results.

``kernels="vector"`` (stage 1b, opt-in) swaps libm's ``exp`` and ``tanh`` (and, stage 1c, the
reference's ``sin`` and ``cos``) for the call-free ones of :mod:`adaptive_ftc.sim.lane_kernels`,
which vectorise too; with RK4 it also pastes the rhs into the five stages and allows fused
multiply-adds (``fastmath={"contract"}``, nothing else): faster, compiles about 5x longer, no
longer bit-identical (about 1e-14 of the signal scale from the single run).
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from typing import cast

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim import codegen
from adaptive_ftc.sim.layout import Header

__all__ = [
    "LANE_PLANTS",
    "KERNELS",
    "LANE_WIDTH",
    "at_lane_level",
    "ineligible",
    "ineligible_reason",
    "integrate_lanes",
    "simulate_lanes",
]

#: members per call: one 512-bit register of doubles per row (W = 4 was slower everywhere in
#: the prototype, W = 16 no faster; docs/performance.md)
LANE_WIDTH = 8

#: the plants with a lane form of their dynamics: class name -> emitter of the lane lines
LANE_PLANTS: dict[str, Callable[..., list[str]]] = {}

#: the solver methods with a lane form: fixed-step RK4 (stage 1) and DOPRI5 (stage 2)
METHODS = ("rk4", "dopri5")

_LANE_OPT = 3  # numba's default level: the prototype's measurements
_PLANT_ROWS = 10


# ----------------------------------------------------------------------------- SLP switch
@contextlib.contextmanager
def _lane_level() -> Iterator[None]:
    """numba's SLP vectoriser on (and ``-O3``) while the caller compiles, under numba's
    global compiler lock, so that numba code compiled before, after or in other threads keeps
    numba's settings (numba reads both whenever it builds an LLVM pass pipeline)."""
    from numba.core import config
    from numba.core.compiler_lock import global_compiler_lock

    with global_compiler_lock:  # re-entrant: callees compile inside their caller's compile
        before = (config.SLP_VECTORIZE, config.OPT)  # type: ignore[attr-defined]
        config.SLP_VECTORIZE = 1  # type: ignore[attr-defined]
        if "NUMBA_OPT" not in os.environ:  # the user's explicit level wins
            config.OPT = type(before[1])(_LANE_OPT)  # type: ignore[attr-defined]
        try:
            yield
        finally:
            config.SLP_VECTORIZE, config.OPT = before  # type: ignore[attr-defined]


def at_lane_level(decorator: Callable) -> Callable:
    """Wrap a numba decorator so that its dispatchers compile (or load from the cache) with
    the SLP vectoriser on (:func:`_lane_level`); the lane modules define ``hot`` this way."""
    from adaptive_ftc.sim.optlevel import compiling_within

    return compiling_within(decorator, _lane_level)


# ----------------------------------------------------------------------------- eligibility
def ineligible(loop, solver) -> str | None:
    """Why ``loop`` with ``solver`` cannot run in lanes (``None``: it can, as far as its parts
    tell; the failures' kinds are checked once the loop is assembled, see
    :func:`_ineligible_numbers`)."""
    from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
    from adaptive_ftc.controllers.direct import DirectAdaptive

    if solver is None:  # simulate's default: RK4, dt 1e-3
        from adaptive_ftc.sim.engine import SolverOptions

        solver = SolverOptions()
    if solver.method not in METHODS:
        return (
            "the lane engine runs fixed-step RK4 and DOPRI5 only (method "
            f"{solver.method!r} asked for)"
        )
    if solver.sdot_for(loop) != "exact":
        return "the lane engine computes the exact s' only (sdot 'filtered' asked for)"
    plant = type(loop.plant).__name__
    if plant not in LANE_PLANTS:
        return f"plant {loop.plant.name!r} has no lane form of its dynamics"
    ctrl = loop.controller
    if type(ctrl) is not DirectAdaptive:
        return f"design {ctrl.design!r} has no lane form (the direct design (2.22) has)"
    if ctrl.constraint_aware is not None:
        return "the constraint-aware option has no lane form"
    if type(ctrl.regressor) not in (FuzzyBasis, LinearRegressor):
        return f"regressor {type(ctrl.regressor).__name__} has no lane form"
    if loop.plant.n_outputs != 1:
        return "the lane engine takes one output"
    if loop.has_actuator_dynamics or loop.actuators is not None:
        return "actuators with dynamics, limits or delays have no lane form"
    if loop.sensors is not None:
        return "sensors (bias, noise) have no lane form"
    if loop.sample_time:
        return "a digital (sampled) controller has no lane form"
    if loop.allocator is not None or loop.annunciations:
        return "only the fixed allocation u = R^T u0 has a lane form"
    return None


def ineligible_reason(loop, solver) -> str | None:
    """:func:`ineligible`, then the failures' kinds of the assembled loop (compiles or loads
    its single-run module)."""
    why = ineligible(loop, solver)
    if why is not None:
        return why
    from adaptive_ftc.sim.engine import CompiledLoop

    return _ineligible_numbers(CompiledLoop.build(loop, solver).asm)


def _ineligible_numbers(asm) -> str | None:
    """Why an assembled loop cannot run in lanes: a failure that is not affine in ``u``."""
    d = asm.data
    used = {int(k) for k in np.ravel(d.fphase) if k >= 0}
    for k in sorted(used):
        if int(d.inst[k, 0]) > 1:
            return "a failure pattern that is not affine in u (a pattern of t, x or u)"
    if int(d.i[Header.PH0]) != 0:
        return "a run that starts in a later interval"
    return None


# ----------------------------------------------------------------------------- generation
def _hypersonic_lines(plant, y: str, consts: Callable[[int], str], m: int) -> list[str]:
    """Lane form of :func:`adaptive_ftc.plants.hypersonic.dynamics` (2.50), the same operations
    in the same order (``consts(k)``: the row of the plant's k-th parameter)."""
    names = ("scale", "k_alpha", "a2", "a1", "a0", "k_q", "q2", "q1", "q0", "k_e")
    return [
        "    for w in range(W):",
        "        usum = 0.0",
        *[f"        usum += B[(UF + {j}) * W + w]" for j in range(m)],
        f"        a = B[{y} * W + w]",
        f"        q = B[({y} + 1) * W + w]",
        *[f"        {n} = B[{consts(k)} * W + w]" for k, n in enumerate(names)],
        "        B[XD * W + w] = q",
        "        B[(XD + 1) * W + w] = scale * (",
        "            k_alpha * (a2 * a * a + a1 * a + a0)",
        "            + k_q * q * (q2 * a * a + q1 * a + q0)",
        "            + k_e * (usum - a)",
        "        )",
    ]


def _expression_lines(plant, y: str, consts: Callable[[int], str], m: int) -> list[str]:
    """Lane form of a plant written as equations (:class:`~adaptive_ftc.plants.custom.
    ExpressionPlant`): its generated assignments ``xdot[i] = ...`` with the states, applied
    outputs and numbers read from the lane's rows (the same text, so the same operations)."""
    lines, _ = plant._layout()
    out = ["    for w in range(W):", "        t = B[tt * W + w]"]
    for ln in lines:
        ln = ln.strip()
        ln = re.sub(r"\bx\[(\d+)\]", lambda mt: f"B[({y} + {mt.group(1)}) * W + w]", ln)
        ln = re.sub(r"\buf\[(\d+)\]", lambda mt: f"B[(UF + {mt.group(1)}) * W + w]", ln)
        ln = re.sub(r"\bc\[(\d+)\]", lambda mt: f"B[{consts(int(mt.group(1)))} * W + w]", ln)
        ln = re.sub(r"^xdot\[(\d+)\] = ", lambda mt: f"B[(XD + {mt.group(1)}) * W + w] = ", ln)
        out.append(f"        {ln}")
    return out


LANE_PLANTS["HypersonicAngleOfAttack"] = _hypersonic_lines
LANE_PLANTS["ExpressionPlant"] = _expression_lines


@dataclass(frozen=True)
class _Plan:
    """A lane module's text and the sizes its caller needs."""

    text: str
    ny: int
    nc: int  # lane rows of constants: D.c[:nc]
    nb: int  # rows of the lane buffer
    rows: dict  # names of rows -> first row (Y, FK, FC, REFT, CR...)
    #: the places in ``D.c`` that the reference reads (None: not all of them constant): lanes
    #: whose numbers there equal lane 0's, bit for bit, share its reference in the lean pass
    ref_consts: tuple[int, ...] | None = None


def _reference_lines(source: str) -> list[str]:
    """The body of the loop module's ``reference(t, c, out)`` (the ``rK = ...`` lines)."""
    m = re.search(r"\ndef reference\(t, c, out\):\n(.*?)\n\n", source, re.S)
    if m is None:  # pragma: no cover - the reference part always writes it
        raise ConfigurationError("The loop module has no reference(); report this as a bug.")
    return [ln.strip() for ln in m.group(1).splitlines() if re.match(r"\s+r\d+ = ", ln)]


def _plan(loop, asm, width: int, kernels: str = "libm", method: str = "rk4") -> _Plan:
    """The lane module of ``loop``'s structure (``asm``: its assembled single-run loop) for
    ``method`` (``"rk4"`` or ``"dopri5"``: the template and its rows)."""
    from adaptive_ftc.approximators import FuzzyBasis

    params = asm.layout.params
    nc = max(s.stop for s in params.values())
    nx, m = asm.n_x, loop.plant.n_actuators
    ny = int(asm.y0.size)
    reg = loop.controller.regressor
    n_phi = int(reg.size)
    if ny != nx + n_phi:  # pragma: no cover - guarded by ineligible()
        raise ConfigurationError("The lane engine expected the states [x, theta] only.")
    pos, vel = loop.plant.position_index[0], loop.plant.velocity_index[0]
    at = {k: s.start for k, s in params.items()}
    # FuzzyBasis keeps one tuple of centres per input (its __post_init__)
    centers = cast("tuple[tuple[float, ...], ...]", getattr(reg, "centers", ()))
    n_mu = sum(len(c) for c in centers) if isinstance(reg, FuzzyBasis) else 0
    sig_index = loop.signal_names()
    rows: dict[str, int] = {}
    nxt = 0

    def claim(name: str, n: int) -> None:
        nonlocal nxt
        rows[name] = nxt
        nxt += max(n, 1)

    claim("CR", nc)
    if method == "rk4":
        for name in ("Y", "K1", "K2", "K3", "K4", "YT", "YN", "FE", "DY"):
            claim(name, ny)
        for name in ("T", "TM", "T1", "HH", "H2", "H6", "TIN", "ACT", "BAD", "REFT", "U0"):
            claim(name, 1)
    else:  # dopri5: the stages k2..k7 (f0 is k1), the error, dense output, tolerances
        for name in ("Y", "YN", "YT", "YS", "F0", "K2", "K3", "K4", "K5", "K6", "K7", "DE"):
            claim(name, ny)
        claim("DY", ny)
        claim("RC", 4 * ny)
        claim("ATOL", ny)
        for name in ("T", "T1", "HH", "TIN", "ACT", "ERR", "RT", "REFT", "U0"):
            claim(name, 1)
    for name in ("TOT", "QQ"):
        claim(name, 1)
    claim("FK", m)
    claim("FC", 5 * m)
    claim("REF", 3)
    claim("SIG", nx + 3)
    claim("MU", n_mu)
    claim("PHI", n_phi)
    claim("XD", nx)
    claim("UF", m)
    claim("UC", m)  # the commands u = R^T u0 (the lean signals' pass, stage 3)
    claim("RSH", 1)  # 1: the lane's reference numbers are lane 0's (the lean signals' pass)
    nb = nxt

    def cr(k: int) -> str:
        return f"(CR + {k})"

    body = [
        "@inl",
        "def rhs(B, tt, y, dy):",
        '    """Closed-loop derivative of the W lanes in rows y.. at their times (row tt) into',
        '    rows dy.. (the single run\'s rhs, statement for statement, per lane)."""',
        "    for w in range(W):  # the reference, per lane whose time moved (as the single run)",
        "        t = B[tt * W + w]",
        "        if B[REFT * W + w] != t:",
    ]
    for ln in _reference_lines(asm.source):
        ln = re.sub(r"\bc\[([^\]]+)\]", lambda mt: f"B[(CR + {mt.group(1)}) * W + w]", ln)
        body.append(f"            {ln}")
    body += [
        "            B[REF * W + w] = r0",
        "            B[(REF + 1) * W + w] = r1",
        "            B[(REF + 2) * W + w] = r2",
        "            B[REFT * W + w] = t",
        "    # tracking errors e = y_d - y and filtered error s (2.18)",
        "    for w in range(W):",
        *[f"        B[(SIG + {i}) * W + w] = B[(y + {i}) * W + w]" for i in range(nx)],
        f"        e = B[REF * W + w] - B[(y + {pos}) * W + w]",
        f"        ed = B[(REF + 1) * W + w] - B[(y + {vel}) * W + w]",
        f"        B[(SIG + {nx}) * W + w] = e",
        f"        B[(SIG + {nx + 1}) * W + w] = ed",
        f"        B[(SIG + {nx + 2}) * W + w] = ed + B[{cr(at['lam'])} * W + w] * e",
    ]
    idx = [sig_index[name] for name in reg.inputs]
    # libm (bit-identical to the single run) or the call-free kernels (stage 1b, ~1e-14)
    exp, tanh = ("math.exp", "math.tanh") if kernels == "libm" else ("vexp", "vtanh")
    if isinstance(reg, FuzzyBasis):
        counts = [len(c) for c in centers]
        body.append(f"    # fuzzy basis: {' x '.join(map(str, counts))} rules (2.40)")
        k0, mus = 0, []
        for i, n in enumerate(counts):
            mus.append(k0)
            body += [
                f"    for l in range({n}):",
                "        for w in range(W):",
                f"            d = B[(SIG + {idx[i]}) * W + w] - B[(CR + {at['centers']} + {k0} + l)"
                " * W + w]",
                f"            B[(MU + {k0} + l) * W + w] = {exp}("
                f"-B[(CR + {at['spread']} + {k0} + l) * W + w] * d * d)",
            ]
            k0 += n
        # phi[i] = ((mu_0 * mu_1) * mu_2)..., the last input fastest (as the single run)
        strides = [int(np.prod(counts[i + 1 :])) for i in range(len(counts))]
        ind = "    "
        for i, n in enumerate(counts):
            body.append(f"{ind}for l{i} in range({n}):")
            ind += "    "
        row = " + ".join(f"{s} * l{i}" for i, s in enumerate(strides))
        prod = " * ".join(f"B[(MU + {mus[i]} + l{i}) * W + w]" for i in range(len(counts)))
        body += [f"{ind}for w in range(W):", f"{ind}    B[(PHI + {row}) * W + w] = {prod}"]
        if reg.normalised:
            body += [
                "    for w in range(W):",
                "        B[TOT * W + w] = 0.0",
                f"    for l in range({n_phi}):",
                "        for w in range(W):",
                "            B[TOT * W + w] += B[(PHI + l) * W + w]",
                f"    for l in range({n_phi}):",
                "        for w in range(W):",
                "            tot = B[TOT * W + w]",
                "            B[(PHI + l) * W + w] = (",
                f"                B[(PHI + l) * W + w] / tot if tot > 1e-300 else {1.0 / n_phi!r}",
                "            )",
            ]
    else:  # linear regressor [1, z_1, ..., z_k]
        body.append("    # linear regressor")
        j = 0
        body.append("    for w in range(W):")
        if reg.bias:
            body.append("        B[PHI * W + w] = 1.0")
            j = 1
        for i in idx:
            body.append(f"        B[(PHI + {j}) * W + w] = B[(SIG + {i}) * W + w]")
            j += 1
    body += [
        "    # u0 = Pi^T theta (2.22)",
        "    for w in range(W):",
        "        B[U0 * W + w] = 0.0",
        f"    for l in range({n_phi}):",
        "        for w in range(W):",
        f"            B[U0 * W + w] += B[(PHI + l) * W + w] * B[(y + {nx} + l) * W + w]",
        "    # allocation u = R^T u0 (3.14) and the lanes' affine failures (each lane its own)",
        f"    for j in range({m}):",
        "        for w in range(W):",
        f"            acc = 0.0 + B[(CR + {at['R']} + j) * W + w] * B[U0 * W + w]",
        "            t = B[tt * W + w]",
        "            c0 = B[(FC + 5 * j) * W + w]",
        "            c1 = B[(FC + 5 * j + 1) * W + w]",
        "            c2 = B[(FC + 5 * j + 2) * W + w]",
        "            c3 = B[(FC + 5 * j + 3) * W + w]",
        "            c4 = B[(FC + 5 * j + 4) * W + w]",
        "            kind = B[(FK + j) * W + w]",
        "            aff = c0 * acc + c1",
        "            inc = (acc + (min(((t - c0) / c1), c2) * ((c3 * acc + c4) - acc)))",
        _FAILURE_SELECT,
        "    # the plant",
        *LANE_PLANTS[type(loop.plant).__name__](loop.plant, "y", lambda k: cr(at["plant"] + k), m),
        "    # q = s' + k s + k0 tanh(s/eps0) (2.20), the adaptive law (2.29)",
        "    for w in range(W):",
        *[f"        B[(dy + {i}) * W + w] = B[(XD + {i}) * W + w]" for i in range(nx)],
        f"        sd = B[(REF + 2) * W + w] - B[(XD + {vel}) * W + w] + B[{cr(at['lam'])} * W + w]"
        f" * B[(SIG + {nx + 1}) * W + w]",
        f"        s = B[(SIG + {nx + 2}) * W + w]",
        f"        B[QQ * W + w] = sd + B[{cr(at['k'])} * W + w] * s + B[{cr(at['k0'])} * W + w]"
        f" * {tanh}(s / B[{cr(at['eps0'])} * W + w])",
        f"    for l in range({n_phi}):",
        "        for w in range(W):",
        f"            gamma = B[{cr(at['gains'])} * W + w]",
        f"            sigma = B[{cr(at['gains'] + 1)} * W + w]",
        f"            v = gamma * 1.0 * B[(PHI + l) * W + w] * B[QQ * W + w] - gamma * sigma * B["
        f"(y + {nx} + l) * W + w]",
        f"            adapt = B[{cr(at['adapt'])} * W + w]",
        f"            B[(dy + {nx} + l) * W + w] = v if adapt != 0.0 else 0.0",
    ]
    # the commands only (the rhs up to the plant, storing u too): the lean signals' pass
    at_plant = body.index("    # the plant")
    commands = [
        "@inl",
        "def commands(B, tt, y):",
        '    """The rhs of the W lanes up to their commands: e (row SIG + NX), u (rows UC..) and',
        '    the applied u (rows UF..), as the single run\'s rhs with a dY one longer than Y."""',
    ]
    # the reference: a lane at lane 0's time with lane 0's numbers copies its values (the
    # same operations on the same numbers: the same bits), the others compute their own
    at_errors = body.index("    # tracking errors e = y_d - y and filtered error s (2.18)")
    reference = body[4:at_errors]
    at_ref = reference.index("        if B[REFT * W + w] != t:")
    computed = reference[at_ref + 1 : -1]  # the rK lines and the REF rows (REFT's last)
    commands += reference[: at_ref + 1] + [
        "            if w > 0 and B[RSH * W + w] != 0.0 and t == B[tt * W]:",
        "                B[REF * W + w] = B[REF * W]",
        "                B[(REF + 1) * W + w] = B[(REF + 1) * W]",
        "                B[(REF + 2) * W + w] = B[(REF + 2) * W]",
        "            else:",
        *["    " + ln for ln in computed],
        reference[-1],
    ]
    for ln in body[at_errors:at_plant]:
        commands.append(ln)
        if ln.lstrip().startswith("acc = 0.0 + "):
            commands.append("            B[(UC + j) * W + w] = acc")
    ref_index = re.findall(r"\bc\[([^\]]+)\]", "\n".join(_reference_lines(asm.source)))
    ref_consts = (
        tuple(sorted({int(k) for k in ref_index}))
        if all(k.strip().isdigit() for k in ref_index)
        else None
    )
    env = params["envelope"]
    consts = [
        f"W = {width}",
        f"NY = {ny}",
        f"NB = {nb}",
        f"NX = {nx}",
        f"M = {m}",
        f"POS = {pos}",
        f"ENV = {env.start}",
        f"NENV = {env.stop - env.start}",
        *[f"{name} = {row}" for name, row in rows.items()],
    ]
    from adaptive_ftc.sim.mathlib import GUARDED  # the expression language's guarded math

    head = _HEAD.format(
        title=f"{loop.plant.name!r} + 'direct'{_TITLE[method]}, W = {width}, {kernels} kernels",
        guarded=", ".join(GUARDED),
        jits="\n".join(f"{name} = inl({name})" for name in GUARDED),
    )
    if kernels == "vector":
        head = _contract(head) + _VECTOR_IMPORTS
        body = _unrolled_u0(_vector_failures(_vector_reference(body)))
    kernel = codegen.template(f"lanes_{method}")
    if kernels == "vector" and method == "rk4":
        kernel = _pasted_stages(kernel)
    text = head + "\n".join(
        [*consts, "", "", "\n".join(body), "", "", "\n".join(commands), "", "", _LEAN_PASS, kernel]
    )
    return _Plan(text=text, ny=ny, nc=nc, nb=nb, rows=rows, ref_consts=ref_consts)


def _vector_reference(body: list[str]) -> list[str]:
    """The rhs ``body`` with the vector kernels' reference (stage 1c): the call-free ``vsin``
    and ``vcos`` for libm's, computed for every lane when any lane's time moved instead of per
    lane whose time moved (the same numbers: a branch per lane would stop the vectoriser, one
    for the group does not)."""
    at_if = body.index("        if B[REFT * W + w] != t:")
    at_errors = body.index("    # tracking errors e = y_d - y and filtered error s (2.18)")
    block = body[at_if + 1 : at_errors]
    out = [
        *body[: at_if - 2],
        # a branch for the group, not per lane: RK4's second stage reuses the first's time
        # and the next step's first stage the last's, so 2 of the 5 stages compute it
        "    moved = False",
        "    for w in range(W):",
        "        moved |= B[REFT * W + w] != B[tt * W + w]  # (nan at the start: moved)",
        "    if moved:",
        "        for w in range(W):  # the reference of every lane (call-free, vectorised)",
        "            t = B[tt * W + w]",
        *block,
        *body[at_errors:],
    ]
    return [re.sub(r"\bmath\.(sin|cos)\(", r"v\1(", ln) for ln in out]


#: the lanes' failure of actuator j: kind -1 healthy, 0 affine, 1 incipient (one of three)
_FAILURE_SELECT = (
    "            B[(UF + j) * W + w] = acc if kind < 0.0 else (aff if kind == 0.0 else inc)"
)
#: the same without a branch (vector kernels): the two formulas with 0/1 weights, the divisor
#: 1 where the lane's failure is not incipient, so that every term is finite
_FAILURE_WEIGHTS = [
    "            den = c1 if kind > 0.0 else 1.0",
    "            aff = c0 * acc + c1",
    "            inc = (acc + (min(((t - c0) / den), c2) * ((c3 * acc + c4) - acc)))",
    "            wh = 1.0 if kind < 0.0 else 0.0",
    "            wa = 1.0 if kind == 0.0 else 0.0",
    "            wi = 1.0 if kind > 0.0 else 0.0",
    "            B[(UF + j) * W + w] = wh * acc + wa * aff + wi * inc",
]


def _vector_failures(body: list[str]) -> list[str]:
    """The rhs ``body`` with the lanes' failures selected by weights instead of a branch
    (vector kernels): the branch made LLVM move the incipient formula (with its division) into
    a block per lane, so the whole failure block ran one lane at a time. The same formulas on
    the same numbers; a lane's own formula times 1 plus the others times 0 (finite) is its
    value."""
    at = body.index(_FAILURE_SELECT)
    if body[at - 2 : at] != [
        "            aff = c0 * acc + c1",
        "            inc = (acc + (min(((t - c0) / c1), c2) * ((c3 * acc + c4) - acc)))",
    ]:  # pragma: no cover - guards the text above
        raise ConfigurationError("The lane failure lines changed; report this as a bug.")
    return [*body[: at - 2], *_FAILURE_WEIGHTS, *body[at + 1 :]]


_FOR = re.compile(r"^( *)for (\w+) in range\((\d+)\):$")
_U0_SUM = "            B[U0 * W + w] += "


def _unrolled_u0(body: list[str]) -> list[str]:
    """The rhs ``body`` with the sum u0 = Pi^T theta written out, one lane loop per term
    (vector kernels): LLVM unrolled its loop over the terms only in part and vectorised the
    lane loops with shuffles between the lanes; written out, it is a chain of fused
    multiply-adds on rows at constant places. The same terms in the same order. (Written
    out everywhere, the pasted module took over 6 minutes to compile.)"""
    at = next(k for k, ln in enumerate(body) if ln.startswith(_U0_SUM))
    m = _FOR.match(body[at - 2])
    if m is None or body[at - 1] != "        for w in range(W):":  # pragma: no cover
        raise ConfigurationError("The lane u0 lines changed; report this as a bug.")
    var, n = m.group(2), int(m.group(3))
    term = re.compile(rf"\b{var}\b")
    out = []
    for value in range(n):
        out += ["    for w in range(W):", "        " + term.sub(str(value), body[at].strip())]
    return [*body[: at - 2], *out, *body[at + 1 :]]


#: the RK4 template's stage: the rhs through its shared compiled copy, rows copied in and out
_SHARED_STAGE = """    for w in range(W):
        B[TIN * W + w] = B[tt * W + w]
    if y != YT:
        for i in range(NY * W):
            B[YT * W + i] = B[y * W + i]
    rhs_rows(B)
    for i in range(NY * W):
        B[dy * W + i] = B[DY * W + i]
"""


def _pasted_stages(kernel: str) -> str:
    """The RK4 template with the rhs pasted into each stage (vector kernels, stage 1c): its
    rows become constants at each of the five call sites and the row copies go; the same
    operations on the same numbers, at the cost of compiling the rhs five times."""
    if _SHARED_STAGE not in kernel:  # pragma: no cover - guards the template's text
        raise ConfigurationError("The lane RK4 template changed its stage; report this as a bug.")
    return kernel.replace(_SHARED_STAGE, "    rhs(B, tt, y, dy)  # pasted: rows as constants\n")


def _contract(head: str) -> str:
    """The module ``head`` with fused multiply-adds allowed (``fastmath={"contract"}``, the
    vector kernels only, stage 1c): no other fast-math flag, since ``nnan`` breaks the NaN
    reference cache and reassociation undoes exp's Cody-Waite split (docs/performance.md)."""
    strict = "_nrt=False"
    # (the two jits of _HEAD: hot and inl)
    head = head.replace(strict, strict + ', fastmath={"contract"}')
    return head.replace(
        "# strict IEEE (no fastmath): every lane reproduces its single run bit for bit",
        "# fused multiply-adds only (vector kernels): ~1e-14 from the single runs, not bit for bit",
    )


_TITLE = {"rk4": "", "dopri5": ", DOPRI5"}  # (the RK4 modules' text as in stage 1)

_HEAD = '''"""Generated lane module (issue 29): {title}.

Written by adaptive_ftc.sim.lanes; numbers live in each lane's rows of B, not here.
"""
# ruff: noqa
import math

import numpy as np
from numba import njit

from adaptive_ftc.sim.lanes import at_lane_level
from adaptive_ftc.sim.mathlib import {guarded}

# strict IEEE (no fastmath): every lane reproduces its single run bit for bit
hot = at_lane_level(njit(cache=CACHE, nogil=True, error_model="numpy", _nrt=False))
inl = njit(nogil=True, error_model="numpy", _nrt=False, inline="always")
{jits}

'''

# the lean signals' pass of a lane group (stage 3), pasted after ``commands``
_LEAN_PASS = '''@hot
def lean_pass(B, t_rec, Ys, phs, nrec, fkind, fcon, outs, outside, prev):
    """The lean signals of the W lanes' records, as each member's single run computes them
    (templates/record.py with lean: its rhs up to the commands at every record): e, u and the
    applied u of record n of lane w into outs[w][n], and per lane the first record whose plant
    states leave the envelope (outside[w], -1: none). Ys[w], phs[w], t_rec[w]: lane w's
    records, phases and times (nrec[w] of them: 0 for a padding lane); fkind, fcon: the
    failures per interval (as run_group's); prev: scratch. Lanes past their last record
    idle."""
    nmax = 0
    for w in range(W):
        B[REFT * W + w] = np.nan
        outside[w] = -1
        prev[w] = -1
        nmax = max(nmax, nrec[w])
    for n in range(nmax):
        for w in range(W):
            if n >= nrec[w]:
                continue
            p = phs[w, n]
            if p != prev[w]:  # the record's interval: its failures
                prev[w] = p
                for j in range(M):
                    B[(FK + j) * W + w] = fkind[w, p, j]
                    for k in range(5):
                        B[(FC + 5 * j + k) * W + w] = fcon[w, p, j, k]
            B[TIN * W + w] = t_rec[w, n]
            Yw = Ys[w]
            for i in range(NY):
                B[(YT + i) * W + w] = Yw[n, i]
        commands(B, TIN, YT)
        for w in range(W):
            if n >= nrec[w]:
                continue
            o = outs[w]
            o[n, 0] = B[(SIG + NX) * W + w]
            for j in range(M):
                o[n, 1 + j] = B[(UC + j) * W + w]
                o[n, 1 + M + j] = B[(UF + j) * W + w]
            if outside[w] < 0:
                for i in range(NENV):
                    if not (abs(B[(YT + i) * W + w]) <= B[(CR + ENV + i) * W + w]):
                        outside[w] = n
                        break


'''

_VECTOR_IMPORTS = """# call-free exp, tanh (1b), sin, cos (1c): they vectorise; ~1 ulp off libm
from adaptive_ftc.sim.lane_kernels import vcos, vexp, vsin, vtanh

"""


# ----------------------------------------------------------------------------- modules
_modules: dict[str, tuple[object, _Plan]] = {}
_plans: dict[str, _Plan] = {}
_announced: set[str] = set()
_modules_lock = threading.Lock()
_LANE_IMPORTS = ["adaptive_ftc.sim.lanes", "adaptive_ftc.sim.mathlib"]

#: CPU seconds to compile a lane module with libm's kernels, its lean signals' pass included,
#: once per structure and machine (the line printed before it): 9.8 s (RK4) and 13.8 s
#: (DOPRI5) measured by ``benchmarks/bench_lane_break_even.py`` (docs/performance.md); the
#: wall time is that on a quiet machine, two to three times it on a busy one
COMPILE_SECONDS = {"rk4": 10.0, "dopri5": 15.0}


def _module_key(asm, width: int, kernels: str, method: str) -> str:
    return f"{width} {kernels} {method}\n{asm.source}"


def _imports(kernels: str, method: str) -> list[str]:
    """The modules a lane module imports (their source is part of its cache key)."""
    imports = _LANE_IMPORTS + (["adaptive_ftc.sim.lane_kernels"] if kernels == "vector" else [])
    if method == "dopri5":  # its tableau is imported from the single run's integrators
        imports = [*imports, "adaptive_ftc.sim.templates.adaptive"]
    return imports


def _plan_of(loop, asm, width: int, kernels: str, method: str) -> _Plan:
    """:func:`_plan`, once per structure, width, kernels and method in this process."""
    key = _module_key(asm, width, kernels, method)
    with _modules_lock:
        plan = _plans.get(key)
    if plan is None:
        plan = _plan(loop, asm, width, _kernels(kernels), method)
        with _modules_lock:
            _plans[key] = plan
    return plan


def lane_module_state(
    loop, asm, width: int = LANE_WIDTH, kernels: str = "libm", method: str = "rk4"
) -> str:
    """Where the lane module of ``loop``'s structure (``asm``: its assembled single run) is:
    ``"loaded"`` in this process, ``"cached"`` compiled in the disk cache (loading it takes
    0.05-0.3 s), or ``"absent"`` (its first use compiles it: :data:`COMPILE_SECONDS`)."""
    key = _module_key(asm, width, kernels, method)
    with _modules_lock:
        if key in _modules:
            return "loaded"
    plan = _plan_of(loop, asm, width, kernels, method)
    cached = codegen.is_cached(plan.text, _imports(kernels, method), kind="lanes")
    return "cached" if cached else "absent"


def compile_message(loop, width: int, kernels: str, method: str) -> str:
    """The line printed before a lane module compiles (the single path's ``compiling ...``
    line of the command-line tools, for the lane engine)."""
    seconds = COMPILE_SECONDS[method] * (13.0 if kernels == "vector" else 1.0)
    return (
        f"compiling the SIMD lane module of {loop.plant.name!r} + 'direct' ({method}, {width} "
        f"lanes, {kernels} kernels; first use on this machine only, ~{seconds:.0f} s of CPU; "
        "later runs load it from the cache)..."
    )


def lane_module(loop, asm, width: int = LANE_WIDTH, kernels: str = "libm", method: str = "rk4"):
    """The compiled lane module of ``loop``'s structure and its plan (generated once per
    structure, width and method, cached on disk like the loop modules). A module that is not
    in the disk cache yet is announced on stderr (:func:`compile_message`) before it compiles
    (numba compiles it at its first call, next)."""
    key = _module_key(asm, width, kernels, method)
    with _modules_lock:
        found = _modules.get(key)
    if found is not None:
        return found
    plan = _plan_of(loop, asm, width, kernels, method)
    imports = _imports(kernels, method)
    if not codegen.is_cached(plan.text, imports, kind="lanes"):
        with _modules_lock:
            first = key not in _announced
            _announced.add(key)
        if first:
            print(compile_message(loop, width, kernels, method), file=sys.stderr, flush=True)
    module = codegen.load_module(plan.text, imports=imports, kind="lanes")
    with _modules_lock:
        _modules[key] = (module, plan)
    return module, plan


def lane_source(loop, solver=None, width: int = LANE_WIDTH, kernels: str = "libm") -> str:
    """The generated lane module text of ``loop`` (to read), or a ConfigurationError naming
    why the loop has none."""
    from adaptive_ftc.sim.engine import CompiledLoop, SolverOptions

    solver = solver or SolverOptions()
    why = ineligible(loop, solver)
    if why is not None:
        raise ConfigurationError(_refusal(loop, why))
    cl = CompiledLoop.build(loop, solver)
    return _plan(loop, cl.asm, width, _kernels(kernels), solver.method).text


#: the lane kernels: libm's exp and tanh (bit-identical to the single run) or the call-free
#: ones of :mod:`adaptive_ftc.sim.lane_kernels` (stage 1b: faster, about 1e-14 from it)
KERNELS = ("libm", "vector")


def _kernels(kernels: str) -> str:
    if kernels not in KERNELS:
        raise ConfigurationError(
            f"`kernels` must be 'libm' (bit-identical to single runs) or 'vector' (call-free "
            f"exp, tanh, sin and cos, about 1e-14 from them); got {kernels!r}."
        )
    return kernels


def _refusal(loop, why: str) -> str:
    label = f"'{loop.name}'" if getattr(loop, "name", "") else "(unnamed loop)"
    return (
        f"Loop {label} cannot run in SIMD lanes: {why}. Run it with lanes=False (or 'auto', "
        "which runs such loops one at a time)."
    )


# ----------------------------------------------------------------------------- running
def _failure_tables(asm, m: int):
    """Per interval and actuator: the failure's kind (-1 healthy, 0 affine, 1 incipient) and
    its up to 5 numbers (healthy: zeros; affine: ``c0 u + c1``)."""
    d = asm.data
    fphase = d.fphase
    nph = fphase.shape[0]
    kind = -np.ones((nph, m))
    con = np.zeros((nph, m, 5))
    con[:, :, 1] = 1.0  # a safe divisor where the incipient formula is computed and dropped
    inst, c = d.inst, d.c
    for p, j in zip(*np.nonzero(fphase >= 0), strict=True):
        k = int(fphase[p, j])
        kd, o = int(inst[k, 0]), int(inst[k, 1])
        kind[p, j] = kd
        n = 2 if kd == 0 else 5
        con[p, j, :n] = c[o : o + n]
    return kind, con


_checked: set[str] = set()


def _self_check(module, plan: _Plan, cl, width: int, kernels: str) -> None:
    """The lane ``rhs`` of a structure against its single run's ``rhs``, once per process:
    each lane at another state, time and failure interval of ``cl`` (exactly equal with libm's
    kernels, within 1e-12 with the call-free ones). The lane form of a plant or law written
    twice (here and in its part) cannot drift apart silently."""
    key = f"{width} {kernels} {cl.solver.method}\n{cl.asm.source}"
    if key in _checked:
        return
    rows, asm = plan.rows, cl.asm
    m = cl.loop.plant.n_actuators
    kind, con = _failure_tables(asm, m)
    bps = asm.breakpoints
    B = np.zeros(plan.nb * width)
    wanted = []
    for w in range(width):
        ph = w % (len(bps) - 1)
        t = bps[ph] + 0.37 * (bps[ph + 1] - bps[ph])
        y = asm.y0 * (1.0 + 0.1 * w) + 1e-3 * (w + 1) * np.cos(np.arange(plan.ny) + w)
        B[(rows["CR"]) * width + w : (rows["CR"] + plan.nc) * width : width] = asm.data.c[: plan.nc]
        B[rows["REFT"] * width + w] = np.nan
        B[rows["TIN"] * width + w] = t
        B[rows["YT"] * width + w : (rows["YT"] + plan.ny) * width : width] = y
        B[rows["FK"] * width + w : (rows["FK"] + m) * width : width] = kind[ph]
        B[rows["FC"] * width + w : (rows["FC"] + 5 * m) * width : width] = con[ph].ravel()
        wanted.append(asm.derivative(t, y, ph))
    module.rhs_rows(B)
    got = B[rows["DY"] * width : (rows["DY"] + plan.ny) * width].reshape(plan.ny, width).T
    want = np.array(wanted)
    same = (
        np.array_equal(got, want)
        if kernels == "libm"
        else np.allclose(got, want, rtol=1e-12, atol=1e-12 * float(np.max(np.abs(want))))
    )
    if not same:
        raise ConfigurationError(
            f"The lane form of plant {cl.loop.plant.name!r} with design 'direct' disagrees "
            "with its single run's right-hand side (a part changed without its lane form in "
            "sim/lanes.py). Run with lanes=False, and report this."
        )
    _checked.add(key)


def _run_outputs(width: int, maxrec: int) -> tuple:
    """A lane group's per-lane outputs, as the lane modules write them: each record's interval,
    status, records written, stop time, first bad state (-1: none), step counts."""
    return (
        np.zeros((width, maxrec), dtype=np.int64),
        np.zeros(width, dtype=np.int64),
        np.zeros(width, dtype=np.int64),
        np.zeros(width),
        -np.ones(width, dtype=np.int64),
        np.zeros((width, 5), dtype=np.int64),
    )


def integrate_lanes(
    compiled: Sequence, width: int = LANE_WIDTH, kernels: str = "libm", *, lean: bool = False
) -> list:
    """Integrate ``compiled`` (:class:`~adaptive_ftc.sim.engine.CompiledLoop` of one structure,
    every one eligible) in one lane group; returns one
    :class:`~adaptive_ftc.sim.engine.Integration` per member, each equal to its own
    ``integrate()``. RK4: at most ``width`` members. DOPRI5: any number, a queue (lane
    refill): ``width`` lanes start on the first members, and a lane whose member ends takes
    the next one of the queue, so the group runs until the queue is empty rather than each
    ``width`` members until their slowest (:func:`lane_occupancy` counts the lanes' use).
    ``lean``: with the lean signals of every record too, computed for the lanes at once
    (stage 3: the module's ``lean_pass``), each member's equal to its single run's lean pass
    (:func:`~adaptive_ftc.sim.engine.finish_run` with ``lean`` takes them)."""
    n = len(compiled)
    first = compiled[0] if n else None
    method = first.solver.method if first is not None else "rk4"
    if not 1 <= n <= (width if method == "rk4" else sys.maxsize):
        raise ConfigurationError(
            f"An RK4 lane group holds 1 to {width} members (a DOPRI5 one 1 or more); got {n}. "
            f"Split the members into groups of at most {width} (simulate_lanes and "
            "iter_simulate do)."
        )
    assert first is not None
    if any(cl.solver.method != method for cl in compiled):
        raise ConfigurationError(
            "A lane group runs one solver method; group the members by method (got "
            f"{sorted({cl.solver.method for cl in compiled})})."
        )
    if method == "dopri5" and kernels == "vector":
        # measured 1.3e-10 of the signal scale from the single runs (docs/performance.md,
        # "Lane engine (stage 2)"), not the ~1e-14 that the vector kernels promise with RK4
        raise ConfigurationError(
            "The call-free lane kernels (kernels='vector') are for fixed-step RK4 only; with "
            "DOPRI5 use kernels='libm' (bit-identical to the single runs)."
        )
    module, plan = lane_module(first.loop, first.asm, width, kernels, method)
    _self_check(module, plan, first, width, kernels)
    if method == "dopri5":
        return _dopri5_queue(module, plan, compiled, width, lean)
    m = first.loop.plant.n_actuators
    pick = [*range(n), *([0] * (width - n))]  # padding lanes: copies of the first member
    members = [compiled[k] for k in pick]
    rows = plan.rows
    B = np.zeros(plan.nb * width)
    for w, cl in enumerate(members):
        B[rows["CR"] * width + w : (rows["CR"] + plan.nc) * width : width] = cl.asm.data.c[
            : plan.nc
        ]
    tables = [_failure_tables(cl.asm, m) for cl in members]
    maxph = max(len(cl.asm.breakpoints) - 1 for cl in members)
    brk = np.zeros((width, maxph + 1))
    nph = np.zeros(width, dtype=np.int64)
    fkind = -np.ones((width, maxph, m))
    fcon = np.zeros((width, maxph, m, 5))
    maxrec = max(cl.t_rec.size for cl in members)
    t_rec = np.zeros((width, maxrec))
    n_rec = np.zeros(width, dtype=np.int64)
    y0 = np.zeros((width, plan.ny))
    for w, (cl, (kind, con)) in enumerate(zip(members, tables, strict=True)):
        bps = cl.asm.breakpoints
        brk[w, : len(bps)] = bps
        nph[w] = len(bps) - 1
        fkind[w, : kind.shape[0]] = kind
        fcon[w, : con.shape[0]] = con
        t_rec[w, : cl.t_rec.size] = cl.t_rec
        n_rec[w] = cl.t_rec.size
        y0[w] = cl.asm.y0
    out_ph, status, nrec, t_stop, bad, stats = _run_outputs(width, maxrec)
    bound = float(first.solver.divergence_bound)
    start = time.perf_counter()
    out_Y = np.empty((width, maxrec, plan.ny))
    # per lane: interval, step in it, its steps, next record; its ends, step, tolerance
    ph, st, nst, r = (np.zeros(width, dtype=np.int64) for _ in range(4))
    a, b, h, tol = (np.zeros(width) for _ in range(4))
    active = np.zeros(width, dtype=np.bool_)
    dt = float(first.solver.dt)
    module.run_group(  # type: ignore[attr-defined]
        B, y0, brk, nph, fkind, fcon, dt, t_rec, n_rec, bound, out_Y, out_ph, status, nrec,
        t_stop, bad, stats, ph, st, nst, a, b, h, tol, r, active,
    )  # fmt: skip
    wall = (time.perf_counter() - start) / width
    lean_out: list = [None] * n
    if lean:
        lean_out = _lean_signals(module, plan, B, compiled, t_rec, out_Y, out_ph, nrec, fkind, fcon)
    ends = [
        _Ended(out_Y[w][: cl.t_rec.size], out_ph[w, : cl.t_rec.size].copy(), int(nrec[w]),
               int(status[w]), float(t_stop[w]), int(bad[w]), stats[w].copy(), wall)
        for w, cl in enumerate(compiled)
    ]  # fmt: skip
    return _integrations(compiled, ends, lean_out)


@dataclass(frozen=True)
class _Ended:
    """What a lane hands back when its member's run ends: its records (the member's own
    block, the state where it stopped in the row after the last record), their phases, the
    number of records, status (0 finished, 1 diverged, 2 step-size underflow or too many
    steps), stop time, first bad state, counts and wall time per member (-1: the group's)."""

    Y: np.ndarray
    phases: np.ndarray
    nrec: int
    status: int
    t_stop: float
    bad: int
    stats: np.ndarray
    wall: float = -1.0


@dataclass(frozen=True)
class LaneCounts:
    """The DOPRI5 lanes' use since the process started (:func:`lane_occupancy`): the
    members' step attempts (accepted and rejected) and the lane slots (``width`` per pass of
    a group, whether a lane held a member or idled)."""

    attempts: int
    slots: int

    @property
    def occupancy(self) -> float:
        """The share of the lane slots that were a member's step attempt."""
        return self.attempts / self.slots if self.slots else 0.0


_counts = [0, 0]  # attempts, slots (under _modules_lock)


def lane_occupancy() -> LaneCounts:
    """The DOPRI5 lane groups' use so far in this process (:class:`LaneCounts`); subtract
    two readings to measure a stretch of work."""
    with _modules_lock:
        return LaneCounts(*_counts)


def _dopri5_queue(module, plan: _Plan, compiled: Sequence, width: int, lean: bool) -> list:
    """:func:`integrate_lanes` of DOPRI5 members as a queue (lane refill): each lane takes the
    next member when its own ends (the member's rows of constants, tolerances, state, breaks,
    failures and record times copied into the lane; its records into its own block), so that
    the lanes idle only for the queue's tail."""
    from adaptive_ftc.sim import blocks

    n = len(compiled)
    first = compiled[0]
    m = first.loop.plant.n_actuators
    rows, ny, nc = plan.rows, plan.ny, plan.nc
    maxph = max(len(cl.asm.breakpoints) - 1 for cl in compiled)
    maxrec = max(cl.t_rec.size for cl in compiled)
    B = np.zeros(plan.nb * width)
    brk = np.zeros((width, maxph + 1))
    nph = np.zeros(width, dtype=np.int64)
    fkind = -np.ones((width, maxph, m))
    fcon = np.zeros((width, maxph, m, 5))
    t_rec = np.zeros((width, maxrec))
    n_rec = np.zeros(width, dtype=np.int64)
    y0 = np.zeros((width, ny))
    rtol = np.zeros(width)
    h_max = np.zeros(width)
    out_ph, status, nrec, t_stop, bad, stats = _run_outputs(width, maxrec)
    ph, r, nstep = (np.zeros(width, dtype=np.int64) for _ in range(3))
    a, b, tol, h, facold, hs, dnf, limit = (np.zeros(width) for _ in range(8))
    start_, reject, last, inside, active = (np.zeros(width, dtype=np.bool_) for _ in range(5))
    fresh = np.zeros(width, dtype=np.bool_)
    done = np.ones(width, dtype=np.bool_)
    passes = np.zeros(1, dtype=np.int64)
    P = np.empty((6, ny))
    # each member's records in its own block (from the pool of sim/blocks.py, as a single
    # run's: no fresh pages to zero, 26 MB a 120 s run recorded every millisecond); a lane
    # without a member records nothing
    idle = np.empty((1, ny))
    outs = [idle] * width
    holder = [-1] * width  # the member each lane runs (-1: none)
    tables: dict[int, tuple] = {}
    ends: list = [None] * n
    bound = float(first.solver.divergence_bound)

    def lane_rows(w: int, cl) -> None:
        """Member ``cl``'s constants, tolerances and initial state into lane w's rows."""
        B[rows["CR"] * width + w : (rows["CR"] + nc) * width : width] = cl.asm.data.c[:nc]
        B[rows["ATOL"] * width + w : (rows["ATOL"] + ny) * width : width] = cl.atol
        y0[w] = cl.asm.y0

    def load(w: int, k: int) -> None:
        """Member k into lane w, to start at the next call."""
        cl = compiled[k]
        lane_rows(w, cl)
        kind, con = tables[k] = _failure_tables(cl.asm, m)
        bps = cl.asm.breakpoints
        brk[w, : len(bps)] = bps
        nph[w] = len(bps) - 1
        fkind[w] = -1.0
        fkind[w, : kind.shape[0]] = kind
        fcon[w] = 0.0
        fcon[w, : con.shape[0]] = con
        t_rec[w, : cl.t_rec.size] = cl.t_rec
        n_rec[w] = cl.t_rec.size
        rtol[w] = float(cl.solver.rtol)
        h_max[w] = float(min(cl.solver.max_step, 1e300))
        outs[w] = blocks.empty((cl.t_rec.size, ny))
        holder[w] = k
        fresh[w] = True
        done[w] = False

    def collect(w: int) -> None:
        k = holder[w]
        size = compiled[k].t_rec.size
        ends[k] = _Ended(
            outs[w], out_ph[w, :size].copy(), int(nrec[w]), int(status[w]), float(t_stop[w]),
            int(bad[w]), stats[w].copy(),
        )  # fmt: skip
        holder[w] = -1
        outs[w] = idle

    nxt = 0
    for w in range(width):
        if nxt < n:
            load(w, nxt)
            nxt += 1
        else:  # no member for it: member 0's numbers, so its idle rhs computes sane values
            lane_rows(w, first)
    start = time.perf_counter()
    while True:
        module.run_group(  # type: ignore[attr-defined]
            B, y0, brk, nph, fkind, fcon, rtol, h_max, t_rec, n_rec, bound, tuple(outs), out_ph,
            status, nrec, t_stop, bad, stats, ph, r, nstep, a, b, tol, h, facold, hs, dnf,
            limit, start_, reject, last, inside, active, P, fresh, done, nxt < n, passes,
        )  # fmt: skip
        ended = [w for w in range(width) if holder[w] >= 0 and done[w]]
        if not ended:  # pragma: no cover - the kernel returns when a lane ended or all idle
            raise RuntimeError("The DOPRI5 lane group returned with no member ended; a bug.")
        for w in ended:
            collect(w)
            if nxt < n:
                load(w, nxt)
                nxt += 1
        if all(k < 0 for k in holder):
            break
    wall = (time.perf_counter() - start) / max(n, width)
    ends = [replace(end, wall=wall) for end in ends]
    attempts = sum(int(end.stats[0]) + int(end.stats[1]) for end in ends)
    with _modules_lock:
        _counts[0] += attempts
        _counts[1] += width * int(passes[0])
    lean_out: list = [None] * n
    if lean:
        for s in range(0, n, width):
            lean_out[s : s + width] = _lean_chunk(
                module, plan, compiled[s : s + width], ends[s : s + width],
                [tables[k] for k in range(s, min(n, s + width))], width, m,
            )  # fmt: skip
    return _integrations(compiled, ends, lean_out)


def _lean_chunk(module, plan: _Plan, compiled, ends, tables, width: int, m: int) -> list:
    """The lean signals' pass of up to ``width`` ended DOPRI5 members, in lanes (their rows
    of constants, records, phases and failures set for it)."""
    rows = plan.rows
    c = len(compiled)
    B = np.zeros(plan.nb * width)
    maxrec = max(cl.t_rec.size for cl in compiled)
    maxph = max(kind.shape[0] for kind, _ in tables)
    t_rec = np.zeros((width, maxrec))
    out_ph = np.zeros((width, maxrec), dtype=np.int64)
    nrec = np.zeros(width, dtype=np.int64)
    fkind = -np.ones((width, maxph, m))
    fcon = np.zeros((width, maxph, m, 5))
    for w, (cl, end, (kind, con)) in enumerate(zip(compiled, ends, tables, strict=True)):
        B[rows["CR"] * width + w : (rows["CR"] + plan.nc) * width : width] = cl.asm.data.c[
            : plan.nc
        ]
        t_rec[w, : cl.t_rec.size] = cl.t_rec
        out_ph[w, : cl.t_rec.size] = end.phases
        nrec[w] = end.nrec
        fkind[w, : kind.shape[0]] = kind
        fcon[w, : con.shape[0]] = con
    out_Y = tuple([end.Y for end in ends] + [np.empty((1, plan.ny))] * (width - c))
    return _lean_signals(module, plan, B, compiled, t_rec, out_Y, out_ph, nrec, fkind, fcon)


def _integrations(compiled, ends, lean_out) -> list:
    """One :class:`~adaptive_ftc.sim.engine.Integration` per member from what its lane
    handed back (:class:`_Ended`): the single run's outcome, diagnosis included."""
    from adaptive_ftc.sim.engine import Integration, _stop
    from adaptive_ftc.sim.status import RunStatus

    out = []
    for cl, end, lean_signals in zip(compiled, ends, lean_out, strict=True):
        size = cl.t_rec.size
        Y, k = end.Y[:size], end.nrec
        if end.status == 0:
            outcome = (RunStatus.COMPLETED, None)
        else:
            outcome = _stop(
                cl.loop, cl.asm, cl.solver, cl.t_rec, Y, k, end.status, end.t_stop, end.bad,
                Y[k].copy() if k < size else None,
            )  # fmt: skip
            if outcome[0] is RunStatus.STEP_UNDERFLOW and outcome[1] is not None:
                from adaptive_ftc.sim.templates.adaptive import MAX_STEPS

                if int(end.stats[0]) + int(end.stats[1]) >= MAX_STEPS:  # as the single run
                    outcome = (outcome[0], replace(outcome[1], step_limit=MAX_STEPS))
        out.append(
            Integration(Y, end.phases, k, *outcome, end.wall, end.stats, lean_signals=lean_signals)
        )
    return out


def _lean_signals(module, plan, B, compiled, t_rec, out_Y, out_ph, nrec, fkind, fcon) -> list:
    """The lean signals' pass of a lane group's records (the module's ``lean_pass``): per
    member ``(block, first record outside the envelope or -1)``."""
    from adaptive_ftc.sim.result import lean_signal_block

    n, width = len(compiled), nrec.size
    rows = plan.rows
    share = np.zeros(width)
    if plan.ref_consts is not None:  # the lanes whose reference numbers are lane 0's, bit for bit
        c = B[rows["CR"] * width : (rows["CR"] + plan.nc) * width].reshape(plan.nc, width)
        bits = c[list(plan.ref_consts)].view(np.int64)
        share = np.all(bits == bits[:, :1], axis=0).astype(float)
    B[rows["RSH"] * width : (rows["RSH"] + 1) * width] = share
    blocks_ = [lean_signal_block(cl.loop, int(nrec[w])) for w, cl in enumerate(compiled)]
    cols = blocks_[0].shape[1]
    outs = tuple(blocks_ + [np.empty((1, cols)) for _ in range(width - n)])
    counts = nrec.copy()
    counts[n:] = 0  # padding lanes: no records
    ys = tuple(out_Y[w] for w in range(width))
    outside = np.empty(width, dtype=np.int64)
    prev = np.empty(width, dtype=np.int64)
    module.lean_pass(B, t_rec, ys, out_ph, counts, fkind, fcon, outs, outside, prev)
    return [(blocks_[w], int(outside[w])) for w in range(n)]


def simulate_lanes(
    loops: Sequence, solver=None, *, width: int = LANE_WIDTH, kernels: str = "libm"
) -> list:
    """:func:`~adaptive_ftc.sim.engine.simulate` of loops of one structure in lane groups of
    ``width`` (in order, on this thread): the same :class:`~adaptive_ftc.sim.result.SimResult`
    per loop (states, signals, status and reason, meta counts; a :class:`DivergenceWarning`
    per diverged run). ``kernels``: ``"libm"`` (bit-identical to :func:`simulate`) or
    ``"vector"`` (stage 1b, :mod:`adaptive_ftc.sim.lane_kernels`: about 1e-14 from it).

    Raises :class:`ConfigurationError` naming why when a loop is not eligible or the loops do
    not share one structure."""
    from adaptive_ftc.sim.engine import CompiledLoop, SolverOptions, finish_run

    solver = solver or SolverOptions()
    for loop in loops:
        why = ineligible(loop, solver)
        if why is not None:
            raise ConfigurationError(_refusal(loop, why))
    compiled = [CompiledLoop.build(loop, solver) for loop in loops]
    for cl in compiled:
        why = _ineligible_numbers(cl.asm)
        if why is not None:
            raise ConfigurationError(_refusal(cl.loop, why))
    if len({cl.asm.source for cl in compiled}) > 1:
        raise ConfigurationError(
            "simulate_lanes() runs loops of one structure (the same plant, design, regressor "
            "and reference shapes); group the loops by structure, or use simulate_many()."
        )
    kernels = _kernels(kernels)
    out = []
    # DOPRI5: queues of queue_members (lane refill; a longer queue measured slower end to end:
    # docs/performance.md); RK4: groups of width
    step = width if solver.method == "rk4" else queue_members(compiled[0])
    for s in range(0, len(compiled), step):
        group = compiled[s : s + step]
        runs = integrate_lanes(group, width, kernels)
        out += [finish_run(cl, run) for cl, run in zip(group, runs, strict=True)]
    return out


def lane_groups(loops: Sequence, solver, width: int = LANE_WIDTH):
    """Split ``loops`` (in order) into runs: ``("lanes", [indices])`` for up to ``width``
    eligible loops of one structure, ``("single", [index])`` for the others; with the
    :class:`~adaptive_ftc.sim.engine.CompiledLoop` of each eligible loop."""
    from adaptive_ftc.sim.engine import CompiledLoop

    groups: dict[str, list[int]] = {}
    built: dict[int, object] = {}
    singles: list[int] = []
    for k, loop in enumerate(loops):
        if ineligible(loop, solver) is not None:
            singles.append(k)
            continue
        cl = CompiledLoop.build(loop, solver)
        if _ineligible_numbers(cl.asm) is not None:
            singles.append(k)
            continue
        built[k] = cl
        groups.setdefault(cl.asm.source, []).append(k)
    out = [("single", [k]) for k in singles]
    for idx in groups.values():
        for s in range(0, len(idx), width):
            out.append(("lanes", idx[s : s + width]))
    return out, built


# ----------------------------------------------------------------------------- lanes="auto"
#: ``lanes="auto"`` (the default of :func:`~adaptive_ftc.sim.batch.iter_simulate`,
#: ``simulate_many`` and campaigns), per (method, lean signals): the members of one structure
#: that repay a cold compile of its lane module (:data:`COMPILE_SECONDS` over the CPU time
#: lanes save per member), measured by ``benchmarks/bench_lane_break_even.py`` on 120 s
#: members of hypersonic-direct-s1 (docs/performance.md, "Lane engine: the default"). A
#: structure whose lane module is loaded or in the disk cache runs in lanes at any count.
AUTO_COMPILE_MIN = {
    ("rk4", False): 500,  # records every 10 steps: 21-22 ms saved per member
    ("rk4", True): 500,
    ("dopri5", False): 3_000,  # records every 10 ms: 4.5-5 ms saved per member
    ("dopri5", True): 10_000,  # a campaign's (records every 1 ms): 1-4 ms saved per member
}

#: members per lane job of :func:`~adaptive_ftc.sim.batch.iter_simulate` (one call of
#: :func:`integrate_lanes`), per method: RK4 a group of :data:`LANE_WIDTH`; DOPRI5 a queue of
#: two groups' worth (lane refill: a lane whose member ends takes the next one, so the lanes
#: idle only for the tail of 16 members, not of every 8), fewer where the members' records
#: would exceed :data:`QUEUE_BYTES` (:func:`queue_members`).
QUEUE_MEMBERS = {"rk4": LANE_WIDTH, "dopri5": 2 * LANE_WIDTH}

#: a DOPRI5 queue's records stay in memory until its job ends: a queue holds more than
#: ``LANE_WIDTH`` members only while their records fit in this many bytes (members of 120 s
#: recorded every 10 ms: 2.6 MB each, a queue of 16; every millisecond, a campaign's: 26 MB
#: each, groups of 8 as without refill, so a campaign's memory stays what it was)
QUEUE_BYTES = 64 << 20


def queue_members(cl) -> int:
    """Members per lane job of ``cl``'s structure and solver (one
    :class:`~adaptive_ftc.sim.engine.CompiledLoop` of them): :data:`QUEUE_MEMBERS` of its
    method, at least ``LANE_WIDTH``, at most as many as :data:`QUEUE_BYTES` of records hold."""
    cap = QUEUE_MEMBERS.get(cl.solver.method, LANE_WIDTH)
    per = max(1, int(cl.t_rec.size) * int(cl.asm.y0.size) * 8)
    return max(LANE_WIDTH, min(cap, QUEUE_BYTES // per))


#: RK4 lanes write their records per lane (strided): with a record every step (1 ms records
#: at dt 1 ms, a campaign that judges the control activity) they cost 1.26x the members one
#: at a time (lean signals); with one every 10 steps, 0.68x. "auto" runs RK4 members in
#: lanes only when their records are at least this many steps apart.
RK4_RECORD_STEPS = 10

#: the members a lane group needs to beat running them one at a time (a group of fewer than
#: ``LANE_WIDTH`` costs what a full one costs: its padding lanes compute too), per (method,
#: lean signals): the smallest ``n > LANE_WIDTH * r``, ``r`` the measured lane / single CPU
#: time per member; a smaller group's members run one at a time
AUTO_GROUP_MIN = {
    ("rk4", False): 6,  # r = 0.67-0.68
    ("rk4", True): 6,
    ("dopri5", False): 7,  # r = 0.75-0.78
    ("dopri5", True): 8,  # r = 0.88-0.97
}


def auto_uses_lanes(cl, expected: int | None, kernels: str = "libm", lean: bool = False) -> bool:
    """``lanes="auto"``'s verdict for the members of ``cl``'s structure (``cl``: one eligible
    :class:`~adaptive_ftc.sim.engine.CompiledLoop` of them): lanes when its lane module is
    loaded or in the disk cache (:func:`lane_module_state`), or when ``expected`` (the
    members of that structure the caller expects; ``None``: not known) repays compiling it
    (:data:`AUTO_COMPILE_MIN`); never for RK4 members recorded more often than every
    :data:`RK4_RECORD_STEPS` steps. Each lane group still needs :data:`AUTO_GROUP_MIN`
    members."""
    method = cl.solver.method
    solver = cl.solver
    if method == "rk4" and solver.record_dt < RK4_RECORD_STEPS * solver.dt * (1.0 - 1e-9):
        return False  # records too dense for RK4 lanes to pay (RK4_RECORD_STEPS)
    if lane_module_state(cl.loop, cl.asm, LANE_WIDTH, kernels, method) != "absent":
        return True
    return expected is not None and expected >= AUTO_COMPILE_MIN[(method, bool(lean))]


def auto_group_min(method: str, lean: bool = False) -> int:
    """The members a lane group of ``method`` needs under ``lanes="auto"``
    (:data:`AUTO_GROUP_MIN`)."""
    return AUTO_GROUP_MIN[(method, bool(lean))]
