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
        Gaussian width ``w``: one number for all inputs, or one per input (inputs of different
        scales).
    normalised
        Normalise the firing strengths, or use raw products (default: the convention that
        reproduces the thesis's claims, see the README).

    Examples
    --------
    >>> fls = FuzzyBasis(inputs=("x1", "x2"), centers=(-1.0, 0.0, 1.0), width=0.7071)
    >>> fls.size
    9
    >>> round(float(fls([0.0, 0.0]).max()), 12)  # the rule centred at the origin fires fully
    1.0
    """

    inputs: tuple[str, ...]
    centers: tuple[tuple[float, ...], ...] | tuple[float, ...]
    width: float | tuple[float, ...] = 2**-0.5
    normalised: bool = False

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
        w = self.width
        if isinstance(w, bool) or not isinstance(w, (int, float)):
            try:
                w = tuple(float(v) for v in w)
            except (TypeError, ValueError):
                raise ConfigurationError(
                    f"`width` of FuzzyBasis must be a number or one number per input; got {w!r}."
                ) from None
            if len(w) != len(self.inputs):
                raise ConfigurationError(
                    f"`width` of FuzzyBasis gives {len(w)} widths for {len(self.inputs)} inputs; "
                    "give one number, or one per input."
                )
            object.__setattr__(self, "width", w)
        if not all(np.isfinite(v) and 1e-150 < v < 1e150 for v in self.widths):
            raise ConfigurationError(
                f"`width` of FuzzyBasis must be positive and finite (1e-150 to 1e150); got "
                f"{self.width}."
            )
        if self.size > 100_000:
            raise ConfigurationError(
                f"FuzzyBasis would have {self.size} rules; use fewer inputs or memberships."
            )

    @property
    def size(self) -> int:
        """Number of rules (= parameters)."""
        return int(np.prod([len(c) for c in self.centers]))

    def emit(self, g, inputs: list[int], off: int, r: int) -> list[str]:
        """Generated code writing the firing strengths (2.40) into ``phi[off:off+size]``.

        ``inputs`` are the indices of the input signals in ``sig``; the centres and spreads
        ``1/(2 w^2)`` go into the loop's numbers, the grid sizes into the code.
        """
        counts = [len(c) for c in self.centers]
        widths = self.widths
        kind = "normalised" if self.normalised else "raw"
        lines = [f"    # fuzzy basis {r + 1}: {' x '.join(map(str, counts))} rules, {kind} (2.40)"]
        mus = []
        for i, (n, c, w) in enumerate(zip(counts, self.centers, widths, strict=True)):
            k0 = len(g.centers)
            g.centers.extend(c)
            g.spread.extend([1.0 / (2.0 * w**2)] * n)
            m0 = g.n_mu
            g.n_mu += n
            mus.append(m0)
            lines += [
                f"    z = sig[{inputs[i]}]",
                f"    for l in range({n}):",
                f"        d = z - c[CEN + {k0} + l]",
                f"        mu[{m0} + l] = math.exp(-c[SPREAD + {k0} + l] * d * d)",
            ]
        lines.append(f"    i = {off}")
        indent = "    "
        prev = None
        for i, n in enumerate(counts):
            lines.append(f"{indent}for l{i} in range({n}):")
            indent += "    "
            cur = f"mu[{mus[i]} + l{i}]"
            if i == len(counts) - 1:
                val = cur if prev is None else f"{prev} * {cur}"
                lines += [f"{indent}phi[i] = {val}", f"{indent}i += 1"]
            else:
                lines.append(f"{indent}p{i} = {cur if prev is None else f'{prev} * {cur}'}")
                prev = f"p{i}"
        if self.normalised:
            lines += [
                "    total = 0.0",
                f"    for l in range({self.size}):",
                f"        total += phi[{off} + l]",
                f"    for l in range({self.size}):",
                f"        phi[{off} + l] = phi[{off} + l] / total if total > 1e-300 "
                f"else {1.0 / self.size!r}",
            ]
        return lines

    @property
    def widths(self) -> tuple[float, ...]:
        """Gaussian width of each input's memberships."""
        if isinstance(self.width, (int, float)):
            return (float(self.width),) * len(self.inputs)
        return tuple(float(w) for w in self.width)

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
            np.exp(-((z[..., i, None] - np.asarray(c)) ** 2) / (2 * w**2))
            for i, (c, w) in enumerate(zip(self.centers, self.widths, strict=True))
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
