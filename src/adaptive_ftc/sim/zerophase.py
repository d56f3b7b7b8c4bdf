"""The zero-phase Butterworth low-pass of the activity metrics, without importing scipy.signal.

``import scipy.signal`` costs 0.5-0.9 s (it imports scipy.stats and wraps every function for
alternative array backends), more than the whole integration of a catalogue run, and every
``SimResult.metrics`` needs one low-pass. So the filter is split in two:

* the *design* (second-order sections and their steady-state initial conditions,
  :func:`scipy.signal.butter` and :func:`scipy.signal.sosfilt_zi`) depends only on the order,
  the cut-off and the record rate: it is computed by scipy once and kept in the loop cache
  folder (:func:`adaptive_ftc.sim.codegen.cache_dir`), a small JSON file per design, so a later
  process reads it instead of importing scipy.signal;
* the *filter* (:func:`scipy.signal.sosfiltfilt` with ``padtype="odd"``) is a compiled loop
  (a generated module, cached like the closed loops) that does what scipy's does, operation
  for operation (its direct-form II transposed sections, the odd extension, the initial
  conditions scaled by the first sample each way): the output equals scipy's bit for bit
  (tests/test_first_run.py holds it to scipy's on random records).

With ``NUMBA_DISABLE_JIT=1`` (stepping through generated code in Python) scipy's function is
used: the loop in Python would take seconds.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import threading
from pathlib import Path

import numpy as np

__all__ = ["lowpass_design", "sosfiltfilt_odd"]

_KERNEL = '''"""The zero-phase low-pass of the activity metrics (written by sim/zerophase.py)."""
# ruff: noqa
import numpy as np
from numba import njit


@njit(nogil=True, error_model="numpy", inline="always")
def start(zi, z, i, x0):
    """Column i's sections at rest for a constant input ``x0`` (scipy's ``zi * x[0]``)."""
    for s in range(zi.shape[0]):
        z[i, s, 0] = zi[s, 0] * x0
        z[i, s, 1] = zi[s, 1] * x0


@njit(nogil=True, error_model="numpy", inline="always")
def sections(sos, z, i, x_cur):
    """One sample of column i through the direct-form II transposed sections (scipy's
    sosfilt; ``z[i]``: that column's state)."""
    for s in range(sos.shape[0]):
        x_new = sos[s, 0] * x_cur + z[i, s, 0]
        z[i, s, 0] = sos[s, 1] * x_cur - sos[s, 4] * x_new + z[i, s, 1]
        z[i, s, 1] = sos[s, 2] * x_cur - sos[s, 5] * x_new
        x_cur = x_new
    return x_cur


@njit(cache=CACHE, nogil=True, error_model="numpy")
def filtfilt_odd(sos, zi, u, pad):
    """scipy.signal.sosfiltfilt's two passes over ``u`` (samples, columns; any strides)
    extended by scipy's odd extension of ``pad`` samples each side, which is built here
    sample by sample as numpy computes it (``2 u[0] - u[pad - k]`` before, ``2 u[-1] -
    u[-2 - k]`` after): each column forwards from ``zi * ext[0]``, then backwards from ``zi *
    y[-1]``. The columns are interleaved (two independent chains of operations at a time),
    each column's operations in scipy's order. Returns the rows of ``u``."""
    n0, m = u.shape
    n = n0 + 2 * pad
    y = np.empty((n, m))
    z = np.empty((m, sos.shape[0], 2))
    for i in range(m):
        start(zi, z, i, 2.0 * u[0, i] - u[pad, i])
    for k in range(pad):
        for i in range(m):
            y[k, i] = sections(sos, z, i, 2.0 * u[0, i] - u[pad - k, i])
    for k in range(n0):
        for i in range(m):
            y[pad + k, i] = sections(sos, z, i, u[k, i])
    for k in range(pad):
        for i in range(m):
            y[pad + n0 + k, i] = sections(sos, z, i, 2.0 * u[n0 - 1, i] - u[n0 - 2 - k, i])
    for i in range(m):
        start(zi, z, i, y[n - 1, i])
    for k in range(n - 1, -1, -1):
        for i in range(m):
            y[k, i] = sections(sos, z, i, y[k, i])
    return y[pad : n - pad]
'''

_lock = threading.Lock()


@functools.lru_cache(maxsize=32)
def lowpass_design(order: int, f_c: float, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """``(sos, zi)`` of the Butterworth low-pass of ``order`` at ``f_c`` Hz for records at
    ``fs`` Hz: scipy's ``butter(order, f_c, fs=fs, output="sos")`` and ``sosfilt_zi`` of it,
    read from the cache folder when an earlier process designed it (read-only arrays)."""
    import scipy  # its version only (a few ms): scipy.signal is imported on a miss

    # a design is scipy's: another scipy version designs it again
    key = json.dumps([int(order), float(f_c), float(fs), scipy.__version__])
    path = _design_path(key)
    design = _read_design(path, key) if path is not None else None
    if design is None:
        from scipy.signal import butter, sosfilt_zi

        sos = np.asarray(butter(order, f_c, btype="low", fs=fs, output="sos"), dtype=float)
        zi = np.asarray(sosfilt_zi(sos), dtype=float)
        design = sos, zi
        if path is not None:
            _write_design(path, key, sos, zi)
    for a in design:
        a.setflags(write=False)
    return design


def _design_path(key: str) -> Path | None:
    from adaptive_ftc.sim.codegen import cache_dir

    folder = cache_dir()
    if folder is None:
        return None
    return folder / f"lowpass_{hashlib.sha256(key.encode()).hexdigest()[:24]}.json"


def _read_design(path: Path, key: str) -> tuple[np.ndarray, np.ndarray] | None:
    """The stored design, or ``None`` when there is none (or it is not ours: redesigned)."""
    try:
        stored = json.loads(path.read_text(encoding="utf-8"))
        if stored["key"] != key:
            return None
        sos = np.array(stored["sos"], dtype=float)
        zi = np.array(stored["zi"], dtype=float)
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if sos.ndim != 2 or sos.shape[1] != 6 or zi.shape != (sos.shape[0], 2):
        return None
    return sos, zi


def _write_design(path: Path, key: str, sos: np.ndarray, zi: np.ndarray) -> None:
    # JSON numbers round-trip Python floats exactly; written under a private name, then renamed
    text = json.dumps({"key": key, "sos": sos.tolist(), "zi": zi.tolist()})
    tmp = path.with_suffix(f".{os.getpid()}.{threading.get_ident()}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    except OSError:  # a full or vanished cache folder: the design is recomputed next time
        tmp.unlink(missing_ok=True)


@functools.cache
def _kernel():
    from adaptive_ftc.sim.codegen import load_module

    with _lock:
        return load_module(_KERNEL, imports=[], kind="lowpass").filtfilt_odd


def sosfiltfilt_odd(sos: np.ndarray, zi: np.ndarray, u: np.ndarray, pad: int) -> np.ndarray:
    """``scipy.signal.sosfiltfilt(sos, u, axis=0, padtype="odd", padlen=pad)`` for a 2-d
    record ``u`` (samples, columns) with ``0 < pad < len(u)``; ``zi`` is ``sosfilt_zi(sos)``."""
    from numba.core.config import DISABLE_JIT  # type: ignore[attr-defined]  # set at import

    if DISABLE_JIT:
        from scipy.signal import sosfiltfilt

        return sosfiltfilt(sos.copy(), u, axis=0, padtype="odd", padlen=pad)
    u = np.asarray(u, dtype=float)
    # scipy's odd_ext (the record reflected through its end values, pad samples each side) is
    # built inside the kernel, read straight from u's rows (no padded copy of the record)
    return _kernel()(np.ascontiguousarray(sos), np.ascontiguousarray(zi), u, int(pad))
