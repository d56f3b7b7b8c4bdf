"""Ctrl-C held back over a block that must not be cut in the middle."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

__all__ = ["sigint_deferred"]


@contextlib.contextmanager
def sigint_deferred() -> Iterator[None]:
    """Hold Ctrl-C (SIGINT) until the block ends, then deliver it as usual.

    A ``KeyboardInterrupt`` raised inside netCDF4/HDF5 while xarray holds its file lock leaves
    the lock taken: closing the file then waits on it forever (measured: ``aftc run`` hung in
    ``to_netcdf`` when Ctrl-C came while it wrote a data file). Writes are short, so the
    interrupt waits for the write to finish and is raised right after it. Outside the main
    thread (where Python delivers no signal) the block runs unchanged.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if received:
        if callable(previous):
            previous(signal.SIGINT, None)  # the default handler raises KeyboardInterrupt
        elif previous == signal.SIG_DFL:
            raise KeyboardInterrupt
