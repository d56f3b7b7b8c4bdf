"""Clear errors for a closed loop's compiled code: numba's compiler errors and the bounds-checked
indices of a plant's equations become a :class:`~adaptive_ftc.errors.ConfigurationError` that
names the plant (used where the loop's modules are compiled, :mod:`adaptive_ftc.sim.compose`,
and where they run, :mod:`adaptive_ftc.sim.engine`)."""

from __future__ import annotations

import contextlib
import os
from typing import TYPE_CHECKING

from adaptive_ftc.errors import ConfigurationError

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["clear_compile_errors"]


@contextlib.contextmanager
def clear_compile_errors(loop: ClosedLoop):
    """Compile or run ``loop``'s compiled code: numba's errors (and a bounds-checked index of
    the plant's equations) become a :class:`ConfigurationError` naming the plant."""
    try:
        yield
    except Exception as exc:
        err, chain = _compile_error(loop, exc)
        if err is exc:
            raise
        raise err from (exc if chain else None)


def _compile_error(loop: ClosedLoop, exc: Exception) -> tuple[Exception, bool]:
    """The clear error for ``exc`` raised while compiling or running ``loop``'s compiled code
    (``exc`` itself when it is none of numba's), and whether to chain ``exc`` to it."""
    if isinstance(exc, IndexError):
        if _inside_numba(exc):  # the compiler's own error, not an index of the plant's
            return ConfigurationError(
                f"The closed loop of plant '{loop.plant.name}' cannot be compiled: numba failed "
                f"inside its compiler (IndexError: {exc}). Unset NUMBA_DEBUGINFO / "
                "NUMBA_ENABLE_PROFILING if set, and report the plant's equations."
            ), True
        return ConfigurationError(
            f"The equations of plant '{loop.plant.name}' index outside an array ({exc}): "
            f"x has {loop.plant.n_states} states, u has {loop.plant.n_actuators} actuators and "
            "xdot has one entry per state."
        ), False
    import numba.core.errors

    if not (
        isinstance(exc, numba.core.errors.NumbaError) or type(exc).__module__.startswith("numba.")
    ):
        return exc, False
    first = next((ln for ln in str(exc).splitlines() if ln.strip()), str(exc))
    where = [ln.strip() for ln in str(exc).splitlines() if ln.strip().startswith("File ")]
    return ConfigurationError(
        f"The closed loop of plant '{loop.plant.name}' cannot be compiled: {first.strip()}"
        + (f" ({where[-1]})" if where else "")
        + ". Plant equations must use numbers, arrays, indexing, loops and the math "
        "module only (the subset numba compiles)."
    ), False


def _inside_numba(exc: BaseException) -> bool:
    """Whether ``exc`` was raised by numba's own Python code (its compiler), not by compiled
    code at run time (a bounds-checked index of the plant's equations)."""
    import traceback

    frames = traceback.extract_tb(exc.__traceback__)
    return any(f"{os.sep}numba{os.sep}" in f.filename for f in frames)
