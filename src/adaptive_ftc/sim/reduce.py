"""Compiled reductions of recorded runs: the numbers of :meth:`SimResult.metrics`,
:meth:`SimResult.recovery` and a campaign's outcome row in one pass over the records.

A 120 s run recorded every millisecond holds 120,001 rows of a signal block about 17 columns
wide; the tracking error, the commands and the actuator outputs are columns of it (strided
views). Reduced with numpy, every ``np.max(np.abs(...))`` and ``np.mean(... ** 2)`` is one more
pass over the whole block and one more temporary array (18 ms of CPU per run in a campaign,
a third of its simulation's). These kernels read each row once and allocate nothing on the
common path; they release the GIL, so the threads of a batch reduce their own runs.

Equal to numpy, bit for bit: sums of squares are added in numpy's own pairwise order
(``pairwise_sum`` of numpy's ufunc loops: blocks of at most 128 elements summed with eight
accumulators, halves split on multiples of eight), over the row-major flattening numpy sums a
contiguous ``e[rows] ** 2`` in; maxima propagate ``nan`` as ``np.max`` does. ``tests/
test_fast_metrics.py`` compares every number with the plain numpy expressions.

Imported on first use; each entry point compiles on its first call, once per machine (cached
on disk), and loads from the cache in about 0.06 s for all after that.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import boolean, float64, int64, njit, types

__all__ = [
    "error_stats",
    "grid_spacing",
    "last_above",
    "nondecreasing",
    "rms_rows",
    "row_span",
]

_A1 = float64[:]  # any layout: strided columns and contiguous buffers alike
_A2 = float64[:, :]


def _jit(signature):
    """An entry point, cached on disk; compiled (or loaded) on its first call. (``signature``
    documents the types it is called with: given to numba, it compiles or loads every entry
    point at import, 0.5 s warm against 0.06 s for those a caller uses.)"""
    del signature
    return njit(cache=True, nogil=True, error_model="numpy")


#: A helper: compiled into the entry points that call it (no cache entry of its own to load)
_inner = njit(nogil=True, error_model="numpy")


@_inner
def _leaf(x, lo, n):
    """numpy's pairwise sum of the squares of a block of at most 128 elements."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += x[i] * x[i]
        return res
    # eight accumulators, as numpy's unrolled loop
    r0 = x[lo] * x[lo]
    r1 = x[lo + 1] * x[lo + 1]
    r2 = x[lo + 2] * x[lo + 2]
    r3 = x[lo + 3] * x[lo + 3]
    r4 = x[lo + 4] * x[lo + 4]
    r5 = x[lo + 5] * x[lo + 5]
    r6 = x[lo + 6] * x[lo + 6]
    r7 = x[lo + 7] * x[lo + 7]
    i = 8
    stop = n - (n % 8)
    while i < stop:
        j = lo + i
        r0 += x[j] * x[j]
        r1 += x[j + 1] * x[j + 1]
        r2 += x[j + 2] * x[j + 2]
        r3 += x[j + 3] * x[j + 3]
        r4 += x[j + 4] * x[j + 4]
        r5 += x[j + 5] * x[j + 5]
        r6 += x[j + 6] * x[j + 6]
        r7 += x[j + 7] * x[j + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += x[lo + i] * x[lo + i]
        i += 1
    return res


@_inner
def _fold_max(m, a, r0, r1):
    """``max(m, max |a[r0:r1]|)``, ``nan`` sticky as ``np.max`` propagates it."""
    for i in range(r0, r1):
        for j in range(a.shape[1]):
            v = abs(a[i, j])
            if v > m:
                m = v
            elif v != v:
                return np.nan
    return m


@_inner
def _fold3(x, a2, b2, lo, n, acc):
    m = acc[0]
    for i in range(lo, lo + n):
        v = abs(x[i])
        if v > m:
            m = v
        elif v != v:
            m = np.nan
            break
    acc[0] = m
    acc[1] = _fold_max(acc[1], a2, lo, lo + n)
    acc[2] = _fold_max(acc[2], b2, lo, lo + n)


@_inner
def _pairwise(x, lo, n, fold, a2, b2, acc):
    """numpy's pairwise sum of the squares of ``x[lo:lo + n]``: halves split
    on multiples of eight down to blocks of at most 128, each half summed before the two are
    added. Without recursion (numba's disk cache does not keep recursive functions): a stack
    of tasks (a block to sum, or -1: add the top two sums) and a stack of sums.

    ``fold``: also fold ``max |x|``, ``max |a2|`` and ``max |b2|`` over the same rows into
    ``acc[0:3]`` (``x`` a column of ``a2``'s rows: one pass over the records for all; each
    block is in the L1 cache when its maxima are taken)."""
    if n <= 128:
        if fold:
            _fold3(x, a2, b2, lo, n, acc)
        return _leaf(x, lo, n)
    task_lo = np.empty(256, np.int64)
    task_n = np.empty(256, np.int64)
    sums = np.empty(128)
    nt = 1
    ns = 0
    task_lo[0] = lo
    task_n[0] = n
    while nt:
        nt -= 1
        a, m = task_lo[nt], task_n[nt]
        if m < 0:  # both halves summed: add them
            ns -= 1
            sums[ns - 1] = sums[ns - 1] + sums[ns]
        elif m <= 128:
            sums[ns] = _leaf(x, a, m)
            if fold:
                _fold3(x, a2, b2, a, m, acc)
            ns += 1
        else:
            m2 = m // 2
            m2 -= m2 % 8
            task_lo[nt], task_n[nt] = 0, -1  # after both halves
            task_lo[nt + 1], task_n[nt + 1] = a + m2, m - m2  # the right half, second
            task_lo[nt + 2], task_n[nt + 2] = a, m2  # the left half, first
            nt += 3
    return sums[0]


@_inner
def _sum_squares(a, r0, r1):
    """``np.sum(a[r0:r1] ** 2)`` (``a``: 2-D, any strides), numpy's order."""
    p = a.shape[1]
    if r1 <= r0 or p == 0:
        return 0.0
    acc = np.empty(3)
    if p == 1:
        return _pairwise(a[:, 0], r0, r1 - r0, False, a, a, acc)
    flat = np.empty(((r1 - r0) * p, 1))  # the row-major order numpy sums e[rows] ** 2 in
    k = 0
    for i in range(r0, r1):
        for j in range(p):
            flat[k, 0] = a[i, j]
            k += 1
    return _pairwise(flat[:, 0], 0, flat.shape[0], False, a, a, acc)


@_jit(float64[::1](_A2, _A2, _A2, int64))
def _error_stats(e, u_cmd, u_applied, i_final):
    """``[sum e^2, max |e|, sum e^2 and max |e| from row i_final on, max |u_cmd|,
    max |u_applied|]`` over the records; one pass over them for a single output."""
    n = e.shape[0]
    out = np.empty(6)
    acc = np.full(3, -np.inf)
    if e.shape[1] == 1 and n > 0:
        out[0] = _pairwise(e[:, 0], 0, n, True, u_cmd, u_applied, acc)
        out[1], out[4], out[5] = acc[0], acc[1], acc[2]
    else:
        out[0] = _sum_squares(e, 0, n)
        out[1] = _fold_max(-np.inf, e, 0, n)
        out[4] = _fold_max(-np.inf, u_cmd, 0, u_cmd.shape[0])
        out[5] = _fold_max(-np.inf, u_applied, 0, u_applied.shape[0])
    out[2] = _sum_squares(e, i_final, n)
    out[3] = _fold_max(-np.inf, e, i_final, n)
    return out


@_jit(int64(_A2, int64, int64, float64))
def _last_above(e, r0, r1, tol):
    """Index (from ``r0``) of the last row of ``e[r0:r1]`` whose ``max |e|`` exceeds ``tol``
    (a row holding ``nan`` does not); ``-1``: none."""
    for i in range(r1 - 1, r0 - 1, -1):
        m = -np.inf
        bad = False
        for j in range(e.shape[1]):
            v = abs(e[i, j])
            if v != v:
                bad = True
                break
            if v > m:
                m = v
        if not bad and m > tol:
            return i - r0
    return -1


@_jit(boolean(_A1))
def _nondecreasing(t):
    for i in range(1, t.size):
        if not t[i] >= t[i - 1]:
            return False
    return True


def nondecreasing(time: np.ndarray) -> bool:
    """Whether ``time`` never decreases (and holds no ``nan``): windows are then row spans."""
    t = np.asarray(time)
    if t.ndim != 1 or t.dtype != np.float64:
        return bool(t.size < 2 or np.all(t[1:] >= t[:-1]))
    known = _known_grid(t)
    if known is not None:
        return known.facts("nondecreasing", lambda: bool(_nondecreasing(t)))
    return bool(_nondecreasing(t))


# ----------------------------------------------------------------- facts of known grids
#: Record grids of at least this many rows are remembered once seen twice (a campaign's
#: members share one grid: its facts are found once, not a pass over every member's times
#: per question; a diverged member's shorter grid is seen once and never kept).
MEMO_MIN_ROWS = 4096
#: Grids remembered (the most recently used kept).
MEMO_GRIDS = 4

_memo_lock = threading.Lock()
_memo: list[_Grid] = []
_seen: dict[tuple[int, float, float], int] = {}


class _Grid:
    """A remembered record grid (its own copy) and the facts found about it so far."""

    __slots__ = ("bits", "found")

    def __init__(self, t: np.ndarray) -> None:
        self.bits = t.view(np.int64).copy()
        self.found: dict[str, Any] = {}

    def facts(self, name: str, compute: Callable[[], Any]) -> Any:
        """The fact ``name`` of this grid, computed by ``compute`` the first time (a pure
        function of the times: the same value for every array with these bits)."""
        found = self.found.get(name, _MISSING)
        if found is _MISSING:
            found = self.found[name] = compute()
        return found


_MISSING = object()


@_jit(boolean(int64[::1], int64[::1]))
def _same_bits(a, b):
    """Whether two int64 arrays hold the same values (early exit at the first difference)."""
    if a.size != b.size:
        return False
    for i in range(a.size):
        if a[i] != b[i]:
            return False
    return True


def _known_grid(t: np.ndarray) -> _Grid | None:
    """The remembered grid whose times are ``t``'s bit for bit (remembering ``t`` when it is
    seen the second time), or ``None`` (short, not contiguous, or first seen)."""
    if t.size < MEMO_MIN_ROWS or not (t.flags.c_contiguous and t.flags.writeable):
        return None  # (a read-only array would compile _same_bits once more)
    bits = t.view(np.int64)
    key = (int(t.size), int(bits[0]), int(bits[-1]))
    with _memo_lock:
        candidates = [g for g in _memo if g.bits.size == key[0] and g.bits[0] == key[1]]
    for g in candidates:
        if g.bits[-1] == key[2] and _same_bits(g.bits, bits):
            with _memo_lock:
                if g in _memo:  # most recently used last
                    _memo.remove(g)
                    _memo.append(g)
            return g
    with _memo_lock:
        seen = _seen.get(key, 0) + 1
        if seen < 2:
            if len(_seen) > 64:
                _seen.clear()
            _seen[key] = seen
            return None
        _seen.pop(key, None)
    g = _Grid(t)
    with _memo_lock:
        _memo.append(g)
        del _memo[:-MEMO_GRIDS]
    return g


#: Most distinct spacings :func:`grid_spacing` tracks (an engine record holds about 16: the
#: rounding of ``t0 + k dt`` differs between binades); more: numpy's median instead.
_SPACINGS = 64


@_jit(types.Tuple((int64, float64))(_A1))
def _grid_spacing(t):
    """``(kind, dt)``: ``dt = np.median(np.diff(t))`` (bit for bit) and ``kind`` 0 when every
    spacing is within 1e-6 of it, 1 when all but a shorter last one are, 2 otherwise (or when
    a spacing is not positive or there are too many distinct spacings: ``dt`` is then nan)."""
    n = t.size - 1
    vals = np.empty(_SPACINGS)
    counts = np.zeros(_SPACINGS, np.int64)
    k = 0
    hit = 0
    for i in range(n):
        d = t[i + 1] - t[i]
        if not d > 0:
            return 2, np.nan
        if k and vals[hit] == d:
            counts[hit] += 1
            continue
        lo, hi = 0, k  # binary search in the sorted distinct spacings
        while lo < hi:
            mid = (lo + hi) // 2
            if vals[mid] < d:
                lo = mid + 1
            else:
                hi = mid
        if lo < k and vals[lo] == d:
            counts[lo] += 1
            hit = lo
            continue
        if k == _SPACINGS:
            return 2, np.nan
        for j in range(k, lo, -1):
            vals[j] = vals[j - 1]
            counts[j] = counts[j - 1]
        vals[lo] = d
        counts[lo] = 1
        k += 1
        hit = lo
    # numpy's median: the middle order statistic, or the mean of the two middle ones
    want_a = (n - 1) // 2
    want_b = n // 2
    a = b = np.nan
    seen = 0
    for j in range(k):
        nxt = seen + counts[j]
        if seen <= want_a < nxt:
            a = vals[j]
        if seen <= want_b < nxt:
            b = vals[j]
            break
        seen = nxt
    dt = a if n % 2 else (0.0 + a + b) / 2.0
    tol = 1e-6 * dt
    last_ok = True
    for i in range(n):
        if not abs((t[i + 1] - t[i]) - dt) <= tol:
            if i < n - 1:
                return 2, dt
            last_ok = False
    if last_ok:
        return 0, dt
    return (1, dt) if t[n] - t[n - 1] < dt else (2, dt)


def grid_spacing(t: np.ndarray) -> tuple[int, float]:
    """``(kind, dt)`` of record times ``t`` (at least two): see :func:`_grid_spacing`."""
    t = np.ascontiguousarray(t, dtype=np.float64)

    def compute() -> tuple[int, float]:
        kind, dt = _grid_spacing(t)
        return int(kind), float(dt)

    known = _known_grid(t) if t.ndim == 1 else None
    return known.facts("spacing", compute) if known is not None else compute()


def row_span(time: np.ndarray, start: float, end: float) -> tuple[int, int]:
    """``(i0, i1)``: the rows with ``start - 1e-9 <= t <= end + 1e-9`` of a non-decreasing
    ``time`` (the mask of :meth:`SimResult.window`), as a half-open span."""
    i0 = int(np.searchsorted(time, start - 1e-9, side="left"))
    i1 = int(np.searchsorted(time, end + 1e-9, side="right"))
    return i0, max(i0, i1)


def rms_rows(a: np.ndarray, i0: int, i1: int) -> float:
    """``sqrt(mean(a[i0:i1] ** 2))`` (``nan`` for no rows): numpy on the span (a short window
    of rows: no compiled kernel needed), the same numbers as over the window's mask."""
    if i1 <= i0:
        return math.nan
    return float(np.sqrt(np.mean(a[i0:i1] ** 2)))


def error_stats(
    e: np.ndarray, u_cmd: np.ndarray, u_applied: np.ndarray, i_final: int
) -> tuple[float, float, float, float, float, float]:
    """``(sum e^2, max |e|, sum e^2 final, max |e| final, peak |u_cmd|, peak |u_applied|)``
    over the records (final: from row ``i_final`` on), in one compiled call."""
    out = _error_stats(_f2(e), _f2(u_cmd), _f2(u_applied), int(i_final))
    return tuple(float(v) for v in out)  # type: ignore[return-value]


def last_above(e: np.ndarray, i0: int, i1: int, tol: float) -> int:
    """Offset in ``e[i0:i1]`` of the last row whose ``max |e|`` exceeds ``tol`` (-1: none)."""
    return int(_last_above(_f2(e), int(i0), int(i1), float(tol)))


def _f2(a: np.ndarray) -> np.ndarray:
    a = a.reshape(a.shape[0], -1) if a.ndim != 2 else a
    return a if a.dtype == np.float64 else a.astype(np.float64)
