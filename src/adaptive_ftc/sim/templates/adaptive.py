"""Compiled adaptive-step integrators, pasted as text into the shared integrator module.

The text after the line ``# --- template: begin ---`` is the template: the code generator pastes it
(with ``templates/rk4.py``) into the module of integrators that every closed loop shares
(``compose.integrators``), which defines, at module level,

- ``rhs(t, Y, ph, D, W, dY)``: the closed-loop derivative, written into ``dY`` in place;
- ``make_work(D)``: the work arrays ``W`` that ``rhs`` uses;
- ``jit``: the numba decorator (``numba.njit(cache=..., nogil=True, error_model="numpy")``).

There ``rhs`` and ``jump`` call the loop's own compiled functions through the addresses in
``D.i`` (``sim/fptr.py``): one compiled integrator per method serves every loop, compiled once
per machine. (A function passed as an argument would defeat numba's disk cache.)
Everything above the marker is a stand-in so that this file imports, lints and can be tested
on its own; :func:`bind` executes the template against any jitted ``rhs``.

Structure: one driver and per-method step functions. The driver is ``_solve`` (the run: scratch
arrays, breaks, records at interval starts and at the end) with ``_steps`` (one interval: step
size, stop flag, step-size underflow, acceptance, divergence check, records, the switch between
explicit and Rosenbrock steps). A method brings its step functions: DOPRI5 ``_dopri5_step``
(tableau constants ``_A*``, ``_E*``), ``_dopri5_dense``, ``_dopri5_control``, ``_dopri5_retry``;
the Rosenbrock methods ``_jacobian``, ``_rosenbrock_step`` over ``_rodasp_stages`` or
``_rodas5p_stages`` (tableaus ``_R*``, ``_P*``), ``_rosenbrock_dense``, ``_rosenbrock_control``,
``_rosenbrock_retry``; ``auto`` adds ``_stiffness_test`` and ``_nonstiff_test``. The step
functions are inlined into ``_steps`` by numba (``inl``) and share one :class:`Work` of scratch
arrays (``integrate_dopri5``: :class:`WorkExplicit`, the 13 that the Dormand-Prince code reads,
rows of one block: less to compile on a first run); ``_steps`` runs without reference counting
(``hot``). The arithmetic is that of the
single core it replaced, in the same order (every catalogue trajectory bit-identical).

Entry points (same signature; each is its own copy of the driver, pasted by :func:`specialise`
with the other method's code dropped, so a ``dopri5`` loop compiles no Rosenbrock code: on
hypersonic-direct-s1 the whole cold compile fell from 11-12 s to 8.4 s)::

    integrate_dopri5(y0, t_breaks, t_rec, D, W, rtol, atol, h_max, bound, stop,
                     out_Y, out_phase, stats) -> (nrec, status, t_stop, bad)
    integrate_rodasp(...)   # same
    integrate_rodas5p(...)  # same
    integrate_auto(...)     # same

``atol`` is an array with one absolute tolerance per state (the engine fills it from
``SolverOptions.atol``: one number repeated, or one per state).

``status``: 0 finished, 1 diverged (a state non-finite or ``|y_i| >= bound``; ``bad = i``), 2 step
size underflow or more than ``MAX_STEPS`` steps (``bad = -1``), 3 interrupted (``stop[0] != 0``,
checked before every step; ``bad = -1``). On statuses 1 and 2 the state where the run stopped is
left in ``out_Y[n_recorded]`` (when that row exists). ``stats`` (int64, length >= 5) receives
``[accepted steps, rejected steps, rhs evaluations, Jacobians, LU factorisations]``.

Integration restarts at every break time ``t_breaks[k]`` with a fresh step-size guess, and the
interval ``[t_breaks[k], t_breaks[k+1]]`` runs with ``ph = k``. The state is recorded on ``t_rec``
with the semantics of the fixed-step RK4 (``kernel.integrate_rk4``): a record at a break time
belongs to the phase that starts there (``out_phase``), a record where a step ends is that step's
state exactly, any other record comes from the method's dense output.

Error control: every accepted step satisfies ``max_i |err_i| / (atol_i + rtol max(|y_i|,
|y_new_i|)) <= 1`` (a max norm, so no state's error is averaged away by the others).

Methods and why (measured on the catalogue loops; docs/solvers.md and
benchmarks/bench_tolerance.py hold the numbers):

- ``dopri5``: Dormand-Prince 5(4) with Hairer's PI step control and 4th-order dense output
  (Hairer, Norsett & Wanner, *Solving ODEs I*, II.5 and II.6). For non-stiff loops.
- ``rodasp``: the L-stable, stiffly accurate Rosenbrock method RODASP of order 4(3)
  (Steinebach 1995, the ``METH=3`` coefficients of Hairer & Wanner's ``rodas.f``; known as
  Rodas4P), whose order does not drop on Prothero-Robinson problems ``y' = L (y - g(t)) + g'``
  with ``|L h|`` large, as the adaptive laws driven by ``sin 5t`` are in the wing-rock loops.
  Measured there, Hairer's original RODAS coefficients needed 18x more steps for the same
  error on such a problem. Jacobian by forward differences (stored transposed), ``df/dt`` by a
  central difference, skipped where ``f(t + d, y)`` equals ``f(t, y)`` bit for bit (n + 2 rhs
  evaluations per step, n + 1 where the loop does not depend on ``t``), in-place LU with
  partial pivoting of ``(I / (gamma h) - J)^T`` solved by contiguous column sweeps (nothing
  allocated per step; 1.1-1.8x faster per step than row-wise substitution on the wing-rock
  loops), Gustafsson's predictive step control, the method's own 3rd-order
  dense output (a cubic Hermite interpolant is useless on stiff components: ``f(y1)``
  multiplies the step's error by the fast rate). The dense output is an order below the steps
  and degrades on stiff components, so a step with a record inside must also pass a dense-output
  check (else it is rejected, and the next step size is limited by it): the interpolant's slope
  at the step's end against ``h f(y1)``, and its defect ``y_d' - f(y_d)`` at the middle, both
  mapped to an error by ``(I/(gamma h) - J)^-1`` (which is ``-J^-1`` on stiff components and
  ``gamma h`` on the others); one rhs evaluation and two solves per such step. Measured: the
  wing-rock direct loop goes from 10495 steps (capped at the record spacing) to 874 at rtol
  1e-6, same error (3.8e-7).
- ``rodas5p``: the same Rosenbrock core with Steinebach's Rodas5P 5(4) tableau (2023; 8
  stages, 7 new rhs evaluations per step, ``gamma`` 0.2119), stiffly accurate, order 5 on
  Prothero-Robinson problems, with a 4th-order dense output ``y0 + s (y1 - y0) + s (1 - s)
  (K1 + s K2 + s^2 K3)``; same Jacobian, LU, dense-output checks and controller (exponent 1/5).
  Measured on wingrock-estimation-s2, where RODASP's 3rd-order dense output set the error
  (records 1.07e-6 off at rtol 2e-6 while the step ends were 4.2e-7 off): 6531 steps at rtol
  5e-7 (error 6.9e-7) against RODASP's 10813 at rtol 1e-6 (8.9e-7), 5.5x faster than RK4 at
  dt 2e-5 instead of 4.6x.
- ``auto``: starts with ``dopri5`` and switches to ``rodasp`` when Hairer's stiffness test
  (``h |k7 - k6| / |y1 - y6| > 3.25`` on 15 accepted steps) fires, and back when DOPRI5
  would be cheaper for 5 accepted Rosenbrock steps: its stable step ``3.3 / rho`` (``rho``
  the spectral radius of the Jacobian, by power iteration) at 6 evaluations against the
  Rosenbrock step at ``n + 8``.
"""

from __future__ import annotations

import re
import types
from pathlib import Path

import numba

TEMPLATE_MARKER = "# --- template: begin ---"
#: the line after which the template's per-method part starts (:func:`specialise`)
PER_METHOD = "# --- per method: begin ---"

jit = numba.njit(nogil=True, error_model="numpy")
#: the interval loop: allocates nothing, so it runs without reference counting
hot = numba.njit(nogil=True, error_model="numpy", _nrt=False)  # type: ignore[call-overload]  # numba's stubs omit its private _nrt option
#: the step functions: inlined into the interval loop by numba (``inline="always"``)
inl = numba.njit(nogil=True, error_model="numpy", _nrt=False, inline="always")  # type: ignore[call-overload]  # numba's stubs omit its private _nrt option
#: the helpers that only compiled code calls (``_steps``, ``_h_start``, ``_work``,
#: ``_records_at``): numba builds no Python or C entry wrapper for them (less to lower and
#: optimise on a first run; a call from Python fails)
_NO_WRAPPERS = {"no_cpython_wrapper": True, "no_cfunc_wrapper": True}
inner = numba.njit(nogil=True, error_model="numpy", **_NO_WRAPPERS)  # type: ignore[call-overload]  # numba's stubs omit these options
hot_inner = numba.njit(nogil=True, error_model="numpy", _nrt=False, **_NO_WRAPPERS)  # type: ignore[call-overload]  # numba's stubs omit these options

#: the docstring of every entry point after its first line
_ENTRY_DOC = """    Returns ``(n_recorded, status, t_stop, bad_index)``; the arguments, statuses and
    ``stats`` are documented in ``adaptive_ftc/sim/templates/adaptive.py``.
    """


def rhs(t, Y, ph, D, W, dY):  # pragma: no cover - stand-in, replaced by the generated module
    """Stand-in for the generated closed-loop derivative."""
    raise NotImplementedError("the template's rhs is a stand-in; use bind() or a generated module")


def jump(t, Y, ph, D, W):  # pragma: no cover - stand-in, replaced by the generated module
    """Stand-in for the generated state update at the start of each interval."""
    raise NotImplementedError("the template's jump is a stand-in")


def _no_jump(t, Y, ph, D, W):
    """A continuous loop's ``jump``: nothing happens at interval starts."""
    return  # a statement: numba's debug-info line finder fails on a docstring-only body


def leaves_envelope(Y, D):  # pragma: no cover - stand-in, replaced by the generated module
    """Stand-in for the generated envelope check."""
    raise NotImplementedError("the template's leaves_envelope is a stand-in")


def _no_envelope(Y, D):
    """A loop without a physical envelope: no state is ever outside it."""
    return -1


def make_work(D):  # pragma: no cover - stand-in, replaced by the generated module
    """Stand-in for the generated work-array factory."""
    raise NotImplementedError("the template's make_work is a stand-in")


# Stand-ins of the constants and entry cores that :func:`specialise` writes into the text.
_DOPRI5 = _RODASP = _SWITCH = _RODAS5P = True

#: per entry point: (name, _DOPRI5, _RODASP, _SWITCH, _RODAS5P); ``_RODASP`` means Rosenbrock
#: steps, with the Rodas5P tableau where ``_RODAS5P``
_CORES = (
    ("integrate_dopri5", True, False, False, False),
    ("integrate_rodasp", False, True, False, False),
    ("integrate_rodas5p", False, True, False, True),
    ("integrate_auto", True, True, True, False),
)
#: the first line of each entry point's docstring
_DOCS = {
    "integrate_dopri5": "Dormand-Prince 5(4), adaptive step, restarts at every break "
    "(non-stiff loops).",
    "integrate_rodasp": "RODASP Rosenbrock 4(3), L-stable, finite-difference Jacobian "
    "(stiff loops).",
    "integrate_rodas5p": "Rodas5P Rosenbrock 5(4), stiffly accurate, 4th-order dense output "
    "(stiff loops).",
    "integrate_auto": "Dormand-Prince 5(4) switching to RODASP while the loop is stiff.",
}


def specialise(text: str) -> str:
    """Paste the per-method part of ``text`` (after ``# --- per method: begin ---``: the driver
    ``_solve`` and its interval loop ``_steps``) once per entry point, as ``integrate_<method>``
    and ``_steps_<method>``, with its method constants as literals (Python drops a block under
    ``if False``), so that ``integrate_dopri5`` compiles no Rosenbrock code and
    ``integrate_rodasp`` no Dormand-Prince code. The step functions before the marker are
    shared.

    Measured on hypersonic-direct-s1 (``dopri5``): the core's own compile time fell from 3.7 s
    (both methods, one core) to about 1.5 s. The entry points are the drivers themselves (no
    wrapper: a wrapper calling the core cost numba a second optimisation and code generation
    of the whole linked loop).
    """
    head, core = text.split(PER_METHOD + "\n", 1)
    cores = []
    for name, dopri5, rodasp, switch, rodas5p in _CORES:
        body = re.sub(
            r'(def _solve\([^"]*)"""[^"]*"""',
            lambda m, name=name: f'{m.group(1)}"""{_DOCS[name]}\n\n{_ENTRY_DOC}"""',  # type: ignore[misc]
            core,
            count=1,
        )
        body = re.sub(r"\b_solve\b", name, body)
        body = re.sub(r"\b_steps\b", f"_steps_{name.removeprefix('integrate_')}", body)
        for const, value in (
            ("_DOPRI5", dopri5),
            ("_RODASP", rodasp),
            ("_SWITCH", switch),
            ("_RODAS5P", rodas5p),
        ):
            body = re.sub(rf"\b{const}\b", str(value), body)
        cores.append(body.strip("\n"))
    return head + "\n\n\n".join(cores) + "\n"


def template_text() -> str:
    """Return the template source (everything after the ``# --- template: begin ---`` line),
    specialised per entry point (:func:`specialise`)."""
    text = Path(__file__).read_text(encoding="utf-8")
    return specialise(text.split(TEMPLATE_MARKER + "\n", 1)[1])


def bind(rhs, make_work, jit=None, name: str = "adaptive_ftc_bound_integrators", jump=None):
    """Execute the template against a jitted ``rhs`` (for tests and benchmarks).

    Parameters
    ----------
    rhs
        A numba-jitted ``rhs(t, Y, ph, D, W, dY)``.
    make_work
        A (jitted or plain) ``make_work(D)``.
    jit
        The decorator for the template's functions; default ``numba.njit(nogil=True,
        error_model="numpy")`` (in memory: code executed from a string cannot be disk-cached).
    name
        Name of the returned module object.
    jump
        A jitted ``jump(t, Y, ph, D, W)`` run at the start of every interval (default: none).

    Returns
    -------
    types.ModuleType
        Holds ``integrate_dopri5``, ``integrate_rodasp``, ``integrate_auto`` and the helpers.
    """
    mod = types.ModuleType(name)
    mod.__dict__.update(
        rhs=rhs,
        jump=jump if jump is not None else numba.njit(_no_jump),
        leaves_envelope=numba.njit(_no_envelope),
        make_work=make_work,
        jit=jit if jit is not None else numba.njit(nogil=True, error_model="numpy"),
        hot=numba.njit(nogil=True, error_model="numpy", _nrt=False),  # type: ignore[call-overload]  # numba's stubs omit its private _nrt option
        inl=numba.njit(nogil=True, error_model="numpy", _nrt=False, inline="always"),  # type: ignore[call-overload]  # numba's stubs omit its private _nrt option
        inner=inner,
        hot_inner=hot_inner,
    )
    exec(compile(template_text(), f"<{name}>", "exec"), mod.__dict__)  # noqa: S102
    return mod


# --- template: begin ---
# ============================================================================ adaptive step
# Pasted from adaptive_ftc/sim/templates/adaptive.py: Dormand-Prince 5(4), RODASP, Rodas5P and
# automatic switching between DOPRI5 and RODASP. Needs the module globals ``rhs``,
# ``make_work`` and ``jit``.
import math  # noqa: E402
from typing import NamedTuple  # noqa: E402

import numpy as np  # noqa: E402

MAX_STEPS = 50_000_000
_UROUND = 2.220446049250313e-16

# Dormand-Prince 5(4) (Hairer, Norsett & Wanner I, Table II.5.2), dense output II.6 (6.12)
_C2, _C3, _C4, _C5 = 0.2, 0.3, 0.8, 8.0 / 9.0
_A21 = 0.2
_A31, _A32 = 3.0 / 40.0, 9.0 / 40.0
_A41, _A42, _A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
_A51, _A52, _A53, _A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
_A61, _A62, _A63 = 9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0
_A64, _A65 = 49.0 / 176.0, -5103.0 / 18656.0
_A71, _A73, _A74 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0
_A75, _A76 = -2187.0 / 6784.0, 11.0 / 84.0
_E1, _E3, _E4 = 71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0
_E5, _E6, _E7 = -17253.0 / 339200.0, 22.0 / 525.0, -1.0 / 40.0
_D1, _D3 = -12715105075.0 / 11282082432.0, 87487479700.0 / 32700410799.0
_D4, _D5 = -10690763975.0 / 1880347072.0, 701980252875.0 / 199316789632.0
_D6, _D7 = -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0

# RODASP 4(3) (Steinebach 1995; rodas.f METH=3): Rodas4 coefficients re-derived so that the
# order stays 4 on Prothero-Robinson problems y' = L (y - g(t)) + g'(t) with |L h| large
_RG = 0.25
_RC2, _RC3, _RC4 = 0.75, 0.21, 0.63
_RD1, _RD2, _RD3, _RD4 = 0.25, -0.5, -0.023504, -0.0362
_RA21 = 3.0
_RA31, _RA32 = 1.831036793486759, 0.4955183967433795
_RA41, _RA42, _RA43 = 2.304376582692669, -0.05249275245743001, -1.176798761832782
_RA51, _RA52 = -7.170454962423024, -4.741636671481785
_RA53, _RA54 = -16.31002631330971, -1.062004044111401
_RC21 = -12.0
_RC31, _RC32 = -8.791795173947035, -2.207865586973518
_RC41, _RC42, _RC43 = 10.81793056857153, 6.780270611428266, 19.5348594464241
_RC51, _RC52 = 34.19095006749676, 15.49671153725963
_RC53, _RC54 = 54.7476087596413, 14.16005392148534
_RC61, _RC62, _RC63 = 34.62605830930532, 15.30084976114473, 56.99955578662667
_RC64, _RC65 = 18.40807009793095, -5.714285714285717
# dense output y(t + s h) = y0 + s (y1 - y0) + s (1 - s) (H2 + s H3), H_k = sum_j _RHkj k_j
_RH21, _RH22, _RH23 = 25.09876703708589, 11.62013104361867, 28.49148307714626
_RH24, _RH25 = -5.664021568594133, 0.0
_RH31, _RH32, _RH33 = 1.638054557396973, -0.7373619806678748, 8.47791821923899
_RH34, _RH35 = 15.9925314877952, -1.882352941176471

# Rodas5P 5(4) (Steinebach 2023, BIT Numer. Math. 63:27; the tableau of OrdinaryDiffEq.jl's
# Rodas5PTableau): 8 stages, stiffly accurate, order 5 also on Prothero-Robinson problems, and
# a 4th-order dense output y(t + s h) = y0 + s (y1 - y0) + s (1 - s) (K1 + s K2 + s^2 K3),
# K_j = sum_i _PH[j, i] k_i. Stage i is at t + _PC[i] h from y0 + sum_j _PA[i, j] k_j.
_PG = 0.21193756319429014
_PA = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [2.849394379747939, 0.45842242204463923, 0.0, 0.0, 0.0, 0.0, 0.0],
        [-6.954028509809101, 2.489845061869568, -10.358996098473584, 0.0, 0.0, 0.0, 0.0],
        [2.8029986275628964, 0.5072464736228206, -0.3988312541770524, -0.04721187230404641]
        + [0.0, 0.0, 0.0],
        [-7.502846399306121, 2.561846144803919, -11.627539656261098, -0.18268767659942256]
        + [0.030198172008377946, 0.0, 0.0],
        [-7.502846399306121, 2.561846144803919, -11.627539656261098, -0.18268767659942256]
        + [0.030198172008377946, 1.0, 0.0],
        [-7.502846399306121, 2.561846144803919, -11.627539656261098, -0.18268767659942256]
        + [0.030198172008377946, 1.0, 1.0],
    ]
)
_PCM = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [-14.155112264123755, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [-17.97296035885952, -2.859693295451294, 0.0, 0.0, 0.0, 0.0, 0.0],
        [147.12150275711716, -1.41221402718213, 71.68940251302358, 0.0, 0.0, 0.0, 0.0],
        [165.43517024871676, -0.4592823456491126, 42.90938336958603, -5.961986721573306]
        + [0.0, 0.0, 0.0],
        [24.854864614690072, -3.0009227002832186, 47.4931110020768, 5.5814197821558125]
        + [-0.6610691825249471, 0.0, 0.0],
        [30.91273214028599, -3.1208243349937974, 77.79954646070892, 34.28646028294783]
        + [-19.097331116725623, -28.087943162872662, 0.0],
        [37.80277123390563, -3.2571969029072276, 112.26918849496327, 66.9347231244047]
        + [-40.06618937091002, -54.66780262877968, -9.48861652309627],
    ]
)
_PC = np.array(
    [0.0, 0.6358126895828704, 0.4095798393397535, 0.9769306725060716, 0.4288403609558664]
    + [1.0, 1.0, 1.0]
)
_PD = np.array(
    [0.21193756319429014, -0.42387512638858027, -0.3384627126235924, 1.8046452872882734]
    + [2.325825639765069, 0.0, 0.0, 0.0]
)
_PH = np.array(
    [
        [25.948786856663858, -2.5579724845846235, 10.433815404888879, -2.3679251022685204]
        + [0.524948541321073, 1.1241088310450404, 0.4272876194431874, -0.17202221070155493],
        [-9.91568850695171, -0.9689944594115154, 3.0438037242978453, -24.495224566215796]
        + [20.176138334709044, 15.98066361424651, -6.789040303419874, -6.710236069923372],
        [11.419903575922262, 2.8879645146136994, 72.92137995996029, 80.12511834622643]
        + [-52.072871366152654, -59.78993625266729, -0.15582684282751913, 4.883087185713722],
    ]
)


@inl
def _keep_stop(r, out_Y, Y):
    """Leave the state where a run stopped early in the row after the last record (never read
    as a record; the engine reads it to say why the run stopped)."""
    if r < out_Y.shape[0]:
        for i in range(Y.size):
            out_Y[r, i] = Y[i]


@inl
def _first_bad(Y, bound, D):
    for i in range(Y.size):
        if not (abs(Y[i]) < bound):  # catches nan too
            return i
    return leaves_envelope(Y, D)  # a plant state outside the plant's envelope


@inl
def _err_max(e, y0, y1, rtol, atol):
    """Max-norm of ``e`` scaled by ``atol + rtol max(|y0|, |y1|)``; inf if not finite."""
    m = 0.0
    for i in range(e.size):
        v = abs(e[i]) / (atol[i] + rtol * max(abs(y0[i]), abs(y1[i])))
        if not (v <= m):
            m = v
    if not (m < math.inf):
        return math.inf
    return m


@inner
def _h_start(t, Y, f0, ph, D, W, rtol, atol, h_max, span, order, y1, f1):
    """Initial step size (Hairer, Norsett & Wanner I, II.4); one rhs evaluation."""
    n = Y.size
    dnf = 0.0
    dny = 0.0
    for i in range(n):
        sk = atol[i] + rtol * abs(Y[i])
        dnf += (f0[i] / sk) ** 2
        dny += (Y[i] / sk) ** 2
    dnf = math.sqrt(dnf / n)
    dny = math.sqrt(dny / n)
    h = 1e-6 if (dnf <= 1e-5 or dny <= 1e-5) else 0.01 * dny / dnf
    h = min(h, h_max, span)
    for i in range(n):
        y1[i] = Y[i] + h * f0[i]
    rhs(t + h, y1, ph, D, W, f1)
    der2 = 0.0
    for i in range(n):
        sk = atol[i] + rtol * abs(Y[i])
        der2 += ((f1[i] - f0[i]) / sk) ** 2
    der2 = math.sqrt(der2 / n) / h
    der12 = max(der2, dnf)
    if not (der12 > 1e-15):
        h1 = max(1e-6, h * 1e-3)
    else:
        h1 = (0.01 / der12) ** (1.0 / order)
    h = min(100.0 * h, h1, h_max, span)
    if not (h > 0.0):
        h = min(1e-6, span)
    return h


@jit
def _lu_factor(A, piv, dinv):
    """In-place LU with partial pivoting (rows swapped whole), the pivots' reciprocals in
    ``dinv``; False if singular."""
    n = A.shape[0]
    for k in range(n):
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            v = abs(A[i, k])
            if v > amax:
                amax = v
                p = i
        piv[k] = p
        if not (amax > 0.0) or not (amax < math.inf):
            return False
        if p != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        inv = 1.0 / A[k, k]
        dinv[k] = inv
        for i in range(k + 1, n):
            lik = A[i, k] * inv
            A[i, k] = lik
            if lik != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= lik * A[k, j]
    return True


@jit
def _lu_solve_t(A, piv, dinv, b):
    """Solve ``A^T x = b`` in place with the factors ``P A = L U`` of :func:`_lu_factor`.

    ``A^T = U^T L^T P``: the triangular solves run over rows of ``U`` and ``L`` (contiguous
    axpy updates, no serial dot products), then the row swaps in reverse order. The core
    factors the transpose of ``I / (gamma h) - J`` so that this solves with the matrix itself:
    measured on a 14-state loop, about 15-20 % faster per solve than the row-oriented
    substitution.
    """
    n = A.shape[0]
    for j in range(n):
        v = b[j] * dinv[j]
        b[j] = v
        for i in range(j + 1, n):
            b[i] -= A[j, i] * v
    for j in range(n - 1, 0, -1):
        v = b[j]
        for i in range(j):
            b[i] -= A[j, i] * v
    for k in range(n - 1, -1, -1):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp


@jit
def _lu_solve_t2(A, piv, dinv, b, c):
    """:func:`_lu_solve_t` for two right-hand sides at once (independent chains overlap)."""
    n = A.shape[0]
    for j in range(n):
        v = b[j] * dinv[j]
        w = c[j] * dinv[j]
        b[j] = v
        c[j] = w
        for i in range(j + 1, n):
            a = A[j, i]
            b[i] -= a * v
            c[i] -= a * w
    for j in range(n - 1, 0, -1):
        v = b[j]
        w = c[j]
        for i in range(j):
            a = A[j, i]
            b[i] -= a * v
            c[i] -= a * w
    for k in range(n - 1, -1, -1):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
            tmp = c[k]
            c[k] = c[p]
            c[p] = tmp


@inl
def _record(r, t_rec, limit, t, t1, hh, tol, Y, yn, rc, ph, out_Y, out_phase):
    """Write the records ``t_rec[r] < limit`` of the step ``[t, t1]``; returns the new ``r``.

    ``rc`` holds the dense-output coefficients: ``y(t + s hh) = rc0 + s (rc1 + (1 - s) (rc2 +
    s (rc3 + (1 - s) rc4)))``.
    """
    n = Y.size
    nrec = t_rec.size
    while r < nrec and t_rec[r] < limit:
        tr = t_rec[r]
        if abs(tr - t1) <= tol:
            for i in range(n):
                out_Y[r, i] = yn[i]
        else:
            s = (tr - t) / hh
            s1 = 1.0 - s
            for i in range(n):
                out_Y[r, i] = Y[i] + s * (
                    rc[1, i] + s1 * (rc[2, i] + s * (rc[3, i] + s1 * rc[4, i]))
                )
        out_phase[r] = ph
        r += 1
    return r


@inl
def _dense_terms(k1, k2, k3, k4, k5, i):
    """The two RODASP dense-output combinations of the stages at component ``i``."""
    h2 = _RH21 * k1[i] + _RH22 * k2[i] + _RH23 * k3[i] + _RH24 * k4[i] + _RH25 * k5[i]
    h3 = _RH31 * k1[i] + _RH32 * k2[i] + _RH33 * k3[i] + _RH34 * k4[i] + _RH35 * k5[i]
    return h2, h3


@inl
def _dense_terms5(ks, i):
    """The three Rodas5P dense-output combinations ``K1, K2, K3`` of the stages at ``i``."""
    a = 0.0
    b = 0.0
    c = 0.0
    for j in range(8):
        v = ks[j, i]
        a += _PH[0, j] * v
        b += _PH[1, j] * v
        c += _PH[2, j] * v
    return a, b, c


class Work(NamedTuple):
    """The scratch arrays of one run, allocated once by :func:`_work` (nothing per step)."""

    Y: np.ndarray  # the state at the step's start
    yn: np.ndarray  # the state at the step's end
    yt: np.ndarray  # a stage's state
    ysti: np.ndarray  # DOPRI5's 6th stage state; the Rosenbrock dense output's defect
    f0: np.ndarray  # f(t, Y)
    fs: np.ndarray  # a stage's f
    ft: np.ndarray  # df/dt (Rosenbrock)
    dy: np.ndarray  # DOPRI5's error estimate; RODASP's increment
    k1: np.ndarray  # the stages (DOPRI5: k2..k7, f0 being k1; RODASP: k1..k6)
    k2: np.ndarray
    k3: np.ndarray
    k4: np.ndarray
    k5: np.ndarray
    k6: np.ndarray
    k7: np.ndarray  # f(t1, yn): the next step's f0
    ks: np.ndarray  # Rodas5P's 8 stages
    rc: np.ndarray  # the accepted step's dense-output coefficients (:func:`_record`)
    JT: np.ndarray  # the Jacobian, transposed
    A: np.ndarray  # (I / (gamma h) - J)^T and its LU factors
    piv: np.ndarray
    dinv: np.ndarray
    pv: np.ndarray  # power-iteration vector (auto)
    pw: np.ndarray  # its product with J; the dense output's slope check


@inner
def _work(y0, stages):
    """The scratch arrays of one run from ``y0``; ``stages`` rows for Rodas5P's stages.

    The vectors, the stages and the dense-output rows are rows of one block, the two
    matrices the planes of another: three allocations of three kinds (numba compiles one
    implementation per kind on a first run; this was 23 allocations of seven kinds)."""
    n = y0.size
    s = np.empty((23 + stages, n))  # 18 vectors, the stages, rc
    v = 1.0 / math.sqrt(max(n, 1))
    for i in range(n):
        s[0, i] = y0[i]
        s[16, i] = v  # the power iteration's first vector
    for j in range(18 + stages, 23 + stages):
        for i in range(n):
            s[j, i] = 0.0
    m = np.empty((2, n, n))
    return Work(
        s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7], s[8], s[9], s[10], s[11], s[12], s[13],
        s[14], s[18 : 18 + stages], s[18 + stages : 23 + stages], m[0], m[1],
        np.empty(n, dtype=np.int64), s[15], s[16], s[17],
    )  # fmt: skip


class WorkExplicit(NamedTuple):
    """The scratch arrays of a Dormand-Prince run (:func:`_work_explicit`): the fields of
    :class:`Work` that its steps use, and nothing of the Rosenbrock methods'.

    ``integrate_dopri5`` passes these 13 arrays to its step loop instead of :class:`Work`'s 23,
    all rows of one allocation: less for numba to type, lower and optimise on a first run
    (and one allocation compiled, not five kinds). The same arithmetic on the same numbers."""

    Y: np.ndarray
    yn: np.ndarray
    yt: np.ndarray
    ysti: np.ndarray
    f0: np.ndarray
    dy: np.ndarray
    k2: np.ndarray
    k3: np.ndarray
    k4: np.ndarray
    k5: np.ndarray
    k6: np.ndarray
    k7: np.ndarray
    rc: np.ndarray


@inner
def _work_explicit(y0):
    """:class:`WorkExplicit` from ``y0``: the rows of one ``(17, n)`` block (``Y`` a copy of
    ``y0``, the dense-output coefficients ``rc`` zero)."""
    n = y0.size
    s = np.empty((17, n))
    for i in range(n):
        s[0, i] = y0[i]
    for j in range(12, 17):
        for i in range(n):
            s[j, i] = 0.0
    return WorkExplicit(
        s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7], s[8], s[9], s[10], s[11], s[12:17]
    )


# ============================================================================ Dormand-Prince 5(4)
@inl
def _dopri5_step(t, t1, hh, ph, D, W, rtol, atol, w, stats):
    """One Dormand-Prince 5(4) step from ``(t, w.Y)`` (``f(t, Y)`` in ``w.f0``): the new state
    in ``w.yn``, ``f(t1, yn)`` in ``w.k7`` (first same as last); returns the error's norm."""
    Y, yt, ysti, yn, f0, dy = w.Y, w.yt, w.ysti, w.yn, w.f0, w.dy
    k2, k3, k4, k5, k6, k7 = w.k2, w.k3, w.k4, w.k5, w.k6, w.k7
    n = Y.size
    for i in range(n):
        yt[i] = Y[i] + hh * _A21 * f0[i]
    rhs(t + _C2 * hh, yt, ph, D, W, k2)
    for i in range(n):
        yt[i] = Y[i] + hh * (_A31 * f0[i] + _A32 * k2[i])
    rhs(t + _C3 * hh, yt, ph, D, W, k3)
    for i in range(n):
        yt[i] = Y[i] + hh * (_A41 * f0[i] + _A42 * k2[i] + _A43 * k3[i])
    rhs(t + _C4 * hh, yt, ph, D, W, k4)
    for i in range(n):
        yt[i] = Y[i] + hh * (_A51 * f0[i] + _A52 * k2[i] + _A53 * k3[i] + _A54 * k4[i])
    rhs(t + _C5 * hh, yt, ph, D, W, k5)
    for i in range(n):
        ysti[i] = Y[i] + hh * (
            _A61 * f0[i] + _A62 * k2[i] + _A63 * k3[i] + _A64 * k4[i] + _A65 * k5[i]
        )
    rhs(t1, ysti, ph, D, W, k6)
    for i in range(n):
        yn[i] = Y[i] + hh * (
            _A71 * f0[i] + _A73 * k3[i] + _A74 * k4[i] + _A75 * k5[i] + _A76 * k6[i]
        )
    rhs(t1, yn, ph, D, W, k7)
    stats[2] += 6
    for i in range(n):
        dy[i] = hh * (
            _E1 * f0[i] + _E3 * k3[i] + _E4 * k4[i] + _E5 * k5[i] + _E6 * k6[i] + _E7 * k7[i]
        )
    return _err_max(dy, Y, yn, rtol, atol)


@inl
def _dopri5_dense(hh, w):
    """The accepted step's dense-output coefficients into ``w.rc`` (HNW I, II.6 (6.12))."""
    Y, yn, f0, rc = w.Y, w.yn, w.f0, w.rc
    k3, k4, k5, k6, k7 = w.k3, w.k4, w.k5, w.k6, w.k7
    for i in range(Y.size):
        ydiff = yn[i] - Y[i]
        bspl = hh * f0[i] - ydiff
        rc[1, i] = ydiff
        rc[2, i] = bspl
        rc[3, i] = ydiff - hh * k7[i] - bspl
        rc[4, i] = hh * (
            _D1 * f0[i] + _D3 * k3[i] + _D4 * k4[i] + _D5 * k5[i] + _D6 * k6[i] + _D7 * k7[i]
        )


@inl
def _dopri5_control(err, hh, facold, reject_last):
    """Hairer's PI step control after an accepted step: ``(next step, facold)``."""
    fac11 = err**0.17
    fac = fac11 / facold**0.04
    fac = max(0.1, min(5.0, fac / 0.9))
    hnew = hh / fac
    if reject_last:
        hnew = min(hnew, hh)
    return hnew, max(err, 1e-4)


@inl
def _dopri5_retry(err, hh):
    """The step to try after a rejected DOPRI5 step."""
    if err < math.inf:
        return hh / min(5.0, err**0.17 / 0.9)
    return 0.1 * hh


@inl
def _stiffness_test(hh, w, n_stiff, n_nonstiff):
    """Hairer's stiffness test (HNW I, IV.2) on an accepted DOPRI5 step: ``h |k7 - k6| / |yn -
    ysti| > 3.25`` on 15 steps says stiff. Returns ``(stiff, n_stiff, n_nonstiff)``."""
    num = 0.0
    den = 0.0
    for i in range(w.Y.size):
        num += (w.k7[i] - w.k6[i]) ** 2
        den += (w.yn[i] - w.ysti[i]) ** 2
    if den > 0.0 and hh * math.sqrt(num / den) > 3.25:
        n_nonstiff = 0
        n_stiff += 1
        if n_stiff >= 15:
            return True, 0, n_nonstiff
    else:
        n_nonstiff += 1
        if n_nonstiff >= 6:
            n_stiff = 0
    return False, n_stiff, n_nonstiff


# ============================================================================ Rosenbrock
@inl
def _jacobian(t, ph, D, W, w, stats):
    """The finite-difference Jacobian at ``(t, w.Y)`` into ``w.JT`` (transposed: ``JT[j, i] =
    df_i / dy_j``) and ``df/dt`` into ``w.ft``."""
    Y, yt, fs, ft, f0, JT = w.Y, w.yt, w.fs, w.ft, w.f0, w.JT
    n = Y.size
    for i in range(n):
        yt[i] = Y[i]
    for j in range(n):
        yj = Y[j]
        delt = math.sqrt(_UROUND * max(1e-5, abs(yj)))
        yt[j] = yj + delt
        rhs(t, yt, ph, D, W, fs)
        yt[j] = yj
        delt = 1.0 / ((yj + delt) - yj)  # the step actually taken
        for i in range(n):
            JT[j, i] = (fs[i] - f0[i]) * delt
    # df/dt by a central difference: a forward one (its O(delt) bias times the large f_tt of
    # the wing-rock loops) tripled the rejected steps at rtol 1e-9. Where f(t + delt, y) equals
    # f(t, y) bit for bit, the loop does not depend on t there (no moving reference or failure
    # pattern): df/dt = 0 and the second evaluation is saved.
    delt = 1e-5 * max(1.0, abs(t))
    rhs(t + delt, Y, ph, D, W, fs)
    moving = False
    for i in range(n):
        if fs[i] != f0[i]:
            moving = True
            break
    if moving:
        rhs(t - delt, Y, ph, D, W, ft)
        for i in range(n):
            ft[i] = (fs[i] - ft[i]) / (2.0 * delt)
        stats[2] += n + 2
    else:
        for i in range(n):
            ft[i] = 0.0
        stats[2] += n + 1
    stats[3] += 1


@inl
def _rosenbrock_matrix(fac, w, stats):
    """Factor ``A = (I / (gamma h) - J)^T`` (``fac = 1 / (gamma h)``) in place; False if
    singular. :func:`_lu_solve_t` then solves with its transpose."""
    A, JT = w.A, w.JT
    n = A.shape[0]
    for i in range(n):
        for j in range(n):
            A[i, j] = -JT[i, j]
        A[i, i] += fac
    stats[4] += 1
    return _lu_factor(A, w.piv, w.dinv)


@inl
def _rodasp_stages(t, t1, hh, ph, D, W, rtol, atol, w, stats):
    """RODASP's six stages (``w.k1..k6``) and new state ``w.yn``; returns the error's norm."""
    Y, yt, yn, fs, ft, dy = w.Y, w.yt, w.yn, w.fs, w.ft, w.dy
    k1, k2, k3, k4, k5, k6 = w.k1, w.k2, w.k3, w.k4, w.k5, w.k6
    A, piv, dinv = w.A, w.piv, w.dinv
    n = Y.size
    ihh = 1.0 / hh
    for i in range(n):
        k1[i] = w.f0[i] + hh * _RD1 * ft[i]
    _lu_solve_t(A, piv, dinv, k1)
    for i in range(n):
        yt[i] = Y[i] + _RA21 * k1[i]
    rhs(t + _RC2 * hh, yt, ph, D, W, fs)
    for i in range(n):
        k2[i] = fs[i] + hh * _RD2 * ft[i] + _RC21 * k1[i] * ihh
    _lu_solve_t(A, piv, dinv, k2)
    for i in range(n):
        yt[i] = Y[i] + _RA31 * k1[i] + _RA32 * k2[i]
    rhs(t + _RC3 * hh, yt, ph, D, W, fs)
    for i in range(n):
        k3[i] = fs[i] + hh * _RD3 * ft[i] + (_RC31 * k1[i] + _RC32 * k2[i]) * ihh
    _lu_solve_t(A, piv, dinv, k3)
    for i in range(n):
        yt[i] = Y[i] + _RA41 * k1[i] + _RA42 * k2[i] + _RA43 * k3[i]
    rhs(t + _RC4 * hh, yt, ph, D, W, fs)
    for i in range(n):
        k4[i] = fs[i] + hh * _RD4 * ft[i] + (_RC41 * k1[i] + _RC42 * k2[i] + _RC43 * k3[i]) * ihh
    _lu_solve_t(A, piv, dinv, k4)
    for i in range(n):
        dy[i] = _RA51 * k1[i] + _RA52 * k2[i] + _RA53 * k3[i] + _RA54 * k4[i]
        yt[i] = Y[i] + dy[i]
    rhs(t1, yt, ph, D, W, fs)
    for i in range(n):
        k5[i] = fs[i] + (_RC51 * k1[i] + _RC52 * k2[i] + _RC53 * k3[i] + _RC54 * k4[i]) * ihh
    _lu_solve_t(A, piv, dinv, k5)
    for i in range(n):
        dy[i] += k5[i]
        yt[i] = Y[i] + dy[i]
    rhs(t1, yt, ph, D, W, fs)
    for i in range(n):
        k6[i] = (
            fs[i]
            + (_RC61 * k1[i] + _RC62 * k2[i] + _RC63 * k3[i] + _RC64 * k4[i] + _RC65 * k5[i]) * ihh
        )
    _lu_solve_t(A, piv, dinv, k6)
    for i in range(n):
        yn[i] = Y[i] + dy[i] + k6[i]
    stats[2] += 5
    return _err_max(k6, Y, yn, rtol, atol)


@inl
def _rodas5p_stages(t, t1, hh, ph, D, W, rtol, atol, w, stats):
    """Rodas5P's eight stages (``w.ks``) and new state ``w.yn``; returns the error's norm."""
    Y, yt, yn, fs, ft, ks = w.Y, w.yt, w.yn, w.fs, w.ft, w.ks
    A, piv, dinv = w.A, w.piv, w.dinv
    n = Y.size
    ihh = 1.0 / hh
    for i in range(n):
        ks[0, i] = w.f0[i] + hh * _PD[0] * ft[i]
    _lu_solve_t(A, piv, dinv, ks[0])
    for st in range(1, 8):
        # stage sums as contiguous axpy sweeps over the stored stages
        for i in range(n):
            yt[i] = Y[i]
        for j in range(st):
            cf = _PA[st, j]
            if cf != 0.0:
                for i in range(n):
                    yt[i] += cf * ks[j, i]
        rhs(t + _PC[st] * hh, yt, ph, D, W, fs)
        hd = hh * _PD[st]
        for i in range(n):
            ks[st, i] = fs[i] + hd * ft[i]
        for j in range(st):
            cf = _PCM[st, j] * ihh
            for i in range(n):
                ks[st, i] += cf * ks[j, i]
        _lu_solve_t(A, piv, dinv, ks[st])
    for i in range(n):
        yn[i] = yt[i] + ks[7, i]
    stats[2] += 7
    return _err_max(ks[7], Y, yn, rtol, atol)


@inl
def _dense_error(t, t1, hh, fac, inside, ph, D, W, rtol, atol, w, stats, five):
    """The dense-output check of a Rosenbrock step whose own error passed (``five``: Rodas5P,
    else RODASP); leaves ``f(t1, yn)`` in ``w.k7``. Returns the interpolant's error norm.

    The interpolant's slope at the step's end against ``h f(y1)``, filtered by ``(I - gamma h
    J)^-1`` (stiff components damped); with a record ``inside`` the step, also the defect of the
    interpolant at the step's middle, whose error there is about ``(I/(gamma h) - J)^-1`` times
    the defect (``J^-1`` on stiff parts)."""
    Y, yn, yt, ysti, pw, fs, k7 = w.Y, w.yn, w.yt, w.ysti, w.pw, w.fs, w.k7
    k1, k2, k3, k4, k5, ks = w.k1, w.k2, w.k3, w.k4, w.k5, w.ks
    n = Y.size
    ihh = 1.0 / hh
    rhs(t1, yn, ph, D, W, k7)
    stats[2] += 1
    for i in range(n):
        if five:
            h2, h3, h4 = _dense_terms5(ks, i)
            pw[i] = hh * k7[i] - (yn[i] - Y[i] - h2 - h3 - h4)
        else:
            h2, h3 = _dense_terms(k1, k2, k3, k4, k5, i)
            pw[i] = hh * k7[i] - (yn[i] - Y[i] - h2 - h3)
    if inside:
        for i in range(n):
            rc1 = yn[i] - Y[i]
            if five:
                h2, h3, h4 = _dense_terms5(ks, i)
                yt[i] = Y[i] + 0.5 * rc1 + 0.25 * (h2 + 0.5 * (h3 + 0.5 * h4))
                ysti[i] = (rc1 + 0.25 * (h3 + h4)) * ihh
            else:
                h2, h3 = _dense_terms(k1, k2, k3, k4, k5, i)
                yt[i] = Y[i] + 0.5 * rc1 + 0.25 * (h2 + 0.5 * h3)
                ysti[i] = (rc1 + 0.25 * h3) * ihh
        rhs(t + 0.5 * hh, yt, ph, D, W, fs)
        stats[2] += 1
        for i in range(n):
            ysti[i] -= fs[i]
        _lu_solve_t2(w.A, w.piv, w.dinv, pw, ysti)
    else:
        _lu_solve_t(w.A, w.piv, w.dinv, pw)
    for i in range(n):
        pw[i] *= fac * 0.25
    edense = _err_max(pw, Y, yn, rtol, atol)
    if inside:
        edense = max(edense, _err_max(ysti, Y, yn, rtol, atol))
    return edense


@inl
def _rosenbrock_step(t, t1, hh, inside, ph, D, W, rtol, atol, w, stats, five):
    """One Rosenbrock step with the Jacobian in ``w.JT`` (``five``: Rodas5P, else RODASP).

    Returns ``(err, edense, factored)``: the error's norm (``inf`` when the dense output fails
    its check with a record ``inside``), the dense output's, and False if ``I / (gamma h) - J``
    is singular."""
    fac = 1.0 / ((_PG if five else _RG) * hh)
    if not _rosenbrock_matrix(fac, w, stats):
        return math.inf, 0.0, False
    if five:
        err = _rodas5p_stages(t, t1, hh, ph, D, W, rtol, atol, w, stats)
    else:
        err = _rodasp_stages(t, t1, hh, ph, D, W, rtol, atol, w, stats)
    edense = 0.0
    if err <= 1.0:
        edense = _dense_error(t, t1, hh, fac, inside, ph, D, W, rtol, atol, w, stats, five)
        if inside and edense > 1.0:
            err = math.inf  # reject: a record falls inside the step
    return err, edense, True


@inl
def _rosenbrock_dense(w, five):
    """The accepted step's dense-output coefficients into ``w.rc`` (rodas.f's own; Rodas5P's
    ``s^3 (1 - s)`` written as ``s^2 (1 - s) - s^2 (1 - s)^2``)."""
    Y, yn, rc = w.Y, w.yn, w.rc
    for i in range(Y.size):
        rc[1, i] = yn[i] - Y[i]
        if five:
            h2, h3, h4 = _dense_terms5(w.ks, i)
            rc[2, i] = h2
            rc[3, i] = h3 + h4
            rc[4, i] = -h4
        else:
            rc[2, i], rc[3, i] = _dense_terms(w.k1, w.k2, w.k3, w.k4, w.k5, i)
            rc[4, i] = 0.0


@inl
def _rosenbrock_control(err, edense, hh, qexp, first, hacc, erracc, reject_last):
    """Gustafsson's predictive step control after an accepted step, limited by the dense
    output's error: ``(next step, erracc)``."""
    e = max(err, 1e-10)
    ratio = min(6.0, max(0.2, 0.9 * e**-qexp))
    if not first:
        rg = 0.9 * (hh / hacc) * (erracc / (e * e)) ** qexp
        ratio = min(ratio, min(6.0, max(0.2, rg)))
    if edense > 0.0:
        ratio = min(ratio, max(0.2, 0.9 * edense**-qexp))
    hnew = hh * ratio
    if reject_last:
        hnew = min(hnew, hh)
    return hnew, max(1e-2, e)


@inl
def _rosenbrock_retry(err, edense, hh, qexp, factored):
    """The step to try after a rejected Rosenbrock step."""
    if not factored:
        return 0.5 * hh
    if edense > 1.0:  # the dense output failed its check
        return hh * max(0.2, 0.9 * edense**-qexp)
    if err < math.inf:
        return hh * max(0.2, 0.9 * err**-qexp)
    return 0.1 * hh


@inl
def _nonstiff_test(hh, w, n_stiff, n_nonstiff):
    """Back to DOPRI5 when it would be cheaper for 5 accepted Rosenbrock steps: its stable step
    is about ``3.3 / rho`` (``rho``: the spectral radius of J, by a few power iterations
    continued from the last step's vector) at 6 evaluations, against ``hh`` at ``n + 8`` plus
    an LU here. Returns ``(stiff, n_stiff, n_nonstiff)``."""
    JT, pv, pw = w.JT, w.pv, w.pw
    n = pv.size
    rho = 0.0
    for _ in range(6):
        for i in range(n):
            pw[i] = 0.0
        for j in range(n):
            v = pv[j]
            for i in range(n):
                pw[i] += JT[j, i] * v
        nw = 0.0
        for i in range(n):
            nw += pw[i] * pw[i]
        nw = math.sqrt(nw)
        if not (nw > 0.0) or not (nw < math.inf):
            break
        rho = nw
        for i in range(n):
            pv[i] = pw[i] / nw
    if rho * hh < 3.3 * (n + 8) / 6.0:
        n_nonstiff += 1
        if n_nonstiff >= 5:
            return False, 0, 0
        return True, n_stiff, n_nonstiff
    return True, n_stiff, 0


# ============================================================================ the driver
@inner
def _records_at(upto, ph, t_rec, r, Y, out_Y, out_phase):
    """The records ``t_rec[r] <= upto`` (at the start of interval ``ph``, or at the end of the
    run) take the state ``Y``; returns the new ``r``."""
    while r < t_rec.size and t_rec[r] <= upto:
        for i in range(Y.size):
            out_Y[r, i] = Y[i]
        out_phase[r] = ph
        r += 1
    return r


# --- per method: begin ---
@jit
def _solve(y0, t_breaks, t_rec, D, W, rtol, atol, h_max, bound, stop, out_Y, out_phase, stats):
    """Shared core, pasted as each ``integrate_<method>`` by :func:`specialise` with ``_DOPRI5``
    (Dormand-Prince steps), ``_RODASP`` (Rosenbrock steps) and ``_SWITCH`` (stiffness
    switching) written as literals: each entry point compiles only its method's code."""
    if _RODASP:
        w = _work(y0, 8 if _RODAS5P else 1)
    else:  # Dormand-Prince alone: its own, smaller scratch (WorkExplicit)
        w = _work_explicit(y0)
    for i in range(5):
        stats[i] = 0
    if not (h_max > 0.0):
        h_max = math.inf
    nph = t_breaks.size - 1
    bad = _first_bad(w.Y, bound, D)
    if bad >= 0:
        _keep_stop(0, out_Y, w.Y)
        return 0, 1, t_breaks[0], bad
    # np.int64, not a literal 0: numba would otherwise also compile _records_at and _steps
    # for a Literal[int](0) argument, a second copy of the step loop (about 2 s of CPU on a
    # first run; benchmarks/bench_compile_events.py)
    r = np.int64(0)
    stiff = not _DOPRI5
    nstep = np.int64(0)
    for ph in range(nph):
        a = t_breaks[ph]
        b = t_breaks[ph + 1]
        jump(a, w.Y, ph, D, W)  # e.g. a sampled controller's new command (no-op if continuous)
        r = _records_at(a + 1e-9 * max(1.0, abs(b)), ph, t_rec, r, w.Y, out_Y, out_phase)
        if not (b > a):
            continue
        r, code, t_stop, bad, stiff, nstep = _steps(
            a, b, ph, ph == nph - 1, D, W, rtol, atol, h_max, bound, stop,
            t_rec, r, out_Y, out_phase, stats, w, stiff, nstep,
        )  # fmt: skip
        if code != 0:
            return r, code, t_stop, bad
    t_end = t_breaks[nph]
    upto = t_end + 1e-9 * max(1.0, abs(t_end))
    return _records_at(upto, nph - 1, t_rec, r, w.Y, out_Y, out_phase), 0, t_end, -1


@hot_inner
def _steps(
    a, b, ph, last_phase, D, W, rtol, atol, h_max, bound, stop,
    t_rec, r, out_Y, out_phase, stats, w, stiff, nstep,
):  # fmt: skip
    """Integrate ``[a, b]`` (interval ``ph``) from ``w.Y`` with a fresh step-size guess; returns
    ``(r, status, t_stop, bad, stiff, nstep)`` (status 0: ``b`` reached)."""
    Y, yn, f0 = w.Y, w.yn, w.f0
    t, tol = a, 1e-9 * max(1.0, abs(b))
    rhs(t, Y, ph, D, W, f0)
    # explicit steps now: a literal where the method does not switch (so numba drops the other)
    explicit = not stiff if _SWITCH else _DOPRI5
    order = 5.0 if (_RODAS5P or explicit) else 4.0
    h = _h_start(t, Y, f0, ph, D, W, rtol, atol, h_max, b - a, order, w.yt, w.k2)
    stats[2] += 2
    qexp = 0.2 if _RODAS5P else 0.25  # 1 / (q + 1), q: the Rosenbrock error estimate's order
    reject_last, first, jac_ok = False, True, False
    facold, hacc, erracc = 1e-4, 0.0, 1e-2
    n_stiff = n_nonstiff = 0
    while True:
        if stop[0] != 0:
            return r, 3, t, -1, stiff, nstep
        if nstep >= MAX_STEPS or h < 10.0 * _UROUND * max(1.0, abs(t)):
            _keep_stop(r, out_Y, Y)
            return r, 2, t, -1, stiff, nstep
        last = t + 1.01 * h >= b
        t1 = b if last else t + h
        hh, nstep = t1 - t, nstep + 1
        limit = t1 + tol if (last and last_phase) else t1 - tol
        inside = r < t_rec.size and t_rec[r] < limit  # a record falls inside the step
        explicit = not stiff if _SWITCH else _DOPRI5
        if _DOPRI5 and explicit:
            err = _dopri5_step(t, t1, hh, ph, D, W, rtol, atol, w, stats)
        elif _RODASP:
            if not jac_ok:
                _jacobian(t, ph, D, W, w, stats)
                jac_ok = True
            err, edense, factored = _rosenbrock_step(
                t, t1, hh, inside, ph, D, W, rtol, atol, w, stats, _RODAS5P
            )
        if not (err <= 1.0):
            stats[1] += 1
            if _DOPRI5 and explicit:
                h = _dopri5_retry(err, hh)
            elif _RODASP:
                h = _rosenbrock_retry(err, edense, hh, qexp, factored)
            reject_last = True
            continue
        bad = _first_bad(yn, bound, D)
        if bad >= 0:
            _keep_stop(r, out_Y, yn)
            return r, 1, t1, bad, stiff, nstep
        stats[0] += 1
        if _DOPRI5 and explicit:
            if inside:
                _dopri5_dense(hh, w)
            if _SWITCH:
                stiff, n_stiff, n_nonstiff = _stiffness_test(hh, w, n_stiff, n_nonstiff)
                first = first or stiff
            hnew, facold = _dopri5_control(err, hh, facold, reject_last)
        elif _RODASP:
            if inside:
                _rosenbrock_dense(w, _RODAS5P)
            hnew, erracc = _rosenbrock_control(
                err, edense, hh, qexp, first, hacc, erracc, reject_last
            )
            first, hacc, jac_ok = False, hh, False
            if _SWITCH:
                stiff, n_stiff, n_nonstiff = _nonstiff_test(hh, w, n_stiff, n_nonstiff)
                if not stiff:
                    facold = 1e-4
        if inside:
            r = _record(r, t_rec, limit, t, t1, hh, tol, Y, yn, w.rc, ph, out_Y, out_phase)
        for i in range(Y.size):
            Y[i] = yn[i]
            f0[i] = w.k7[i]
        t, h, reject_last = t1, min(hnew, h_max), False
        if last:
            return r, 0, t, -1, stiff, nstep
