"""The plant interface shared by the thesis plants."""

from __future__ import annotations

from abc import ABC, abstractmethod
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
    kind: ClassVar[int]
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
    def parameter_vector(self) -> np.ndarray:
        """Numeric parameters in the order the compiled kernel expects."""

    def derivative(self, t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """State derivative for applied actuator outputs ``u``.

        ``x`` has shape ``(..., n_states)`` and ``u`` shape ``(..., n_actuators)``; leading batch
        axes broadcast. Returns an array of shape ``(..., n_states)``.
        """
        from adaptive_ftc.sim.kernel import plant_derivative_alloc

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
        params = self.parameter_vector()
        out = np.empty_like(xb)
        for i in range(xb.shape[0]):
            out[i] = plant_derivative_alloc(
                self.kind, params, self.n_states, float(t), xb[i], ub[i]
            )
        return out.reshape(shape + (self.n_states,))

    def aliases(self) -> dict[str, int]:
        """Names usable in expressions for each state: ``x1..xn`` and the state names."""
        names = {f"x{i + 1}": i for i in range(self.n_states)}
        for i, name in enumerate(self.state_names):
            names.setdefault(name, i)
        return names


def require_finite(owner: str, **values: object) -> None:
    """Raise a ConfigurationError naming any non-finite numeric parameter."""
    for key, value in values.items():
        arr = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(arr)):
            raise ConfigurationError(f"`{key}` of {owner} must be finite; got {value}.")
