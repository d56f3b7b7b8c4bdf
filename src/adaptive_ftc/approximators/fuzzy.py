"""Fuzzy logic system regressor (thesis §2.3.4, §3.4.1)."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from adaptive_ftc.errors import ConfigurationError

__all__ = ["FuzzyBasis"]


@dataclass(frozen=True, kw_only=True)
class FuzzyBasis:
    """Grid fuzzy logic system with Gaussian memberships and product inference.

    One rule per combination of membership functions; the regressor is the vector of rule
    firing strengths ``xi_l(z) = prod_i mu_i(z_i)``, normalised by their sum when
    ``normalised`` is true (the thesis does not say which; both are offered, SPEC §4).
    Memberships are ``mu(z) = exp(-(z - c)^2 / (2 w^2))``: the thesis's
    ``exp(-(z - c)^2)`` is ``w = 1/sqrt(2)``; its ``exp(-((z - c)/0.6)^2 / 2)`` is ``w = 0.6``.

    Parameters
    ----------
    inputs
        Names of the controller signals fed to the FLS (``"x1"``, ``"e"``, ``"edot2"``, ...).
    centers
        Centers per input (one tuple per input), or one tuple used for every input.
    width
        Gaussian width ``w`` (one number for all memberships).
    normalised
        Normalise the firing strengths (default) or use raw products.

    Examples
    --------
    >>> fls = FuzzyBasis(inputs=("x1", "x2"), centers=(-1.0, 0.0, 1.0), width=0.7071)
    >>> fls.size
    9
    >>> round(float(fls([0.0, 0.0]).sum()), 12)
    1.0
    """

    inputs: tuple[str, ...]
    centers: tuple[tuple[float, ...], ...] | tuple[float, ...]
    width: float = 2**-0.5
    normalised: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "inputs", tuple(str(i) for i in self.inputs))
        if not self.inputs:
            raise ConfigurationError("`inputs` of FuzzyBasis must name at least one signal.")
        cen = self.centers
        if len(cen) and all(np.ndim(c) == 0 for c in cen):
            cen = tuple(tuple(float(c) for c in cen) for _ in self.inputs)
        else:
            cen = tuple(tuple(float(v) for v in c) for c in cen)
        if len(cen) != len(self.inputs) or any(len(c) == 0 for c in cen):
            raise ConfigurationError(
                f"`centers` of FuzzyBasis must give at least one center per input "
                f"({len(self.inputs)} inputs); got {self.centers!r}."
            )
        if not np.all(np.isfinite(np.concatenate([np.asarray(c) for c in cen]))):
            raise ConfigurationError("`centers` of FuzzyBasis must be finite numbers.")
        object.__setattr__(self, "centers", cen)
        if not (np.isfinite(self.width) and self.width > 0):
            raise ConfigurationError(f"`width` of FuzzyBasis must be positive; got {self.width}.")
        if self.size > 100_000:
            raise ConfigurationError(
                f"FuzzyBasis would have {self.size} rules; use fewer inputs or memberships."
            )

    @property
    def size(self) -> int:
        """Number of rules (= parameters)."""
        return int(np.prod([len(c) for c in self.centers]))

    def __call__(self, z) -> np.ndarray:
        """Firing strengths for inputs ``z`` of shape ``(..., n_inputs)``; rules last.

        Rule order: the last input's membership index varies fastest.
        """
        z = np.asarray(z, dtype=float)
        if z.shape[-1:] != (len(self.inputs),):
            raise ConfigurationError(
                f"FuzzyBasis expects {len(self.inputs)} inputs on the last axis; got shape "
                f"{z.shape}."
            )
        mus = [
            np.exp(-((z[..., i, None] - np.asarray(c)) ** 2) / (2 * self.width**2))
            for i, c in enumerate(self.centers)
        ]
        rules = []
        for combo in itertools.product(*(range(len(c)) for c in self.centers)):
            prod = np.ones(z.shape[:-1])
            for i, l in enumerate(combo):
                prod = prod * mus[i][..., l]
            rules.append(prod)
        out = np.stack(rules, axis=-1)
        if self.normalised:
            out = out / out.sum(axis=-1, keepdims=True)
        return out
