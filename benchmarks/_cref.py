"""Build and run the plain C reference of the hypersonic §2.3 closed loop (``c/hypersonic_loop.c``).

The C is compiled at benchmark time with the system C compiler (``$CC``, else ``cc``, ``gcc`` or
``clang``; flags ``-O3 -march=native``) into a temporary directory removed at exit. Used by
``bench_engine.py``, ``bench_batch.py`` and ``tests/test_cref.py``.

Examples
--------
>>> from _cref import build, run_single
>>> exe = build()
>>> run = run_single(exe, t_final=10.0)
>>> run.status, run.time.size
(0, 1001)
"""

from __future__ import annotations

import atexit
import math
import os
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.faults import Affine, Bias, Failure, LossOfEffectiveness, Stuck

__all__ = [
    "CReferenceError",
    "CRun",
    "N_STATE",
    "SIGNAL_COLUMNS",
    "SOURCE",
    "build",
    "failure_records",
    "find_compiler",
    "run_batch",
    "run_single",
]

SOURCE = Path(__file__).resolve().parent / "c" / "hypersonic_loop.c"
FLAGS = ("-O3", "-march=native")
LIBS = ("-lm", "-pthread")
N_STATE = 27  # alpha, q, theta_1..theta_25
#: Columns of the C's recorded signals (the order of the generated ``signals``,
#: ``sim/templates/record.py``).
SIGNAL_COLUMNS = (
    "y",
    "yd",
    "yd_dot",
    "e",
    "edot",
    "s",
    "sdot",
    "q",
    "u0",
    "u_cmd1",
    "u_cmd2",
    "u_applied1",
    "u_applied2",
    "u_f",
    "gain",
    "control_gain",
    "sdot_used",
)
# failure kinds of the C program
_LOE, _BIAS, _STUCK, _AFFINE = 0, 1, 2, 3

_built: dict[tuple[str, ...], Path] = {}


class CReferenceError(ConfigurationError):
    """The C reference could not be built or run, or cannot represent a failure."""


def find_compiler() -> str:
    """Path of the system C compiler (``$CC``, else ``cc``, ``gcc``, ``clang``).

    Raises
    ------
    CReferenceError
        When none is installed.
    """
    names = [os.environ["CC"]] if os.environ.get("CC") else []
    for name in (*names, "cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return path
    raise CReferenceError(
        "No C compiler found for the C reference benchmark (looked for $CC, cc, gcc, clang). "
        "Install one (e.g. `apt-get install gcc`) or set CC to its path."
    )


def build(flags: Sequence[str] = FLAGS) -> Path:
    """Compile ``c/hypersonic_loop.c`` into a temporary directory (once per process).

    Returns the path of the executable.
    """
    key = tuple(flags)
    if key in _built and _built[key].exists():
        return _built[key]
    cc = find_compiler()
    tmp = Path(tempfile.mkdtemp(prefix="aftc-cref-"))
    atexit.register(shutil.rmtree, tmp, True)
    exe = tmp / "hypersonic_loop"
    cmd = [cc, *flags, "-o", str(exe), str(SOURCE), *LIBS]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise CReferenceError(
            f"Compiling the C reference failed ({' '.join(cmd)}):\n{proc.stderr.strip()}\n"
            "Check that the compiler works, or set CC to another compiler."
        )
    _built[key] = exe
    return exe


def _number(value, what: str, f: Failure) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CReferenceError(
            f"The C reference needs a numeric `{what}` for {type(f).__name__} on actuator "
            f"{f.actuator}; got {value!r}. Use numbers, not expressions, in benchmark failures."
        )
    return float(value)


def failure_records(failures: Sequence[Failure]) -> list[tuple]:
    """C records ``(actuator, kind, onset, recovery, p0, p1, p2, p3)`` for library failures.

    Supports :class:`LossOfEffectiveness`, :class:`Bias`, :class:`Stuck` and :class:`Affine`
    with numeric values and abrupt onset (``ramp = 0``).
    """
    out = []
    for f in failures:
        if f.ramp != 0:
            raise CReferenceError(
                f"The C reference has no incipient failures; {type(f).__name__} on actuator "
                f"{f.actuator} has ramp = {f.ramp}. Use ramp = 0."
            )
        rec = math.inf if f.recovery is None else float(f.recovery)
        if isinstance(f, LossOfEffectiveness):
            kind, p = _LOE, (_number(f.effectiveness, "effectiveness", f), 0.0)
        elif isinstance(f, Bias):
            kind, p = _BIAS, (_number(f.bias, "bias", f), 0.0)
        elif isinstance(f, Stuck):
            kind, p = _STUCK, (_number(f.value, "value", f), 0.0)
        elif isinstance(f, Affine):
            kind = _AFFINE
            p = (_number(f.effectiveness, "effectiveness", f), _number(f.bias, "bias", f))
        else:
            raise CReferenceError(
                f"The C reference implements LossOfEffectiveness, Bias, Stuck and Affine; got "
                f"{type(f).__name__}. Draw benchmark failures from those models."
            )
        out.append((f.actuator, kind, float(f.onset), rec, *p, 0.0, 0.0))
    return out


def _format_records(records: Sequence[tuple]) -> str:
    return "".join(f"{a} {k} {' '.join(repr(float(v)) for v in rest)}\n" for a, k, *rest in records)


def _run(cmd: list[str]) -> str:
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise CReferenceError(
            f"The C reference failed ({' '.join(cmd)}): {proc.stderr.strip()}. "
            "Rebuild it with build() and check the arguments."
        )
    return proc.stdout


def _elapsed(stdout: str) -> list[float]:
    return [float(line.split()[1]) for line in stdout.splitlines() if line.startswith("elapsed ")]


@dataclass(frozen=True)
class CRun:
    """One run of the C reference: wall times of each repetition and the last one's records."""

    elapsed: tuple[float, ...]
    status: int
    time: np.ndarray
    states: np.ndarray
    signals: np.ndarray | None

    def signal(self, name: str) -> np.ndarray:
        """One recorded signal column by name (see :data:`SIGNAL_COLUMNS`)."""
        if self.signals is None:
            raise CReferenceError("This C run recorded no signals; run it with mode='whole'.")
        return self.signals[:, SIGNAL_COLUMNS.index(name)]


def run_single(
    exe: Path,
    *,
    mode: str = "whole",
    repeat: int = 1,
    t_final: float = 120.0,
    dt: float = 1e-3,
    record_dt: float = 0.01,
    failures: Sequence[Failure] | None = None,
    records: Sequence[tuple] | None = None,
    read: bool = True,
) -> CRun:
    """Run ``hypersonic-direct-s1`` in C ``repeat`` times (``mode``: ``whole`` or ``integrate``).

    ``failures`` replaces the scenario's own (numeric LossOfEffectiveness, Bias, Stuck or
    Affine); ``records`` does the same with C failure records (see :func:`failure_records`;
    kind 4 is the oscillating stuck surface ``p0 + p1 cos(p2 t) - p3 sin(p2 t)`` of scenario 1).
    ``read=False`` skips reading the records back (timing only).
    """
    if failures is not None and records is not None:
        raise CReferenceError("Give `failures` or `records` to run_single, not both.")
    if mode not in ("whole", "integrate"):
        raise CReferenceError(f"`mode` must be 'whole' or 'integrate'; got {mode!r}.")
    with tempfile.TemporaryDirectory(prefix="aftc-cref-run-") as tmp:
        out = Path(tmp) / "run.bin"
        cmd = [str(exe), "single", "--mode", mode, "--repeat", str(int(repeat))]
        cmd += ["--t-final", repr(float(t_final)), "--dt", repr(float(dt))]
        cmd += ["--record-dt", repr(float(record_dt))]
        if failures is not None or records is not None:
            recs = failure_records(failures) if failures is not None else list(records)
            fpath = Path(tmp) / "failures.txt"
            fpath.write_text(f"{len(recs)}\n{_format_records(recs)}")
            cmd += ["--failures", str(fpath)]
        if read:
            cmd += ["--out", str(out)]
        stdout = _run(cmd)
        elapsed = tuple(_elapsed(stdout))
        if not read:
            return CRun(elapsed, 0, np.zeros(0), np.zeros((0, N_STATE)), None)
        raw = np.fromfile(out, dtype=np.float64)
    n, ny, ns, status = (int(v) for v in raw[:4])
    o = 4
    time = raw[o : o + n]
    o += n
    states = raw[o : o + n * ny].reshape(n, ny)
    o += n * ny
    sig = raw[o : o + n * ns].reshape(n, ns) if ns else None
    return CRun(elapsed, status, time, states, sig)


def run_batch(
    exe: Path,
    runs: Sequence[tuple[tuple[float, float], Sequence[tuple]]],
    *,
    threads: int = 2,
    t_final: float = 120.0,
    dt: float = 1e-3,
    record_dt: float = 0.01,
) -> tuple[float, np.ndarray]:
    """Run many whole runs on ``threads`` pthreads.

    ``runs`` holds ``((alpha0, q0), failure_records)`` per run. Returns the wall time of the
    batch (measured inside the C program, without reading the input) and an array with one row
    ``[status, n_recorded, final closed-loop state (27)]`` per run.
    """
    with tempfile.TemporaryDirectory(prefix="aftc-cref-batch-") as tmp:
        rpath = Path(tmp) / "runs.txt"
        out = Path(tmp) / "out.bin"
        lines = [f"{len(runs)}\n"]
        for (a0, q0), recs in runs:
            lines.append(f"{float(a0)!r} {float(q0)!r} {len(recs)}\n{_format_records(recs)}")
        rpath.write_text("".join(lines))
        cmd = [str(exe), "batch", "--runs", str(rpath), "--threads", str(int(threads))]
        cmd += ["--t-final", repr(float(t_final)), "--dt", repr(float(dt))]
        cmd += ["--record-dt", repr(float(record_dt)), "--out", str(out)]
        stdout = _run(cmd)
        rows = np.fromfile(out, dtype=np.float64).reshape(len(runs), 2 + N_STATE)
    return _elapsed(stdout)[0], rows


def rk4_scenario(name: str = "hypersonic-direct-s1"):
    """The catalogue scenario on the path the C implements: RK4, dt 1e-3, record_dt 0.01 (the
    catalogue itself now runs the compiled DOPRI5, see docs/solvers.md)."""
    from dataclasses import replace

    from adaptive_ftc import SolverOptions, load_scenario

    sc = load_scenario(name)
    return replace(sc, solver=SolverOptions(method="rk4", dt=1e-3, record_dt=0.01))
