"""Record blocks that are used again: the big uninitialised arrays of a run's records.

A 120 s run recorded every millisecond fills a 26 MB block of states and a 16 MB block of
signals. Allocated fresh each run, the system hands out new pages and zeroes them: 5-12 ms of
system time per run on the 2-core machine, a fifth of a campaign run's cost (issue 29). Here a
block whose arrays are all gone goes back to a small pool and the next run of the same size
takes it, already mapped.

A block is an array over a ``bytearray``: numpy's views of it (a result's ``states``, ``e``,
...) keep that array alive, so the block returns to the pool only when nothing can read it
any more (``weakref.finalize`` on the array). Blocks under :data:`MIN_BYTES` are plain
``np.empty``; the pool holds at most :data:`MAX_POOLED_BYTES` in all (the oldest size is
dropped first), so a long session keeps little memory it does not use.
"""

from __future__ import annotations

import threading
import weakref
from collections import OrderedDict

import numpy as np

__all__ = ["MAX_POOLED_BYTES", "MIN_BYTES", "empty"]

#: Smallest block taken from / given back to the pool (smaller ones: ``np.empty``).
MIN_BYTES = 4 << 20
#: Most bytes the pool keeps for later runs.
MAX_POOLED_BYTES = 256 << 20

_lock = threading.Lock()
_pool: OrderedDict[int, list[bytearray]] = OrderedDict()  # nbytes -> free buffers
_pooled = 0


def empty(
    shape: tuple[int, ...], dtype: type | np.dtype = np.float64, *, min_bytes: int = MIN_BYTES
) -> np.ndarray:
    """An uninitialised C-contiguous array, like ``np.empty(shape, dtype)``; a big one (at
    least ``min_bytes``) over a buffer from the pool when one of its size is free."""
    dt = np.dtype(dtype)
    nbytes = int(np.prod(shape, dtype=np.int64)) * dt.itemsize
    if nbytes < min_bytes:
        return np.empty(shape, dt)
    raw = _take(nbytes)
    owner = np.frombuffer(raw, dtype=dt)  # not the buffer's owner: views collapse onto it
    finalizer = weakref.finalize(owner, _give_back, raw)
    finalizer.atexit = False
    return owner.reshape(shape)


def _take(nbytes: int) -> bytearray:
    global _pooled
    with _lock:
        free = _pool.get(nbytes)
        if free:
            _pooled -= nbytes
            raw = free.pop()
            if not free:  # no empty list left behind for _give_back's eviction to pop from
                del _pool[nbytes]
            return raw
    return bytearray(nbytes)


def _give_back(raw: bytearray) -> None:
    global _pooled
    nbytes = len(raw)
    with _lock:
        _pool.setdefault(nbytes, []).append(raw)
        _pool.move_to_end(nbytes)
        _pooled += nbytes
        while _pooled > MAX_POOLED_BYTES and _pool:
            size, free = next(iter(_pool.items()))  # the size used longest ago
            free.pop()
            _pooled -= size
            if not free:
                del _pool[size]


def pooled_bytes() -> int:
    """Bytes held by the pool now (free blocks)."""
    with _lock:
        return _pooled
