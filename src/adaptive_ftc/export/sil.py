"""Software-in-the-loop checks of an exported C controller.

Both checks export a loop's controller (:func:`~adaptive_ftc.export.export_c`), compile it
with the system C compiler (``cc -O2 -Wall -Wextra -Werror -std=c99``), load it with ctypes
and compare it with the project's own simulation of the digital loop (RK4 steps of ``dt``
landing on every sample and failure time, the command and the controller's derivatives held
between samples):

* :func:`verify` closes the loop: the C computes every command, the project's plant (its
  right-hand side, failures and sensors) is integrated between samples exactly as the
  simulator integrates it, and commands, plant states and controller states are compared at
  every sample. Rounding differences (the C moves its states by ``sample_time * derivative``,
  the simulator by the sum of its RK4 steps) grow as the closed loop amplifies them: a
  sensitive loop is compared over a short window.
* :func:`replay` feeds the C, at every sample of the whole run, the simulator's own
  measurement and controller states, and compares its command and next states: the
  controller's equivalence without the loop's amplification.
"""

from __future__ import annotations

import ctypes
import dataclasses
import math
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.export.c import controller_loop, export_c
from adaptive_ftc.sim.parts.decimation import READING, SAMPLE

if TYPE_CHECKING:
    from adaptive_ftc.sim.compose import Assembled
    from adaptive_ftc.sim.result import SimResult
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = [
    "CFLAGS",
    "CompiledController",
    "SilReport",
    "compile_library",
    "replay",
    "verify",
    "verify_fmu",
    "verify_loop_fmu",
]

#: the flags of the checks (warnings are errors: the exported C compiles clean)
CFLAGS = ("-O2", "-Wall", "-Wextra", "-Werror", "-std=c99", "-shared", "-fPIC")


@dataclass(frozen=True)
class SilReport:
    """The largest differences between the exported C and the simulator, each relative to
    the signal's largest magnitude over the run (taken per command, plant state and controller
    state), and the number of samples compared."""

    samples: int
    command: float
    plant_state: float
    controller_state: float
    library: Path

    @property
    def worst(self) -> float:
        """The largest of the three differences."""
        return max(self.command, self.plant_state, self.controller_state)


def compile_library(source: Path, out: Path, cc: str | None = None) -> Path:
    """Compile ``source`` (an exported ``.c``) into the shared library ``out`` with
    :data:`CFLAGS`; ``cc``: the compiler (default: ``$CC`` or ``cc``)."""
    cc = cc or os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        raise ConfigurationError(
            f"No C compiler {cc!r} on PATH: install one (gcc or clang) or set CC."
        )
    cmd = [cc, *CFLAGS, str(source), "-o", str(out), "-lm"]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise ConfigurationError(
            f"The exported C did not compile ({' '.join(cmd)}):\n{done.stderr.strip()}"
        )
    return out


class CompiledController:
    """An exported controller compiled and loaded with ctypes: ``step(y, r, t) -> u``, its
    states (:attr:`states`, a writable view) and ``init()``. A design with the decimation
    filter (``readings`` > 1, :attr:`ExportedC.readings
    <adaptive_ftc.export.c.ExportedC.readings>`): ``read(y)`` per sensor reading, then
    ``step(None, r, t)`` at the sample (the mean of the readings)."""

    def __init__(
        self,
        library: Path,
        n_y: int,
        n_s: int,
        n_u: int,
        n_work: int,
        prefix="aftc",
        readings: int = 1,
    ):
        self.library = library
        self.lib = ctypes.CDLL(str(library))
        dbl = ctypes.POINTER(ctypes.c_double)
        self._dbl = dbl
        self.readings = readings
        self._step = getattr(self.lib, f"{prefix}_step")
        if readings > 1:  # <prefix>_read per reading; <prefix>_step takes no measurement
            self._read = getattr(self.lib, f"{prefix}_read")
            self._read.argtypes = [ctypes.c_void_p, dbl]
            self._step.argtypes = [ctypes.c_void_p, ctypes.c_void_p, dbl, ctypes.c_double, dbl]
        else:
            self._step.argtypes = [
                ctypes.c_void_p, ctypes.c_void_p, dbl, dbl, ctypes.c_double, dbl,
            ]  # fmt: skip
        self._init = getattr(self.lib, f"{prefix}_init")
        self._init.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
        self.params = ctypes.addressof(ctypes.c_char.in_dll(self.lib, f"{prefix}_default_params"))
        n = n_y + n_s
        self._started_at = 8 * (2 * n + n_work)  # the layout of <prefix>_state
        # (then, with the decimation filter, the readings' sum and count)
        self.state = ctypes.create_string_buffer(self._started_at + 64 + 8 * n_y)
        # a view of the ctypes buffer (numpy's stubs list no ctypes arrays: the memoryview)
        buf = np.frombuffer(memoryview(self.state), dtype=np.float64, count=2 * n + n_work)
        self.n_y = n_y
        self.states = buf[n_y:n]  # the controller's states (state.Y[NY:])
        self.u = np.zeros(n_u)
        self.init()

    def init(self) -> None:
        self._init(self.state, self.params)

    def set_started(self) -> None:
        """Mark the state started (the filters are not started again at the next step)."""
        ctypes.c_int.from_buffer(self.state, self._started_at).value = 1

    def read(self, y: np.ndarray) -> None:
        """One sensor reading into the decimation filter (``<prefix>_read``)."""
        if self.readings < 2:
            raise ConfigurationError(
                "read() is the decimation filter's (a design that averages its sensor "
                "readings); this controller takes its measurement in step(y, r, t)."
            )
        y = np.ascontiguousarray(y, dtype=float)
        self._read(self.state, y.ctypes.data_as(self._dbl))

    def step(self, y: np.ndarray | None, r: np.ndarray, t: float) -> np.ndarray:
        """The command at ``t`` from the measurement ``y`` (``None`` with the decimation
        filter: the mean of the readings given to :meth:`read`) and the reference ``r``."""
        if (y is None) != (self.readings > 1):
            raise ConfigurationError(
                "step(y, r, t) takes the measurement y, or None for a design with the "
                "decimation filter (its readings go to read(y) first); got "
                f"{'None' if y is None else 'a measurement'} for a controller averaging "
                f"{self.readings} reading(s) per sample."
            )
        r = np.ascontiguousarray(r, dtype=float)
        out = self.u.ctypes.data_as(self._dbl)
        if y is None:
            self._step(self.state, self.params, r.ctypes.data_as(self._dbl), float(t), out)
            return self.u.copy()
        y = np.ascontiguousarray(y, dtype=float)
        self._step(
            self.state,
            self.params,
            y.ctypes.data_as(self._dbl),
            r.ctypes.data_as(self._dbl),
            float(t),
            out,
        )
        return self.u.copy()


@dataclass
class _Setup:
    loop: ClosedLoop
    asm: Assembled
    result: SimResult  # the simulator's digital run, recorded at every sample
    ctrl: CompiledController
    dt: float
    ny: int
    case: _Case
    #: with the decimation filter: per interval, the sensor reading at its start (-1: none)
    #: and each reading's offset (bias + its noise draw), as the simulator draws them
    reading: np.ndarray | None = None
    offsets: np.ndarray | None = None


@dataclass
class _Case:
    """The digital loop of a check, its RK4 step and the folder its exports are written to."""

    loop: ClosedLoop
    tau: float  # the s' filter's time constant
    T: float  # the sample period
    dt: float
    tmp: Path

    def solver(self):
        """The simulator's options of the digital run: RK4 at ``dt``, recorded every sample."""
        from adaptive_ftc.sim.engine import SolverOptions

        return SolverOptions(
            method="rk4", dt=self.dt, sdot="filtered", filter_tau=self.tau, record_dt=self.T
        )


def _case(scenario, sample_time, t_final, dt, workdir, tmp_prefix: str) -> _Case:
    """The scenario's digital loop (ended at ``t_final``), the RK4 step (default: the sample
    period split into steps of at most 1 ms) and the folder (default: a new temporary one)."""
    loop, tau = controller_loop(scenario, sample_time)
    if t_final is not None:
        loop = dataclasses.replace(loop, t_final=float(t_final))
    T = float(loop.sample_time)
    if dt is None:
        dt = T / max(1, math.ceil(T / 1e-3 - 1e-9))
    tmp = Path(workdir) if workdir is not None else Path(tempfile.mkdtemp(prefix=tmp_prefix))
    return _Case(loop, tau, T, dt, tmp)


def _digital_run(case: _Case) -> tuple[Assembled, list[int], SimResult]:
    """The assembled loop, its sampled intervals and the simulator's run recorded at every
    sample."""
    from adaptive_ftc.sim.compose import assemble
    from adaptive_ftc.sim.engine import simulate

    asm = assemble(case.loop, sdot="filtered", filter_tau=case.tau)
    bps, samp = asm.breakpoints, asm.data.samp
    rows = [k for k in range(len(bps) - 1) if samp[k] == SAMPLE]
    grid = np.array([bps[k] for k in rows])
    return asm, rows, simulate(case.loop, case.solver(), t_eval=grid)


def _valid_fmu(case: _Case, **options):
    """``export_fmu(case.loop, case.tmp, **options)``, validated by FMPy."""
    from fmpy.validation import validate_fmu

    from adaptive_ftc.export.fmu import export_fmu

    fmu = export_fmu(case.loop, case.tmp, **options)
    problems = validate_fmu(str(fmu.path))
    if problems:
        raise ConfigurationError(f"The FMU does not validate: {'; '.join(problems)}")
    return fmu


def _setup(scenario, sample_time, t_final, dt, workdir, cc) -> _Setup:
    case = _case(scenario, sample_time, t_final, dt, workdir, "aftc-sil-")
    loop, tmp = case.loop, case.tmp
    exported = export_c(loop, tmp, prefix="aftc")
    lib = compile_library(exported.source, tmp / "libaftc.so", cc)
    asm, _, result = _digital_run(case)
    if result.status != "completed":
        raise ConfigurationError(
            f"The simulator's digital run did not complete ({result.message}); shorten it "
            "with t_final, sample faster, or check the scenario."
        )
    ny = asm.n_x + len(asm.adaptive_names)
    ctrl = CompiledController(
        lib,
        asm.n_x,
        ny - asm.n_x,
        loop.plant.n_actuators,
        asm.layout["w:size"].stop,
        readings=exported.readings,
    )
    setup = _Setup(loop, asm, result, ctrl, case.dt, ny, case)
    if exported.readings > 1:
        setup.reading, setup.offsets = _readings(loop, asm, exported.readings)
    return setup


def _readings(loop: ClosedLoop, asm: Assembled, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A decimating loop's sensor readings (``n`` per sample): per interval the index of the
    reading at its start (-1: an interval that starts at a failure time), and each reading's
    offset ``bias + std z_j`` (the ``j``-th draw of the sensors' seed, as
    ``compose._measurements`` draws them). Checked: the mean of each sample's readings'
    offsets is the simulator's offset of that sample (``D.meas``)."""
    sensors = loop.sensors
    assert sensors is not None  # a decimating loop has sensors (decimation_readings)
    nx, t0, period = asm.n_x, float(loop.t0), float(loop.sample_time) / n
    samp = np.asarray(asm.data.samp)
    starts = np.asarray(asm.breakpoints[:-1], dtype=float)
    reading = np.where(samp > 0, np.rint((starts - t0) / period), -1).astype(np.int64)
    std, bias = sensors.per_state(loop.plant.aliases(), nx)
    rows = int(reading.max()) + 1
    z = (
        np.random.default_rng(sensors.seed).standard_normal((rows, nx))
        if sensors.has_noise
        else np.zeros((rows, nx))
    )
    offsets = bias[None, :] + z * std[None, :]
    for ph in np.flatnonzero(samp == SAMPLE):
        j = int(reading[ph])
        mean = offsets[max(j - n + 1, 0) : j + 1].mean(axis=0)
        if not np.allclose(mean, asm.data.meas[ph], rtol=1e-12, atol=1e-15):
            raise RuntimeError(
                f"The SIL's sensor readings of the sample at {starts[ph]:g} s disagree with "
                "the simulator's mean (compose._measurements changed?)."
            )
    return reading, offsets


def verify(
    scenario,
    *,
    sample_time: float | None = None,
    t_final: float | None = None,
    dt: float | None = None,
    workdir=None,
    cc: str | None = None,
) -> SilReport:
    """Close the loop with the exported C controller and compare it with the simulator's
    digital run at every sample (see the module docstring).

    Parameters
    ----------
    scenario
        A scenario (object, catalogue name or file) or a closed loop.
    sample_time
        The controller's period (s); default: the scenario's.
    t_final
        End the comparison earlier (s).
    dt
        The RK4 step of both runs (default: the sample period split into steps of at most
        1 ms).
    workdir
        Where the C and the library are written (default: a new temporary folder).
    cc
        The C compiler (default: ``$CC`` or ``cc``).
    """
    s = _setup(scenario, sample_time, t_final, dt, workdir, cc)
    asm, data, mod, ctrl = s.asm, s.asm.data, s.asm.module, s.ctrl
    bps, samp, meas = asm.breakpoints, data.samp, data.meas
    nx, ny = asm.n_x, s.ny
    plant_names = s.loop.plant.actuator_names
    held = ny + asm.extra_names.index(f"held command of {plant_names[0]}")
    m = len(plant_names)
    Y = asm.y0.copy()
    W = asm.work()
    k1, k2, k3, k4 = (np.zeros_like(Y) for _ in range(4))
    ref = np.zeros(3 * s.loop.plant.n_outputs)
    cmds: list[np.ndarray] = []
    plant: list[np.ndarray] = []
    states: list[np.ndarray] = []
    if s.loop.sensors is not None:
        # the simulator starts the s' filter from the true initial state, the C from its first
        # measurement (bias, noise): the C is started where the simulator starts
        ctrl.states[:] = Y[nx:ny]
        ctrl.set_started()
    for ph in range(len(bps) - 1):
        a, b = bps[ph], bps[ph + 1]
        if samp[ph] == SAMPLE:
            mod.reference_at(a, data.c, ref)
            plant.append(Y[:nx].copy())
            if cmds:  # the simulator's controller states: the C's (after its first step)
                Y[nx:ny] = ctrl.states
        # the simulator's interval update (templates/rk4.py): the actuators, the input delay
        # and, at a sample, the held command (replaced below by the C's)
        mod.jump(a, Y, ph, data, W)
        if s.reading is not None and s.offsets is not None and samp[ph] in (SAMPLE, READING):
            ctrl.read(Y[:nx] + s.offsets[s.reading[ph]])  # a sensor reading (decimation)
        if samp[ph] == SAMPLE:
            u = ctrl.step(None if ctrl.readings > 1 else Y[:nx] + meas[ph], ref, a)
            cmds.append(u)
            states.append(ctrl.states.copy())  # the controller's states at the next sample
            Y[held : held + m] = u
        nsteps = max(1, int(math.ceil((b - a) / s.dt - 1e-9)))
        h = (b - a) / nsteps
        for st in range(nsteps):  # templates/rk4.py, step for step
            t = a + st * h
            t1 = b if st == nsteps - 1 else a + (st + 1) * h
            hh = t1 - t
            mod.rhs(t, Y, ph, data, W, k1)
            mod.rhs(t + 0.5 * hh, Y + 0.5 * hh * k1, ph, data, W, k2)
            mod.rhs(t + 0.5 * hh, Y + 0.5 * hh * k2, ph, data, W, k3)
            mod.rhs(t1, Y + hh * k3, ph, data, W, k4)
            Y = Y + hh / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    res = s.result
    n = min(len(cmds), res.time.size)
    return SilReport(
        samples=n,
        command=_rel(np.array(cmds)[:n], res.u_cmd[:n]),
        plant_state=_rel(np.array(plant)[:n], res.states[:n]),
        controller_state=_rel(np.array(states)[: n - 1], res.adaptive[1:n]),
        library=ctrl.library,
    )


def replay(
    scenario,
    *,
    sample_time: float | None = None,
    t_final: float | None = None,
    dt: float | None = None,
    workdir=None,
    cc: str | None = None,
) -> SilReport:
    """Give the exported C, at every sample of the simulator's digital run, that run's
    measurement and controller states, and compare its command and next states with the
    run's (the arguments as :func:`verify`'s; ``plant_state`` is 0: the plant is the run's)."""
    s = _setup(scenario, sample_time, t_final, dt, workdir, cc)
    if s.ctrl.readings > 1:
        return _replay_readings(s)
    asm, data, ctrl, res = s.asm, s.asm.data, s.ctrl, s.result
    ref = np.zeros(3 * s.loop.plant.n_outputs)
    rows = [k for k in range(len(asm.breakpoints) - 1) if data.samp[k] == SAMPLE]
    n = min(len(rows), res.time.size)
    cmds, states = [], []
    for k in range(n):
        t = float(res.time[k])
        asm.module.reference_at(t, data.c, ref)
        ctrl.states[:] = res.adaptive[k]
        ctrl.set_started()
        cmds.append(ctrl.step(res.states[k] + data.meas[rows[k]], ref, t))
        states.append(ctrl.states.copy())
    return SilReport(
        samples=n,
        command=_rel(np.array(cmds), res.u_cmd[:n]),
        plant_state=0.0,
        controller_state=_rel(np.array(states)[: n - 1], res.adaptive[1:n]),
        library=ctrl.library,
    )


def _replay_readings(s: _Setup) -> SilReport:
    """:func:`replay` of a design with the decimation filter: the simulator's run recorded at
    every sensor reading (RK4: the same steps), each reading given to the C's ``read``, and
    at each sample the run's controller states and the C's ``step``."""
    from adaptive_ftc.sim.engine import simulate

    asm, data, ctrl = s.asm, s.asm.data, s.ctrl
    assert s.reading is not None and s.offsets is not None  # set by _setup for N > 1
    samp, bps = data.samp, asm.breakpoints
    rows = [k for k in range(len(bps) - 1) if samp[k] in (SAMPLE, READING)]
    res = simulate(s.loop, s.case.solver(), t_eval=np.array([bps[k] for k in rows]))
    if res.status != "completed":
        raise ConfigurationError(
            f"The simulator's digital run did not complete ({res.message}); shorten it "
            "with t_final, sample faster, or check the scenario."
        )
    ref = np.zeros(3 * s.loop.plant.n_outputs)
    at = [i for i, k in enumerate(rows) if samp[k] == SAMPLE and i < res.time.size]
    cmds, states = [], []
    for i, k in enumerate(rows[: res.time.size]):
        ctrl.read(res.states[i] + s.offsets[s.reading[k]])
        if samp[k] != SAMPLE:
            continue
        t = float(res.time[i])
        asm.module.reference_at(t, data.c, ref)
        ctrl.states[:] = res.adaptive[i]
        ctrl.set_started()
        cmds.append(ctrl.step(None, ref, t))
        states.append(ctrl.states.copy())
    n = len(at)
    return SilReport(
        samples=n,
        command=_rel(np.array(cmds), res.u_cmd[at]),
        plant_state=0.0,
        controller_state=_rel(np.array(states)[: n - 1], res.adaptive[at[1:]]),
        library=ctrl.library,
    )


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    """Largest ``|a - b|`` per column over the column's largest ``|b|`` (1e-300 at least)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.size == 0:
        return 0.0
    scale = np.maximum(np.max(np.abs(b), axis=0), 1e-300)
    return float(np.max(np.max(np.abs(a - b), axis=0) / scale))


def verify_fmu(
    scenario,
    *,
    sample_time: float | None = None,
    t_final: float | None = None,
    dt: float | None = None,
    workdir=None,
) -> SilReport:
    """Simulate the controller FMU (:func:`~adaptive_ftc.export.fmu.export_fmu`) with FMPy,
    its inputs the measurements and references of the simulator's digital run at every
    sample, and compare its commands and states with the run's (``plant_state`` is 0: the
    plant is the run's; the arguments as :func:`verify`'s). The FMU is validated with
    ``fmpy.validation.validate_fmu`` first."""
    from fmpy import simulate_fmu

    case = _case(scenario, sample_time, t_final, dt, workdir, "aftc-fmu-")
    loop, T = case.loop, case.T
    fmu = _valid_fmu(case, name="controller")
    asm, rows, res = _digital_run(case)
    n = min(len(rows), res.time.size)
    nx, p = asm.n_x, loop.plant.n_outputs
    inputs = [v for v in fmu.variables if v.startswith(("y.", "r."))]
    table = np.zeros(n, dtype=[("time", float)] + [(v, float) for v in inputs])
    table["time"] = res.time[:n]
    ref = np.zeros(3 * p)
    y = res.states[:n] + asm.data.meas[rows[:n]]
    for i in range(nx):
        table[inputs[i]] = y[:, i]
    for k in range(n):
        asm.module.reference_at(float(res.time[k]), asm.data.c, ref)
        for i in range(3 * p):
            table[k][inputs[nx + i]] = ref[i]
    outputs = [v for v in fmu.variables if v.startswith(("u.", "xc."))]
    start = {}
    if loop.sensors is not None:  # started where the simulator starts (see verify)
        first = asm.y0[nx : nx + len(asm.adaptive_names)]
        start = {"start_filters": 0.0}
        names = asm.adaptive_names
        start.update({f"initial.{n}": float(v) for n, v in zip(names, first, strict=True)})
    out = simulate_fmu(
        str(fmu.path),
        start_time=float(res.time[0]),
        stop_time=float(res.time[n - 1]),
        step_size=T,
        output_interval=T,
        input=table,
        output=outputs,
        start_values=start,
    )
    # the FMU's outputs after the step to t_k+1 are the sample's at t_k (held; states moved on)
    u = np.column_stack([out[v] for v in outputs if v.startswith("u.")])
    xc = np.column_stack([out[v] for v in outputs if v.startswith("xc.")])
    m = min(u.shape[0] - 1, n - 1)
    return SilReport(
        samples=m,
        command=_rel(u[1 : m + 1], res.u_cmd[:m]),
        plant_state=0.0,
        controller_state=_rel(xc[1 : m + 1], res.adaptive[1 : m + 1]),
        library=fmu.path,
    )


def verify_loop_fmu(
    scenario,
    *,
    sample_time: float | None = None,
    t_final: float | None = None,
    workdir=None,
) -> SilReport:
    """Simulate the closed-loop FMU (``export_fmu(..., part="loop")``) with FMPy from break
    time to break time of the loop, and compare its plant states, commands and controller
    states at every sample with the simulator's digital run (RK4 at the same step). The FMU
    is validated with ``fmpy.validation.validate_fmu`` first."""
    from fmpy import simulate_fmu

    from adaptive_ftc.sim.engine import simulate

    case = _case(scenario, sample_time, t_final, None, workdir, "aftc-fmu-")
    loop, T, solver = case.loop, case.T, case.solver()
    fmu = _valid_fmu(case, name="loop", part="loop")
    n = int(math.floor((loop.t_final - loop.t0) / T + 1e-9))
    grid = loop.t0 + T * np.arange(n)
    res = simulate(loop, solver, t_eval=grid)
    out = simulate_fmu(
        str(fmu.path),
        start_time=float(loop.t0),
        stop_time=float(grid[-1]),
        step_size=T,
        output_interval=T,
        output=list(fmu.variables),
    )
    m = min(len(out), res.time.size)

    def cols(prefix):
        return np.column_stack([out[v][:m] for v in fmu.variables if v.startswith(prefix)])

    return SilReport(
        samples=m,
        command=_rel(cols("u."), res.u_cmd[:m]),
        plant_state=_rel(cols("x."), res.states[:m]),
        controller_state=_rel(cols("xc."), res.adaptive[:m]),
        library=fmu.path,
    )
