"""Software-in-the-loop check of an exported C controller.

:func:`verify` exports a loop's controller (:func:`~adaptive_ftc.export.export_c`), compiles
it with the system C compiler (``cc -O2 -Wall -Wextra -Werror -std=c99``), loads it with
ctypes and closes the loop with the project's plant integrated as the simulator's digital mode
integrates it (RK4 steps of ``dt`` landing on every sample and failure time, the command held
between samples, the same right-hand side for the plant, its failures and sensors), then
compares the commands, the plant states and the controller states at every sample with the
project's own simulation of the digital loop.
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

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.export.c import controller_loop, export_c

__all__ = ["CFLAGS", "SilReport", "compile_library", "verify"]

#: the flags of the check (warnings are errors: the exported C compiles clean)
CFLAGS = ("-O2", "-Wall", "-Wextra", "-Werror", "-std=c99", "-shared", "-fPIC")


@dataclass(frozen=True)
class SilReport:
    """The largest differences between the exported C in the loop and the simulator, each
    relative to the signal's largest magnitude over the run (per command, state, controller
    state), and the number of samples compared."""

    samples: int
    command: float
    plant_state: float
    controller_state: float
    library: Path

    @property
    def worst(self) -> float:
        return max(self.command, self.plant_state, self.controller_state)


def compile_library(source: Path, out: Path, cc: str | None = None) -> Path:
    """Compile ``source`` (an exported ``.c``) into the shared library ``out``."""
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


def verify(
    scenario,
    *,
    sample_time: float | None = None,
    t_final: float | None = None,
    dt: float | None = None,
    workdir=None,
    cc: str | None = None,
) -> SilReport:
    """Run the exported C controller of ``scenario`` in the loop and compare it with the
    simulator's digital run (see the module docstring).

    ``t_final``: end the comparison earlier; ``dt``: the RK4 step of both runs (default: the
    sample time split into steps of at most 1 ms).
    """
    from adaptive_ftc.sim.compose import assemble
    from adaptive_ftc.sim.engine import SolverOptions, simulate

    loop, tau = controller_loop(scenario, sample_time)
    if t_final is not None:
        loop = dataclasses.replace(loop, t_final=float(t_final))
    if loop.has_actuator_dynamics or (loop.actuators is not None and loop.actuators.has_delay):
        raise ConfigurationError(
            "The SIL check integrates ideal actuators only; this loop has actuator dynamics "
            "or an input delay (the exported controller itself does not depend on them)."
        )
    T = float(loop.sample_time)
    if dt is None:
        dt = T / max(1, math.ceil(T / 1e-3 - 1e-9))
    solver = SolverOptions(method="rk4", dt=dt, sdot="filtered", filter_tau=tau, record_dt=T)
    tmp = Path(workdir) if workdir is not None else Path(tempfile.mkdtemp(prefix="aftc-sil-"))
    exported = export_c(loop, tmp, prefix="aftc")
    lib_path = compile_library(exported.source, tmp / "libaftc.so", cc)

    asm = assemble(loop, sdot="filtered", filter_tau=tau)
    data, mod = asm.data, asm.module
    bps = asm.breakpoints
    samp = data.samp
    meas = data.meas
    nx, m = asm.n_x, loop.plant.n_actuators
    ny = nx + len(asm.adaptive_names)
    at_hu = ny  # held commands, then held derivatives (no actuator states: checked above)
    grid = np.array([bps[k] for k in range(len(bps) - 1) if samp[k]])
    ref_sim = simulate(loop, solver, t_eval=grid)
    if ref_sim.status != "completed":
        raise ConfigurationError(
            f"The simulator's digital run did not complete ({ref_sim.message}); shorten it "
            "with t_final or check the scenario."
        )

    lib = ctypes.CDLL(str(lib_path))
    dbl = ctypes.POINTER(ctypes.c_double)
    lib.aftc_step.argtypes = [ctypes.c_void_p, ctypes.c_void_p, dbl, dbl, ctypes.c_double, dbl]
    lib.aftc_init.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
    params = ctypes.addressof(ctypes.c_char.in_dll(lib, "aftc_default_params"))
    n_state = 8 * (2 * ny + asm.layout["w:size"].stop) + 64
    state = ctypes.create_string_buffer(n_state)
    lib.aftc_init(state, params)
    c_states = np.frombuffer(state, dtype=np.float64, count=ny)  # Y of the C state

    Y = asm.y0.copy()
    W = asm.work()
    k1, k2, k3, k4 = (np.zeros_like(Y) for _ in range(4))
    ref = np.zeros(3 * loop.plant.n_outputs)
    u = np.zeros(m)
    cmds, plant, ctrl = [], [], []

    def ptr(a):
        return a.ctypes.data_as(dbl)

    for ph in range(len(bps) - 1):
        a, b = bps[ph], bps[ph + 1]
        if samp[ph]:
            y = np.ascontiguousarray(Y[:nx] + meas[ph])
            mod.reference_at(a, data.c, ref)
            plant.append(Y[:nx].copy())
            lib.aftc_step(state, params, ptr(y), ptr(ref), a, ptr(u))
            ctrl.append(c_states[nx:ny].copy())  # the states at the next sample
            cmds.append(u.copy())
            Y[at_hu : at_hu + m] = u
            Y[at_hu + m :] = 0.0  # the controller's states are the C's: none move here
        nsteps = max(1, int(math.ceil((b - a) / dt - 1e-9)))
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

    n = min(len(cmds), ref_sim.time.size)
    return SilReport(
        samples=n,
        command=_rel(np.array(cmds)[:n], ref_sim.u_cmd[:n]),
        plant_state=_rel(np.array(plant)[:n], ref_sim.states[:n]),
        controller_state=_rel(np.array(ctrl)[: n - 1], ref_sim.adaptive[1:n]),
        library=lib_path,
    )


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    """Largest ``|a - b|`` per column over the column's largest ``|b|`` (1e-300 at least)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.size == 0:
        return 0.0
    scale = np.maximum(np.max(np.abs(b), axis=0), 1e-300)
    return float(np.max(np.max(np.abs(a - b), axis=0) / scale))
