"""A small translator from the numba subset of Python the design laws are written in to C99.

What it translates: functions of float scalars, integers and 1-D float arrays; ``for`` loops
over ``range``; ``while``; ``if``/``elif``/``else``; conditional expressions; ``math.*`` calls;
``min``/``max``/``abs``; views ``Y[a:b]`` (a pointer into the array); calls of other part
functions (each translated once per argument types); tuple returns (out-pointers); and the
parameters of the loop (``D.c[...]``, ``gains(D).name``), which become fields of the exported
params struct. Anything else is refused with a :class:`ConfigurationError` that names the
construct and its file and line.

Python's semantics are kept where C differs: ``/`` is a true division (integers converted),
``//`` and ``%`` of integers round toward minus infinity, ``min``/``max`` return the first
argument on ties and NaN as Python does (``min(a, b)`` is ``b < a ? b : a``).
"""

from __future__ import annotations

import ast
from collections.abc import Callable
from dataclasses import dataclass, field

from adaptive_ftc.errors import ConfigurationError

__all__ = ["Field", "Source", "Translator", "c_float"]

DOUBLE, LONG, PTR, PARAMS = "double", "long", "double *", "params"
LPTR, DATA = "long *", "data"  # an integer array; a closed loop's data (D.c, D.i), flat


def _ptr(ty) -> bool:
    """A float array (of unknown or known size ``double *#n``) or a NamedTuple's numbers."""
    return isinstance(ty, str) and (ty.startswith("double *") or ty.startswith("nt:"))


def _lptr(ty) -> bool:
    return isinstance(ty, str) and ty.startswith("long *")


def _arr(ty) -> bool:
    return _ptr(ty) or _lptr(ty)


def _size(ty) -> int | None:
    """The known size of an array type (``double *#3``), else ``None``."""
    if isinstance(ty, str) and "#" in ty:
        return int(ty.split("#")[1])
    return None


def _sized(base: str, n: int | None) -> str:
    return base if n is None else f"{base}#{n}"


#: ``math`` functions and their C99 names (libm): all take and return doubles
MATH = {
    "sin": "sin",
    "cos": "cos",
    "tan": "tan",
    "asin": "asin",
    "acos": "acos",
    "atan": "atan",
    "atan2": "atan2",
    "sinh": "sinh",
    "cosh": "cosh",
    "tanh": "tanh",
    "exp": "exp",
    "expm1": "expm1",
    "log": "log",
    "log10": "log10",
    "log1p": "log1p",
    "sqrt": "sqrt",
    "fabs": "fabs",
    "floor": "floor",
    "ceil": "ceil",
    "copysign": "copysign",
    "hypot": "hypot",
    "pow": "pow",
    "fmod": "fmod",
}
MATH_CONSTANTS = {"pi": "M_PI_AFTC", "e": "M_E_AFTC", "inf": "INFINITY", "nan": "NAN"}

#: helpers every translated file starts with (Python's min/max/floor division)
PRELUDE = """#define M_PI_AFTC 3.141592653589793
#define M_E_AFTC 2.718281828459045
static inline double PFX_min(double a, double b) { return b < a ? b : a; }
static inline double PFX_max(double a, double b) { return b > a ? b : a; }
static inline long PFX_lmin(long a, long b) { return b < a ? b : a; }
static inline long PFX_lmax(long a, long b) { return b > a ? b : a; }
static inline long PFX_floordiv(long a, long b) { long q = a / b; return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q; }
static inline long PFX_mod(long a, long b) { long r = a % b; return (r != 0 && ((r < 0) != (b < 0))) ? r + b : r; }"""  # noqa: E501


@dataclass(frozen=True)
class Source:
    """A Python function to translate: its AST and where its text comes from."""

    node: ast.FunctionDef
    filename: str
    line_offset: int = 0  # added to the AST's line numbers
    constants: dict = field(default_factory=dict)  # module constants (name -> number)


@dataclass(frozen=True)
class Field:
    """A field of the params struct: its name, its place in the loop's ``D.c`` and its size
    (``scalar``: a ``double``, else an array)."""

    name: str
    start: int
    size: int
    scalar: bool = False


@dataclass
class _Fn:
    """A function being translated (its locals and their C types)."""

    src: Source
    types: dict  # name -> C type (params, arrays and locals)
    params: list  # parameter names in order
    lines: list = field(default_factory=list)
    returns: set = field(default_factory=set)
    tuple_types: tuple | None = None
    temps: int = 0
    aliases: dict = field(default_factory=dict)  # name -> the params argument it names

    def params_name(self, name: str) -> str:
        return self.aliases.get(name, name)


class Translator:
    """Translates functions (and everything they call) into C text.

    ``resolve(name)``: the :class:`Source` of a called function (``None``: not a part
    function). ``fields``: the params struct (the places of ``D.c``); ``gains``: the names of
    the design's gains, in the order of ``D.c[GAINS:]``. ``prefix``: of every C name.
    """

    def __init__(
        self,
        resolve: Callable[[str], Source | None],
        fields: list[Field],
        gains: tuple[str, ...],
        prefix: str,
        *,
        classes: dict | None = None,
        gains_at: int | None = None,
    ):
        self.resolve = resolve
        self.classes = classes or {}  # NamedTuple aliases -> their field names
        self.gains_at = gains_at  # where the gains start in D.c (a flat loop's data)
        self.nt_places: dict[str, list] = {}  # NamedTuple alias -> (offset, size) per field
        self.fields = sorted(fields, key=lambda f: f.start)
        self.gains = gains
        self.prefix = prefix
        # (name, arg types) -> (C name, return type: None until translated, or void)
        self.done: dict[tuple, tuple[str, object]] = {}
        self.order: list[str] = []  # C function definitions, callees first
        self.protos: list[str] = []
        self.fields_used: set[str] = set()
        self.busy: set[tuple] = set()
        #: C names a translated function must not take (the exported interface's)
        self.reserved: set[str] = set()
        #: ``{called name: sentence}`` added to a refusal raised while translating that call
        #: (what the part is and how to leave it out)
        self.notes: dict[str, str] = {}

    # ---------------------------------------------------------------- entry points
    def function(self, src: Source, arg_types: list[str], name: str | None = None) -> str:
        """Translate ``src`` for ``arg_types``; returns its C name."""
        return self._function(src, tuple(arg_types), name)[0]

    def text(self) -> str:
        """The C definitions so far (helpers first)."""
        return "\n\n".join([PRELUDE.replace("PFX", self.prefix), *self.order])

    # ---------------------------------------------------------------- errors
    def _refuse(self, fn: _Fn, node: ast.AST, what: str) -> ConfigurationError:
        line = getattr(node, "lineno", 0) + fn.src.line_offset
        try:
            shown = ast.unparse(node)
        except Exception:  # noqa: BLE001
            shown = type(node).__name__
        if len(shown) > 80:
            shown = shown[:77] + "..."
        return ConfigurationError(
            f"Cannot export to C: {what} in `{shown}` ({fn.src.filename}:{line}, function "
            f"{fn.src.node.name!r}). Write that part in the subset the exporter translates "
            "(floats, integers, 1-D float arrays, for/while/if, math.* calls), or export a "
            "loop without it."
        )

    # ---------------------------------------------------------------- functions
    def _function(self, src: Source, arg_types: tuple, cname: str | None) -> tuple[str, object]:
        key = (id(src.node), arg_types)
        if key in self.done:
            return self.done[key]
        node = src.node
        names = [a.arg for a in node.args.args]
        if node.args.vararg or node.args.kwarg or node.args.kwonlyargs or node.args.defaults:
            fn0 = _Fn(src, {}, names)
            raise self._refuse(fn0, node, "default, keyword or variable arguments")
        if len(names) != len(arg_types):
            raise self._refuse(_Fn(src, {}, names), node, "a call with the wrong argument count")
        if cname is None:
            base = f"{self.prefix}_{node.name.lstrip('_')}"
            cname = base
            n = 2
            while cname in {v[0] for v in self.done.values()} | self.reserved:
                cname = f"{base}_{n}"
                n += 1
        fn = _Fn(src, dict(zip(names, arg_types, strict=True)), names)
        self.done[key] = (cname, None)
        self.busy.add(key)  # a call back into it is recursion (refused in _call_user)
        body = self._block(fn, node.body, 1)
        self.busy.discard(key)
        ret = self._return_type(fn, node)
        self.done[key] = (cname, ret)
        decls = []
        for name, ty in fn.types.items():
            if name in fn.params or ty == PARAMS or ty is None:
                continue
            decls.append(f"    {self._decl(ty, _c_name(name))} = 0;")
        # every argument and local marked used: a part may ignore one (-Wunused under -Werror)
        used = [f"(void){_c_name(n)};" for n, ty in fn.types.items() if ty not in (PARAMS, None)]
        used += [f"(void){n};" for n in names if fn.types[n] == PARAMS]
        used = [u for u in used if u[6:-1] not in fn.aliases]
        if used:
            decls.append("    " + " ".join(used))
        args = [self._decl(fn.types[a], a) for a in names]
        if isinstance(ret, tuple):
            args += [f"{t} *ret{k}" for k, t in enumerate(ret)]
        rtype = "void" if ret is None or isinstance(ret, tuple) else self._decl(ret, "").strip()
        sig = f"static {rtype} {cname}({', '.join(args) or 'void'})"
        doc = ast.get_docstring(node)
        head = [f"/* {src.node.name} ({src.filename}:{node.lineno + src.line_offset})"]
        if doc:
            head[0] += ": " + doc.splitlines()[0].replace("*/", "* /")
        head[0] += " */"
        self.order.append("\n".join([*head, sig, "{", *decls, *body, "}"]))
        self.protos.append(sig + ";")
        return cname, ret

    def _decl(self, ty: str, name: str) -> str:
        if ty == PARAMS:
            return f"const {self.prefix}_params *{name}"
        if ty == DATA:
            return f"const {self.prefix}_data *{name}"
        if _ptr(ty):
            return f"double *{name}"
        if _lptr(ty):
            return f"long *{name}"
        return f"{ty} {name}"

    def _return_type(self, fn: _Fn, node):
        kinds = fn.returns
        if not kinds or kinds == {None}:
            return None
        if fn.tuple_types is not None:
            return fn.tuple_types
        if None in kinds:
            raise self._refuse(fn, node, "a function that returns a value only on some paths")
        arrays = {k for k in kinds if _arr(k)}
        if arrays:
            if len(kinds) > 1:
                raise self._refuse(fn, node, "a function returning an array or a number")
            return arrays.pop()
        return DOUBLE if DOUBLE in kinds else LONG

    # ---------------------------------------------------------------- statements
    def _block(self, fn: _Fn, stmts, depth: int) -> list[str]:
        out: list[str] = []
        for st in stmts:
            out += self._stmt(fn, st, depth)
        return out

    def _stmt(self, fn: _Fn, st: ast.stmt, depth: int) -> list[str]:
        ind = "    " * depth
        if isinstance(st, ast.Expr):
            if isinstance(st.value, ast.Constant) and isinstance(st.value.value, str):
                return []  # a docstring
            if isinstance(st.value, ast.Call):
                text, _ = self._expr(fn, st.value, statement=True)
                return [f"{ind}{text};"]
            raise self._refuse(fn, st, "an expression statement that is not a call")
        if isinstance(st, ast.Pass):
            return []
        if isinstance(st, ast.Break):
            return [f"{ind}break;"]
        if isinstance(st, ast.Continue):
            return [f"{ind}continue;"]
        if isinstance(st, ast.Return):
            return self._return(fn, st, ind)
        if isinstance(st, ast.Assign):
            if len(st.targets) != 1:
                raise self._refuse(fn, st, "a chained assignment")
            return self._assign(fn, st.targets[0], st.value, ind, st)
        if isinstance(st, ast.AnnAssign) and st.value is not None:
            return self._assign(fn, st.target, st.value, ind, st)
        if isinstance(st, ast.AugAssign):
            op = _BINOPS.get(type(st.op))
            if op is None or op in ("//", "%", "**"):
                raise self._refuse(fn, st, f"the augmented operator {type(st.op).__name__}")
            value = ast.BinOp(left=_load(st.target), op=st.op, right=st.value)
            ast.copy_location(value, st)
            return self._assign(fn, st.target, value, ind, st)
        if isinstance(st, ast.If):
            test, _ = self._expr(fn, st.test)
            out = [f"{ind}if ({_strip(test)}) {{", *self._block(fn, st.body, depth + 1)]
            if st.orelse:
                out.append(f"{ind}}} else {{")
                out += self._block(fn, st.orelse, depth + 1)
            out.append(f"{ind}}}")
            return out
        if isinstance(st, ast.While):
            if st.orelse:
                raise self._refuse(fn, st, "while ... else")
            test, _ = self._expr(fn, st.test)
            return [
                f"{ind}while ({_strip(test)}) {{",
                *self._block(fn, st.body, depth + 1),
                f"{ind}}}",
            ]
        if isinstance(st, ast.For):
            return self._for(fn, st, depth)
        raise self._refuse(fn, st, f"the statement {type(st).__name__}")

    def _return(self, fn: _Fn, st: ast.Return, ind: str) -> list[str]:
        if st.value is None:
            fn.returns.add(None)
            return [f"{ind}return;"]
        if isinstance(st.value, ast.Tuple):
            try:  # a tuple of consecutive numbers: a pointer to them
                text, ty = self._numbers(fn, st.value, st.value.elts, "double *#0")
            except ConfigurationError:
                pass
            else:
                fn.returns.add(ty)
                return [f"{ind}return {_strip(text)};"]
            parts = [self._expr(fn, e) for e in st.value.elts]
            types = tuple(DOUBLE if t == DOUBLE else LONG for _, t in parts)
            if any(t not in (DOUBLE, LONG) for _, t in parts):
                raise self._refuse(fn, st, "a returned tuple that holds an array")
            if fn.tuple_types is not None and len(fn.tuple_types) != len(types):
                raise self._refuse(fn, st, "returned tuples of different lengths")
            if fn.tuple_types is not None:
                types = tuple(
                    DOUBLE if DOUBLE in (a, b) else LONG
                    for a, b in zip(fn.tuple_types, types, strict=True)
                )
            fn.tuple_types = types
            fn.returns.add("tuple")
            # each value computed before any is stored (a value may read another's target)
            out = []
            for k, (text, _) in enumerate(parts):
                out.append(f"{ind}*ret{k} = {_strip(text)};")
            return [*out, f"{ind}return;"]
        text, ty = self._expr(fn, st.value)
        if ty not in (DOUBLE, LONG) and not _arr(ty):
            raise self._refuse(fn, st, "a returned value of this kind")
        fn.returns.add(ty)
        return [f"{ind}return {_strip(text)};"]

    def _assign(self, fn: _Fn, target, value, ind: str, st) -> list[str]:
        if isinstance(target, ast.Tuple):
            return self._unpack(fn, target, value, ind, st)
        # D.c: the params (an alias, no C code)
        if isinstance(target, ast.Name) and self._is_params_attr(fn, value):
            fn.types[target.id] = PARAMS
            fn.aliases[target.id] = fn.params_name(value.value.id)
            return []
        text, ty = self._expr(fn, value)
        if isinstance(target, ast.Name):
            name = target.id
            old = fn.types.get(name)
            if name in fn.params and old != ty and not (old == DOUBLE and ty == LONG):
                raise self._refuse(fn, st, f"an assignment changing the type of argument {name}")
            if ty == PARAMS:
                raise self._refuse(fn, st, "an alias of the parameters")
            if old is None:
                fn.types[name] = ty
            elif old != ty:
                if {old, ty} == {DOUBLE, LONG}:
                    fn.types[name] = DOUBLE
                elif _ptr(old) and _ptr(ty):
                    fn.types[name] = PTR  # views of different sizes: the size is unknown
                elif _lptr(old) and _lptr(ty):
                    fn.types[name] = LPTR
                else:
                    raise self._refuse(fn, st, f"a name ({name}) holding an array and a number")
            return [f"{ind}{_c_name(name)} = {_strip(text)};"]
        if isinstance(target, ast.Subscript):
            ref, rty = self._subscript(fn, target, store=True)
            return [f"{ind}{ref} = {_strip(text)};"]
        raise self._refuse(fn, st, "an assignment to this target")

    def _unpack(self, fn: _Fn, target: ast.Tuple, value, ind: str, st) -> list[str]:
        if isinstance(value, ast.Tuple) and len(value.elts) == len(target.elts):
            # every value before any name is assigned (a, b = b, a)
            out, temps = [], []
            for e in value.elts:
                text, ty = self._expr(fn, e)
                if ty not in (DOUBLE, LONG):
                    raise self._refuse(fn, st, "unpacking a tuple of arrays")
                fn.temps += 1
                tmp = f"_tup{fn.temps}"
                fn.types[tmp] = ty
                out.append(f"{ind}{tmp} = {_strip(text)};")
                temps.append(tmp)
            for tgt, tmp in zip(target.elts, temps, strict=True):
                out += self._assign(fn, tgt, ast.Name(id=tmp, ctx=ast.Load()), ind, st)
            return out
        if not isinstance(value, ast.Call):
            raise self._refuse(fn, st, "tuple unpacking of something other than a call")
        cname, ret, args = self._call_user(fn, value)
        if not isinstance(ret, tuple) or len(ret) != len(target.elts):
            raise self._refuse(fn, st, "unpacking a call that does not return a tuple this long")
        outs = []
        for elt, ty in zip(target.elts, ret, strict=True):
            if not isinstance(elt, ast.Name):
                raise self._refuse(fn, st, "unpacking into something other than names")
            old = fn.types.get(elt.id)
            fn.types[elt.id] = DOUBLE if DOUBLE in (old, ty) else ty
            if fn.types[elt.id] != ty:  # a long result into a double local: a temporary
                raise self._refuse(fn, st, "unpacking an integer into a float name")
            outs.append(f"&{_c_name(elt.id)}")
        return [f"{ind}{cname}({', '.join([*args, *outs])});"]

    def _for(self, fn: _Fn, st: ast.For, depth: int) -> list[str]:
        ind = "    " * depth
        it = st.iter
        if st.orelse:
            raise self._refuse(fn, st, "for ... else")
        if not (
            isinstance(it, ast.Call)
            and isinstance(it.func, ast.Name)
            and it.func.id == "range"
            and not it.keywords
            and 1 <= len(it.args) <= 3
            and isinstance(st.target, ast.Name)
        ):
            raise self._refuse(fn, st, "a for loop that is not over range(...)")
        args = [self._expr(fn, a) for a in it.args]
        if any(t != LONG for _, t in args):
            raise self._refuse(fn, st, "range() of a non-integer")
        texts = [_strip(t) for t, _ in args]
        start, stop, step = ("0", texts[0], "1") if len(texts) == 1 else (*texts[:2], "1")
        if len(texts) == 3:
            step = texts[2]
        step_v = _const_int(it.args[2]) if len(it.args) == 3 else 1
        if step_v is None or step_v == 0:
            raise self._refuse(fn, st, "range() with a step that is not a nonzero literal")
        var = st.target.id
        if fn.types.get(var, LONG) != LONG:
            raise self._refuse(fn, st, f"a loop variable ({var}) that also holds a float")
        fn.types[var] = LONG
        out = []
        if not _is_literal(stop):  # evaluated once, as Python's range is
            fn.temps += 1
            tmp = f"_stop{fn.temps}"
            fn.types[tmp] = LONG
            out.append(f"{ind}{tmp} = {stop};")
            stop = tmp
        cmp = "<" if step_v > 0 else ">"
        inc = f"{_c_name(var)}++" if step_v == 1 else f"{_c_name(var)} += {step}"
        v = _c_name(var)
        out.append(f"{ind}for ({v} = {start}; {v} {cmp} {stop}; {inc}) {{")
        out += self._block(fn, st.body, depth + 1)
        out.append(f"{ind}}}")
        return out

    # ---------------------------------------------------------------- expressions
    def _is_params_attr(self, fn: _Fn, node) -> bool:
        return (
            isinstance(node, ast.Attribute)
            and node.attr == "c"
            and isinstance(node.value, ast.Name)
            and fn.types.get(node.value.id) == PARAMS
        )

    def _expr(self, fn: _Fn, node, statement: bool = False) -> tuple[str, str]:
        """C text (parenthesised where it is compound) and C type of an expression."""
        if isinstance(node, ast.Constant):
            v = node.value
            if isinstance(v, bool):
                return ("1" if v else "0"), LONG
            if isinstance(v, int):
                return str(v), LONG
            if isinstance(v, float):
                return c_float(v), DOUBLE
            raise self._refuse(fn, node, f"the constant {v!r}")
        if isinstance(node, ast.Name):
            name = node.id
            if name in fn.types:
                if fn.types[name] == PARAMS:
                    return fn.params_name(name), PARAMS
                return _c_name(name), fn.types[name]
            if name in fn.src.constants:
                v = fn.src.constants[name]
                return (str(v), LONG) if isinstance(v, int) else (c_float(v), DOUBLE)
            if name in ("True", "False"):
                return ("1" if name == "True" else "0"), LONG
            raise self._refuse(fn, node, f"the name {name!r}, not defined before it is used")
        if isinstance(node, ast.Attribute):
            if isinstance(node.value, ast.Name) and node.value.id == "math":
                if node.attr in MATH_CONSTANTS:
                    return MATH_CONSTANTS[node.attr], DOUBLE
            gain = self._gain(fn, node)
            if gain is not None:
                return gain, DOUBLE
            if isinstance(node.value, ast.Name):
                vty = fn.types.get(node.value.id)
                base = _c_name(node.value.id)
                if vty == DATA and node.attr in ("c", "i"):
                    return f"{base}->{node.attr}", (PTR if node.attr == "c" else LPTR)
                if _arr(vty) and node.attr == "size" and _size(vty) is not None:
                    return str(_size(vty)), LONG
                if isinstance(vty, str) and vty.startswith("nt:"):
                    fields = self.classes.get(vty[3:], ())
                    if node.attr in fields:
                        k = fields.index(node.attr)
                        places = self.nt_places.get(vty[3:])
                        off, size = places[k] if places else (k, None)
                        if size is None:
                            return f"{base}[{off}]", DOUBLE
                        return f"({base} + {off})", f"double *#{size}"
            raise self._refuse(fn, node, f"the attribute .{node.attr}")
        if isinstance(node, ast.Subscript):
            return self._subscript(fn, node, store=False)
        if isinstance(node, ast.UnaryOp):
            text, ty = self._expr(fn, node.operand)
            if isinstance(node.op, ast.USub):
                return f"(-{text})", ty
            if isinstance(node.op, ast.UAdd):
                return text, ty
            if isinstance(node.op, ast.Not):
                return f"(!{text})", LONG
            raise self._refuse(fn, node, "the operator ~")
        if isinstance(node, ast.BinOp):
            return self._binop(fn, node)
        if isinstance(node, ast.BoolOp):
            op = " && " if isinstance(node.op, ast.And) else " || "
            parts = [self._expr(fn, v) for v in node.values]
            return "(" + op.join(t for t, _ in parts) + ")", LONG
        if isinstance(node, ast.Compare):
            tests: list[str] = []
            left = node.left
            for cmpop, right in zip(node.ops, node.comparators, strict=True):
                cop = _CMPOPS.get(type(cmpop))
                if cop is None:
                    raise self._refuse(fn, node, f"the comparison {type(cmpop).__name__}")
                lt, lty = self._expr(fn, left)
                rt, rty = self._expr(fn, right)
                if _arr(lty) or _arr(rty) or PARAMS in (lty, rty):
                    raise self._refuse(fn, node, "a comparison of arrays")
                tests.append(f"{lt} {cop} {rt}")
                left = right
            return "(" + " && ".join(tests) + ")", LONG
        if isinstance(node, ast.IfExp):
            test, _ = self._expr(fn, node.test)
            a, at = self._expr(fn, node.body)
            b, bt = self._expr(fn, node.orelse)
            if _arr(at) or _arr(bt):
                raise self._refuse(fn, node, "a conditional expression of arrays")
            ty = DOUBLE if DOUBLE in (at, bt) else LONG
            return f"({test} ? {a} : {b})", ty
        if isinstance(node, ast.Call):
            return self._call(fn, node, statement)
        if isinstance(node, ast.Tuple):
            return self._numbers(fn, node, node.elts, f"double *#{len(node.elts)}")
        raise self._refuse(fn, node, f"the expression {type(node).__name__}")

    def _numbers(self, fn: _Fn, node, elts, ty: str) -> tuple[str, str]:
        """A tuple (or NamedTuple) of consecutive numbers of one array, ``a[B + 0], a[B + 1],
        ...`` (a field may be a tuple of them too): a pointer to the first (the callee reads
        them in place). A NamedTuple's field places are remembered for ``p.field``."""
        flat: list[ast.expr] = []
        places: list[tuple[int, int | None]] = []  # (offset, size) per field
        for e in elts:
            inner = e.elts if isinstance(e, ast.Tuple) else None
            places.append((len(flat), None if inner is None else len(inner)))
            flat += inner if inner is not None else [e]
        first = None
        for k, e in enumerate(flat):
            if not (isinstance(e, ast.Subscript) and isinstance(e.value, ast.Name)):
                raise self._refuse(fn, node, "a tuple that is not consecutive array entries")
            const, rest = self._split(fn, e.slice)
            if first is None:
                first = (e.value.id, const, rest)
            elif (e.value.id, const - k, rest) != first:
                raise self._refuse(fn, node, "a tuple that is not consecutive array entries")
        if first is None or not (_ptr(fn.types.get(first[0])) or fn.types.get(first[0]) == PARAMS):
            raise self._refuse(fn, node, "a tuple that is not consecutive array entries")
        if ty.startswith("nt:"):
            self.nt_places[ty[3:]] = places
        elif ty.startswith("double *#"):
            ty = f"double *#{len(flat)}"
        name, const, rest = first
        if fn.types.get(name) == PARAMS:  # c[PLACE + 0], c[PLACE + 1]...: one params field
            return self._param_numbers(fn, node, fn.params_name(name), const, rest, len(flat)), ty
        idx = str(const) if rest is None else f"{const} + {rest}"
        return f"({_c_name(name)} + {idx})", ty

    def _param_numbers(self, fn: _Fn, node, pname: str, const, rest, n: int) -> str:
        """A pointer to ``n`` consecutive numbers of one array field of the params struct
        (a NamedTuple of the plant's parameters, ``plant_params(D)``). Its ``const`` is cast
        away: the callee only reads it (a NamedTuple is immutable in the numba subset)."""
        for f in self.fields:
            if rest is None and not f.scalar and f.start <= const < f.start + f.size:
                if const + n > f.start + f.size:
                    break
                self.fields_used.add(f.name)
                return f"((double *){pname}->{f.name} + {const - f.start})"
        raise self._refuse(fn, node, "a tuple of the parameters that is not one exported array")

    def _gain(self, fn: _Fn, node: ast.Attribute) -> str | None:
        """``gains(D).name`` -> ``D->gains.name`` (``D->c[GAINS + k]`` of a flat loop's data)."""
        v = node.value
        if not (
            isinstance(v, ast.Call)
            and isinstance(v.func, ast.Name)
            and v.func.id == "gains"
            and len(v.args) == 1
            and isinstance(v.args[0], ast.Name)
        ):
            return None
        arg = v.args[0].id
        kind = fn.types.get(arg)
        at = self.gains_at if kind == DATA else None  # a flat loop's data: D->c[GAINS + k]
        if at is None and kind != PARAMS:
            return None
        if node.attr not in self.gains:
            raise self._refuse(fn, node, f"an unknown gain {node.attr!r}")
        if at is not None:
            return f"{_c_name(arg)}->c[{at + self.gains.index(node.attr)}]"
        self.fields_used.add("gains")
        return f"{fn.params_name(arg)}->gains.{node.attr}"

    def _binop(self, fn: _Fn, node: ast.BinOp) -> tuple[str, str]:
        op = _BINOPS.get(type(node.op))
        if op is None:
            raise self._refuse(fn, node, f"the operator {type(node.op).__name__}")
        a, at = self._expr(fn, node.left)
        b, bt = self._expr(fn, node.right)
        if at not in (DOUBLE, LONG) or bt not in (DOUBLE, LONG):
            raise self._refuse(fn, node, "arithmetic on arrays")
        both_int = at == LONG and bt == LONG
        if op == "**":
            if both_int:
                raise self._refuse(fn, node, "an integer power")
            return f"pow({_strip(a)}, {_strip(b)})", DOUBLE
        if op == "/":
            if both_int:
                return f"((double){a} / (double){b})", DOUBLE
            return f"({a} / {b})", DOUBLE
        if op == "//":
            if both_int:
                return f"{self.prefix}_floordiv({_strip(a)}, {_strip(b)})", LONG
            return f"floor({a} / {b})", DOUBLE
        if op == "%":
            if both_int:
                return f"{self.prefix}_mod({_strip(a)}, {_strip(b)})", LONG
            raise self._refuse(fn, node, "% of floats")
        return f"({a} {op} {b})", LONG if both_int else DOUBLE

    def _subscript(self, fn: _Fn, node: ast.Subscript, store: bool) -> tuple[str, str]:
        base = node.value
        bty: str | None  # the base's C type (None: unknown, refused below)
        if (
            isinstance(base, ast.Attribute)
            and isinstance(base.value, ast.Name)
            and fn.types.get(base.value.id) == DATA
        ):
            btext, bty = self._expr(fn, base)  # D.c, D.i of a flat loop's data
        elif isinstance(base, ast.Name) or self._is_params_attr(fn, base):
            if isinstance(base, ast.Name):
                bname = base.id
            else:  # P.c of a params argument P (see _is_params_attr)
                assert isinstance(base, ast.Attribute) and isinstance(base.value, ast.Name)
                bname = base.value.id
            bty = fn.types.get(bname)
            if bty == PARAMS:
                if store:
                    raise self._refuse(fn, node, "a write to the parameters")
                return self._param(fn, fn.params_name(bname), node)
            btext = _c_name(bname)
        elif isinstance(base, ast.Attribute):  # a NamedTuple's tuple field: p.b[j]
            btext, bty = self._expr(fn, base)
        else:
            raise self._refuse(fn, node, "indexing something other than a named array")
        if not _arr(bty):
            raise self._refuse(fn, node, "indexing something that is not an array")
        elem = LONG if _lptr(bty) else DOUBLE
        sl = node.slice
        if isinstance(sl, ast.Slice):
            if store or sl.step is not None or sl.lower is None:
                raise self._refuse(fn, node, "this slice (only views a[i:j] are exported)")
            lo, lty = self._expr(fn, sl.lower)
            if lty != LONG:
                raise self._refuse(fn, node, "a slice bound that is not an integer")
            n = None
            if sl.upper is not None:
                a, ra = self._split(fn, sl.lower)
                b, rb = self._split(fn, sl.upper)
                if ra is None and rb is None:
                    n = b - a
            return f"({btext} + {_strip(lo)})", _sized(LPTR if _lptr(bty) else PTR, n)
        idx, ity = self._expr(fn, sl)
        if ity != LONG:
            raise self._refuse(fn, node, "an index that is not an integer")
        return f"{btext}[{_strip(idx)}]", elem

    def _param(self, fn: _Fn, pname: str, node: ast.Subscript) -> tuple[str, str]:
        """``c[PLACE + i]`` -> the field of the params struct that holds ``PLACE``."""
        const, rest = self._split(fn, node.slice)
        if const is None:
            raise self._refuse(fn, node, "an index of the parameters with no constant place")
        for f in self.fields:
            if f.start <= const < f.start + f.size:
                self.fields_used.add(f.name)
                off = const - f.start
                if f.scalar:
                    if rest is not None or off:
                        raise self._refuse(fn, node, f"an index into the scalar {f.name}")
                    return f"{pname}->{f.name}", DOUBLE
                idx = str(off) if rest is None else (f"{off} + {rest}" if off else rest)
                return f"{pname}->{f.name}[{idx}]", DOUBLE
        raise self._refuse(fn, node, f"a place of the parameters ({const}) that is not exported")

    def _split(self, fn: _Fn, node) -> tuple[int, str | None]:
        """An index ``A + B + ...`` as (the sum of its constant terms, C text of the rest)."""
        terms: list = []

        def walk(n, sign):
            if isinstance(n, ast.BinOp) and isinstance(n.op, (ast.Add, ast.Sub)):
                walk(n.left, sign)
                walk(n.right, sign if isinstance(n.op, ast.Add) else -sign)
            else:
                terms.append((sign, n))

        walk(node, 1)
        const, rest = 0, []
        for sign, t in terms:
            v = _const_int(t, fn.src.constants)
            if v is not None:
                const += sign * v
                continue
            text, ty = self._expr(fn, t)
            if ty != LONG:
                raise self._refuse(fn, node, "an index that is not an integer")
            rest.append(("" if sign > 0 else "-") + text)
        return const, (" + ".join(rest) if rest else None)

    def _call(self, fn: _Fn, node: ast.Call, statement: bool) -> tuple[str, str]:
        if node.keywords:
            raise self._refuse(fn, node, "a call with keyword arguments")
        f = node.func
        if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == "math":
            if f.attr == "isfinite":
                ((a, _),) = [self._expr(fn, x) for x in node.args]
                return f"(isfinite({_strip(a)}) != 0)", LONG
            if f.attr in ("isnan", "isinf"):
                ((a, _),) = [self._expr(fn, x) for x in node.args]
                return f"({f.attr}({_strip(a)}) != 0)", LONG
            cf = MATH.get(f.attr)
            if cf is None:
                raise self._refuse(fn, node, f"math.{f.attr}")
            args = [self._expr(fn, a) for a in node.args]
            if any(t not in (DOUBLE, LONG) for _, t in args):
                raise self._refuse(fn, node, f"math.{f.attr} of an array")
            return f"{cf}({', '.join(_as_double(t, ty) for t, ty in args)})", DOUBLE
        if not isinstance(f, ast.Name):
            raise self._refuse(fn, node, "a call of something other than a named function")
        name = f.id
        if name in ("min", "max") and len(node.args) >= 2:
            args = [self._expr(fn, a) for a in node.args]
            if any(t not in (DOUBLE, LONG) for _, t in args):
                raise self._refuse(fn, node, f"{name}() of arrays")
            ints = all(t == LONG for _, t in args)
            cf = f"{self.prefix}_{'l' if ints else ''}{name}"
            acc = _as_double(*args[0]) if not ints else _strip(args[0][0])
            for t, ty in args[1:]:
                acc = f"{cf}({acc}, {_strip(t) if ints else _as_double(t, ty)})"
            return acc, LONG if ints else DOUBLE
        if name == "abs" and len(node.args) == 1:
            a, ty = self._expr(fn, node.args[0])
            return (f"labs({_strip(a)})", LONG) if ty == LONG else (f"fabs({_strip(a)})", DOUBLE)
        if name == "float" and len(node.args) == 1:
            a, ty = self._expr(fn, node.args[0])
            return _as_double(a, ty), DOUBLE
        if name == "int" and len(node.args) == 1:
            a, ty = self._expr(fn, node.args[0])
            return f"((long){a})", LONG
        if name in self.classes:
            return self._numbers(fn, node, node.args, f"nt:{name}")
        cname, ret, args = self._call_user(fn, node)
        if isinstance(ret, tuple):
            raise self._refuse(fn, node, "a call returning a tuple outside `a, b = f(...)`")
        if ret is None and not statement:
            raise self._refuse(fn, node, "the value of a call that returns nothing")
        return f"{cname}({', '.join(args)})", ret or "void"

    def _call_user(self, fn: _Fn, node: ast.Call):
        name = node.func.id if isinstance(node.func, ast.Name) else "?"
        src = self.resolve(name)
        if src is None:
            raise self._refuse(fn, node, f"a call of {name!r}, which is not a part function")
        texts, types = [], []
        for a in node.args:
            t, ty = self._expr(fn, a)
            texts.append(_strip(t))
            types.append(ty)
        key = (id(src.node), tuple(types))
        if key in self.busy:
            raise self._refuse(fn, node, f"a recursive call of {name!r}")
        try:
            cname, ret = self._function(src, tuple(types), None)
        except ConfigurationError as exc:
            note = self.notes.get(name)
            if note is None or note in str(exc):
                raise
            raise ConfigurationError(f"{exc} {note}") from exc
        return cname, ret, texts


_BINOPS = {
    ast.Add: "+",
    ast.Sub: "-",
    ast.Mult: "*",
    ast.Div: "/",
    ast.FloorDiv: "//",
    ast.Mod: "%",
    ast.Pow: "**",
}
_CMPOPS = {
    ast.Eq: "==",
    ast.NotEq: "!=",
    ast.Lt: "<",
    ast.LtE: "<=",
    ast.Gt: ">",
    ast.GtE: ">=",
}
_C_KEYWORDS = {
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else",
    "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register",
    "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch",
    "typedef", "union", "unsigned", "void", "volatile", "while",
}  # fmt: skip


def _c_name(name: str) -> str:
    return f"{name}_" if name in _C_KEYWORDS else name


def c_float(v: float) -> str:
    """A C literal of ``v`` that reads back as the same double (INFINITY, NAN)."""
    if v != v:
        return "NAN"
    if v in (float("inf"), float("-inf")):
        return "INFINITY" if v > 0 else "(-INFINITY)"
    text = repr(v)
    if "e" not in text and "." not in text:
        text += ".0"
    return f"({text})" if text.startswith("-") else text


def _as_double(text: str, ty: str) -> str:
    return f"(double){text}" if ty == LONG else _strip(text)


def _strip(text: str) -> str:
    """``(a + b)`` -> ``a + b`` where the outer parentheses enclose the whole text."""
    if not (text.startswith("(") and text.endswith(")")):
        return text
    depth = 0
    for k, ch in enumerate(text):
        depth += ch == "("
        depth -= ch == ")"
        if depth == 0 and k < len(text) - 1:
            return text
    return text[1:-1]


def _is_literal(text: str) -> bool:
    return text.lstrip("-").isdigit()


def _const_int(node, constants: dict | None = None) -> int | None:
    if isinstance(node, ast.Constant) and isinstance(node.value, int):
        return int(node.value)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        v = _const_int(node.operand, constants)
        return None if v is None else -v
    if constants and isinstance(node, ast.Name) and isinstance(constants.get(node.id), int):
        return constants[node.id]
    return None


def _load(target):
    """The load form of an assignment target (for ``a += b``)."""
    node = ast.parse(ast.unparse(target), mode="eval").body
    return ast.copy_location(node, target)
