"""Linear-in-the-signals regressors (thesis §2.4.4 ``[1, e, e']``, §3.4.2 ``[1, s_i, x^T]``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from adaptive_ftc.errors import ConfigurationError

__all__ = ["LinearRegressor"]


@dataclass(frozen=True, kw_only=True)
class LinearRegressor:
    """Regressor ``Pi(z) = [1, z_1, ..., z_k]`` (or without the leading 1).

    Examples
    --------
    >>> LinearRegressor(inputs=("e", "edot")).size
    3
    >>> LinearRegressor(inputs=("e", "edot"))([0.5, -1.0]).tolist()
    [1.0, 0.5, -1.0]
    """

    inputs: tuple[str, ...]
    bias: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "inputs", tuple(str(i) for i in self.inputs))
        if not self.inputs and not self.bias:
            raise ConfigurationError("LinearRegressor needs at least one input or `bias=True`.")

    @property
    def size(self) -> int:
        """Number of parameters."""
        return len(self.inputs) + int(self.bias)

    def emit(self, g, inputs: list[int], off: int, r: int) -> list[str]:
        """Generated code writing ``[1, z_1, ..., z_k]`` into ``phi[off:off+size]``."""
        lines = [
            f"    # linear regressor {r + 1}: "
            f"[{'1, ' if self.bias else ''}{', '.join(self.inputs)}]"
        ]
        j = off
        if self.bias:
            lines.append(f"    phi[{j}] = 1.0")
            j += 1
        for i in inputs:
            lines.append(f"    phi[{j}] = sig[{i}]")
            j += 1
        return lines

    def __call__(self, z) -> np.ndarray:
        """Regressor for inputs ``z`` of shape ``(..., n_inputs)``."""
        z = np.asarray(z, dtype=float)
        if z.shape[-1:] != (len(self.inputs),):
            raise ConfigurationError(
                f"LinearRegressor expects {len(self.inputs)} inputs on the last axis; got "
                f"shape {z.shape}."
            )
        if not self.bias:
            return z.copy()
        return np.concatenate([np.ones(z.shape[:-1] + (1,)), z], axis=-1)
