"""Scenario files, the safe expression language and the thesis catalogue.

The loader is imported lazily so that the expression language (used by the failure models and
designs) does not pull in the whole package.
"""

from __future__ import annotations

from typing import Any

__all__ = ["CATALOG", "Scenario", "list_scenarios", "load_scenario"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from adaptive_ftc.scenarios import loader

        return getattr(loader, name)
    raise AttributeError(f"module 'adaptive_ftc.scenarios' has no attribute '{name}'")
