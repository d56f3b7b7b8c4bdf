"""Guarded math for generated code: the same results as numpy on every input, never an error.

Generated loop modules call these for the functions of the expression language whose plain
``math`` version would raise on some inputs (``log(-1)``, ``sqrt(-1)``, ``exp(1000)``...). They are
plain Python functions written in the subset numba compiles; each generated module jits them.
"""

from __future__ import annotations

import math

__all__ = ["FUNCTIONS"]


def g_pow(a, b):
    """``a**b`` with numpy's answers for a negative base or zero to a negative power."""
    if a < 0.0 and b != math.floor(b):
        return math.nan
    if a == 0.0 and b < 0.0:
        return math.inf
    return a**b


def g_exp(a):
    return math.exp(a) if a < 700.0 else math.inf


def g_log(a):
    if a > 0.0:
        return math.log(a)
    return -math.inf if a == 0.0 else math.nan


def g_sqrt(a):
    return math.sqrt(a) if a >= 0.0 else math.nan


def g_sign(a):
    return 1.0 if a > 0.0 else (-1.0 if a < 0.0 else 0.0)


def g_asin(a):
    return math.asin(a) if abs(a) <= 1.0 else math.nan


def g_acos(a):
    return math.acos(a) if abs(a) <= 1.0 else math.nan


def g_sinh(a):
    return math.sinh(a) if abs(a) < 700.0 else math.copysign(math.inf, a)


def g_cosh(a):
    return math.cosh(a) if abs(a) < 700.0 else math.inf


def g_clip(a, lo, hi):
    return min(max(a, lo), hi)


def g_lt(a, b):
    return 1.0 if a < b else 0.0


def g_inside(a, lo, hi):
    return 1.0 if (a > lo and a < hi) else 0.0


#: Expression-language function -> the Python text generated for it.
FUNCTIONS = {
    "sin": "math.sin",
    "cos": "math.cos",
    "tan": "math.tan",
    "tanh": "math.tanh",
    "atan": "math.atan",
    "abs": "abs",
    "min": "min",
    "max": "max",
    "atan2": "math.atan2",
    "exp": "g_exp",
    "log": "g_log",
    "sqrt": "g_sqrt",
    "sign": "g_sign",
    "asin": "g_asin",
    "acos": "g_acos",
    "sinh": "g_sinh",
    "cosh": "g_cosh",
    "clip": "g_clip",
    "_lt": "g_lt",
    "_inside": "g_inside",
}
GUARDED = (
    "g_pow",
    "g_exp",
    "g_log",
    "g_sqrt",
    "g_sign",
    "g_asin",
    "g_acos",
    "g_sinh",
    "g_cosh",
    "g_clip",
    "g_lt",
    "g_inside",
)
