"""Calls to compiled functions through their addresses, from compiled code.

The integrators (RK4, DOPRI5, the Rosenbrock methods) are the same for every closed loop; only
the right-hand side ``rhs`` and the interval update ``jump`` differ. Calling those through an
address read from the loop's data (``D.i``) lets one compiled integrator serve every loop
structure: it compiles once per machine (disk cache) instead of once per structure, where it
was about half of a new structure's compile time (1.7 s of 3.5 s for DOPRI5).

The address is that of numba's own compiled function (numba's internal calling convention,
not a C wrapper), so the call costs what a direct, non-inlined call costs, and an exception the
callee raises (a bounds-checked index of a user's plant) propagates as usual. The argument
types must be exactly those the callee was compiled for; :func:`address` compiles it for the
types the integrators pass (C-contiguous float64 arrays, float64 time, int64 interval, the
loop's data tuple), and these intrinsics refuse anything else at compile time.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.core.errors import TypingError
from numba.core.extending import intrinsic

__all__ = [
    "address",
    "python_function",
    "call_gain",
    "call_jump",
    "call_rhs",
    "signature_gain",
    "signature_jump",
    "signature_rhs",
]

_VEC = types.Array(types.float64, 1, "C")


def signature_rhs(data_type) -> tuple:
    """Argument types of ``rhs(t, Y, ph, D, W, dY)`` as the integrators call it."""
    return (types.float64, _VEC, types.int64, data_type, _VEC, _VEC)


def signature_jump(data_type) -> tuple:
    """Argument types of ``jump(t, Y, ph, D, W)`` as the integrators call it."""
    return (types.float64, _VEC, types.int64, data_type, _VEC)


def signature_gain(data_type) -> tuple:
    """Argument types of ``control_gain(t, Y, ph, D, W, unit, x0dot, x1dot)`` as the shared
    ``signals`` calls it."""
    return (types.float64, _VEC, types.int64, data_type, _VEC, _VEC, _VEC, _VEC)


#: with ``NUMBA_DISABLE_JIT=1`` (stepping through the generated code in Python) an "address"
#: is the id of the Python function, looked up here by :func:`python_function`
_PYTHON: dict[int, object] = {}


def python_function(addr: int):
    """The Python function that :func:`address` registered as ``addr`` (no-JIT mode)."""
    return _PYTHON[int(addr)]


def address(dispatcher, sig: tuple) -> int:
    """Compile (or load) ``dispatcher`` for ``sig`` and return the address of the compiled
    function (numba's calling convention); with ``NUMBA_DISABLE_JIT=1``, a key of
    :func:`python_function`."""
    if not hasattr(dispatcher, "compile"):  # NUMBA_DISABLE_JIT=1: a plain Python function
        _PYTHON[id(dispatcher)] = dispatcher
        return id(dispatcher)
    dispatcher.compile(sig)
    cres = dispatcher.overloads[sig]
    return int(cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name))


def _check(args: tuple, expected: tuple, what: str) -> None:
    if tuple(args) != tuple(expected):
        raise TypingError(
            f"{what} through an address needs arguments {expected}; got {tuple(args)} (the "
            "integrator would pass other types than the function was compiled for)."
        )


def _call(context, builder, argtys, args, fptr, restype=types.none):
    fnty = context.call_conv.get_function_type(restype, argtys)
    fn = builder.inttoptr(fptr, fnty.as_pointer())
    status, out = context.call_conv.call_function(builder, fn, restype, argtys, args)
    with cgutils.if_unlikely(builder, status.is_error):
        context.call_conv.return_status_propagate(builder, status)
    return context.get_dummy_value() if restype is types.none else out


@intrinsic
def call_rhs(typingctx, fptr, t, Y, ph, D, W, dY):
    """``rhs(t, Y, ph, D, W, dY)`` at address ``fptr`` (an int64)."""
    args = (t, Y, ph, D, W, dY)
    _check(args, signature_rhs(D), "rhs")

    def codegen(context, builder, signature, llargs):
        return _call(context, builder, signature.args[1:], llargs[1:], llargs[0])

    return types.none(fptr, *args), codegen


@intrinsic
def call_jump(typingctx, fptr, t, Y, ph, D, W):
    """``jump(t, Y, ph, D, W)`` at address ``fptr`` (an int64)."""
    args = (t, Y, ph, D, W)
    _check(args, signature_jump(D), "jump")

    def codegen(context, builder, signature, llargs):
        return _call(context, builder, signature.args[1:], llargs[1:], llargs[0])

    return types.none(fptr, *args), codegen


@intrinsic
def call_gain(typingctx, fptr, t, Y, ph, D, W, unit, x0dot, x1dot):
    """``control_gain(t, Y, ph, D, W, unit, x0dot, x1dot)`` at address ``fptr`` (a float)."""
    args = (t, Y, ph, D, W, unit, x0dot, x1dot)
    _check(args, signature_gain(D), "control_gain")

    def codegen(context, builder, signature, llargs):
        return _call(
            context, builder, signature.args[1:], llargs[1:], llargs[0], restype=types.float64
        )

    return types.float64(fptr, *args), codegen
