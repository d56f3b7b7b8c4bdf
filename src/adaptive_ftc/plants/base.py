"""The plant interface shared by the thesis plants."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from adaptive_ftc.errors import ConfigurationError

__all__ = ["Plant"]


@dataclass(frozen=True, kw_only=True)
class Plant(ABC):
    """A redundant-actuator plant ``x' = f(t, x, u^f)`` whose outputs have relative degree 2.

    Each output ``y_i`` is a state (``position_index[i]``) whose derivative is another state
    (``velocity_index[i]``), as in every plant of the thesis. ``u^f`` is the vector of the
    actuators' applied (possibly failed) outputs.
    """

    name: ClassVar[str]
    state_names: ClassVar[tuple[str, ...]]
    output_names: ClassVar[tuple[str, ...]]
    position_index: ClassVar[tuple[int, ...]]
    velocity_index: ClassVar[tuple[int, ...]]

    @property
    def n_states(self) -> int:
        """Number of plant states."""
        return len(self.state_names)

    @property
    def n_outputs(self) -> int:
        """Number of controlled outputs."""
        return len(self.position_index)

    @property
    @abstractmethod
    def n_actuators(self) -> int:
        """Number of (redundant) actuators."""

    @property
    def actuator_names(self) -> tuple[str, ...]:
        """Actuator labels, numbered from 1 as in the thesis."""
        return tuple(f"u{j + 1}" for j in range(self.n_actuators))

    @abstractmethod
    def parameter_values(self) -> tuple:
        """The plant's numbers as a NamedTuple (passed to :attr:`equations` as ``p``)."""

    #: The dynamics ``equations(t, x, u, p, xdot)``: plain Python in the subset numba compiles,
    #: writing ``dx/dt`` into ``xdot`` for applied actuator outputs ``u`` and parameters ``p``.
    equations: ClassVar[Callable]
    #: Units of the states (CF style), for labelled results.
    units: ClassVar[tuple[str, ...]] = ()
    #: Unit of the actuator outputs.
    actuator_units: ClassVar[str] = "1"
    #: Physical envelope: largest plausible ``|x_i|`` per state (``inf``: none). A run whose
    #: recorded state leaves it is reported as diverged, as a non-finite state is.
    envelope: ClassVar[tuple[float, ...]] = ()

    def dynamics_source(self, g) -> str:
        """Code generation hook: make ``plant_dynamics`` available in the generated loop.

        The default imports :attr:`equations`; a plant written as expressions returns the text
        of its generated function instead.
        """
        if not callable(getattr(self, "equations", None)):
            raise ConfigurationError(
                f"Plant class {type(self).__name__} defines no `equations(t, x, u, p, xdot)`: "
                "give it one (see adaptive_ftc.plants.pendulum for a complete plant), or use "
                "CustomPlant / the @plant decorator."
            )
        # bounds-checked unless the equations are the library's own (a CustomPlant's are the
        # user's function, although the class is the library's)
        module = getattr(self.equations, "__module__", None) or ""
        checked = not module.startswith("adaptive_ftc.")
        g.use("plant_dynamics", self.equations, checked=checked)
        return ""

    def input_gains(self, t: float = 0.0, x=None) -> np.ndarray:
        """``d(rate of output i)/d u_j`` at ``(t, x)`` (default: the zero state), shape
        ``(outputs, actuators)``: the sign of each actuator's effect (conditions (2.16), (4.6))."""
        x = np.zeros(self.n_states) if x is None else np.asarray(x, dtype=float)
        u = np.zeros(self.n_actuators)
        f0 = self.evaluate(t, x.copy(), u.copy())
        out = np.zeros((self.n_outputs, self.n_actuators))
        for j in range(self.n_actuators):
            du = u.copy()
            du[j] = 1.0
            f1 = self.evaluate(t, x.copy(), du)
            out[:, j] = (f1 - f0)[list(self.velocity_index)]
        return out

    def evaluate(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``dx/dt`` by running :attr:`equations` as plain Python (no compilation); used by
        :func:`~adaptive_ftc.plants.check_plant`."""
        xdot = np.full(self.n_states, np.nan)
        f = getattr(self.equations, "py_func", self.equations)
        f(float(t), x, u, self.parameter_values(), xdot)
        return xdot

    def derivative(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """State derivative for applied actuator outputs ``u``.

        ``x`` has shape ``(..., n_states)`` and ``u`` shape ``(..., n_actuators)``; leading batch
        axes broadcast. Returns an array of shape ``(..., n_states)``.
        """
        x = np.asarray(x, dtype=float)
        u = np.asarray(u, dtype=float)
        if x.shape[-1:] != (self.n_states,):
            raise ConfigurationError(
                f"x must have {self.n_states} entries on its last axis for plant '{self.name}' "
                f"({', '.join(self.state_names)}); got shape {x.shape}."
            )
        if u.shape[-1:] != (self.n_actuators,):
            raise ConfigurationError(
                f"u must have {self.n_actuators} entries on its last axis for plant "
                f"'{self.name}'; got shape {u.shape}."
            )
        shape = np.broadcast_shapes(x.shape[:-1], u.shape[:-1])
        xb = np.ascontiguousarray(np.broadcast_to(x, shape + x.shape[-1:]).reshape(-1, x.shape[-1]))
        ub = np.ascontiguousarray(np.broadcast_to(u, shape + u.shape[-1:]).reshape(-1, u.shape[-1]))
        params = self.parameter_values()
        f = _compiled(self.equations)
        out = np.zeros_like(xb)
        for i in range(xb.shape[0]):
            f(float(t), xb[i], ub[i], params, out[i])
        return out.reshape(shape + (self.n_states,))

    def aliases(self) -> dict[str, int]:
        """Names usable in expressions for each state: ``x1..xn`` and the state names."""
        names = {f"x{i + 1}": i for i in range(self.n_states)}
        for i, name in enumerate(self.state_names):
            names.setdefault(name, i)
        return names


_COMPILED: dict[Callable, Callable] = {}


def _compiled(func: Callable) -> Callable:
    """``func`` jitted once per process (in memory; loops have their own cached copies)."""
    if func not in _COMPILED:
        import numba

        _COMPILED[func] = numba.njit(error_model="numpy")(getattr(func, "py_func", func))
    return _COMPILED[func]


def require_finite(owner: str, **values: object) -> None:
    """Raise a ConfigurationError naming any non-finite numeric parameter."""
    for key, value in values.items():
        arr = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(arr)):
            raise ConfigurationError(f"`{key}` of {owner} must be finite; got {value}.")
