"""Compose a :class:`ClosedLoop` from its parts into one generated, compiled module.

The generated right-hand side reads like the thesis: reference and tracking errors (2.18),
regressors (each emitted by its own class), the design's control law and compensator, the
allocation ``u = R^T u0`` (3.14) with the actuator failures, the plant's own ``dynamics``, the
signal ``q`` and the design's adaptive laws. The simulation core names no plant and no design:
every part contributes its code through a small interface (:meth:`Plant.dynamics_source`,
``Regressor.emit``, ``AdaptiveController.emit_control`` / ``emit_adapt``).

What a loop *is* decides the text; its numbers go into :class:`LoopData`. Set
``NUMBA_DISABLE_JIT=1`` to step through a generated module (printed by :func:`source_of`).
"""

from __future__ import annotations

import functools
import math
import re
import threading
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from adaptive_ftc.errors import ConfigurationError, did_you_mean
from adaptive_ftc.expressions import Expression
from adaptive_ftc.sim import codegen
from adaptive_ftc.sim.layout import (
    HEADER,
    PARAMS,
    WORK,
    Header,
    LoopLayout,
    Misc,
    RecordLayout,
    SignalTable,
)
from adaptive_ftc.sim.parts import Build, skeleton
from adaptive_ftc.sim.parts import parts as loop_parts
from adaptive_ftc.sim.parts.approximator import Approximator
from adaptive_ftc.sim.parts.failures import DFAILURE_SRC, INSTANCE_SRC
from adaptive_ftc.sim.parts.plant import Plant as PlantPart
from adaptive_ftc.sim.parts.plant import pack_plant

if TYPE_CHECKING:  # pragma: no cover - annotations only
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["Assembled", "Generator", "LoopData", "assemble", "generate", "source_of"]


class LoopData(NamedTuple):
    """The numbers of a closed loop (everything a campaign may vary without recompiling).

    Two flat arrays: the compiled right-hand side receives them on every call, and a call's
    cost grows with the number of arrays and tuple fields it passes (each array is seven
    machine words). :attr:`Assembled.layout` names the places in ``c`` (``"c:lam"``, ``"c:k"``,
    ``"c:R"``, ``"c:gains"``, ``"c:plant"``...); the tables are readable as the properties
    below. ``c`` holds, in order: the expressions' lifted constants, the settings, the design's
    gains, the plant's parameters, the failure constants, the actuator table and the
    measurement table. ``i`` holds a header (see ``_I_*``), the failure instance per (interval,
    actuator), the instance table and the sample flags.
    """

    c: np.ndarray  # every number (float64)
    i: np.ndarray  # every integer (int64)
    p: Any = ()  # the plant's parameters, only when they cannot live in ``c`` (else empty)

    def _table(self, at: int, shape: tuple[int, ...], ints: bool = False) -> np.ndarray:
        base = self.i if ints else self.c
        return base[at : at + int(np.prod(shape))].reshape(shape)

    @property
    def fphase(self) -> np.ndarray:
        """Failure instance per (interval, actuator); -1 = healthy (a view)."""
        return self._table(
            Header.head(), (int(self.i[Header.NPH]), int(self.i[Header.M])), ints=True
        )

    @property
    def inst(self) -> np.ndarray:
        """Per failure instance: [kind (0 affine, 1 incipient affine, 2 a pattern of t
        alone, 3 any other pattern), offset of its numbers in ``c``, addresses of the
        pattern's compiled value and slope (kinds 2, 3)] (a view)."""
        return self._table(int(self.i[Header.INST]), (int(self.i[Header.NINST]), 4), ints=True)

    @property
    def samp(self) -> np.ndarray:
        """Per interval: 1 where it starts at a controller sample (digital control; a view)."""
        return self._table(int(self.i[Header.SAMP]), (int(self.i[Header.NPH]),), ints=True)

    @property
    def act(self) -> np.ndarray:
        """Per (interval, actuator): [tau, rate, lower, upper, omega, zeta] (a view)."""
        return self._table(
            int(self.i[Header.ACT]), (int(self.i[Header.NPH]), int(self.i[Header.M]), 6)
        )

    @property
    def meas(self) -> np.ndarray:
        """Per (interval, state): measurement offset, bias + noise (sensors; a view)."""
        return self._table(
            int(self.i[Header.MEAS]), (int(self.i[Header.NPH]), int(self.i[Header.NX]))
        )


# the layout's names (sim/layout.py): the header of ``LoopData.i``, the work buffers
_HEADER = HEADER
_WORK = WORK
# the former names of the header's places, for code written against them (new code: Header)
_I_NPH, _I_M, _I_NX, _I_NINST, _I_INST, _I_SAMP, _I_ACT, _I_MEAS = tuple(Header)[:8]
_I_ENV, _I_NENV, _I_RHS, _I_JUMP, _I_GAIN, _I_SIGT, _I_PH0 = tuple(Header)[8:]
_I_HEAD = Header.head()


@dataclass
class Generator:
    """Collects the text and the numbers of one closed loop while its parts emit their code."""

    loop: ClosedLoop
    sdot: str
    consts: list[float] = field(default_factory=list)
    imports: dict[str, str] = field(default_factory=dict)  # alias -> "module:function"
    inject: dict[str, object] = field(default_factory=dict)
    checked: set[str] = field(default_factory=set)
    defs: list[str] = field(default_factory=list)  # generated functions
    centers: list[float] = field(default_factory=list)
    spread: list[float] = field(default_factory=list)
    n_mu: int = 0
    n_w: int = 0
    y0_extra: list[float] = field(default_factory=list)
    adaptive_names: list[str] = field(default_factory=list)
    classes: set[str] = field(default_factory=set)  # aliases of imported classes
    #: lines that depend on t alone, run once per distinct t (with the reference): a
    #: Rosenbrock step evaluates its Jacobian's columns at one t
    per_time: list[str] = field(default_factory=list)
    #: what the controller reads of state ``i`` (generated code; a decimation filter's mean,
    #: sim/parts/decimation.py)
    measured: str = "x[i] + meas(ph, i, D)"
    #: the last controller states that keep running while adaptation is frozen (filters of
    #: the constraint-aware option)
    free_running: int = 0
    #: lines of the constraint-aware option inside the allocation's loop over the actuators
    #: (after ``acc = sum_i R_ij u0_i``; ``j`` the actuator)
    allocate_lines: list[str] = field(default_factory=list)

    # sizes fixed by the plant
    @property
    def nx(self) -> int:
        return self.loop.plant.n_states

    @property
    def p(self) -> int:
        return self.loop.plant.n_outputs

    @property
    def m(self) -> int:
        return self.loop.plant.n_actuators

    def use(self, alias: str, func, *, checked: bool = False) -> str:
        """Make the plain-Python part function ``func`` available, jitted, as ``alias``.

        ``checked``: compile with bounds checking (user code: an index error becomes an
        exception instead of a memory error).
        """
        if checked:
            self.checked.add(alias)
        func = getattr(func, "py_func", func)  # accept numba dispatchers too
        where = _importable(func)
        if where:
            self.imports[alias] = where
        else:
            self.inject[f"_py_{alias}"] = func
            self.imports[alias] = ""
        return alias

    def use_class(self, alias: str, cls: type) -> str:
        """Make the class ``cls`` (a NamedTuple of numbers) available as ``alias``."""
        where = _importable(cls)
        self.classes.add(alias)
        self.imports[alias] = where
        if not where:
            self.inject[alias] = cls
        return alias

    def constant_block(self, node, names: dict[str, str], share_from: int | None = None) -> str:
        """Text of an expression whose numbers sit at a fixed place of ``c``."""
        return codegen.emit_at(node, names, self.consts, share_from=share_from)

    def signal(self, name: str, where: str) -> int:
        names = self.loop.signal_names()
        if name not in names:
            raise ConfigurationError(
                f"Unknown regressor input '{name}' in {where}.{did_you_mean(name, names)} "
                f"Available signals: {', '.join(names)}."
            )
        return names[name]


_importable = codegen.importable


@dataclass(frozen=True)
class Assembled:
    """A closed loop ready to run: its compiled module, its numbers and its state layout."""

    module: Any
    data: LoopData
    y0: np.ndarray
    breakpoints: tuple[float, ...]
    adaptive_names: tuple[str, ...]
    theta_slices: tuple[slice, ...]
    n_x: int
    #: where everything lives: named states (``layout["y:held_command"]``: a digital
    #: controller's held command), parameters (``layout["c:lam"]``), work buffers
    #: (``layout["w:ref"]``) and recorded columns
    layout: LoopLayout
    source: str = field(repr=False, default="")
    #: names of the states after the controller's: actuator positions, held command and held
    #: controller derivatives (digital control)
    extra_names: tuple[str, ...] = ()

    def work(self) -> np.ndarray:
        """A fresh work array for one run (never shared between threads)."""
        return np.zeros(self.layout.work_size)

    def integrator(self, method: str):
        """The compiled ``integrate_<method>`` (``rk4``, ``dopri5``, ``rodasp``, ``rodas5p``,
        ``auto``): shared by every loop, it calls this loop's ``rhs`` and ``jump`` through the
        addresses in ``data.i`` (see :func:`integrators`)."""
        return getattr(self._shared(), f"integrate_{method}")

    def _shared(self):
        """The shared compiled module, once this loop's addresses are known to be set."""
        i = self.data.i
        # a call to address 0 crashes (a jump of 0: none)
        if not (i[Header.RHS] and i[Header.GAIN]):
            raise ConfigurationError(
                "This loop's data holds no compiled rhs/control-gain addresses (made or copied "
                "outside assemble(), or unpickled in another process): call assemble(loop) here."
            )
        return integrators()

    def derivative(self, t: float, y: np.ndarray, phase: int) -> np.ndarray:
        """Closed-loop derivative at ``(t, y)`` in failure phase ``phase`` (allocating)."""
        dY = np.zeros(self.y0.size)
        y = np.ascontiguousarray(y, dtype=float)
        self.module.rhs(float(t), y, int(phase), self.data, self.work(), dY)
        return dY

    def regressor_values(self, t: float, y: np.ndarray, phase: int = 0) -> np.ndarray:
        """All regressor values ``Pi`` at ``(t, y)`` (a copy), e.g. to check a regressor."""
        W = self.work()
        y = np.ascontiguousarray(y, dtype=float)
        self.module.rhs(float(t), y, int(phase), self.data, W, np.zeros(self.y0.size))
        return W[self.layout.work["phi"]].copy()

    def signals(
        self,
        T: np.ndarray,
        Y: np.ndarray,
        phases: np.ndarray,
        out: np.ndarray,
        *,
        lean: bool = False,
    ) -> int:
        """Recompute the recorded signals into ``out`` (the shared ``signals`` of
        ``templates/record.py``, which calls this loop's ``rhs`` and its plant's
        ``control_gain``); returns the first row outside the plant's envelope (-1: none).
        ``lean``: only the tracking errors, commands and applied commands, into the narrow
        block of :func:`~adaptive_ftc.sim.result.lean_signal_block` (``simulate``'s
        ``lean_signals``)."""
        m = int(self.data.i[Header.M])
        # lean: a dY one longer than the state, so that rhs stops once the commands are known
        # (parts/skeleton.py)
        dY = np.zeros(self.y0.size + 1 if lean else self.y0.size)
        scratch = (dY, np.zeros(m), np.zeros(self.n_x), np.zeros(self.n_x))
        shared = self._shared()
        return int(shared.signals(T, Y, phases, self.data, self.work(), out, *scratch, int(lean)))


# the plant's part of the recorded signals (one module per plant, _gain_module_source): the
# shared ``signals`` (templates/record.py) calls it by address once per recorded row, after
# the loop's ``rhs`` (which left u in W)
_CONTROL_GAIN = f'''@hot_inner
def control_gain(t, Y, ph, D, W, unit, x0dot, x1dot):
    """sum_j g_j R_0j df_j/du: the true control gain of output 1 along the allocation (g_j:
    the rate of output 1 per unit command of actuator j; df_j/du: its failure's slope)."""
    c = D.c
    s = D.i[I_SIGT]
    v0 = D.i[s + {int(SignalTable.POS)} + D.i[s]]  # VEL[0]
    U = D.i[s + {int(SignalTable.U)}]
    RMAT = D.i[s + {int(SignalTable.RMAT)}]
    u = W[U : U + M]
    x = Y[:NX]
    gain = 0.0
    # j = -1: the plant's rate at zero command (x0dot); then with each unit command. One
    # call site: numba pastes the plant's equations once
    for j in range(-1, M):
        for i in range(M):
            unit[i] = 0.0
        if j >= 0:
            unit[j] = 1.0
        plant_dynamics(t, x, unit, plant_params(D), x0dot if j < 0 else x1dot)
        if j < 0:
            continue
        gj = x1dot[v0] - x0dot[v0]
        k = instance(ph, j, D)
        df = 1.0 if k < 0 else dfailure(k, t, x, u[j], D)
        gain += gj * c[RMAT + j] * df
    return gain'''


# ----------------------------------------------------------------------------- integrators
_INTEGRATORS_HEAD = '''"""The integrators shared by every closed loop (written by sim/compose.py).

A loop's ``rhs`` and ``jump`` are called through the addresses in ``D.i`` (sim/fptr.py), so
this module compiles once per machine and numba version, not once per loop structure; the
envelope check reads its bounds from ``D`` as well.
"""
# ruff: noqa
import math

import numpy as np
from numba import njit

from adaptive_ftc.controllers.laws import filtered_error
from adaptive_ftc.sim.fptr import call_gain, call_jump, call_rhs, python_function
from adaptive_ftc.sim.optlevel import at_loop_level
from numba.core.config import DISABLE_JIT

jit = at_loop_level(njit(cache=CACHE, nogil=True, error_model="numpy"))
hot = at_loop_level(njit(cache=CACHE, nogil=True, error_model="numpy", _nrt=False))
inl = njit(nogil=True, error_model="numpy", _nrt=False, inline="always")
# inner, hot_inner: functions only compiled code calls (never Python): numba builds no Python
# or C entry wrapper for them (less to lower and optimise on a first run; from Python: fails)
_INNER = dict(cache=CACHE, nogil=True, error_model="numpy")
_INNER.update(no_cpython_wrapper=True, no_cfunc_wrapper=True)
inner = at_loop_level(njit(**_INNER))
hot_inner = at_loop_level(njit(_nrt=False, **_INNER))
filtered_error = inl(filtered_error)

{constants}


if not DISABLE_JIT:
    # hot, not inl: pasted into an integrator that counts references (the adaptive-step ones
    # allocate), the arrays passed would be counted at every call (measured: DOPRI5 30 % slower)
    @hot_inner
    def rhs(t, Y, ph, D, W, dY):
        """The loop's right-hand side, compiled in the loop's own module (``ph``: the
        interval of this call, the loop's interval ``ph + D.i[I_PH0]``)."""
        call_rhs(D.i[I_RHS], t, Y, ph + D.i[I_PH0], D, W, dY)

    @hot_inner
    def jump(t, Y, ph, D, W):
        """The loop's state update at the start of interval ``ph`` (address 0: a continuous
        loop, which has none, or a caller that runs the updates itself)."""
        if D.i[I_JUMP] != 0:
            call_jump(D.i[I_JUMP], t, Y, ph + D.i[I_PH0], D, W)

    @hot_inner
    def control_gain(t, Y, ph, D, W, unit, x0dot, x1dot):
        """The loop's control gain at a recorded row (for signals)."""
        return call_gain(D.i[I_GAIN], t, Y, ph, D, W, unit, x0dot, x1dot)

else:  # NUMBA_DISABLE_JIT=1: the same calls, in Python, to the loop's Python functions

    def rhs(t, Y, ph, D, W, dY):
        python_function(D.i[I_RHS])(t, Y, ph + D.i[I_PH0], D, W, dY)

    def jump(t, Y, ph, D, W):
        if D.i[I_JUMP] != 0:
            python_function(D.i[I_JUMP])(t, Y, ph + D.i[I_PH0], D, W)

    def control_gain(t, Y, ph, D, W, unit, x0dot, x1dot):
        return python_function(D.i[I_GAIN])(t, Y, ph, D, W, unit, x0dot, x1dot)


@hot_inner
def leaves_envelope(Y, D):
    """Index of the first plant state outside the plant's envelope, else -1."""
    at = D.i[I_ENV]
    for i in range(D.i[I_NENV]):
        if not (abs(Y[i]) <= D.c[at + i]):
            return i
    return -1
'''

_INTEGRATORS_IMPORTS = [
    "adaptive_ftc.controllers.laws",
    "adaptive_ftc.sim.fptr",
    "adaptive_ftc.sim.optlevel",
]


def _integrators_source() -> str:
    constants = "\n".join(
        [
            *(f"I_{name} = {k}" for k, name in enumerate(_HEADER)),
            *(f"SIGT_{t.name} = {int(t)}" for t in SignalTable),
            *(f"MISC_{slot.name} = {int(slot)}" for slot in Misc),
        ]
    )
    return "\n\n".join(
        [
            _INTEGRATORS_HEAD.format(constants=constants),
            codegen.template("rk4"),
            codegen.template("adaptive"),
            codegen.template("record"),
        ]
    )


@functools.cache
def integrators():
    """The module of the shared compiled integrators (generated, cached on disk like a loop;
    ``load_module`` gives every caller the same module, threads included)."""
    return codegen.load_module(
        _integrators_source(), imports=_INTEGRATORS_IMPORTS, kind="integrators"
    )


def _addresses(module, gain_module, data: LoopData) -> tuple[int, int, int]:
    """Addresses of ``module``'s compiled ``rhs`` and ``jump`` and ``gain_module``'s
    ``control_gain`` for ``data``'s types (compiled or loaded from the cache on first use;
    remembered on the modules)."""
    import numba

    from adaptive_ftc.sim import fptr

    dtype = numba.typeof(data)
    memo = module.__dict__.setdefault("_ADDRESSES", {})
    found = memo.get(dtype)
    if found is None:
        found = memo[dtype] = (
            fptr.address(module.rhs, fptr.signature_rhs(dtype)),
            # a continuous loop's jump does nothing: not compiled, address 0 (the integrators
            # then call none: about 0.05 s of compile saved per continuous structure)
            0
            if getattr(module, "CONTINUOUS", False)
            else fptr.address(module.jump, fptr.signature_jump(dtype)),
        )
    gmemo = gain_module.__dict__.setdefault("_ADDRESSES", {})
    gain = gmemo.get(dtype)
    if gain is None:
        gain = gmemo[dtype] = fptr.address(gain_module.control_gain, fptr.signature_gain(dtype))
    return (*found, gain)


# ----------------------------------------------------------------------------- generation
def _intervals(
    loop: ClosedLoop, readings: int = 1
) -> tuple[tuple[float, ...], np.ndarray, np.ndarray]:
    """Break times of the integration, whether each interval starts at a controller/sensor
    sample, and the sample index of each interval.

    The failure times always break the integration; a digital controller (or noise held at the
    sensor rate) adds the sample instants ``t0 + k T``. A controller with a decimation filter
    (``readings`` = ``N`` >= 2 sensor readings per sample) adds every reading instant ``t0 + j
    T/N``: its flag is 1 at a sample (``j`` a multiple of ``N``), 2 at a reading between two
    (:mod:`adaptive_ftc.sim.parts.decimation`), and its sample index ``j // N``.
    """
    t0, t1 = float(loop.t0), float(loop.t_final)
    fail = _with_annunciations(loop, loop.failures.breakpoints(t0, t1))
    period = loop.sample_time / readings if readings > 1 else loop.sample_time
    if not period and loop.sensors is not None and loop.sensors.has_noise:
        period = 1.0 / float(loop.sensors.rate)
    if not period:
        nph = len(fail) - 1
        return fail, np.zeros(nph, dtype=np.int64), np.zeros(nph, dtype=np.int64)
    n = int(math.floor((t1 - t0) / period + 1e-9))
    grid = t0 + period * np.arange(n + 1)
    tol = 1e-9 * max(1.0, abs(t1))
    grid = grid[grid < t1 - tol]
    # a failure time within rounding of a sample instant is that instant: such grid points
    # are dropped and the failure time kept (the failure times are few, the grid is long)
    fail_arr = np.asarray(fail, dtype=float)
    near = np.searchsorted(fail_arr, grid)
    close = np.zeros(grid.size, dtype=bool)
    for shift in (-1, 0):
        j = np.clip(near + shift, 0, fail_arr.size - 1)
        close |= np.abs(fail_arr[j] - grid) <= tol
    times = np.union1d(fail_arr, grid[~close])
    keep = np.ones(times.size, dtype=bool)
    keep[:-1] = np.diff(times) > tol  # failure times within rounding: the last one stands
    bps = tuple(float(t) for t in times[keep])
    starts = np.asarray(bps[:-1])
    k = np.floor((starts - t0) / period + 1e-9).astype(np.int64)
    on_grid = np.abs(starts - (t0 + k * period)) <= tol
    if readings > 1:  # 1 at a sample, 2 at a reading between samples; the sample's index
        flags = np.where(k % readings == 0, 1, 2) * on_grid
        return bps, flags.astype(np.int64), k // readings
    return bps, on_grid.astype(np.int64), k


def _failures(loop: ClosedLoop, m: int, variables: tuple[str, ...], names: dict[str, str], bps):
    """The per-interval instance table and, per failure instance, its kind, numbers and (for
    a pattern that is not affine) the text of its pattern and slope.

    Affine failures (kinds 0 and 1) are evaluated in the loop itself; any other pattern
    (kind 2: of ``t`` alone, remembered per actuator while ``t`` stays the same; kind 3: of the
    states or ``u`` too) is compiled in a small module of its own and called through the
    address that :func:`assemble` writes into the instance table. So the loop's text does not
    depend on which failures it has: a structure compiles once whatever the scenario's
    failure patterns, and each pattern text once (both cached on disk).
    """
    nph = len(bps) - 1
    fphase = -np.ones((nph, m), dtype=np.int64)
    kinds: list[int] = []
    offsets: list[int] = []
    patterns: list[tuple[str, str, str] | None] = []
    consts: list[float] = []
    seen: dict[int, int] = {}
    # every failure of the schedule, active in this window or not: a shortened run (quick
    # mode, a test) shares the numbers' layout of the full one
    for f in (*loop.failures.failures, *loop.dormant_failures):
        ctx = f"{type(f).__name__} on actuator {f.actuator} (onset {f.onset:g} s)"
        e = f.expression(variables, context=ctx)
        raw = Expression(f.pattern(), variables, context=ctx) if f.ramp > 0 else e
        draw = raw.derivative("u")
        pattern = None
        if raw.used <= {"u"} and draw.is_constant:
            # a*u + b with constant a, b (loss of effectiveness, stuck, bias, affine,
            # reversal), abrupt or incipient
            a_, b_ = float(draw.node[1]), float(raw(u=0.0))
            if f.ramp > 0:
                kind, numbers = 1, [float(f.onset), float(f.ramp), 1.0, a_, b_]
            else:
                kind, numbers = 0, [a_, b_]
        else:
            local: list[float] = []
            text = codegen.emit(e.node, names, local)
            dlocal: list[float] = []
            dtext = codegen.emit(e.derivative("u").node, names, dlocal)
            # the pattern at u = uh (the same numbers as the pattern's: the same tree): the
            # slope's central difference where the derivative is undefined
            htext = codegen.emit(e.node, {**names, "u": "uh"}, [])
            # the slope's numbers follow the pattern's
            pattern, numbers = (text, _shift(dtext, len(local)), htext), local + dlocal
            kind = 3 if re.search(r"\b(u|x)\b", text) else 2
        seen[id(f)] = len(kinds)
        kinds.append(kind)
        offsets.append(len(consts))
        patterns.append(pattern)
        consts.extend(numbers)
    # the failure acting on each actuator in each interval (at its midpoint; a later failure
    # of the schedule on the same actuator wins, as in FailureSchedule.active)
    edges = np.asarray(bps, dtype=float)
    mids = 0.5 * (edges[:-1] + edges[1:])
    for f in loop.failures.failures:
        fphase[(f.onset <= mids) & (mids < f.end), f.actuator - 1] = seen[id(f)]
    return bps, fphase, kinds, offsets, patterns, consts


_PATTERN_IMPORTS = ["adaptive_ftc.sim.mathlib", "adaptive_ftc.sim.fptr"]


def _pattern_source(text: str, dtext: str, htext: str) -> str:
    """The module of one failure pattern (not affine): its value and its slope in ``u``
    (``htext``: the pattern at ``u = uh``, for the slope where its derivative is undefined)."""
    guarded = _guarded()
    return "\n".join(
        [
            '"""A failure pattern, compiled on its own (written by sim/compose.py); loops call',
            'it through its address (sim/fptr.py), so it compiles once, whatever the loop."""',
            "# ruff: noqa",
            "import math",
            "",
            "from numba import cfunc, njit",
            "from numba.core.config import DISABLE_JIT",
            "",
            "from adaptive_ftc.sim.fptr import SIGNATURE_PATTERN",
            "from adaptive_ftc.sim.mathlib import " + ", ".join(guarded),
            "",
            "# C functions (x and c are pointers): the loop calls them as reading memory only",
            "hot = (lambda f: f) if DISABLE_JIT else cfunc(",
            '    SIGNATURE_PATTERN, cache=CACHE, error_model="numpy", nopython=True',
            ")",
            'inl = njit(nogil=True, error_model="numpy", _nrt=False, inline="always")',
            *[f"{name} = inl({name})" for name in guarded],
            "",
            "",
            "@hot",
            "def value(t, x, u, c, o):",
            '    """The failed output (its numbers in c from o on)."""',
            f"    return {text}",
            "",
            "",
            "@hot",
            "def slope(t, x, u, c, o):",
            '    """d(failed output)/du; where it is undefined (a kink: sqrt(u**2), abs(u)**0.5',
            "    at u = 0) the central difference over 2e-6 max(1, |u|), so that the recorded",
            '    control gain stays finite."""',
            f"    d = {dtext}",
            "    if math.isfinite(d):",
            "        return d",
            "    h = 1e-6 * max(1.0, abs(u))",
            "    uh = u + h",
            f"    above = {htext}",
            "    uh = u - h",
            f"    below = {htext}",
            "    return (above - below) / (2.0 * h)",
            "",
        ]
    )


def _pattern_addresses(pattern: tuple[str, str, str]) -> tuple[int, int]:
    """Addresses of the compiled ``value`` and ``slope`` of ``pattern`` (its module compiled
    or loaded from the cache on first use; remembered on the module)."""
    from adaptive_ftc.sim import fptr

    module = codegen.load_module(
        _pattern_source(*pattern), imports=_PATTERN_IMPORTS, kind="pattern"
    )
    found = module.__dict__.get("_ADDRESSES")
    if found is None:
        found = (fptr.address(module.value), fptr.address(module.slope))
        module._ADDRESSES = found  # type: ignore[attr-defined]  # remembered on the module
    return found


def _shift(text: str, by: int) -> str:
    return re.sub(r"c\[o \+ (\d+)\]", lambda mt: f"c[o + {int(mt.group(1)) + by}]", text)


def _module_header(g: Generator, title: str, *, laws: bool) -> tuple[list[str], list[str]]:
    """The head of a generated module (docstring, imports of the parts ``g`` collected, the
    decorators) and the modules whose source keys its cache."""
    imports = [
        "import math",
        "",
        "import numpy as np",
        "from numba import njit",
        "",
        *(["from adaptive_ftc.controllers.laws import " + ", ".join(_LAWS)] if laws else []),
        "from adaptive_ftc.sim.fptr import call_pattern",
        "from adaptive_ftc.sim.mathlib import " + ", ".join(_guarded()),
        "from adaptive_ftc.sim.optlevel import at_loop_level",
    ]
    jits = [*(_LAWS if laws else ()), *_guarded()]
    mods = [
        *(["adaptive_ftc.controllers.laws"] if laws else []),
        "adaptive_ftc.sim.mathlib",
        "adaptive_ftc.sim.fptr",
    ]
    for alias, target in sorted(g.imports.items()):
        if alias in g.classes:
            if target:
                mod, cls = target.split(":")
                imports.append(f"from {mod} import {cls} as {alias}")
                mods.append(mod)
            continue
        if target:
            mod, fn = target.split(":")
            owner, _, attr = fn.partition(".")
            if attr:  # a function kept by the decorated object that took its name
                imports.append(f"from {mod} import {owner} as _owner_{alias}")
                imports.append(
                    f"_py_{alias} = getattr(_owner_{alias}.{attr}, 'py_func', "
                    f"_owner_{alias}.{attr})"
                )
            else:
                imports.append(f"from {mod} import {fn} as _py_{alias}")
            mods.append(mod)
        jits.append(alias)
    header = [
        f'"""{title}',
        "",
        "Written by adaptive_ftc.sim.compose; numbers live in LoopData, not here.",
        '"""',
        "# ruff: noqa",
        *imports,
        "",
        "# jit: functions that allocate; hot: the right-hand side and its parts, which never",
        "# allocate and so run without reference counting (the generated code's inner loop)",
        "# both compile at the loops' LLVM level (adaptive_ftc.sim.optlevel: -O2)",
        'jit = at_loop_level(njit(cache=CACHE, nogil=True, error_model="numpy"))',
        'hot = at_loop_level(njit(cache=CACHE, nogil=True, error_model="numpy", _nrt=False))',
        "# hot_inner: a hot function only compiled code calls (by its address): no Python or C",
        "# entry wrapper is built for it (less to compile on a first run)",
        'hot_inner = at_loop_level(njit(cache=CACHE, nogil=True, error_model="numpy", '
        "_nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True))",
        "# inl: small helpers and the parts' functions, pasted by numba into every caller (no",
        "# call, no compilation of their own): loops run 7-12 % faster and compile sooner",
        'inl = njit(nogil=True, error_model="numpy", _nrt=False, inline="always")',
        "_part = inl",
        '_user_part = njit(nogil=True, error_model="numpy", _nrt=False, boundscheck=True)',
    ]
    for name in jits:
        src = f"_py_{name}" if name in g.imports else name
        deco = "_user_part" if name in g.checked else "_part"
        header.append(f"{name} = {deco}({src})")
    return header, mods


_LAWS = ("filtered_error", "robust_q", "weighted_sum")


def _gain_module_source(loop: ClosedLoop, sdot: str) -> tuple[str, list[str], dict]:
    """The module of ``loop``'s plant that computes the recorded control gain (its
    ``control_gain``, called by the shared ``signals`` through its address), with the modules
    that key its cache and the parts to inject.

    It depends on the plant alone (the loop's sizes and places are read from ``D.i``), so
    every design on one plant shares it: 6 compiles for the catalogue's 22 loops instead of
    22 (0.25-0.6 s each).
    """
    plant = loop.plant
    g = Generator(loop=loop, sdot=sdot)
    plant_src = plant.dynamics_source(g)
    _, plant_expr = pack_plant(g, plant.parameter_values())
    header, mods = _module_header(
        g, f"Generated control gain of plant {plant.name!r} (any design).", laws=False
    )
    consts = "\n".join(
        [
            "# the header of D.i (sizes, where the tables start)",
            *[f"I_{name} = {k}" for k, name in enumerate(_HEADER)],
            f"I_HEAD = {Header.head()}",
            f"NX = {g.nx}",
            f"M = {g.m}",
        ]
    )
    tables = "\n".join(
        [
            "@inl",
            "def plant_params(D):",
            '    """The plant parameters (at the place in D.c named by the signal table)."""',
            "    c = D.c",
            "    s = D.i[I_SIGT]",
            f"    PLANT = D.i[s + {int(SignalTable.POS)} + 2 * D.i[s]]",
            f"    return {plant_expr}",
            "",
            "",
            INSTANCE_SRC,
        ]
    )
    parts = ["\n".join(header), consts, *([plant_src] if plant_src else []), *g.defs]
    parts += [tables, DFAILURE_SRC, _CONTROL_GAIN]
    return "\n\n".join(parts) + "\n", mods, dict(g.inject)


@dataclass(frozen=True)
class _Structure:
    """What :func:`generate` derives from a loop's structure and its parts' numbers, not from
    its failures, times or initial state (shared by loops that differ only in those)."""

    text: str
    g: Generator
    layout: dict
    values: tuple[float, ...]  # D.c up to the failures' numbers
    variables: tuple[str, ...]
    names: dict[str, str]
    has_act: bool
    has_meas: bool
    sampled: bool
    sig_table: tuple[int, ...]
    plant_p: tuple
    #: sensor readings per sample a decimation filter averages (1 = none)
    readings: int = 1
    #: what :func:`assemble` loads for this structure (its modules, the compiled addresses)
    loaded: dict = field(default_factory=dict)


#: recently generated structures: key (the parts' ids, ...) -> (the parts, _Structure); an
#: entry keeps its parts alive, so no other object can take their ids while it is kept
_structures: OrderedDict = OrderedDict()
_STRUCTURES_KEPT = 32
_structures_lock = threading.Lock()


def generate(loop: ClosedLoop, *, sdot: str = "exact"):
    """Generate the module text and the numbers of ``loop`` (see :func:`assemble`).

    The text and the numbers of the loop's parts are remembered for the last few structures
    whose parts are immutable (hashable frozen dataclasses, compared by identity): a batch of
    loops that differ only in failures, times or initial state (``simulate_many``, campaigns)
    generates its text once. Measured: 0.3 of the 0.4 ms of an assemble on
    hypersonic-direct-s1.
    """
    parts = (loop.plant, loop.controller, loop.actuators, loop.sensors)
    try:
        key = (
            *map(id, parts),
            loop.allocation,
            loop.reference,
            bool(loop.adapt),
            float(loop.sample_time),
            loop.has_actuator_dynamics,
            sdot,
            loop.allocator,
        )
        hash(key)
    except TypeError:  # an unhashable allocation or reference: not remembered
        key = None
    st = None
    if key is not None:
        with _structures_lock:
            st = _structures.get(key, (None, None))[1]
    if st is None:
        st = _structure(loop, sdot)
        if key is not None and _immutable(parts):
            with _structures_lock:
                _structures[key] = (parts, st)
                while len(_structures) > _STRUCTURES_KEPT:
                    _structures.popitem(last=False)
    return _numbers(loop, st)


def _immutable(parts) -> bool:
    """Whether ``parts`` hash (frozen dataclasses of numbers, strings and tuples: nothing in
    them can change in place)."""
    try:
        hash(parts)
    except TypeError:
        return False
    return True


def _structure(loop: ClosedLoop, sdot: str) -> _Structure:
    """The failure-independent part of :func:`generate`: the parts of ``loop`` emit their
    code into the skeleton (``sim/parts/skeleton.py``), then the layout of their numbers,
    states and work buffers is written into the module's constants."""
    plant, ctrl = loop.plant, loop.controller.bound(loop)  # constraint-aware: from the loop
    g = Generator(loop=loop, sdot=sdot)
    b = Build(g=g, loop=loop, ctrl=ctrl, sdot=sdot)
    # expression variables: t, u and the plant states by every alias
    aliases = plant.aliases()
    variables = ("t", "u", *aliases)
    names = {"t": "t", "u": "u", **{a: f"x[{i}]" for a, i in aliases.items()}}
    members = loop_parts()
    for part in members:
        part.build(b)
    body = skeleton.rhs_lines(b, members)
    jump_src = skeleton.jump_source(b, members)
    tables_src = "\n\n\n".join(t for part in members for t in part.tables(b))
    title = (
        f"Generated closed loop: plant {plant.name!r}, design {ctrl.code_label()}, "
        f"{g.p} output(s), {g.m} actuator(s), s' {sdot}."
    )
    header, mods = _module_header(g, title, laws=True)
    text_parts = [
        "\n".join(header),
        *[f for part in members for f in part.functions(b)],
        *g.defs,
        *[f for part in members for f in part.helpers(b)],
        "\n".join(skeleton.used_views(body)),
        jump_src,
        tables_src,
    ]
    params = {k: v for part in members for k, v in part.params(b).items()}
    values, param_at = _param_layout(g, params)
    work = _work_layout(b, ny_all=b.states.size)
    pos, vel = plant.position_index, plant.velocity_index
    consts_lines = _constants(param_at, work, g, pos, vel)
    text = "\n\n".join([text_parts[0], "\n".join(consts_lines), *text_parts[1:]]) + "\n"
    ny = b.states.controller_stop
    loop_layout = LoopLayout(
        states=dict(b.states.blocks),
        params=param_at,
        work=work,
        records=RecordLayout(p=g.p, m=g.m),
        extra_names=b.states.labels_after(ny),
        n_states=b.states.size,
        adaptive=slice(g.nx, ny),
    )
    sig_table = loop_layout.signal_table(pos, vel)
    approximator = next(part for part in members if isinstance(part, Approximator))
    plant_part = next(part for part in members if isinstance(part, PlantPart))
    layout: dict = dict(loop_layout.items())  # "c:<param>", "w:<buffer>"
    layout.update(
        loop_layout=loop_layout,
        ny=ny,
        ny_all=b.states.size,
        at_act=b.states["actuator_position"].start,
        extra_names=loop_layout.extra_names,
        filt=b.states["s_filter"].start,
        n_phi=approximator.n_phi,
        theta_slices=tuple(approximator.theta_slices),
        mods=mods,
        gain=_gain_module_source(loop, sdot),
    )
    return _Structure(
        text=text,
        g=g,
        layout=layout,
        values=tuple(values),
        variables=variables,
        names=names,
        has_act=b.has_act,
        has_meas=b.has_meas,
        sampled=b.sampled,
        sig_table=tuple(sig_table),
        plant_p=plant.parameter_values() if plant_part.expr == "D.p" else (),
        readings=b.readings,
    )


def _param_layout(g: Generator, params: dict) -> tuple[list[float], dict[str, slice]]:
    """``D.c`` up to the failures' numbers: the expressions' constants (their indices are in
    the text), then the parts' named blocks in the order of :data:`layout.PARAMS`."""
    values = list(g.consts)
    at: dict[str, slice] = {}
    for key in PARAMS:
        if key not in params:
            continue
        vals = params[key]
        at[key] = slice(len(values), len(values) + len(vals))
        values.extend(float(v) for v in vals)
    return values, at


def _work_layout(b: Build, *, ny_all: int) -> dict[str, slice]:
    """The buffers of the work array ``W`` (:data:`layout.WORK`) with their sizes."""
    nx, p, m, g = b.nx, b.p, b.m, b.g
    sizes = {
        "sig": nx + 3 * p,
        "phi": max(_size(b.states["theta"]), 1),
        "mu": max(g.n_mu, 1),
        "u0": p,
        "u": m,
        "uf": m,
        "xdot": nx,
        "ref": 3 * p,
        "q": p,
        "misc": Misc.size(),
        "wb": max(g.n_w, 1),
        "scr": ny_all if (b.sampled or b.has_act) else 1,
        "fc": 3 * m,
    }
    sizes.update(b.work)  # the parts' own buffers (an allocator's), after those
    work, at = {}, 0
    for name in (*_WORK, *b.work):
        work[name] = slice(at, at + sizes[name])
        at += sizes[name]
    return work


def _size(where: slice) -> int:
    return where.stop - where.start


def _constants(param_at: dict, work: dict, g: Generator, pos, vel) -> list[str]:
    """The constants at the head of a loop's module: the places of the parameters in ``D.c``
    and of the buffers in ``W``, the header of ``D.i``, the sizes and the outputs' states."""
    lines = ["# places of the settings in D.c (the expressions' numbers come first)"]
    lines += [f"{PARAMS[key]} = {where.start}" for key, where in param_at.items()]
    lines.append("# places of the buffers in the work array W")
    for name, where in work.items():
        lines += [
            f"{name.upper()} = {where.start}",
            f"N_{name.upper()} = {where.stop - where.start}",
        ]
    return lines + [
        "# the header of D.i: sizes, then where the tables start (in D.i or D.c)",
        *[f"I_{name} = {k}" for k, name in enumerate(_HEADER)],
        f"I_HEAD = {Header.head()}",
        f"NX = {g.nx}",
        f"P = {g.p}",
        f"M = {g.m}",
        f"POS = {tuple(pos)!r}",
        f"VEL = {tuple(vel)!r}",
    ]


def _numbers(loop: ClosedLoop, st: _Structure):
    """:func:`generate`'s result for ``loop`` from its structure ``st``: the failures,
    intervals and tables of ``loop`` itself."""
    g = st.g
    nx, m = g.nx, g.m
    bps, samp, sample_index = _intervals(loop, st.readings)
    bps, fphase, fkind, foff, fpatterns, fconsts = _failures(loop, m, st.variables, st.names, bps)
    fail_base = len(st.values)
    values = [*st.values, *fconsts]
    # [kind, offset, value address, slope address]: the addresses are written by assemble()
    inst = np.zeros((len(fkind), 4), dtype=np.int64)
    for n_, (kind, of) in enumerate(zip(fkind, foff, strict=True)):
        inst[n_, :2] = (kind, of + fail_base)
    nph = len(bps) - 1
    act_table = _actuator_table(loop, bps) if st.has_act else np.zeros((nph, m, 6))
    meas_table = (
        _measurements(loop, sample_index, st.readings) if st.has_meas else np.zeros((nph, nx))
    )
    act_at = len(values)
    meas_at = act_at + act_table.size
    c_all = np.concatenate([np.array(values, dtype=float), act_table.ravel(), meas_table.ravel()])
    if "c:alloc" in st.layout:  # the allocator's table of annunciated failures, per interval
        c_all = _with_known_table(loop, st.layout["c:alloc"].start, bps, m, c_all)
    inst_at = Header.head() + fphase.size
    samp_at = inst_at + inst.size
    env_at = st.layout["c:envelope"]
    header = [nph, m, nx, len(fkind), inst_at, samp_at, act_at, meas_at]
    samp_flags = (samp if st.sampled else np.zeros(nph, dtype=np.int64)).ravel()
    sigt_at = samp_at + samp_flags.size
    # the addresses are written by assemble()
    header += [env_at.start, env_at.stop - env_at.start, 0, 0, 0, sigt_at, 0]
    ints = np.concatenate(
        [
            np.array(header, dtype=np.int64),
            fphase.ravel(),
            inst.ravel(),
            samp_flags,
            np.array(st.sig_table, dtype=np.int64),
        ]
    ).astype(np.int64)
    data = LoopData(c=c_all, i=ints, p=st.plant_p)
    layout = {**st.layout, "bps": bps, "patterns": tuple(fpatterns), "loaded": st.loaded}
    return st.text, data, g, layout


def _with_annunciations(loop: ClosedLoop, times: tuple[float, ...]) -> tuple[float, ...]:
    """``times`` with the instants where the allocator learns of a failure (onset +
    detection delay) or takes a recovered actuator back: the integration restarts there (the
    fixed allocation ignores annunciations: no restart)."""
    if not loop.annunciations or loop.allocator is None:
        return times
    from adaptive_ftc.allocation.inloop import breakpoints

    return breakpoints(loop.annunciations, times, float(loop.t0), float(loop.t_final))


def _with_known_table(loop: ClosedLoop, at: int, bps, m: int, c_all: np.ndarray) -> np.ndarray:
    """``c_all`` with the per-interval table of annunciated failures appended and its place
    written at ``c[ALLOC]``."""
    from adaptive_ftc.allocation.inloop import known_table

    table = known_table(loop.annunciations, bps, m, loop.R)
    c_all[at] = float(c_all.size)
    return np.concatenate([c_all, table.ravel()])


def _actuator_table(loop: ClosedLoop, bps) -> np.ndarray:
    """``[tau, rate, lower, upper, omega, zeta]`` per (interval, actuator): the declared
    actuators, changed
    by the dynamics failures (:class:`~adaptive_ftc.faults.models.RateLimited`,
    :class:`~adaptive_ftc.faults.models.Sluggish`) in their windows."""
    from adaptive_ftc.hardware import RATE_ONLY_TAU, Actuators

    m = loop.plant.n_actuators
    base = (loop.actuators or Actuators()).table(m)
    out = np.repeat(base[None, :, :], len(bps) - 1, axis=0)
    for k in range(len(bps) - 1):
        mid = 0.5 * (bps[k] + bps[k + 1])
        for j, f in enumerate(loop.failures.active(mid)):
            change = getattr(f, "dynamics", None)
            if change is None:
                continue
            row = out[k, j]
            for key, v in change().items():
                row[{"tau": 0, "rate": 1, "omega": 4}[key]] = v
            if row[0] == 0.0 and row[4] == 0.0 and math.isfinite(row[1]):
                row[0] = RATE_ONLY_TAU
    return out


def _measurements(loop: ClosedLoop, sample_index: np.ndarray, readings: int = 1) -> np.ndarray:
    """Measurement offset ``bias + noise`` per (interval, state); the noise of sensor reading
    ``j`` is the ``j``-th draw (drawn in time order, so a shorter run sees the same noise).

    A continuous controller, or a digital one whose sensors are not faster than it
    (``Sensors.rate <= 1/T``): reading ``k`` holds on sample interval ``k``. A digital
    controller with faster sensors reads, at its sample ``k`` (``t_k = t0 + k T``), the latest
    reading, ``j = floor(k T rate)`` (``j = k N`` where ``N = T rate`` is an integer): the
    noise of the readings it does not read is drawn and dropped, so its noise statistics are
    the declared ones. With a decimation filter (``readings`` = ``N`` >= 2: the design averages
    the ``N`` readings of the last period, :attr:`ConstraintAware.readings`) the offset of
    sample ``k`` is ``bias`` plus the mean noise of readings ``kN - N + 1 ... kN`` (reading 0
    alone at the first sample: no reading before ``t0``)."""
    sensors = loop.sensors
    assert sensors is not None  # called for a loop with sensors only (has_meas)
    n = loop.plant.n_states
    std, bias = sensors.per_state(loop.plant.aliases(), n)
    n_rows = len(sample_index)
    out = np.repeat(bias[None, :], n_rows, axis=0)
    if sensors.has_noise:
        rng = np.random.default_rng(sensors.seed)
        k_max = int(sample_index.max())
        ratio = _readings_per_sample(sensors, loop.sample_time)
        if ratio <= 1.0 + 1e-9:  # one draw per sample (or per noise sample of a continuous loop)
            z = rng.standard_normal((k_max + 1, n))
            out += z[sample_index] * std[None, :]
            return out
        ks = np.arange(k_max + 1, dtype=np.int64)
        whole = round(ratio)
        if abs(ratio - whole) <= 1e-9 * ratio:
            latest = ks * int(whole)
        else:  # the latest reading at or before the sample instant
            latest = np.floor(ks * ratio + 1e-9).astype(np.int64)
        z = rng.standard_normal((int(latest[-1]) + 1, n))
        if readings > 1:  # the mean of the period's readings (a boxcar, integrate and dump)
            total = np.zeros((latest.size, n))
            count = np.zeros(latest.size)
            for back in range(readings):
                at = latest - back
                there = at >= 0
                total[there] += z[at[there]]
                count += there
            per_sample = total / count[:, None]
        else:
            per_sample = z[latest]
        out += per_sample[sample_index] * std[None, :]
    return out


def _readings_per_sample(sensors, sample_time: float) -> float:
    """How many sensor readings a digital controller's sample period holds (``T rate``); 0
    for a continuous controller or a loop without noise."""
    if not sample_time or sensors is None or not sensors.has_noise:
        return 0.0
    return float(sample_time) * float(sensors.rate)


def _guarded() -> list[str]:
    from adaptive_ftc.sim.mathlib import GUARDED

    return list(GUARDED)


def is_compiled(loop: ClosedLoop, *, sdot: str = "exact") -> bool:
    """Whether ``loop``'s structure, and the integrators every loop shares, are already
    compiled (in this process or the disk cache)."""
    text, _, g, layout = generate(loop, sdot=sdot)
    shared = _integrators_source()
    patterns = {pt for pt in layout["patterns"] if pt is not None}
    return (
        codegen.is_cached(text, layout["mods"], g.inject)
        and codegen.is_cached(*layout["gain"], kind="gain")
        and codegen.is_cached(shared, _INTEGRATORS_IMPORTS, kind="integrators")
        and all(
            codegen.is_cached(_pattern_source(*pt), _PATTERN_IMPORTS, kind="pattern")
            for pt in patterns
        )
    )


def source_of(loop: ClosedLoop, *, sdot: str = "exact") -> str:
    """The generated module text of ``loop`` (to read, or to step through without JIT)."""
    return generate(loop, sdot=sdot)[0]


def assemble(loop: ClosedLoop, *, sdot: str = "exact", filter_tau: float = 0.01) -> Assembled:
    """Generate and compile (or load from the cache) the module of ``loop``'s structure."""
    if sdot not in ("exact", "filtered"):
        raise ConfigurationError(f"`sdot` must be 'exact' or 'filtered'; got {sdot!r}.")
    if not filter_tau > 0:
        raise ConfigurationError(f"`filter_tau` must be positive; got {filter_tau}.")
    text, data, g, layout = generate(loop, sdot=sdot)
    where: LoopLayout = layout["loop_layout"]
    data.c[where.params["filter_tau"]] = float(filter_tau)
    # the modules and addresses of a structure seen before: every loop of it has the same
    # (its numbers' types included), so they are looked up once
    loaded = layout["loaded"]
    module = loaded.get("module")
    if module is None:
        module = loaded["module"] = codegen.load_module(
            text, imports=layout["mods"], inject=g.inject
        )
    y0 = _initial_state(loop, g, where)
    if loop.sample_time > 0 and sdot == "filtered" and loop.sample_time >= 2 * filter_tau:
        raise ConfigurationError(
            f"The s' filter (time constant filter_tau = {filter_tau:g} s) is unstable when the "
            f"controller samples every {loop.sample_time:g} s (needs sample_time < 2 filter_tau): "
            f"set the solver's `filter_tau` to at least {loop.sample_time:g} s."
        )
    _link(loop, module, data, layout)
    asm = Assembled(
        module=module,
        data=data,
        y0=y0,
        breakpoints=layout["bps"],
        adaptive_names=tuple(g.adaptive_names),
        theta_slices=layout["theta_slices"],
        n_x=g.nx,
        layout=where,
        source=text,
        extra_names=where.extra_names,
    )
    if sdot == "filtered":  # start the filter at s(0) so the estimated s' starts at 0
        ref = np.zeros(3 * g.p)
        module.reference_at(float(loop.t0), data.c, ref)
        lam = data.c[where.params["lam"]]
        x0 = y0[: g.nx]
        at = where.states["s_filter"].start
        # a design's copy of the filter (the constraint-aware MIMO law, digital) starts there too
        copy = g.adaptive_names.index("s_lookahead1") if "s_lookahead1" in g.adaptive_names else -1
        for i in range(g.p):
            e = ref[3 * i] - x0[loop.plant.position_index[i]]
            ed = ref[3 * i + 1] - x0[loop.plant.velocity_index[i]]
            y0[at + i] = ed + lam[i] * e
            if copy >= 0:
                y0[g.nx + copy + i] = y0[at + i]
    if asm.extra_names:  # actuators at their first command, the first sample's held values
        module.jump(float(loop.t0), y0, 0, data, asm.work())
    return asm


def _initial_state(loop: ClosedLoop, g: Generator, where: LoopLayout) -> np.ndarray:
    """``y0`` before the s' filter and ``jump`` set theirs: the plant's initial state, theta0,
    the design's initial states (or ``adaptive_initial``) and the actuators' positions."""
    nx = g.nx
    theta = where.states["theta"]
    filt = where.states["s_filter"].start  # the design's, allocator's, constraint-aware states
    y0 = np.zeros(where.n_states)
    y0[:nx] = loop.initial_state
    y0[theta] = loop.controller.theta0
    y0[theta.stop : filt] = g.y0_extra
    if loop.adaptive_initial:
        n_ad = filt - nx
        if len(loop.adaptive_initial) != n_ad:
            raise ConfigurationError(
                f"`adaptive_initial` has {len(loop.adaptive_initial)} values but the loop has "
                f"{n_ad} adaptive states ({', '.join(g.adaptive_names[:n_ad])})."
            )
        y0[nx:filt] = loop.adaptive_initial
    if loop.actuators is not None and loop.actuators.initial:
        at = where.states["actuator_position"].start
        y0[at : at + g.m] = loop.actuators.initial
    if "measurement_filter1" in g.adaptive_names:  # constraint-aware: starts at x(0)
        at = nx + g.adaptive_names.index("measurement_filter1")
        y0[at : at + nx] = y0[:nx]
    return y0


def _link(loop: ClosedLoop, module, data: LoopData, layout: dict) -> None:
    """Write the addresses of the compiled ``rhs``, ``jump``, the plant's ``control_gain``
    and the failure patterns into ``data.i`` (compiling or loading them on first use)."""
    from adaptive_ftc.sim.compile_errors import clear_compile_errors

    loaded = layout["loaded"]
    with clear_compile_errors(loop):  # rhs, jump, control_gain compile (or load) here
        addresses = loaded.get("addresses")
        if addresses is None:
            gain_text, gain_mods, gain_inject = layout["gain"]
            gain_module = codegen.load_module(
                gain_text, imports=gain_mods, inject=gain_inject, kind="gain"
            )
            addresses = loaded["addresses"] = _addresses(module, gain_module, data)
        data.i[Header.RHS], data.i[Header.JUMP], data.i[Header.GAIN] = addresses
        inst = data.inst
        for n_, pattern in enumerate(layout["patterns"]):
            if pattern is not None:  # the failure patterns that are not affine
                inst[n_, 2], inst[n_, 3] = _pattern_addresses(pattern)
