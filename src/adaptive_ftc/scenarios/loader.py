"""Scenario files (TOML): the thesis's simulations, and the user's own, as data.

A scenario file names a plant, a design with its gains, the reference, the initial state, the
duration, the solver and the per-actuator failure timeline. See ``docs/scenario-format.md``
and the catalogue in ``adaptive_ftc/scenarios/catalog/``. Every mistake is reported as a
:class:`~adaptive_ftc.errors.ScenarioError` naming the file, the table, the key and the fix;
nothing runs until the whole file is valid.
"""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from adaptive_ftc.approximators import FuzzyBasis, LinearRegressor
from adaptive_ftc.controllers import DESIGNS, DirectAdaptive, MimoDirectAdaptive
from adaptive_ftc.errors import ConfigurationError, ExpressionError, ScenarioError, did_you_mean
from adaptive_ftc.faults import FAILURE_MODELS
from adaptive_ftc.plants import PLANTS
from adaptive_ftc.sim.engine import SolverOptions, simulate
from adaptive_ftc.sim.result import SimResult
from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["CATALOG", "Scenario", "list_scenarios", "load_scenario"]

#: Folder of the thesis scenarios shipped with the package.
CATALOG = Path(__file__).with_name("catalog")

_TOP = {
    "name",
    "title",
    "section",
    "figures",
    "description",
    "extends",
    "duration",
    "notes",
    "plant",
    "reference",
    "controller",
    "failures",
    "solver",
    "claims",
    "figure",
    "tags",
}


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
        result.meta["scenario"] = self.name
        return result


def list_scenarios() -> list[str]:
    """Names of the scenarios in the catalogue, sorted."""
    return sorted(p.stem for p in CATALOG.glob("*.toml"))


def _resolve(name_or_path: str | Path) -> Path:
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
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


def _read(path: Path, seen: tuple[Path, ...] = ()) -> dict[str, Any]:
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}.") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read the file: {exc.strerror}.") from None
    base = data.pop("extends", None)
    if base is None:
        return data
    if not isinstance(base, str):
        raise ScenarioError(f"{path}: `extends` must be a scenario name or path (a string).")
    base_path = _resolve(base if not base.endswith(".toml") else path.parent / base)
    if base_path.resolve() in seen or base_path.resolve() == path.resolve():
        raise ScenarioError(f"{path}: `extends = '{base}'` makes a cycle.")
    merged = _read(base_path, seen + (path.resolve(),))
    for key in ("name", "title", "figures", "description", "notes", "claims", "figure"):
        merged.pop(key, None)  # metadata is never inherited
    return _merge(merged, data)


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


class _Ctx:
    def __init__(self, path: Path) -> None:
        self.path = path

    def err(self, where: str, msg: str) -> ScenarioError:
        return ScenarioError(f"{self.path}: [{where}] {msg}" if where else f"{self.path}: {msg}")

    def keys(self, table: dict[str, Any], allowed: set[str], where: str) -> None:
        if not isinstance(table, dict):
            raise self.err(where, f"must be a table; got {type(table).__name__}.")
        for key in table:
            if key not in allowed:
                raise self.err(
                    where,
                    f"unknown key '{key}'.{did_you_mean(key, allowed)} "
                    f"Allowed keys: {', '.join(sorted(allowed))}.",
                )

    def need(self, table: dict[str, Any], key: str, where: str) -> Any:
        if key not in table:
            raise self.err(where, f"missing key '{key}'.")
        return table[key]


def _tupled(value: Any) -> Any:
    if isinstance(value, list):
        return tuple(_tupled(v) for v in value)
    return value


def _fields(cls: type) -> set[str]:
    return {f.name for f in dataclasses.fields(cls) if f.init}


def _build(cls: type, kwargs: dict[str, Any], ctx: _Ctx, where: str):
    try:
        return cls(**{k: _tupled(v) for k, v in kwargs.items()})
    except (ConfigurationError, ExpressionError) as exc:
        raise ctx.err(where, str(exc)) from None
    except TypeError as exc:
        raise ctx.err(where, f"invalid value: {exc}.") from None


def _regressor(table: dict[str, Any], ctx: _Ctx, where: str):
    kind = ctx.need(table, "type", where)
    body = {k: v for k, v in table.items() if k != "type"}
    if kind == "fuzzy":
        ctx.keys(body, _fields(FuzzyBasis), where)
        return _build(FuzzyBasis, body, ctx, where)
    if kind == "linear":
        ctx.keys(body, _fields(LinearRegressor), where)
        return _build(LinearRegressor, body, ctx, where)
    raise ctx.err(
        where,
        f"unknown regressor type '{kind}'.{did_you_mean(kind, ['fuzzy', 'linear'])}"
        " Use 'fuzzy' or 'linear'.",
    )


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load and validate a scenario from the catalogue (by name) or from a TOML file.

    Raises
    ------
    ScenarioError
        With the file, table and key of the first problem and how to fix it.
    """
    path = _resolve(name_or_path)
    ctx = _Ctx(path)
    data = _read(path)
    ctx.keys(data, _TOP - {"extends"}, "")
    name = str(data.get("name", path.stem))
    # plant
    ptab = dict(ctx.need(data, "plant", ""))
    model = ctx.need(ptab, "model", "plant")
    if model not in PLANTS:
        raise ctx.err(
            "plant",
            f"unknown plant model '{model}'.{did_you_mean(model, PLANTS)} "
            f"Available: {', '.join(PLANTS)}.",
        )
    pcls = PLANTS[model]
    x0 = ptab.pop("initial_state", ())
    ptab.pop("model")
    ctx.keys(ptab, _fields(pcls), "plant")
    plant = _build(pcls, ptab, ctx, "plant")
    # reference
    rtab = data.get("reference", {"outputs": ["0"] * plant.n_outputs})
    ctx.keys(rtab, {"outputs"}, "reference")
    outputs = ctx.need(rtab, "outputs", "reference")
    if isinstance(outputs, (str, int, float)):
        outputs = [outputs]
    # controller
    ctab = dict(ctx.need(data, "controller", ""))
    design = ctx.need(ctab, "design", "controller")
    allocation = ctab.pop("allocation", None)
    ctab.pop("design")
    if design == "none":
        ctx.keys(ctab, set(), "controller")
        ctrl = DirectAdaptive(regressor=LinearRegressor(inputs=(), bias=True), theta0=0.0)
        adapt = False
        if allocation is None:
            allocation = [[0.0] * plant.n_actuators for _ in range(plant.n_outputs)]
    else:
        if design not in DESIGNS:
            raise ctx.err(
                "controller",
                f"unknown design '{design}'."
                f"{did_you_mean(design, DESIGNS)} Available: "
                f"{', '.join(list(DESIGNS) + ['none'])}.",
            )
        dcls = DESIGNS[design]
        adapt = bool(ctab.pop("adapt", True))
        if "regressor" not in ctab:
            raise ctx.err(
                "controller", "missing table [controller.regressor] (type = 'fuzzy' or 'linear')."
            )
        regs = ctab.pop("regressor")
        if isinstance(regs, list):
            if dcls is not MimoDirectAdaptive:
                raise ctx.err(
                    "controller.regressor",
                    "a list of regressors is only allowed for the 'mimo' design.",
                )
            reg = tuple(
                _regressor(r, ctx, f"controller.regressor.{i + 1}") for i, r in enumerate(regs)
            )
        else:
            reg = _regressor(regs, ctx, "controller.regressor")
        ctx.keys(ctab, _fields(dcls) - {"regressor"}, "controller")
        ctrl = _build(dcls, {**ctab, "regressor": reg}, ctx, "controller")
    if allocation is None:
        raise ctx.err(
            "controller",
            "missing key 'allocation' (the matrix R of u = R^T u0, or "
            "the list of proportional gains b_j for a single-output plant).",
        )
    # failures
    failures = []
    ftabs = data.get("failures", [])
    if not isinstance(ftabs, list):
        raise ctx.err("failures", "write each failure as a [[failures]] table.")
    for i, ft in enumerate(ftabs):
        where = f"failures.{i + 1}"
        ft = dict(ft)
        fmodel = ctx.need(ft, "model", where)
        if fmodel not in FAILURE_MODELS:
            raise ctx.err(
                where,
                f"unknown failure model '{fmodel}'."
                f"{did_you_mean(fmodel, FAILURE_MODELS)} Available: "
                f"{', '.join(FAILURE_MODELS)}.",
            )
        fcls = FAILURE_MODELS[fmodel]
        ft.pop("model")
        ctx.keys(ft, _fields(fcls), where)
        ctx.need(ft, "actuator", where)
        failures.append(_build(fcls, ft, ctx, where))
    # solver
    stab = data.get("solver", {})
    ctx.keys(stab, _fields(SolverOptions), "solver")
    solver = _build(SolverOptions, stab, ctx, "solver")
    duration = ctx.need(data, "duration", "")
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
        ),
        ctx,
        "",
    )
    # resolve every expression and regressor input now, so nothing half-runs
    try:
        from adaptive_ftc.sim.assemble import assemble

        assemble(loop, sdot=solver.sdot, filter_tau=solver.filter_tau)
    except (ConfigurationError, ExpressionError) as exc:
        raise ctx.err("", str(exc)) from None
    claims = data.get("claims", [])
    figs = data.get("figure", [])
    if not isinstance(claims, list) or not isinstance(figs, list):
        raise ctx.err("", "write claims as [[claims]] and figures as [[figure]] tables.")
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
    )
