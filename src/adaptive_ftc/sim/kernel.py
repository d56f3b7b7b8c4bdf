"""Removed: the monolithic kernel was replaced by generated per-structure modules.

Use :func:`adaptive_ftc.sim.compose.assemble` (``asm = assemble(loop)``): the compiled closed
loop is ``asm.module.rhs(t, Y, phase, asm.data, asm.work(), dY)`` (same argument order as the
old ``closed_loop(t, Y, phase, M, W, dY)``), with ``asm.y0``, ``asm.breakpoints`` and
``asm.module.integrate_rk4`` / ``asm.module.signals``; see ``sim/templates/`` for the pasted
integrators. ``asm.derivative(t, y, phase)`` is an allocating convenience.
"""

raise ImportError(
    "adaptive_ftc.sim.kernel was removed: use adaptive_ftc.sim.compose.assemble(loop); "
    "asm.module.rhs(t, Y, phase, asm.data, asm.work(), dY) is the compiled closed loop "
    "(see the docstring of adaptive_ftc/sim/kernel.py)."
)
