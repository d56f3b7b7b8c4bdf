"""Approximators (regressors ``Pi(z)``): fuzzy logic systems and linear regressors."""

from adaptive_ftc.approximators.fuzzy import FuzzyBasis
from adaptive_ftc.approximators.linear import LinearRegressor

Regressor = FuzzyBasis | LinearRegressor

__all__ = ["FuzzyBasis", "LinearRegressor", "Regressor"]
