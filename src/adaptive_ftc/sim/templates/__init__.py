"""Source templates pasted into every generated closed-loop module (see :mod:`..codegen`).

Each file is importable Python (so it is linted and readable); the text after the line
``# --- template: begin ---`` is what a generated module contains. The generated module defines
``jit``, ``rhs(t, Y, ph, D, W, dY)`` and the part functions the templates call.
"""
