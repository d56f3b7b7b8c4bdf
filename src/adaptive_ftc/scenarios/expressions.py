"""The safe expression language, under its former name.

The language is part of the library core (failure models, designs and the loop generator use
it) and lives in :mod:`adaptive_ftc.expressions`; this module keeps the old import path working.
"""

from adaptive_ftc.expressions import (
    FUNCTIONS,
    MAX_DEPTH,
    MAX_DERIVATIVE_NODES,
    MAX_LENGTH,
    MAX_LITERAL,
    MAX_NODES,
    Expression,
    parse,
)

__all__ = [
    "FUNCTIONS",
    "MAX_DEPTH",
    "MAX_DERIVATIVE_NODES",
    "MAX_LENGTH",
    "MAX_LITERAL",
    "MAX_NODES",
    "Expression",
    "parse",
]
