"""Shared test helpers."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def load_script(name: str):
    """The module of ``scripts/<name>.py`` (registered in ``sys.modules`` under ``name``
    first: a script's dataclasses look their module up), loaded once per process."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def assert_close(actual, expected, *, atol: float, rtol: float = 0.0, what: str = "") -> None:
    """The one closeness check of the suite, with an explicit absolute tolerance."""
    np.testing.assert_allclose(actual, expected, atol=atol, rtol=rtol, err_msg=what)
