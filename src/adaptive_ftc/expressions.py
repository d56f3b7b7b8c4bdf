"""A small, safe expression language for failure patterns and references.

Expressions such as ``0.1 + 0.05*cos(0.5*t) - 0.08*sin(0.5*t)`` or ``0.4*u**3 + 0.5*x1*x2`` are
parsed with :mod:`ast` into a tree of a handful of node kinds (numbers, variables, ``+ - * / **``,
unary minus and calls to a fixed list of math functions). Nothing is ever evaluated by Python's
``eval``/``exec``: anything outside the grammar (attributes, subscripts, ``__import__``, lambdas,
comparisons, ...) is rejected with an :class:`~adaptive_ftc.errors.ExpressionError`.

A parsed :class:`Expression` can be

* evaluated with numpy (broadcasting over any batch shape),
* differentiated symbolically (``d/dt`` of a reference, ``d/du`` of a failure),
* compiled into native code of the closed loop (:func:`adaptive_ftc.sim.codegen.emit`).
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adaptive_ftc.errors import ExpressionError, did_you_mean

__all__ = ["Expression", "FUNCTIONS", "parse"]

#: Functions a user may call, with their number of arguments.
FUNCTIONS: dict[str, int] = {
    "sin": 1,
    "cos": 1,
    "tan": 1,
    "exp": 1,
    "log": 1,
    "sqrt": 1,
    "tanh": 1,
    "abs": 1,
    "sign": 1,
    "atan": 1,
    "asin": 1,
    "acos": 1,
    "sinh": 1,
    "cosh": 1,
    "min": 2,
    "max": 2,
    "clip": 3,
    "atan2": 2,
}
_INTERNAL = {"_lt": 2, "_inside": 3}
_CONSTANTS = {"pi": math.pi, "e": math.e}

_NUMPY: dict[str, Callable[..., Any]] = {
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "exp": np.exp,
    "log": np.log,
    "sqrt": np.sqrt,
    "tanh": np.tanh,
    "abs": np.abs,
    "sign": np.sign,
    "atan": np.arctan,
    "asin": np.arcsin,
    "acos": np.arccos,
    "sinh": np.sinh,
    "cosh": np.cosh,
    "min": np.minimum,
    "max": np.maximum,
    "clip": lambda a, lo, hi: np.minimum(np.maximum(a, lo), hi),
    "atan2": np.arctan2,
    "_lt": lambda a, b: np.where(a < b, 1.0, 0.0),
    "_inside": lambda a, lo, hi: np.where((a > lo) & (a < hi), 1.0, 0.0),
}

#: Parse-time limits: characters, nesting depth of the syntax tree, number of syntax nodes,
#: magnitude of a literal, and size of a symbolic derivative (nodes of the expanded tree).
MAX_LENGTH = 2000
MAX_DEPTH = 100
MAX_NODES = 1000
MAX_LITERAL = 1e100
MAX_DERIVATIVE_NODES = 20_000

# Node = ("const", value) | ("var", name) | ("bin", op, a, b) | ("neg", a) | ("call", f, args)
Node = tuple


# ----------------------------------------------------------------------------- parsing
def _err(text: str, what: str, context: str) -> ExpressionError:
    where = f" in {context}" if context else ""
    text = text if len(text) <= 80 else text[:77] + "..."
    if len(what) > 400:
        what = what[:397] + "..."
    return ExpressionError(f"Bad expression '{text}'{where}: {what}")


#: parsed trees of strings, per (text, variables): a campaign parses the same failure and
#: reference texts for every member (trees are tuples, so sharing them is safe)
_PARSED: dict[tuple[str, tuple[str, ...]], Node] = {}
_DERIVED: dict[tuple[Node, str], Node] = {}
_MEMO_SIZE = 4096


def parse(text: str, variables: tuple[str, ...], *, context: str = "") -> Node:
    """Parse ``text`` into a node tree, allowing only ``variables`` and known functions."""
    if type(text) is str:
        key = (text, tuple(variables))
        node = _PARSED.get(key)
        if node is None:
            node = _parse(text, key[1], context)
            if len(_PARSED) < _MEMO_SIZE:
                _PARSED[key] = node
        return node
    return _parse(text, variables, context)


def _parse(text: str, variables: tuple[str, ...], context: str) -> Node:
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise _err(str(text), "expected a number or a string expression.", context)
    if isinstance(text, (int, float)):
        return ("const", _literal(text, str(text)[:40], context))
    src = text.strip()
    if not src:
        raise _err(text, "the expression is empty.", context)
    if len(src) > MAX_LENGTH:
        raise _err(
            src[:40] + "...",
            f"the expression is longer than {MAX_LENGTH} characters; split it or simplify it.",
            context,
        )
    try:
        tree = ast.parse(src, mode="eval")
    except SyntaxError as exc:
        col = f" at column {exc.offset}" if exc.offset else ""
        raise _err(
            src,
            f"invalid syntax{col}. Use Python-style arithmetic, e.g. '0.75*u**3 - 0.2'.",
            context,
        ) from None
    except (RecursionError, MemoryError, ValueError, OverflowError):
        raise _err(
            src[:40] + "...",
            f"the expression nests too deeply or is too large (at most {MAX_DEPTH} levels); "
            "simplify it.",
            context,
        ) from None
    _check_shape(tree.body, src, context)
    return _convert(tree.body, src, variables, context)


def _literal(value: float | int, shown: str, context: str) -> float:
    """A finite float of magnitude at most :data:`MAX_LITERAL`, or an ExpressionError."""
    if isinstance(value, int) and value.bit_length() > 340:  # > 1e100, before float() overflows
        raise _err(
            shown,
            f"the number is larger than {MAX_LITERAL:g} in magnitude; use a smaller one.",
            context,
        )
    v = float(value)
    if not math.isfinite(v):
        raise _err(shown, "the number must be finite.", context)
    if abs(v) > MAX_LITERAL:
        raise _err(
            shown,
            f"the number is larger than {MAX_LITERAL:g} in magnitude; use a smaller one.",
            context,
        )
    return v


def _check_shape(root: ast.AST, src: str, context: str) -> None:
    """Depth and node-count limits, checked without recursion (before converting)."""
    stack = [(root, 1)]
    count = 0
    while stack:
        node, depth = stack.pop()
        count += 1
        if depth > MAX_DEPTH:
            raise _err(
                src[:40] + ("..." if len(src) > 40 else ""),
                f"the expression nests deeper than {MAX_DEPTH} levels; simplify it.",
                context,
            )
        if count > MAX_NODES:
            raise _err(
                src[:40] + ("..." if len(src) > 40 else ""),
                f"the expression has more than {MAX_NODES} terms; simplify it.",
                context,
            )
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))


def _tree_size(n: Node, memo: dict[int, int] | None = None) -> int:
    """Nodes of ``n`` with shared sub-trees counted each time (what printing, evaluating and
    compiling visit), computed in time linear in the shared graph."""
    memo = {} if memo is None else memo
    key = id(n)
    if key in memo:
        return memo[key]
    kind = n[0]
    if kind in ("const", "var"):
        size = 1
    elif kind == "neg":
        size = 1 + _tree_size(n[1], memo)
    elif kind == "bin":
        size = 1 + _tree_size(n[2], memo) + _tree_size(n[3], memo)
    else:
        size = 1 + sum(_tree_size(a, memo) for a in n[2])
    memo[key] = size
    return size


def _convert(n: ast.AST, src: str, variables: tuple[str, ...], context: str) -> Node:
    if isinstance(n, ast.Constant):
        if isinstance(n.value, bool) or not isinstance(n.value, (int, float)):
            shown = repr(n.value)
            shown = shown if len(shown) <= 40 else shown[:37] + "..."
            raise _err(src, f"only numbers are allowed as constants, got {shown}.", context)
        return ("const", _literal(n.value, src, context))
    if isinstance(n, ast.Name):
        if n.id in variables:
            return ("var", n.id)
        if n.id in _CONSTANTS:
            return ("const", _CONSTANTS[n.id])
        allowed = list(variables) + list(_CONSTANTS)
        hint = did_you_mean(n.id, allowed)
        raise _err(
            src, f"unknown name '{n.id}'.{hint} Allowed names: {', '.join(allowed)}.", context
        )
    if isinstance(n, ast.UnaryOp):
        operand = _convert(n.operand, src, variables, context)
        if isinstance(n.op, ast.USub):
            return _neg(operand)
        if isinstance(n.op, ast.UAdd):
            return operand
        raise _err(src, f"operator '{type(n.op).__name__}' is not allowed.", context)
    if isinstance(n, ast.BinOp):
        ops = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
        op = ops.get(type(n.op))
        if op is None:
            hint = " Use '**' for powers." if isinstance(n.op, ast.BitXor) else ""
            raise _err(src, f"operator '{type(n.op).__name__}' is not allowed.{hint}", context)
        a = _convert(n.left, src, variables, context)
        b = _convert(n.right, src, variables, context)
        if op == "/" and _is_const(b, 0.0):
            raise _err(src, f"'{_segment(src, n)}' divides by zero.", context)
        return _constant_checked(_bin(op, a, b), (a, b), src, n, context)
    if isinstance(n, ast.Call):
        if not isinstance(n.func, ast.Name):
            raise _err(
                src,
                f"only calls of plain function names are allowed (one of {', '.join(FUNCTIONS)}).",
                context,
            )
        name = n.func.id
        if name not in FUNCTIONS:
            hint = did_you_mean(name, FUNCTIONS)
            raise _err(
                src,
                f"unknown function '{name}'.{hint} Allowed functions: {', '.join(FUNCTIONS)}.",
                context,
            )
        if n.keywords or len(n.args) != FUNCTIONS[name]:
            raise _err(
                src,
                f"function '{name}' takes exactly {FUNCTIONS[name]} positional argument(s).",
                context,
            )
        args = tuple(_convert(a, src, variables, context) for a in n.args)
        return _constant_checked(_call(name, args), args, src, n, context)
    kind = type(n).__name__
    raise _err(
        src,
        f"'{kind}' is not allowed; expressions may only use numbers, the variables "
        f"{', '.join(variables)}, + - * / ** and the functions {', '.join(FUNCTIONS)}.",
        context,
    )


def _segment(src: str, n: ast.AST) -> str:
    """The source text of sub-expression ``n`` (shortened)."""
    try:
        text = ast.get_source_segment(src, n) or src
    except (TypeError, ValueError, IndexError):  # pragma: no cover - positions always set
        text = src
    return text if len(text) <= 60 else text[:57] + "..."


def _constant_checked(
    node: Node, parts: tuple[Node, ...], src: str, n: ast.AST, context: str
) -> Node:
    """A sub-expression of constants only is folded to a number when it is built (float
    arithmetic: no big integers, bounded cost); one that is not a finite number (``1/0``,
    ``log(0)``, ``sqrt(-1)``, ``10**1000000``) is refused, naming it."""
    if node[0] != "const" and all(_is_const(p) for p in parts):
        raise _err(
            src,
            f"the constant '{_segment(src, n)}' is not a finite number (infinite, undefined "
            "or too large); fix it or write its value.",
            context,
        )
    if node[0] == "const" and abs(node[1]) > MAX_LITERAL:
        raise _err(
            src,
            f"the constant '{_segment(src, n)}' is larger than {MAX_LITERAL:g} in magnitude; "
            "use a smaller one.",
            context,
        )
    return node


# ----------------------------------------------------------------------------- construction
def _is_const(n: Node, value: float | None = None) -> bool:
    return n[0] == "const" and (value is None or n[1] == value)


def _neg(a: Node) -> Node:
    if _is_const(a):
        return ("const", -a[1])
    if a[0] == "neg":
        return a[1]
    return ("neg", a)


def _bin(op: str, a: Node, b: Node) -> Node:
    if _is_const(a) and _is_const(b):
        try:  # float arithmetic (no big integers); a complex power is not a number here
            value = _NUMPY_BIN[op](float(a[1]), float(b[1]))
            value = float(value) if isinstance(value, float) else float("nan")
        except (ZeroDivisionError, OverflowError, ValueError, TypeError):
            value = float("nan")
        if math.isfinite(value):
            return ("const", value)
    if op == "+":
        if _is_const(a, 0.0):
            return b
        if _is_const(b, 0.0):
            return a
    elif op == "-":
        if _is_const(b, 0.0):
            return a
        if _is_const(a, 0.0):
            return _neg(b)
    elif op == "*":
        if _is_const(a, 0.0) or _is_const(b, 0.0):
            return ("const", 0.0)
        if _is_const(a, 1.0):
            return b
        if _is_const(b, 1.0):
            return a
    elif op == "/":
        if _is_const(a, 0.0) and not _is_const(b, 0.0):
            return ("const", 0.0)
        if _is_const(b, 1.0):
            return a
    elif op == "**":
        if _is_const(b, 1.0):
            return a
        if _is_const(b, 0.0):
            return ("const", 1.0)
    return ("bin", op, a, b)


def _call(name: str, args: tuple[Node, ...]) -> Node:
    if all(_is_const(a) for a in args):
        with np.errstate(all="ignore"):
            value = float(_NUMPY[name](*(a[1] for a in args)))
        if math.isfinite(value):
            return ("const", value)
    return ("call", name, args)


_NUMPY_BIN = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "/": lambda a, b: a / b,
    "**": lambda a, b: a**b,
}


# ----------------------------------------------------------------------------- derivative
def _diff(n: Node, var: str) -> Node:
    kind = n[0]
    if kind == "const":
        return ("const", 0.0)
    if kind == "var":
        return ("const", 1.0 if n[1] == var else 0.0)
    if kind == "neg":
        return _neg(_diff(n[1], var))
    if kind == "bin":
        op, a, b = n[1], n[2], n[3]
        da, db = _diff(a, var), _diff(b, var)
        if op in "+-":
            return _bin(op, da, db)
        if op == "*":
            return _bin("+", _bin("*", da, b), _bin("*", a, db))
        if op == "/":
            num = _bin("-", _bin("*", da, b), _bin("*", a, db))
            return _bin("/", num, _bin("**", b, ("const", 2.0)))
        # power
        if _is_const(db, 0.0):  # exponent does not depend on var
            return _bin("*", _bin("*", b, _bin("**", a, _bin("-", b, ("const", 1.0)))), da)
        term = _bin("+", _bin("*", db, _call("log", (a,))), _bin("/", _bin("*", b, da), a))
        return _bin("*", n, term)
    # call
    name, args = n[1], n[2]
    a = args[0]
    da = _diff(a, var)
    one = ("const", 1.0)
    if name == "sin":
        return _bin("*", _call("cos", (a,)), da)
    if name == "cos":
        return _bin("*", _neg(_call("sin", (a,))), da)
    if name == "tan":
        return _bin("*", _bin("+", one, _bin("**", n, ("const", 2.0))), da)
    if name == "exp":
        return _bin("*", n, da)
    if name == "log":
        return _bin("/", da, a)
    if name == "sqrt":
        return _bin("/", da, _bin("*", ("const", 2.0), n))
    if name == "tanh":
        return _bin("*", _bin("-", one, _bin("**", n, ("const", 2.0))), da)
    if name == "abs":
        return _bin("*", _call("sign", (a,)), da)
    if name == "sign":
        return ("const", 0.0)
    if name == "atan":
        return _bin("/", da, _bin("+", one, _bin("**", a, ("const", 2.0))))
    if name in ("asin", "acos"):
        d = _bin("/", da, _call("sqrt", (_bin("-", one, _bin("**", a, ("const", 2.0))),)))
        return d if name == "asin" else _neg(d)
    if name == "sinh":
        return _bin("*", _call("cosh", (a,)), da)
    if name == "cosh":
        return _bin("*", _call("sinh", (a,)), da)
    if name in ("min", "max"):
        b = args[1]
        db = _diff(b, var)
        first = _call("_lt", (a, b) if name == "min" else (b, a))
        return _bin("+", _bin("*", first, da), _bin("*", _bin("-", one, first), db))
    if name == "clip":
        return _bin("*", _call("_inside", args), da)
    if name == "atan2":  # atan2(y, x)
        b = args[1]
        db = _diff(b, var)
        num = _bin("-", _bin("*", b, da), _bin("*", a, db))
        den = _bin("+", _bin("**", a, ("const", 2.0)), _bin("**", b, ("const", 2.0)))
        return _bin("/", num, den)
    if name in ("_lt", "_inside"):
        return ("const", 0.0)
    raise ExpressionError(f"Cannot differentiate function '{name}'.")  # pragma: no cover


# ----------------------------------------------------------------------------- printing
_PREC = {"+": 1, "-": 1, "*": 2, "/": 2, "**": 4}


def _to_str(n: Node, parent: int = 0) -> str:
    kind = n[0]
    if kind == "const":
        s = repr(float(n[1]))
        s = s[:-2] if s.endswith(".0") else s
        return f"({s})" if n[1] < 0 and parent > 0 else s
    if kind == "var":
        return n[1]
    if kind == "neg":
        s = "-" + _to_str(n[1], 3)
        return f"({s})" if parent > 0 else s
    if kind == "call":
        return f"{n[1]}({', '.join(_to_str(a) for a in n[2])})"
    op = n[1]
    p = _PREC[op]
    left = _to_str(n[2], p + (1 if op == "**" else 0))
    right = _to_str(n[3], p + (0 if op == "**" else (1 if op in "-/" else 0)))
    s = (
        f"{left} {op} {right}"
        if p == 1
        else f"{left}{op}{right}"
        if op == "**"
        else (f"{left}*{right}" if op == "*" else f"{left}/{right}")
    )
    return f"({s})" if p < parent else s


# ----------------------------------------------------------------------------- evaluation
def _eval(n: Node, env: Mapping[str, Any]):
    kind = n[0]
    if kind == "const":
        return n[1]
    if kind == "var":
        return env[n[1]]
    if kind == "neg":
        return -_eval(n[1], env)
    if kind == "bin":
        return _NUMPY_BIN[n[1]](np.asarray(_eval(n[2], env), dtype=float), _eval(n[3], env))
    return _NUMPY[n[1]](*(np.asarray(_eval(a, env), dtype=float) for a in n[2]))


def _variables(n: Node, out: set[str]) -> set[str]:
    kind = n[0]
    if kind == "var":
        out.add(n[1])
    elif kind == "neg":
        _variables(n[1], out)
    elif kind == "bin":
        _variables(n[2], out)
        _variables(n[3], out)
    elif kind == "call":
        for a in n[2]:
            _variables(a, out)
    return out


@dataclass(frozen=True)
class Expression:
    """A parsed, validated expression of ``t``, ``u`` and the plant states ``x1..xn``.

    Parameters
    ----------
    text
        The expression, e.g. ``"0.75*u**3 - 0.2"``, or a number.
    variables
        The names the expression may use, e.g. ``("t", "u", "x1", "x2")``.
    context
        Where the expression comes from (file and key), used in error messages.

    Raises
    ------
    ExpressionError
        If the text is not a valid expression or uses a name that is not allowed.

    Examples
    --------
    >>> f = Expression("0.75*u**3 - 0.2", ("t", "u"))
    >>> float(f(u=2.0))
    5.8
    >>> str(f.derivative("u"))
    '0.75*3*u**2'
    """

    text: str
    variables: tuple[str, ...]
    context: str = field(default="", compare=False)
    # None until __post_init__ parses the text
    node: Node = field(default=None, compare=False, repr=False)  # type: ignore[arg-type]

    def __post_init__(self) -> None:
        if self.node is None:
            node = parse(self.text, tuple(self.variables), context=self.context)
            object.__setattr__(self, "node", node)
        object.__setattr__(self, "text", str(self.text))

    @classmethod
    def _from_node(cls, node: Node, variables: tuple[str, ...]) -> Expression:
        return cls(_to_str(node), tuple(variables), node=node)

    def __str__(self) -> str:
        return _to_str(self.node)

    @property
    def used(self) -> frozenset[str]:
        """The variables the expression actually depends on."""
        return frozenset(_variables(self.node, set()))

    @property
    def is_constant(self) -> bool:
        """True when the expression is a plain number."""
        return self.node[0] == "const"

    def derivative(self, var: str) -> Expression:
        """Symbolic partial derivative with respect to ``var``.

        Raises
        ------
        ExpressionError
            When the derivative would have more than :data:`MAX_DERIVATIVE_NODES` terms
            (e.g. a product of 200 factors ``t*t*...*t``; write ``t**200`` instead).
        """
        limit = MAX_DERIVATIVE_NODES
        key = (self.node, var)
        d = _DERIVED.get(key)
        if d is None:
            if _tree_size(self.node) > limit:
                raise self._too_big(var)
            d = _diff(self.node, var)
            if _tree_size(d) > limit:
                raise self._too_big(var)
            if len(_DERIVED) < _MEMO_SIZE:
                _DERIVED[key] = d
        return Expression._from_node(d, self.variables)

    def _too_big(self, var: str) -> ExpressionError:
        text = self.text if len(self.text) <= 60 else self.text[:57] + "..."
        return ExpressionError(
            f"Expression '{text}'{f' in {self.context}' if self.context else ''}: its "
            f"derivative d/d{var} would have more than {MAX_DERIVATIVE_NODES} terms; simplify "
            "it (write repeated products as powers, e.g. t**200 instead of t*t*...*t)."
        )

    def __call__(self, **env: Any) -> np.ndarray:
        """Evaluate with numpy; arguments broadcast, so any batch shape works."""
        missing = self.used - set(env)
        if missing:
            raise ExpressionError(f"Expression '{self}' needs values for {sorted(missing)}.")
        with np.errstate(all="ignore"):
            return np.asarray(_eval(self.node, env), dtype=float) + 0.0
