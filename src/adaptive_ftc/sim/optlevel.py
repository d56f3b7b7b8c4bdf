"""The LLVM optimisation level of the generated closed loops.

numba optimises at ``-O3`` unless ``NUMBA_OPT`` says otherwise. On our loops ``-O2`` is as
fast or faster (measured with ``NUMBA_OPT=2`` vs ``3`` on seven catalogue scenarios, every
method, two interleaved pairs: equal within the noise, about 1 %, or faster;
hypersonic-direct-s1 on RK4 dt 1e-3, the C benchmark's loop, 6-7 % faster) and gives the same
numbers (all 29 catalogue trajectories bit-identical).

numba reads its level from ``numba.core.config.OPT`` whenever it builds its LLVM pass
pipelines, so the loops' dispatchers (:func:`at_loop_level`) set it for their own
compilation only, under numba's global compiler lock: numba code of other libraries or of the
user compiles at numba's setting, before, after and in other threads. An explicit
``NUMBA_OPT`` in the environment always wins.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator

#: LLVM optimisation level of the generated loops
LOOP_OPT = 2


@contextlib.contextmanager
def _loop_level() -> Iterator[None]:
    if "NUMBA_OPT" in os.environ:  # the user chose: numba's own setting stands
        yield
        return
    from numba.core import config
    from numba.core.compiler_lock import global_compiler_lock

    # numba.core.config sets its settings (OPT among them) at import: mypy does not see them
    with global_compiler_lock:  # re-entrant: callees compile inside their caller's compile
        before = config.OPT  # type: ignore[attr-defined]
        config.OPT = type(before)(LOOP_OPT)  # type: ignore[attr-defined]
        try:
            yield
        finally:
            config.OPT = before  # type: ignore[attr-defined]


def at_loop_level(decorator: Callable) -> Callable:
    """Wrap a numba decorator (``njit(...)``) so that its dispatchers compile (or load from the
    cache) at :data:`LOOP_OPT`; the generated modules define their ``jit`` and ``hot`` this
    way."""
    return compiling_within(decorator, _loop_level)


def compiling_within(decorator: Callable, settings: Callable) -> Callable:
    """Wrap a numba decorator so that its dispatchers compile (or load from the cache) inside
    the context ``settings()`` (numba's settings for that compile only: :func:`_loop_level`,
    the lane modules' SLP switch)."""

    def wrap(func):
        dispatcher = decorator(func)
        if not hasattr(dispatcher, "compile"):  # NUMBA_DISABLE_JIT=1: the plain function
            return dispatcher
        compile_ = dispatcher.compile

        def compile(sig):
            with settings():
                return compile_(sig)

        dispatcher.compile = compile  # numba's first call compiles through self.compile
        return dispatcher

    return wrap
