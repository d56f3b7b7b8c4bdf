"""Scenario files and the thesis catalogue (the expression language they use is in
:mod:`adaptive_ftc.expressions`; ``adaptive_ftc.scenarios.expressions`` still imports it).

The loader is imported lazily: importing this package does not import the whole library.
"""

from __future__ import annotations

from typing import Any

__all__ = ["CATALOG", "Scenario", "list_scenarios", "load_scenario"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from adaptive_ftc.scenarios import loader

        return getattr(loader, name)
    raise AttributeError(f"module 'adaptive_ftc.scenarios' has no attribute '{name}'")
