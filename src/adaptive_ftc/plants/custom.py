"""Bring your own plant: from Python code (:class:`CustomPlant`, :func:`plant`) or from
equations written as expressions (:class:`ExpressionPlant`, the ``model = "equations"`` plant
of scenario files). :func:`check_plant` checks what the designs assume before anything runs.
"""

from __future__ import annotations

import inspect
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from adaptive_ftc.errors import ConfigurationError, ExpressionError
from adaptive_ftc.plants.base import Plant

__all__ = ["CustomPlant", "ExpressionPlant", "check_plant", "plant"]

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_RESERVED = {"t", "u", "e", "pi", "edot", "s"}


def _names(owner: str, key: str, values: Any, *, allow_empty: bool = False) -> tuple[str, ...]:
    if isinstance(values, str) or not isinstance(values, (tuple, list)):
        raise ConfigurationError(f"`{key}` of {owner} must be a list of names; got {values!r}.")
    out = tuple(values)
    if not out and not allow_empty:
        raise ConfigurationError(f"`{key}` of {owner} needs at least one name.")
    for v in out:
        if not isinstance(v, str) or not _NAME.match(v) or v in _RESERVED:
            raise ConfigurationError(
                f"`{key}` of {owner}: {v!r} is not a usable name (letters, digits and _, not "
                f"starting with a digit, and none of {', '.join(sorted(_RESERVED))})."
            )
    dup = sorted({v for v in out if out.count(v) > 1})
    if dup:
        raise ConfigurationError(f"`{key}` of {owner} repeats {', '.join(dup)}.")
    return out


def _outputs(owner: str, outputs: Any, states: tuple[str, ...]) -> tuple[tuple[int, ...], ...]:
    """``{output state: its rate state}`` -> (position_index, velocity_index)."""
    if not isinstance(outputs, Mapping) or not outputs:
        raise ConfigurationError(
            f"`outputs` of {owner} must map each output state to the state that is its rate, "
            f"e.g. {{'{states[0]}': '{states[-1]}'}}; got {outputs!r}."
        )
    pos, vel = [], []
    for out, rate in outputs.items():
        for what, name in (("output", out), ("rate", rate)):
            if name not in states:
                from adaptive_ftc.errors import did_you_mean

                raise ConfigurationError(
                    f"`outputs` of {owner}: {what} {name!r} is not a state."
                    f"{did_you_mean(str(name), states)} States: {', '.join(states)}."
                )
        if out == rate:
            raise ConfigurationError(
                f"`outputs` of {owner}: output {out!r} cannot be its own rate; the designs need "
                "relative degree 2 (y' is a state whose derivative the actuators drive)."
            )
        pos.append(states.index(out))
        vel.append(states.index(rate))
    if len(set(pos)) != len(pos):
        raise ConfigurationError(f"`outputs` of {owner} names an output twice.")
    return tuple(pos), tuple(vel)


def _set_names(p: CustomPlant | ExpressionPlant, owner: str, states, acts, pos, vel) -> None:
    """Check the units and store the validated names and output indices on plant ``p``."""
    if p.units and len(p.units) != len(states):
        raise ConfigurationError(
            f"`units` of {owner} needs one unit per state ({len(states)}); got {len(p.units)}."
        )
    object.__setattr__(p, "state_names", states)
    object.__setattr__(p, "actuators", acts)
    object.__setattr__(p, "output_names", tuple(states[i] for i in pos))
    object.__setattr__(p, "position_index", pos)
    object.__setattr__(p, "velocity_index", vel)
    object.__setattr__(p, "outputs", dict(p.outputs))


class _NamedPlant(Plant):
    """Shared by the user plants: actuators are given by name."""

    actuators: tuple[str, ...]

    @property
    def n_actuators(self) -> int:
        return len(self.actuators)

    @property
    def actuator_names(self) -> tuple[str, ...]:
        return self.actuators


@dataclass(frozen=True, kw_only=True)
class CustomPlant(_NamedPlant):
    """A plant given by your own Python function.

    Parameters
    ----------
    name
        Label used in results and messages.
    states
        State names, in the order of ``x``.
    outputs
        Each controlled output state mapped to the state that is its rate, e.g.
        ``{"theta": "omega"}``: the designs assume relative degree 2 (``y' = x_rate`` and the
        actuators act on ``x_rate'``).
    actuators
        Actuator names, in the order of ``u``.
    equations
        ``f(t, x, u, p, xdot)`` writing ``dx/dt`` into ``xdot``: plain Python using scalars,
        indexing and :mod:`math`, which numba compiles into the closed loop. ``u`` holds the
        actuators' applied (possibly failed) outputs.
    params
        The numbers ``p`` passed to ``equations``: a :class:`typing.NamedTuple` instance (read
        as ``p.mass``); numbers are data, so changing them never recompiles.
    units
        Units of the states (optional).

    A function defined in ``__main__`` or a notebook cannot be cached on disk: its loops are
    compiled in memory each session (a second or two); put it in a module to cache it.

    Examples
    --------
    >>> from typing import NamedTuple
    >>> class P(NamedTuple):
    ...     k: float
    >>> def spring(t, x, u, p, xdot):
    ...     xdot[0] = x[1]
    ...     xdot[1] = -p.k * x[0] + u[0] + u[1]
    >>> mass = CustomPlant(name="mass", states=("pos", "vel"), outputs={"pos": "vel"},
    ...                    actuators=("f1", "f2"), equations=spring, params=P(k=2.0))
    >>> mass.derivative(0.0, [1.0, 0.0], [0.5, 0.5]).tolist()
    [0.0, -1.0]
    """

    name: str = "custom"
    states: tuple[str, ...] = ()
    outputs: Mapping[str, str] = field(default_factory=dict)
    actuators: tuple[str, ...] = ()
    equations: Callable = None  # type: ignore[assignment]
    params: tuple = ()
    units: tuple[str, ...] = ()
    actuator_units: str = "1"

    def __post_init__(self) -> None:
        owner = f"plant '{self.name}'"
        states = _names(owner, "states", self.states)
        acts = _names(owner, "actuators", self.actuators)
        pos, vel = _outputs(owner, self.outputs, states)
        f = self.equations
        py = getattr(f, "py_func", f)
        if not callable(py):
            raise ConfigurationError(
                f"`equations` of {owner} must be a function f(t, x, u, p, xdot); got {f!r}."
            )
        try:
            n_args = len(inspect.signature(py).parameters)
        except (TypeError, ValueError):
            n_args = 5
        if n_args != 5:
            raise ConfigurationError(
                f"`equations` of {owner} must take (t, x, u, p, xdot) and write dx/dt into xdot; "
                f"{getattr(py, '__name__', py)!r} takes {n_args} argument(s)."
            )
        if not isinstance(self.params, tuple) or (
            self.params and not hasattr(self.params, "_fields")
        ):
            raise ConfigurationError(
                f"`params` of {owner} must be a typing.NamedTuple instance (read as p.name in "
                f"the equations); got {type(self.params).__name__}."
            )
        for k, v in zip(getattr(self.params, "_fields", ()), self.params, strict=False):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigurationError(
                    f"parameter `{k}` of {owner} must be a finite number; got {v!r}."
                )
        _set_names(self, owner, states, acts, pos, vel)
        check_plant(self)

    def parameter_values(self) -> tuple:
        return self.params

    def __hash__(self) -> int:
        return hash((self.name, self.states, self.actuators, id(self.equations), self.params))


def plant(
    *,
    states,
    outputs: Mapping[str, str],
    actuators,
    params: tuple = (),
    name: str | None = None,
    units: tuple[str, ...] = (),
) -> Callable[[Callable], CustomPlant]:
    """Decorator: turn ``f(t, x, u, p, xdot)`` into a :class:`CustomPlant`.

    Examples
    --------
    >>> @plant(states=("pos", "vel"), outputs={"pos": "vel"}, actuators=("f1", "f2", "f3"))
    ... def cart(t, x, u, p, xdot):
    ...     xdot[0] = x[1]
    ...     xdot[1] = -0.5 * x[1] + u[0] + u[1] + u[2]
    >>> cart.n_actuators
    3
    """

    def wrap(func: Callable) -> CustomPlant:
        return CustomPlant(
            name=name or str(getattr(func, "__name__", "custom")),
            states=tuple(states),
            outputs=outputs,
            actuators=tuple(actuators),
            equations=func,
            params=params,
            units=tuple(units),
        )

    return wrap


@dataclass(frozen=True, kw_only=True)
class ExpressionPlant(_NamedPlant):
    """A plant whose equations are expressions of the safe language (scenario files).

    ``dynamics`` maps every state to its derivative, written with the state names, the
    actuator names (their applied outputs), the ``parameters`` by name and ``t``. Parameter
    values and the numbers in the equations are data of the compiled loop.

    Examples
    --------
    >>> p = ExpressionPlant(name="pendulum", states=("theta", "omega"),
    ...     outputs={"theta": "omega"}, actuators=("m1", "m2"),
    ...     parameters={"a": 9.81, "c": 0.1},
    ...     dynamics={"theta": "omega", "omega": "-a*sin(theta) - c*omega + m1 + m2"})
    >>> p.derivative(0.0, [0.0, 1.0], [0.5, 0.5]).round(3).tolist()
    [1.0, 0.9]
    """

    name: str = "equations"
    states: tuple[str, ...] = ()
    outputs: dict[str, str] = field(default_factory=dict)
    actuators: tuple[str, ...] = ()
    parameters: dict[str, float] = field(default_factory=dict)
    dynamics: dict[str, str] = field(default_factory=dict)
    units: tuple[str, ...] = ()
    actuator_units: str = "1"

    def __post_init__(self) -> None:
        from adaptive_ftc.expressions import Expression

        owner = f"plant '{self.name}'"
        states = _names(owner, "states", self.states)
        acts = _names(owner, "actuators", self.actuators)
        pos, vel = _outputs(owner, self.outputs, states)
        if not isinstance(self.parameters, Mapping):
            raise ConfigurationError(
                f"`parameters` of {owner} must be a table of name = number; got "
                f"{self.parameters!r}."
            )
        pnames = _names(owner, "parameters", list(self.parameters), allow_empty=True)
        clash = sorted(
            set(states) & set(acts) | set(states) & set(pnames) | set(acts) & set(pnames)
        )
        if clash:
            raise ConfigurationError(
                f"{owner}: {', '.join(clash)} used for more than one of states, actuators and "
                "parameters; give each its own name."
            )
        for k, v in self.parameters.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigurationError(
                    f"parameter `{k}` of {owner} must be a finite number; got {v!r}."
                )
        if not isinstance(self.dynamics, Mapping):
            raise ConfigurationError(
                f"`dynamics` of {owner} must be a table with one expression per state."
            )
        missing = [s for s in states if s not in self.dynamics]
        extra = [s for s in self.dynamics if s not in states]
        if missing or extra:
            parts = []
            if missing:
                parts.append(f"no equation for {', '.join(missing)}")
            if extra:
                parts.append(f"{', '.join(map(str, extra))} is not a state")
            raise ConfigurationError(
                f"`dynamics` of {owner}: {'; '.join(parts)}. Give exactly one expression per "
                f"state ({', '.join(states)})."
            )
        variables = ("t", *states, *acts, *pnames)
        exprs = {}
        for s in states:
            try:
                exprs[s] = Expression(
                    self.dynamics[s], variables, context=f"the equation of {s}' of {owner}"
                )
            except ExpressionError as exc:
                raise ConfigurationError(str(exc)) from None
        _set_names(self, owner, states, acts, pos, vel)
        object.__setattr__(self, "parameters", {k: float(v) for k, v in self.parameters.items()})
        object.__setattr__(self, "_exprs", exprs)
        check_plant(self)

    def _layout(self) -> tuple[list[str], list[float]]:
        """Generated assignments and the numbers they read (parameters, then literals)."""
        from adaptive_ftc.sim import codegen

        names = {"t": "t"}
        names.update({s: f"x[{i}]" for i, s in enumerate(self.state_names)})
        names.update({a: f"uf[{j}]" for j, a in enumerate(self.actuators)})
        consts = list(self.parameters.values())
        names.update({p: f"c[{k}]" for k, p in enumerate(self.parameters)})
        lines = []
        for i, s in enumerate(self.state_names):
            text = codegen.emit_at(self._exprs[s].node, names, consts)
            lines.append(f"    xdot[{i}] = {text}  # d{s}/dt")
        return lines, consts

    def parameter_values(self) -> np.ndarray:
        return np.array(self._layout()[1], dtype=float)

    def dynamics_source(self, g) -> str:
        lines, _ = self._layout()
        return "\n".join(
            [
                "@inl",
                "def plant_dynamics(t, x, uf, c, xdot):",
                f'    """Equations of plant {self.name!r} (from the scenario file)."""',
                *lines,
            ]
        )

    def evaluate(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        env: dict[str, Any] = {"t": float(t)}
        env.update({s: x[..., i] for i, s in enumerate(self.state_names)})
        env.update({a: u[..., j] for j, a in enumerate(self.actuators)})
        env.update(self.parameters)
        with np.errstate(all="ignore"):
            return np.array([float(self._exprs[s](**env)) for s in self.state_names])

    def derivative(self, t: float, x, u) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        if x.ndim == 1 and u.ndim == 1:
            return self.evaluate(t, x, u)
        shape = np.broadcast_shapes(x.shape[:-1], u.shape[:-1])
        xb = np.broadcast_to(x, shape + x.shape[-1:]).reshape(-1, x.shape[-1])
        ub = np.broadcast_to(u, shape + u.shape[-1:]).reshape(-1, u.shape[-1])
        out = np.array([self.evaluate(t, a, b) for a, b in zip(xb, ub, strict=True)])
        return out.reshape(shape + (self.n_states,))

    def __hash__(self) -> int:
        return hash((self.name, self.states, self.actuators))


def check_plant(p: Plant, *, samples: int = 4, seed: int = 0) -> None:
    """Check a plant against what every design assumes, with one clear error per problem.

    Runs the plant's equations (as Python, uncompiled) at a few random states and inputs and
    checks: ``xdot`` fully written with finite numbers of the right shape, ``x`` and ``u`` not
    modified, every output of relative degree 2 (its derivative is its rate state, with no
    direct actuator effect) and some actuator driving each output's rate. Raises
    :class:`~adaptive_ftc.errors.ConfigurationError`.
    """
    owner = f"plant '{p.name}'"
    rng = np.random.default_rng(seed)
    n, m = p.n_states, p.n_actuators
    evaluate = p.evaluate
    gains = np.zeros((len(p.position_index), m))
    for k in range(samples):
        x = np.zeros(n) if k == 0 else rng.uniform(-0.5, 0.5, n)
        u = np.zeros(m) if k == 0 else rng.uniform(-0.5, 0.5, m)
        x_in, u_in = x.copy(), u.copy()
        try:
            f0 = np.asarray(evaluate(0.0, x_in, u_in), dtype=float)
        except IndexError as exc:
            raise ConfigurationError(
                f"The equations of {owner} index outside x ({n} states), u ({m} actuators) or "
                f"xdot: {exc}. Check the state and actuator counts."
            ) from None
        except Exception as exc:
            raise ConfigurationError(
                f"The equations of {owner} failed at x = {x.round(3).tolist()}, u = "
                f"{u.round(3).tolist()}: {type(exc).__name__}: {exc}."
            ) from None
        if not (np.array_equal(x_in, x) and np.array_equal(u_in, u)):
            raise ConfigurationError(
                f"The equations of {owner} modify their inputs x or u; write only into xdot."
            )
        if f0.shape != (n,) or not np.all(np.isfinite(f0)):
            bad = [p.state_names[i] for i in range(min(n, f0.size)) if not np.isfinite(f0[i])]
            raise ConfigurationError(
                f"The equations of {owner} must write a finite dx/dt for every state; "
                + (
                    f"{', '.join(bad)} not written or not finite"
                    if bad
                    else f"got shape {f0.shape}"
                )
                + f" at x = {x.round(3).tolist()}, u = {u.round(3).tolist()}."
            )
        for a, b in zip(p.position_index, p.velocity_index, strict=True):
            if not math.isclose(f0[a], x[b], rel_tol=1e-9, abs_tol=1e-12):
                raise ConfigurationError(
                    f"Output '{p.state_names[a]}' of {owner} must have relative degree 2: its "
                    f"derivative must be the state '{p.state_names[b]}', got "
                    f"{f0[a]:.6g} where '{p.state_names[b]}' = {x[b]:.6g}. Declare the output's "
                    "rate state in `outputs`."
                )
        for j in range(m):
            du = np.zeros(m)
            du[j] = 1e-3
            f1 = np.asarray(evaluate(0.0, x.copy(), u + du), dtype=float)
            for i, (a, b) in enumerate(zip(p.position_index, p.velocity_index, strict=True)):
                if abs(f1[a] - f0[a]) > 1e-12 * max(1.0, abs(f0[a])):
                    raise ConfigurationError(
                        f"Actuator '{p.actuator_names[j]}' acts directly on output "
                        f"'{p.state_names[a]}' of {owner}: the designs need relative degree 2 "
                        f"(actuators act on the rate '{p.state_names[b]}' only)."
                    )
                gains[i, j] = max(gains[i, j], abs(f1[b] - f0[b]) / 1e-3)
    for i, b in enumerate(p.velocity_index):
        if not np.any(gains[i] > 1e-12):
            raise ConfigurationError(
                f"No actuator of {owner} drives '{p.state_names[b]}' (the rate of output "
                f"'{p.output_names[i]}'): that output cannot be controlled."
            )
