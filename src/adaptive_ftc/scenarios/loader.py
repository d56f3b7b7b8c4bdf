"""Scenario files (TOML): the thesis's simulations, and the user's own, as data.

A scenario file names a plant, a design with its gains, the reference, the initial state, the
duration, the solver and the per-actuator failure timeline. See ``docs/scenario-format.md``
and the catalogue in ``adaptive_ftc/scenarios/catalog/``. Every mistake is reported as a
:class:`~adaptive_ftc.errors.ScenarioError` naming the file, the table, the key and the fix;
nothing runs until the whole file is valid.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from adaptive_ftc.allocation.allocators import ALLOCATORS
from adaptive_ftc.allocation.inloop import Annunciation
from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers import DirectAdaptive, MimoDirectAdaptive
from adaptive_ftc.controllers.constraints import ConstraintAware
from adaptive_ftc.errors import ConfigurationError, ExpressionError, ScenarioError, did_you_mean
from adaptive_ftc.hardware import Actuators, Sensors
from adaptive_ftc.registry import DESIGNS, FAILURE_MODELS, PLANTS
from adaptive_ftc.sim.budget import check_run_size
from adaptive_ftc.sim.engine import SolverOptions, simulate
from adaptive_ftc.sim.result import SimResult
from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["CATALOG", "Scenario", "list_scenarios", "load_scenario", "scenario_schema"]

#: Folder of the thesis scenarios shipped with the package.
CATALOG = Path(__file__).with_name("catalog")

_TOP = {
    "name",
    "title",
    "section",
    "figures",
    "description",
    "extends",
    "unset",
    "duration",
    "notes",
    "plant",
    "reference",
    "controller",
    "failures",
    "actuators",
    "sensors",
    "digital",
    "solver",
    "claims",
    "figure",
    "tags",
    "allocation",
}

#: keys of a [[failures]] table that tell the allocator about it (issue 31), not the model
_ANNUNCIATION_SCHEMA: dict[str, dict[str, Any]] = {
    "annunciated": {
        "type": "boolean",
        "default": False,
        "description": "a detector reports this failure to the allocator (else it is silent)",
    },
    "detection_delay": {
        "type": "number",
        "minimum": 0,
        "maximum": 1e100,
        "default": 0.0,
        "description": "seconds from the onset until the allocator knows (annunciated only)",
    },
}


#: Limits of the file itself (sizes the loader accepts before building anything).
MAX_FILE_BYTES = 1_000_000
MAX_ARRAY_ITEMS = 10_000
MAX_STRING_CHARS = 100_000
MAX_FAILURES = 1_000
#: Largest magnitude of a number in a scenario file (physical settings are far below).
MAX_NUMBER = 1e100

_TEXT = {"type": "string", "maxLength": MAX_STRING_CHARS}
_STRINGS = {"type": "array", "items": _TEXT, "maxItems": MAX_ARRAY_ITEMS}

#: Top-level keys that are not tables built from a class: their schema.
_TOP_SCHEMA: dict[str, dict[str, Any]] = {
    "name": {"type": "string", "maxLength": 200, "description": "default: the file name"},
    "title": _TEXT,
    "section": {"type": "string", "maxLength": 200, "description": "thesis section"},
    "figures": {**_STRINGS, "description": "thesis figures reproduced"},
    "description": _TEXT,
    "notes": _TEXT,
    "tags": _STRINGS,
    "extends": {
        "type": "string",
        "maxLength": 1000,
        "description": "scenario name or path whose tables this file overrides",
    },
    "unset": {
        "type": "array",
        "items": {"type": "string", "maxLength": 1000},
        "maxItems": 1000,
        "description": "keys inherited through `extends` to remove, as dotted paths "
        "(e.g. 'actuators', 'controller.regressor', 'solver.filter_tau')",
    },
    "duration": {
        "type": "number",
        "exclusiveMinimum": 0,
        "maximum": MAX_NUMBER,
        "description": "seconds",
    },
    "claims": {
        "type": "array",
        "items": {"type": "object"},
        "maxItems": MAX_ARRAY_ITEMS,
        "description": "[[claims]] tables, see docs/claims.md",
    },
    "figure": {
        "type": "array",
        "items": {"type": "object", "required": ["kind"]},
        "maxItems": MAX_ARRAY_ITEMS,
        "description": "[[figure]] tables: number, kind, caption, outputs",
    },
}


def _split_top(text: str, sep: str) -> list[str]:
    """Split ``text`` on ``sep`` outside brackets."""
    parts, depth, cur = [], 0, ""
    for ch in text:
        if ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        if ch == sep and depth == 0:
            parts.append(cur.strip())
            cur = ""
        else:
            cur += ch
    parts.append(cur.strip())
    return parts


def _type_schema(annotation: str) -> dict[str, Any]:
    """JSON Schema of a dataclass field annotation (the subset the components use)."""
    options = [a for a in _split_top(annotation, "|") if a != "None"]
    if len(options) > 1:
        return {"anyOf": [_type_schema(a) for a in options]}
    a = options[0] if options else "float"
    if a == "int":
        return {"type": "integer", "minimum": -MAX_NUMBER, "maximum": MAX_NUMBER}
    if a == "float":
        return {"type": "number"}
    if a == "bool":
        return {"type": "boolean"}
    if a == "str":
        return {"type": "string", "maxLength": MAX_STRING_CHARS}
    if a == "Value":  # a number or an expression
        return {"anyOf": [{"type": "number"}, {"type": "string", "maxLength": 2000}]}
    if a == "tuple":
        return {
            "type": "array",
            "items": {"anyOf": [{"type": "number"}, {"type": "string", "maxLength": 2000}]},
            "maxItems": MAX_ARRAY_ITEMS,
        }
    if a.startswith("tuple[") and a.endswith("]"):
        inner = _split_top(a[6:-1], ",")
        if len(inner) == 2 and inner[1] == "...":
            return {"type": "array", "items": _type_schema(inner[0]), "maxItems": MAX_ARRAY_ITEMS}
        if all(i == inner[0] for i in inner):
            return {
                "type": "array",
                "items": _type_schema(inner[0]),
                "minItems": len(inner),
                "maxItems": len(inner),
            }
    return {}  # not expressible: checked by the class itself


def _class_schema(cls: type, skip: frozenset[str] | set[str] = frozenset()) -> dict[str, Any]:
    """``properties``/``required`` of a component class, from its dataclass fields."""
    props: dict[str, Any] = {}
    required = []
    for f in dataclasses.fields(cls):
        if not f.init or f.name in skip:
            continue
        sch = dict(_type_schema(str(f.type)))
        if f.default is not dataclasses.MISSING:
            d = f.default
            if isinstance(d, (int, float, str, bool)) and not (
                isinstance(d, float) and not math.isfinite(d)
            ):
                sch["default"] = d
            elif isinstance(d, tuple):
                sch["default"] = _listed(d)
        elif f.default_factory is dataclasses.MISSING:  # type: ignore[misc]
            required.append(f.name)
        props[f.name] = sch
    return {"properties": props, "required": required}


def _listed(v: Any) -> Any:
    return [_listed(x) for x in v] if isinstance(v, (tuple, list)) else v


def _check_value(value: Any, schema: dict[str, Any], *, allow_inf: bool = False) -> str | None:
    """Why ``value`` does not match ``schema`` (the subset :func:`_type_schema` makes), or
    ``None``."""
    if "anyOf" in schema:
        reasons = [_check_value(value, s, allow_inf=allow_inf) for s in schema["anyOf"]]
        if any(r is None for r in reasons):
            return None
        return " or ".join(dict.fromkeys(r for r in reasons if r))
    kind = schema.get("type")
    if kind is None:
        return None
    if kind == "boolean":
        return None if isinstance(value, bool) else f"expected true or false, got {_show(value)}"
    if kind in ("number", "integer"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f"expected a number, got {_show(value)}"
        if kind == "integer" and not isinstance(value, int):
            return f"expected a whole number, got {_show(value)}"
        if isinstance(value, int) and value.bit_length() > 400:  # > 1e120: float() may overflow
            return f"expected a number of magnitude <= {MAX_NUMBER:g}, got {_show(value)}"
        v = float(value)
        if math.isnan(v):
            return "expected a number, got nan"
        if math.isinf(v) and not allow_inf:
            return f"expected a finite number, got {_show(value)}"
        if math.isfinite(v) and abs(v) > MAX_NUMBER:
            return f"expected a number of magnitude <= {MAX_NUMBER:g}, got {_show(value)}"
        if "exclusiveMinimum" in schema and not v > schema["exclusiveMinimum"]:
            return f"expected a number > {schema['exclusiveMinimum']}, got {_show(value)}"
        return None
    if kind == "string":
        if not isinstance(value, str):
            return f"expected a string, got {_show(value)}"
        if len(value) > schema.get("maxLength", MAX_STRING_CHARS):
            return f"the text is longer than {schema.get('maxLength', MAX_STRING_CHARS)} characters"
        return None
    if kind == "array":
        if not isinstance(value, list):
            return f"expected a list, got {_show(value)}"
        n = len(value)
        if n > schema.get("maxItems", MAX_ARRAY_ITEMS):
            return f"expected at most {schema.get('maxItems', MAX_ARRAY_ITEMS)} items, got {n}"
        if n < schema.get("minItems", 0):
            return f"expected {schema['minItems']} items, got {n}"
        items = schema.get("items")
        if items:
            for i, item in enumerate(value):
                why = _check_value(item, items, allow_inf=allow_inf)
                if why:
                    return f"item {i + 1}: {why}"
        return None
    if kind == "object":
        return None if isinstance(value, dict) else f"expected a table, got {_show(value)}"
    return None


def _show(value: Any) -> str:
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 10**20:
        return f"an integer of about {int(value.bit_length() * 0.30103) + 1} digits"
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


@dataclass(frozen=True)
class Scenario:
    """A validated scenario: the closed loop, the solver and the thesis metadata.

    Examples
    --------
    >>> sc = load_scenario("hypersonic-direct-s1")
    >>> sc.figures
    ('2.1', '2.2')
    >>> sc.run().status
    'completed'
    """

    name: str
    title: str
    loop: ClosedLoop
    solver: SolverOptions
    section: str = ""
    figures: tuple[str, ...] = ()
    description: str = ""
    notes: str = ""
    tags: tuple[str, ...] = ()
    claims: tuple[dict[str, Any], ...] = ()
    figure_specs: tuple[dict[str, Any], ...] = ()
    source: Path | None = field(default=None, compare=False)
    text: str = field(default="", compare=False, repr=False)

    def run(
        self, *, adapt: bool = True, failures: bool = True, solver: SolverOptions | None = None
    ) -> SimResult:
        """Simulate; ``adapt=False`` freezes adaptation, ``failures=False`` drops failures."""
        loop = self.loop
        if not failures:
            loop = loop.without_failures()
        if not adapt:
            loop = loop.frozen()
        result = simulate(loop, solver or self.solver)
        self.stamp(result)
        return result

    def stamp(self, result: SimResult) -> SimResult:
        """Record the scenario's name and file text in ``result.meta`` (provenance)."""
        result.meta["scenario"] = self.name
        if self.source is not None:
            result.meta["scenario_file"] = self.source.name
        if self.text:
            result.meta["scenario_file_text"] = self.text
        return result


def list_scenarios() -> list[str]:
    """Names of the scenarios in the catalogue, sorted."""
    return sorted(p.stem for p in CATALOG.glob("*.toml"))


def _resolve(name_or_path: str | Path) -> Path:
    if isinstance(name_or_path, str) and (not name_or_path.strip() or "\x00" in name_or_path):
        raise ScenarioError(
            f"Scenario name {name_or_path!r} is empty or not printable; give a catalogue name "
            "('aftc list') or a path to a .toml file."
        )
    p = Path(name_or_path)
    try:
        exists = p.exists()
    except (OSError, ValueError):
        exists = False
    if p.suffix == ".toml" or exists:
        if not p.is_file():
            raise ScenarioError(f"Scenario file '{p}' does not exist.")
        return p
    candidate = CATALOG / f"{name_or_path}.toml"
    if candidate.is_file():
        return candidate
    names = list_scenarios()
    raise ScenarioError(
        f"Unknown scenario '{name_or_path}'.{did_you_mean(str(name_or_path), names)}"
        f" Run 'aftc list' to see the {len(names)} scenarios, or give a path to "
        "a .toml file."
    )


def _read(path: Path, seen: tuple[Path, ...] = ()) -> tuple[dict[str, Any], str]:
    """Parse ``path`` (and the files it ``extends``); return the merged data and the text of
    every file read (for the provenance of the results)."""
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise ScenarioError(
                f"{path}: the file has {size} bytes; scenario files are limited to "
                f"{MAX_FILE_BYTES} bytes."
            )
        text = path.read_text(encoding="utf-8")
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}.") from None
    except UnicodeDecodeError:
        raise ScenarioError(f"{path}: not UTF-8 text; save the file as UTF-8.") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read the file: {exc.strerror}.") from None
    except (ValueError, RecursionError, MemoryError) as exc:
        raise ScenarioError(
            f"{path}: not a usable TOML file ({type(exc).__name__}: {str(exc)[:200]})."
        ) from None
    base = data.pop("extends", None)
    unset = data.pop("unset", None)
    if base is None:
        if unset is not None:
            raise ScenarioError(
                f"{path}: `unset` removes keys inherited through `extends`, and this file "
                "extends nothing; remove `unset`."
            )
        return data, text
    if not isinstance(base, str) or not base:
        raise ScenarioError(f"{path}: `extends` must be a scenario name or path (a string).")
    if len(seen) > 20:
        raise ScenarioError(f"{path}: `extends` chains more than 20 files; flatten them.")
    base_path = _resolve(base if not base.endswith(".toml") else path.parent / base)
    if base_path.resolve() in seen or base_path.resolve() == path.resolve():
        raise ScenarioError(f"{path}: `extends = '{base}'` makes a cycle.")
    merged, base_text = _read(base_path, seen + (path.resolve(),))
    for key in ("name", "title", "figures", "description", "notes", "claims", "figure"):
        merged.pop(key, None)  # metadata is never inherited
    if unset is not None:
        merged = _unset(merged, unset, path, base)
    return _merge(merged, data), f"# extends {base_path.name}:\n{base_text}\n# {path.name}:\n{text}"


def _unset(base: dict[str, Any], unset: Any, path: Path, name: str) -> dict[str, Any]:
    """``base`` without the keys named in ``unset`` (dotted paths such as ``"actuators"`` or
    ``"controller.regressor"``); a path the base does not have is an error (a typo)."""
    why = _check_value(unset, _TOP_SCHEMA["unset"])
    if why:
        raise ScenarioError(f"{path}: `unset`: {why}. {_fix(_TOP_SCHEMA['unset'])}")
    out = _copy_tables(base)
    for dotted in unset:
        keys = dotted.split(".")
        table: dict[str, Any] | None = out
        for key in keys[:-1]:
            table = table.get(key) if isinstance(table, dict) else None
        if not isinstance(table, dict) or keys[-1] not in table:
            raise ScenarioError(
                f"{path}: `unset` names '{dotted}', which '{name}' does not define (or which "
                "is never inherited: name, title, figures, description, notes, claims, "
                "figure). Remove it from `unset`."
            )
        del table[keys[-1]]
    return out


def _copy_tables(data: dict[str, Any]) -> dict[str, Any]:
    """A copy of ``data`` whose nested tables are copies too (values are shared)."""
    return {k: _copy_tables(v) if isinstance(v, dict) else v for k, v in data.items()}


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


class _Problems(Exception):
    """Internal: a table could not be built (its problems are already recorded)."""


class _Ctx:
    """Collects every problem of a file, one line each (``[table] key: problem. Fix.``)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.problems: list[str] = []

    def err(self, where: str, msg: str) -> ScenarioError:
        return ScenarioError(f"{self.path}: [{where}] {msg}" if where else f"{self.path}: {msg}")

    def add(self, where: str, msg: str) -> None:
        line = f"[{where}] {msg}" if where else msg
        if line not in self.problems:
            self.problems.append(line)

    def raise_if_any(self) -> None:
        if not self.problems:
            return
        if len(self.problems) == 1:
            raise ScenarioError(f"{self.path}: {self.problems[0]}")
        lines = "\n".join(f"  {p}" for p in self.problems)
        raise ScenarioError(f"{self.path}: {len(self.problems)} problems:\n{lines}")

    def table(self, value: Any, where: str) -> dict[str, Any] | None:
        if not isinstance(value, dict):
            self.add(where, f"must be a table ([{where}] section); got {_show(value)}.")
            return None
        return value

    def keys(self, table: dict[str, Any], allowed: set[str], where: str) -> bool:
        ok = True
        for key in table:
            if key not in allowed:
                ok = False
                self.add(
                    where,
                    f"unknown key '{key}'.{did_you_mean(key, allowed)} "
                    f"Allowed keys: {', '.join(sorted(allowed)) or 'none'}.",
                )
        return ok

    def need(self, table: dict[str, Any], key: str, where: str) -> Any:
        if key not in table:
            self.add(where, f"missing key '{key}'.")
            raise _Problems
        return table[key]

    def typed(self, table: dict[str, Any], props: dict[str, Any], where: str) -> bool:
        """Check every value of ``table`` against its schema; record one line per bad key."""
        ok = True
        for key, value in table.items():
            sch = props.get(key)
            if not sch:
                continue
            default = sch.get("default")
            allow_inf = key in ("lower", "upper", "max_step") or (
                isinstance(default, float) and math.isinf(default)
            )
            why = _check_value(value, sch, allow_inf=allow_inf)
            if why:
                ok = False
                self.add(where, f"`{key}`: {why}. {_fix(sch)}")
        return ok


_NOUN = {
    "number": ("a number", "numbers", "1.5", "0.1, 0.2"),
    "integer": ("a whole number", "whole numbers", "2", "1, 2"),
    "boolean": ("true or false", "booleans", "true", "true, false"),
    "string": ("a quoted string", "strings", '"0.1*sin(t)"', '"x1", "x2"'),
    "object": ("a table", "tables", "{...}", "{...}"),
}


def _fix(schema: dict[str, Any]) -> str:
    """A short 'write it like this' hint for a schema."""
    if "anyOf" in schema:
        return "Write " + " or ".join(_what(s) for s in schema["anyOf"]) + "."
    return f"Write {_what(schema)}."


def _what(schema: dict[str, Any]) -> str:
    kind = schema.get("type", "")
    if kind == "array":
        items = schema.get("items", {})
        n = schema.get("minItems")
        count = f"{n} " if n and n == schema.get("maxItems") else ""
        if items.get("type") in _NOUN:
            noun = _NOUN[items["type"]]
            return f"a list of {count}{noun[1]}, e.g. [{noun[3]}]"
        if items.get("type") == "array":
            return f"a list of {count}lists of numbers, e.g. [[1.0, 0.0], [0.0, 1.0]]"
        return f'a list of {count}numbers or expressions, e.g. [0.5, "sin(t)"]'
    if kind in _NOUN:
        noun = _NOUN[kind]
        return f"{noun[0]}, e.g. {noun[2]}"
    return "a valid value"


def _tupled(value: Any) -> Any:
    if isinstance(value, list):
        return tuple(_tupled(v) for v in value)
    return value


def _fields(cls: type) -> set[str]:
    return {f.name for f in dataclasses.fields(cls) if f.init}


#: Exceptions a component constructor may raise on a bad value that passed the type tables;
#: each becomes one problem line naming the table.
_BUILD_ERRORS = (
    ConfigurationError,
    ExpressionError,
    TypeError,
    ValueError,
    ArithmeticError,
    RecursionError,
    MemoryError,
    IndexError,
    KeyError,
)


def _build(cls: type, kwargs: dict[str, Any], ctx: _Ctx, where: str):
    try:
        return cls(**{k: _tupled(v) for k, v in kwargs.items()})
    except (ConfigurationError, ExpressionError) as exc:
        ctx.add(where, str(exc))
    except MemoryError:
        ctx.add(where, "the settings need more memory than available; use smaller sizes.")
    except RecursionError:
        ctx.add(where, "a value nests too deeply; simplify it.")
    except _BUILD_ERRORS as exc:
        ctx.add(where, f"invalid value ({type(exc).__name__}: {exc}). Check the keys' values.")
    raise _Problems


def _partial(cls: type, table: dict[str, Any]):
    """``cls`` built from the keys of ``table`` that are valid on their own (``None`` if even
    that fails): lets later stages check what they can of a table with problems."""
    props = _class_schema(cls)["properties"]
    good = {
        k: v
        for k, v in table.items()
        if k in props and _check_value(v, props[k], allow_inf=k == "max_step") is None
    }
    try:
        return cls(**{k: _tupled(v) for k, v in good.items()})
    except _BUILD_ERRORS:
        return None


def _has_regressor(cls: type) -> bool:
    """Whether design ``cls`` takes a ``regressor`` (the non-adaptive baselines do not)."""
    return any(f.name == "regressor" for f in dataclasses.fields(cls))


def _component(cls: type, table: dict[str, Any], ctx: _Ctx, where: str, skip=frozenset()):
    """Check keys and types of ``table`` against ``cls``'s fields, then build it."""
    schema = _class_schema(cls, set(skip))
    ok = ctx.keys(table, set(schema["properties"]) | set(skip), where)
    ok = ctx.typed(table, schema["properties"], where) and ok
    missing = [k for k in schema["required"] if k not in table]
    for k in missing:
        ctx.add(where, f"missing key '{k}'.")
    if not ok or missing:
        raise _Problems
    return _build(cls, table, ctx, where)


def _constraint_aware(table: Any, ctrl, plant, hardware: dict[str, Any], ctx: _Ctx):
    """``[controller.constraint_aware]``: the designer's model of the hardware, given field
    by field or ``from_hardware = true`` (the declared [actuators], [sensors] and
    [digital] tables; other keys then override)."""
    where = "controller.constraint_aware"
    table = ctx.table(table, where)
    if table is None:
        return None
    table = dict(table)
    schema = _class_schema(ConstraintAware)
    if not ctx.keys(table, set(schema["properties"]) | {"from_hardware"}, where):
        return None
    derive = table.pop("from_hardware", False)
    if not isinstance(derive, bool):
        ctx.add(where, f"`from_hardware`: expected true or false, got {_show(derive)}.")
        return None
    if not ctx.typed(table, schema["properties"], where):
        return None
    try:
        if derive:
            ca = ConstraintAware.from_hardware(
                actuators=hardware.get("actuators"),
                sensors=hardware.get("sensors"),
                sample_time=hardware.get("sample_time", 0.0),
                plant=plant,
                lam=ctrl.lam,
                **table,
            )
        else:
            ca = ConstraintAware(**table)
    except (ConfigurationError, ValueError, TypeError) as exc:
        ctx.add(where, str(exc))
        return None
    return dataclasses.replace(ctrl, constraint_aware=ca)


def _regressor(table: Any, ctx: _Ctx, where: str):
    table = ctx.table(table, where)
    if table is None:
        raise _Problems
    kind = ctx.need(table, "type", where)
    body = {k: v for k, v in table.items() if k != "type"}
    if kind == "fuzzy":
        return _component(FuzzyBasis, body, ctx, where)
    if kind == "linear":
        return _component(LinearRegressor, body, ctx, where)
    ctx.add(
        where,
        f"unknown regressor type {_show(kind)}.{did_you_mean(str(kind), ['fuzzy', 'linear'])}"
        " Use 'fuzzy' or 'linear'.",
    )
    raise _Problems


def _choice(ctx: _Ctx, where: str, what: str, value: Any, choices) -> bool:
    if isinstance(value, str) and value in choices:
        return True
    ctx.add(
        where,
        f"unknown {what} {_show(value)}.{did_you_mean(str(value), choices)} "
        f"Available: {', '.join(choices)}.",
    )
    return False


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load and validate a scenario from the catalogue (by name) or from a TOML file.

    Every problem of the file is reported at once, one line each naming the table, the key
    and the fix; the run size is checked against :mod:`adaptive_ftc.sim.budget`.

    Raises
    ------
    ScenarioError
        With the file and every problem found.
    """
    if not isinstance(name_or_path, (str, Path)):
        raise ScenarioError(
            f"A scenario is given by name or path (a string); got {type(name_or_path).__name__}."
        )
    path = _resolve(name_or_path)
    ctx = _Ctx(path)
    data, text = _read(path)
    try:
        return _load(data, text, path, ctx)
    except _Problems:
        pass
    ctx.raise_if_any()
    raise ctx.err("", "invalid scenario.")  # pragma: no cover - _Problems always records a line


def _load(data: dict[str, Any], text: str, path: Path, ctx: _Ctx) -> Scenario:
    ctx.keys(data, _TOP - {"extends", "unset"}, "")
    for key, sch in _TOP_SCHEMA.items():
        if key in data and key not in ("extends", "unset"):
            why = _check_value(data[key], sch)
            if why:
                ctx.add("", f"`{key}`: {why}. {_fix(sch)}")
    name = str(data.get("name", path.stem))
    # ---------------------------------------------------------------- plant
    plant = None
    ptab = ctx.table(data["plant"], "plant") if "plant" in data else None
    if "plant" not in data:
        ctx.add("", "missing table [plant] (model = 'hypersonic', 'wingrock', ...).")
    if ptab is not None:
        try:
            ptab = dict(ptab)
            model = ctx.need(ptab, "model", "plant")
            x0 = ptab.pop("initial_state", [])
            why = _check_value(x0, _INITIAL_STATE)
            if why:
                ctx.add("plant", f"`initial_state`: {why}. {_fix(_INITIAL_STATE)}")
            ptab.pop("model")
            if _choice(ctx, "plant", "plant model", model, list(PLANTS)):
                plant = _component(PLANTS[model], ptab, ctx, "plant")
        except _Problems:
            plant = None
    # ---------------------------------------------------------------- reference
    outputs: Any = None
    if "reference" in data:
        rtab = ctx.table(data["reference"], "reference")
        if rtab is not None:
            ctx.keys(rtab, {"outputs"}, "reference")
            if "outputs" not in rtab:
                ctx.add("reference", "missing key 'outputs' (one expression of t per output).")
            else:
                outputs = rtab["outputs"]
                if isinstance(outputs, (str, int, float)) and not isinstance(outputs, bool):
                    outputs = [outputs]
                why = _check_value(outputs, _OUTPUTS)
                if why:
                    ctx.add("reference", f"`outputs`: {why}. {_fix(_OUTPUTS)}")
                    outputs = None
                else:
                    outputs = _reference_checked(outputs, plant, ctx)
    elif plant is not None:
        outputs = ["0"] * plant.n_outputs
    # ---------------------------------------------------------------- controller
    ctrl = None
    ca_tab = None  # [controller.constraint_aware], built once the hardware is read
    adapt = True
    allocation = None
    built_regressors: tuple = ()
    if "controller" not in data:
        ctx.add("", "missing table [controller] (design = 'direct', 'estimation', ...).")
    ctab = ctx.table(data["controller"], "controller") if "controller" in data else None
    if ctab is not None:
        try:
            ctab = dict(ctab)
            design = ctx.need(ctab, "design", "controller")
            allocation = ctab.pop("allocation", None)
            if allocation is not None:
                why = _check_value(allocation, _ALLOCATION)
                if why:
                    ctx.add("controller", f"`allocation`: {why}. {_fix(_ALLOCATION)}")
                    allocation = None
                    raise _Problems
            ctab.pop("design")
            if design == "none":
                ctx.keys(ctab, set(), "controller")
                ctrl = DirectAdaptive(regressor=LinearRegressor(inputs=(), bias=True), theta0=0.0)
                adapt = False
                if allocation is None and plant is not None:
                    allocation = [[0.0] * plant.n_actuators for _ in range(plant.n_outputs)]
            elif _choice(ctx, "controller", "design", design, list(DESIGNS) + ["none"]):
                dcls = DESIGNS[design]
                adapt = ctab.pop("adapt", True)
                ca_tab = ctab.pop("constraint_aware", None)
                if not isinstance(adapt, bool):
                    ctx.add("controller", f"`adapt`: expected true or false, got {_show(adapt)}.")
                    adapt = True
                if not _has_regressor(dcls):  # e.g. the nominal-inverse / oracle baselines
                    ctrl = _component(dcls, ctab, ctx, "controller")
                    regs = None
                elif "regressor" not in ctab:
                    ctx.add(
                        "controller",
                        "missing table [controller.regressor] (type = 'fuzzy' or 'linear').",
                    )
                    raise _Problems
                else:
                    regs = ctab.pop("regressor")
                if regs is None:
                    pass
                elif isinstance(regs, list):
                    if dcls is not MimoDirectAdaptive:
                        ctx.add(
                            "controller.regressor",
                            "a list of regressors is only allowed for the 'mimo' design.",
                        )
                        raise _Problems
                    if not regs or len(regs) > 100:
                        ctx.add("controller.regressor", "give 1 to 100 [[controller.regressor]].")
                        raise _Problems
                    each = []
                    bad = False
                    for i, r in enumerate(regs):
                        try:
                            each.append(_regressor(r, ctx, f"controller.regressor.{i + 1}"))
                        except _Problems:
                            bad = True
                    if bad:
                        raise _Problems
                    reg = tuple(each)
                else:
                    reg = _regressor(regs, ctx, "controller.regressor")
                if regs is not None:
                    built_regressors = reg if isinstance(reg, tuple) else (reg,)
                    ctrl = _component(
                        dcls, {**ctab, "regressor": reg}, ctx, "controller", {"regressor"}
                    )
            if allocation is None and ctrl is not None:
                ctx.add(
                    "controller",
                    "missing key 'allocation' (the matrix R of u = R^T u0, or "
                    "the list of proportional gains b_j for a single-output plant).",
                )
        except _Problems:
            ctrl = None
    if ctrl is None and plant is not None:  # the loop's check of the inputs will not run
        _check_regressor_inputs(built_regressors, plant, ctx)
    # ---------------------------------------------------------------- failures
    failures = []
    failures_ok = True
    ftabs = data.get("failures", [])
    if not isinstance(ftabs, list):
        ctx.add("failures", "write each failure as a [[failures]] table.")
        ftabs, failures_ok = [], False
    if len(ftabs) > MAX_FAILURES:
        ctx.add("failures", f"at most {MAX_FAILURES} [[failures]] tables; got {len(ftabs)}.")
        ftabs, failures_ok = [], False
    annunciations: list[Annunciation] = []
    for i, ft in enumerate(ftabs):
        where = f"failures.{i + 1}"
        try:
            ft = ctx.table(ft, where)
            if ft is None:
                raise _Problems
            ft = dict(ft)
            fmodel = ctx.need(ft, "model", where)
            if not _choice(ctx, where, "failure model", fmodel, list(FAILURE_MODELS)):
                raise _Problems
            ft.pop("model")
            known = _annunciation_keys(ft, ctx, where)
            failures.append(_component(FAILURE_MODELS[fmodel], ft, ctx, where))
            if known is not None:
                f = failures[-1]
                annunciations.append(
                    _build(
                        Annunciation,
                        dict(actuator=f.actuator, onset=f.onset, recovery=f.recovery, delay=known),
                        ctx,
                        where,
                    )
                )
        except _Problems:
            failures_ok = False
    allocator = _allocator(data.get("allocation"), ctx)
    # ---------------------------------------------------------------- hardware
    hardware: dict[str, Any] = {}
    for key, cls in (("actuators", Actuators), ("sensors", Sensors)):
        if key in data:
            tab = ctx.table(data[key], key)
            if tab is not None:
                try:
                    hardware[key] = _component(cls, dict(tab), ctx, key)
                except _Problems:
                    pass
    if "digital" in data:
        dtab = ctx.table(data["digital"], "digital")
        if dtab is not None and ctx.keys(dtab, {"sample_time"}, "digital"):
            ts = dtab.get("sample_time")
            if isinstance(ts, bool) or not isinstance(ts, (int, float)) or not ts > 0:
                ctx.add(
                    "digital",
                    f"`sample_time`: the controller's period in seconds (> 0); got {_show(ts)}.",
                )
            else:
                hardware["sample_time"] = float(ts)
    # ---------------------------------------------------------------- solver
    solver = None
    checks = None  # the solver the later stages check with (its good keys when it is bad)
    stab = ctx.table(data.get("solver", {}), "solver")
    if stab is not None:
        try:
            solver = checks = _component(SolverOptions, stab, ctx, "solver")
        except _Problems:
            solver, checks = None, _partial(SolverOptions, stab)
    if "duration" not in data:
        ctx.add("", "missing key 'duration' (seconds, e.g. duration = 10.0).")
    duration = data.get("duration")
    claims = data.get("claims", [])
    figs = data.get("figure", [])
    if not isinstance(claims, list) or not all(isinstance(c, dict) for c in claims):
        ctx.add("claims", "write claims as [[claims]] tables.")
    else:
        _check_claims(claims, ctx)
    if not isinstance(figs, list) or not all(isinstance(f, dict) for f in figs):
        ctx.add("figure", "write figures as [[figure]] tables.")
    else:
        _check_figures(figs, plant, ctx)
    if ca_tab is not None and ctrl is not None and plant is not None:
        ctrl = _constraint_aware(ca_tab, ctrl, plant, hardware, ctx)
    # ---------------------------------------------------------------- the loop
    # the later stages run on whatever parts were built, so every problem shows at once
    if plant is None or not _plant_parts_ok(plant, x0, outputs, failures, ctx):
        raise _Problems
    duration_ok = _check_value(duration, _TOP_SCHEMA["duration"]) is None
    if ctrl is None or not failures_ok or outputs is None or not duration_ok:
        if checks is not None and _check_value(x0, _INITIAL_STATE) is None:
            _check_bound(list(zip(plant.state_names, map(float, x0), strict=False)), checks, ctx)
        raise _Problems
    loop = _build(
        ClosedLoop,
        dict(
            plant=plant,
            controller=ctrl,
            allocation=allocation,
            reference=outputs,
            initial_state=x0,
            failures=tuple(failures),
            t_final=duration,
            adapt=adapt,
            name=name,
            **hardware,
            **({"allocator": allocator} if allocator is not None else {}),
            **({"annunciations": tuple(annunciations)} if annunciations else {}),
        ),
        ctx,
        "",
    )
    if checks is not None:
        _check_solver(loop, checks, ctx)
        # the run must fit in memory and finish: steps, samples and recorded bytes
        try:
            check_run_size(loop, checks)
        except ConfigurationError as exc:
            ctx.add("solver", str(exc))
    # resolve every expression and regressor input now, so nothing half-runs
    sdot = (checks or SolverOptions()).sdot_for(loop)
    try:
        from adaptive_ftc.sim.compose import generate

        _, _, gen, layout = generate(loop, sdot=sdot)  # checks every part
        if solver is not None and isinstance(solver.atol, tuple):  # one atol per state
            names = [*loop.plant.state_names, *gen.adaptive_names, *layout["extra_names"]]
            try:
                solver.atol_for(int(layout["ny_all"]), names)
            except ConfigurationError as exc:
                ctx.add("solver", str(exc))
    except (ConfigurationError, ExpressionError) as exc:
        ctx.add("", str(exc))
    except _BUILD_ERRORS as exc:
        ctx.add("", f"the loop cannot be assembled ({type(exc).__name__}: {exc}).")
    if ctx.problems:
        _add_compensability(loop, ctx)  # listed with the other problems, not a round later
        raise _Problems
    if solver is None:  # pragma: no cover - a failed [solver] table records a problem
        raise _Problems
    return Scenario(
        name=name,
        title=str(data.get("title", name)),
        loop=loop,
        solver=solver,
        section=str(data.get("section", "")),
        figures=tuple(str(f) for f in data.get("figures", [])),
        description=str(data.get("description", "")),
        notes=str(data.get("notes", "")),
        tags=tuple(str(t) for t in data.get("tags", [])),
        claims=tuple(dict(c) for c in claims),
        figure_specs=tuple(dict(f) for f in figs),
        source=path,
        text=text,
    )


def _annunciation_keys(ft: dict[str, Any], ctx: _Ctx, where: str) -> float | None:
    """Pop ``annunciated`` and ``detection_delay`` from a [[failures]] table: the detection
    delay of an annunciated failure, ``None`` for a silent one."""
    known = ft.pop("annunciated", False)
    delay = ft.pop("detection_delay", None)
    bad = False
    for key, value in (("annunciated", known), ("detection_delay", delay)):
        if value is None:
            continue
        why = _check_value(value, _ANNUNCIATION_SCHEMA[key])
        if why:
            ctx.add(where, f"`{key}`: {why}. {_fix(_ANNUNCIATION_SCHEMA[key])}")
            bad = True
    if bad:
        raise _Problems
    if delay is not None and known is not True:
        ctx.add(
            where,
            "`detection_delay` is given but the failure is silent: add `annunciated = true` "
            "(a detector reports it after the delay) or remove `detection_delay`.",
        )
        raise _Problems
    return float(delay or 0.0) if known else None


def _allocator(table: Any, ctx: _Ctx):
    """``[allocation]``: ``kind = "fixed"`` (default: the thesis's ``u = R^T u0``), ``"pinv"``,
    ``"wls"`` or ``"adaptive"`` with the allocator's settings (:mod:`adaptive_ftc.allocation`)."""
    if table is None:
        return None
    tab = ctx.table(table, "allocation")
    if tab is None:
        return None
    tab = dict(tab)
    kind = tab.pop("kind", "fixed")
    if not _choice(ctx, "allocation", "allocation kind", kind, list(ALLOCATORS)):
        return None
    if kind == "fixed":
        ctx.keys(tab, set(), "allocation")
        return None
    try:
        return _component(ALLOCATORS[kind], tab, ctx, "allocation")
    except _Problems:
        return None


def _reference_checked(outputs: list[Any], plant: Any, ctx: _Ctx) -> list[Any] | None:
    """Parse every reference expression now (``None`` when one is bad, each recorded)."""
    from adaptive_ftc.expressions import Expression

    ok = True
    for i, text in enumerate(outputs):
        names = getattr(plant, "output_names", ())
        name = names[i] if i < len(names) else f"{i + 1}"
        try:
            Expression(text, ("t",), context=f"reference of output '{name}'")
        except ExpressionError as exc:
            ctx.add("reference", str(exc))
            ok = False
    return outputs if ok else None


def _plant_parts_ok(plant: Any, x0: Any, outputs: Any, failures: list[Any], ctx: _Ctx) -> bool:
    """Checks of the parts against the plant that need no controller: the initial state
    (its length, inside the plant's envelope), one reference per output, failures of
    existing actuators that do not overlap. Each problem is recorded; ``False`` when the
    loop cannot be built (an initial state outside the envelope does not stop that)."""
    ok = True
    n, p, m = plant.n_states, plant.n_outputs, plant.n_actuators
    if isinstance(x0, list) and _check_value(x0, _INITIAL_STATE) is None:
        if len(x0) > n:
            ok = False
            ctx.add(
                "plant",
                f"`initial_state` has {len(x0)} values but plant '{plant.name}' has {n} states "
                f"({', '.join(plant.state_names)}).",
            )
        env = tuple(getattr(plant, "envelope", ()) or ())
        for i, (x, bound) in enumerate(zip(x0, env, strict=False)):
            if abs(x) > bound:
                name = plant.state_names[i]
                ctx.add(
                    "plant",
                    f"`initial_state`: {name} = {x:g} is outside the plant's envelope "
                    f"|{name}| <= {bound:.4g} (the run would stop at its first sample). Give a "
                    "value inside it.",
                )
    if outputs is not None and len(outputs) != p:
        ok = False
        ctx.add(
            "reference",
            f"`outputs` needs one expression per output of plant '{plant.name}' "
            f"({', '.join(plant.output_names)}); got {len(outputs)}.",
        )
    if failures:
        from adaptive_ftc.faults import FailureSchedule

        try:
            FailureSchedule(tuple(failures), m)
        except ConfigurationError as exc:
            ok = False
            ctx.add("failures", str(exc))
    return ok


def _check_regressor_inputs(regressors: tuple, plant: Any, ctx: _Ctx) -> None:
    """Each regressor input must name a signal of the plant's loop (checked here when the
    controller could not be built, so the loop's own check cannot run)."""
    from adaptive_ftc.sim.system import signal_names

    names = signal_names(plant)
    for i, reg in enumerate(regressors):
        where = "controller.regressor" + (f".{i + 1}" if len(regressors) > 1 else "")
        for name in getattr(reg, "inputs", ()):
            if name not in names:
                ctx.add(
                    where,
                    f"unknown regressor input '{name}'.{did_you_mean(str(name), names)} "
                    f"Available signals: {', '.join(names)}.",
                )


def _check_claims(claims: list[dict[str, Any]], ctx: _Ctx) -> None:
    """Keys and values of each [[claims]] table (what ``aftc reproduce`` will check)."""
    from adaptive_ftc.claims import ClaimError, _params

    for i, claim in enumerate(claims):
        try:
            _params(claim)
        except ClaimError as exc:
            ctx.add(f"claims.{i + 1}", str(exc))
        except _BUILD_ERRORS as exc:  # e.g. an integer too large for a float
            ctx.add(f"claims.{i + 1}", f"invalid value ({type(exc).__name__}: {str(exc)[:200]}).")


#: Keys of a [[figure]] table and the kinds ``adaptive_ftc.plots.plot`` draws.
_FIGURE_KEYS = {"number", "kind", "caption", "outputs", "zoom"}
_FIGURE_KINDS = ("tracking", "control", "parameters", "control_parameters", "modal", "direction")


def _check_figures(figs: list[dict[str, Any]], plant: Any, ctx: _Ctx) -> None:
    """Keys and values of each [[figure]] table, before anything is simulated."""
    for i, fig in enumerate(figs):
        where = f"figure.{i + 1}"
        ctx.keys(fig, _FIGURE_KEYS, where)
        kind = fig.get("kind")
        if "kind" not in fig:
            ctx.add(where, f"missing key 'kind' (one of {', '.join(_FIGURE_KINDS)}).")
        else:
            _choice(ctx, where, "figure kind", kind, _FIGURE_KINDS)
        for key in ("number", "caption"):
            value = fig.get(key, "")
            if isinstance(value, bool) or not isinstance(value, (str, int, float)):
                ctx.add(where, f"`{key}`: expected a text or a number, got {_show(value)}.")
        if "outputs" in fig:
            outs = fig["outputs"]
            p = plant.n_outputs if plant is not None else None
            names = f" ({', '.join(plant.output_names)})" if plant is not None else ""
            good = (
                isinstance(outs, list)
                and outs
                and all(
                    isinstance(o, int)
                    and not isinstance(o, bool)
                    and 1 <= o <= (p if p is not None else o)
                    for o in outs
                )
            )
            if not good:
                ctx.add(
                    where,
                    f"`outputs`: expected a list of output numbers from 1 to {p or 'p'}{names}, "
                    f"got {_show(outs) if isinstance(outs, dict) else repr(outs)[:60]}.",
                )
        if "zoom" in fig:
            zoom = fig["zoom"]
            if not (
                isinstance(zoom, list)
                and len(zoom) == 2
                and all(_check_value(v, {"type": "number"}) is None for v in zoom)
                and zoom[0] < zoom[1]
            ):
                ctx.add(where, "`zoom`: expected [start, end] in s with start < end.")
        if kind == "modal" and plant is not None:
            if not any(n.startswith("eta") for n in plant.state_names):
                ctx.add(
                    where,
                    f"a 'modal' figure needs flexible-mode (eta) states; plant '{plant.name}' "
                    "has none. Use another kind.",
                )


def _add_compensability(loop: ClosedLoop, ctx: _Ctx) -> None:
    """Record the conditions `aftc validate` checks (rank (3.6), sign (2.16)/(4.6)) that the
    loop breaks, as problems of the file."""
    try:
        report = loop.compensability(design=True)
    except _BUILD_ERRORS:  # e.g. a failure expression that cannot be evaluated
        return
    if report.ok:
        return
    for line in report.describe(loop.plant.output_names).splitlines():
        if "NOT compensable" in line:
            ctx.add("failures", f"not compensable: {line}.")


def _check_bound(start: list[tuple[str, float]], solver: SolverOptions, ctx: _Ctx) -> None:
    """The initial values (name, value) must lie below the solver's divergence bound."""
    if not start:
        return
    bound = float(solver.divergence_bound)
    name, x = max(start, key=lambda item: abs(item[1]))
    if not abs(x) < bound:
        ctx.add(
            "solver",
            f"`divergence_bound` = {bound:g}: the initial value {name} = {x:g} is already not "
            f"below it (the run would stop at its first sample). Give a bound above "
            f"{abs(x):g}, e.g. the default 1e8.",
        )


def _check_solver(loop: ClosedLoop, solver: SolverOptions, ctx: _Ctx) -> None:
    """Solver settings that cannot work on this loop: a divergence bound the initial state
    already exceeds, an unstable sampled ``s'`` filter."""
    start = [(n, x) for n, x in zip(loop.plant.state_names, loop.initial_state, strict=False)]
    start.append(("theta0", float(loop.controller.theta0)))
    start += [(f"adaptive_initial[{i + 1}]", v) for i, v in enumerate(loop.adaptive_initial)]
    if loop.actuators is not None:
        start += [(f"actuator {i + 1}", v) for i, v in enumerate(loop.actuators.initial)]
    _check_bound(start, solver, ctx)
    ts = loop.sample_time
    if ts > 0 and solver.sdot_for(loop) == "filtered":
        tau = solver.filter_tau_for(loop)
        if not ts < 2.0 * tau:
            ctx.add(
                "solver",
                f"`filter_tau` = {tau:g} s: the sampled s' filter is unstable with the "
                f"[digital] sample_time = {ts:g} s (it needs sample_time < 2 filter_tau). "
                f"Stable range: filter_tau > {ts / 2:g} s; leave it out for the default "
                f"max(0.01, 2 sample_time) = {max(0.01, 2 * ts):g} s.",
            )


_INITIAL_STATE = {"type": "array", "items": {"type": "number"}, "maxItems": 1000}
_OUTPUTS = {
    "type": "array",
    "items": {"anyOf": [{"type": "number"}, {"type": "string", "maxLength": 2000}]},
    "maxItems": 1000,
}
_ALLOCATION = {
    "anyOf": [
        {"type": "array", "items": {"type": "number"}, "maxItems": 1000},
        {
            "type": "array",
            "items": {"type": "array", "items": {"type": "number"}, "maxItems": 1000},
            "maxItems": 1000,
        },
    ]
}


# ---------------------------------------------------------------------------- JSON Schema
def scenario_schema() -> dict[str, Any]:
    """JSON Schema (draft 2020-12) of the scenario format, generated from the loader's tables
    and the component classes' fields (``aftc schema`` prints it).

    Examples
    --------
    >>> sorted(scenario_schema()["propertyNames"]["enum"])[:3]
    ['actuators', 'allocation', 'claims']
    """
    from adaptive_ftc._version import __version__

    def obj(props: dict[str, Any], required=(), extra: dict[str, Any] | None = None):
        out = {"type": "object", "properties": props, "additionalProperties": False}
        if required:
            out["required"] = list(required)
        if extra:
            out.update(extra)
        return out

    cls: type  # a plant's, a regressor's, a design's, a failure model's class in turn
    plants = []
    for key, cls in PLANTS.items():
        sch = _class_schema(cls)
        plants.append(
            obj(
                {"model": {"const": key}, "initial_state": _INITIAL_STATE, **sch["properties"]},
                ["model", *sch["required"]],
                {"title": f"plant '{key}'"},
            )
        )
    regs = []
    for key, cls in (("fuzzy", FuzzyBasis), ("linear", LinearRegressor)):
        sch = _class_schema(cls)
        regs.append(
            obj(
                {"type": {"const": key}, **sch["properties"]},
                ["type", *sch["required"]],
                {"title": f"regressor '{key}'"},
            )
        )
    reg_schema = {"oneOf": regs}
    designs = [
        obj(
            {"design": {"const": "none"}, "allocation": _ALLOCATION},
            ["design"],
            {"title": "open loop"},
        )
    ]
    for key, cls in DESIGNS.items():
        sch = _class_schema(cls, {"regressor"})
        regressor = (
            {"anyOf": [reg_schema, {"type": "array", "items": reg_schema, "maxItems": 100}]}
            if cls is MimoDirectAdaptive
            else reg_schema
        )
        has_reg = _has_regressor(cls)  # the nominal-inverse / oracle baselines have none
        designs.append(
            obj(
                {
                    "design": {"const": key},
                    "allocation": _ALLOCATION,
                    "adapt": {"type": "boolean", "default": True},
                    **({"regressor": regressor} if has_reg else {}),
                    **sch["properties"],
                },
                ["design", "allocation", *(["regressor"] if has_reg else []), *sch["required"]],
                {"title": f"design '{key}'"},
            )
        )
    fails = []
    for key, cls in FAILURE_MODELS.items():
        sch = _class_schema(cls)
        fails.append(
            obj(
                {"model": {"const": key}, **sch["properties"], **_ANNUNCIATION_SCHEMA},
                ["model", *sch["required"]],
                {"title": f"failure '{key}'"},
            )
        )
    solver = _class_schema(SolverOptions)
    props = {
        **{k: v for k, v in _TOP_SCHEMA.items()},
        "plant": {"oneOf": plants},
        "reference": obj({"outputs": _OUTPUTS}, ["outputs"]),
        "controller": {"oneOf": designs},
        "failures": {"type": "array", "items": {"oneOf": fails}, "maxItems": MAX_FAILURES},
        "solver": obj(solver["properties"]),
        "actuators": obj(
            _class_schema(Actuators)["properties"],
            extra={"description": "actuator lag, rate and position limits (per actuator)"},
        ),
        "sensors": obj(
            _class_schema(Sensors)["properties"],
            extra={"description": "measurement noise (std) and bias by state name, seed"},
        ),
        "digital": obj(
            {"sample_time": {"type": "number", "exclusiveMinimum": 0, "maximum": MAX_NUMBER}},
            ["sample_time"],
            {"description": "sample-and-hold controller period in seconds"},
        ),
        "allocation": {
            "oneOf": [
                obj(
                    {
                        "kind": {"const": key}
                        if key != "fixed"
                        else {"const": key, "default": "fixed"},
                        **({} if key == "fixed" else _class_schema(cls)["properties"]),
                    },
                    ["kind"] if key != "fixed" else (),
                    {"title": f"allocation '{key}'"},
                )
                for key, cls in ALLOCATORS.items()
            ],
            "description": "control allocator (docs/allocation.md); default: the thesis's fixed "
            "u = R^T u0",
        },
    }
    props = dict(sorted(props.items()))
    partial = {k: _without_required(v) for k, v in props.items()}
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "$id": "https://github.com/adaptive-ftc/adaptive-ftc/docs/scenario.schema.json",
        "title": f"adaptive-ftc scenario file (adaptive-ftc {__version__})",
        "description": "Generated by `aftc schema` from the scenario loader's tables; see "
        "docs/scenario-format.md. TOML files map to JSON objects one to one.",
        "type": "object",
        "propertyNames": {"enum": list(props)},
        # a file that `extends` another overrides any part of it: its tables may be partial
        "if": {"required": ["extends"]},
        "then": {"properties": partial},
        "else": {"properties": props, "required": ["plant", "controller", "duration"]},
    }


def _without_required(schema: Any) -> Any:
    """The schema with every ``required`` dropped and ``oneOf`` relaxed to ``anyOf`` (the
    partial tables of a file that ``extends`` another)."""
    if isinstance(schema, list):
        return [_without_required(s) for s in schema]
    if not isinstance(schema, dict):
        return schema
    out = {}
    for k, v in schema.items():
        if k == "required":
            continue
        out["anyOf" if k == "oneOf" else k] = _without_required(v)
    return out
