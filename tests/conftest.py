"""Shared test helpers."""

from __future__ import annotations

import numpy as np


def assert_close(actual, expected, *, atol: float, rtol: float = 0.0, what: str = "") -> None:
    """The one closeness check of the suite, with an explicit absolute tolerance."""
    np.testing.assert_allclose(actual, expected, atol=atol, rtol=rtol, err_msg=what)
