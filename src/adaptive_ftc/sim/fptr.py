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

A failure pattern that is not affine (``0.1 + 0.05*cos(0.5*t)``, ``0.5*u - 0.25*u**3``) is a
C function of its own (numba ``cfunc``), called from a loop's ``rhs`` with
:func:`call_pattern`. The call is marked as reading memory only (a pattern reads the state and
its numbers, writes nothing and raises nothing), so the loop keeps its values in registers
across it.
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
    "call_pattern",
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


#: ``value(t, x, u, c, o)`` and ``slope(t, x, u, c, o)`` of a failure pattern that is not
#: affine (a module of its own per pattern text; sim/compose.py): C functions (numba
#: ``cfunc``) of the time, the plant state's data, the command, the numbers' data and the
#: offset of the pattern's numbers in them
SIGNATURE_PATTERN = types.float64(
    types.float64,
    types.CPointer(types.float64),
    types.float64,
    types.CPointer(types.float64),
    types.int64,
)


#: with ``NUMBA_DISABLE_JIT=1`` (stepping through the generated code in Python) an "address"
#: is the id of the Python function, looked up here by :func:`python_function`
_PYTHON: dict[int, object] = {}


def python_function(addr: int):
    """The Python function that :func:`address` registered as ``addr`` (no-JIT mode)."""
    return _PYTHON[int(addr)]


def address(dispatcher, sig: tuple = ()) -> int:
    """Compile (or load) ``dispatcher`` for ``sig`` and return the address of the compiled
    function (numba's calling convention; a ``cfunc``'s C function, ``sig`` unused); with
    ``NUMBA_DISABLE_JIT=1``, a key of :func:`python_function`."""
    if hasattr(dispatcher, "address"):  # a cfunc: compiled (or loaded) when defined
        return int(dispatcher.address)
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


def _is_vector(ty) -> bool:
    return (
        isinstance(ty, types.Array)
        and ty.dtype == types.float64
        and ty.ndim == 1
        and ty.layout == "C"
    )


@intrinsic
def _call_pattern(typingctx, fptr, t, x, u, c, o):
    if not (
        _is_vector(x)
        and _is_vector(c)
        and t == types.float64
        and u == types.float64
        and isinstance(o, types.Integer)
    ):
        raise TypingError(
            "A failure pattern through an address needs (float64 t, contiguous float64 x, "
            f"float64 u, contiguous float64 c, integer o); got {(t, x, u, c, o)}."
        )

    def codegen(context, builder, signature, llargs):
        from llvmlite import ir

        fp, t_, x_, u_, c_, o_ = llargs
        xd = context.make_array(signature.args[2])(context, builder, x_).data
        cd = context.make_array(signature.args[4])(context, builder, c_).data
        o64 = context.cast(builder, o_, signature.args[5], types.int64)
        d = ir.DoubleType()
        fnty = ir.FunctionType(d, [d, d.as_pointer(), d, d.as_pointer(), ir.IntType(64)])
        fn = builder.inttoptr(fp, fnty.as_pointer())
        # a pattern reads x and c and writes nothing (no exception either: expressions
        # compile with error_model="numpy" and guarded functions): telling LLVM so keeps the
        # loop's values in registers across the call (without it, 3 % slower)
        return builder.call(fn, [t_, xd, u_, cd, o64], attrs=("readonly", "nounwind"))

    return types.float64(fptr, t, x, u, c, o), codegen


def _call_pattern_python(fptr, t, x, u, c, o):
    return python_function(fptr)(t, x, u, c, o)


def _pick_call_pattern():
    from numba.core.config import DISABLE_JIT

    return _call_pattern_python if DISABLE_JIT else _call_pattern


#: ``value`` or ``slope`` of a failure pattern at address ``fptr``: ``(fptr, t, x, u, c, o)``
#: (with ``NUMBA_DISABLE_JIT=1``, the registered Python function)
call_pattern = _pick_call_pattern()
