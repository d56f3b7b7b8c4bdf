"""Imports on first use (PEP 562) for a package's ``__init__``: one ``__getattr__`` and
``__dir__`` pair, shared by ``adaptive_ftc``, ``adaptive_ftc.campaigns`` and
``adaptive_ftc.export``, so that the ``aftc`` command line can build its parser without
importing numpy, pandas or the compiler."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_attributes(
    namespace: dict[str, Any], lazy: Mapping[str, str], *, submodules: bool = False
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``(__getattr__, __dir__)`` of the package whose ``globals()`` is ``namespace``.

    ``__getattr__(name)`` imports ``name`` from the module ``lazy[name]`` on first use and
    caches it in ``namespace``; with ``submodules``, any other name not starting with ``__``
    is tried as a submodule (``adaptive_ftc.plots``), as if ``__init__`` had imported it
    eagerly. ``__dir__()`` lists ``namespace`` and its ``__all__``."""
    package = namespace["__name__"]

    def __getattr__(name: str) -> Any:
        module = lazy.get(name)
        if module is not None:
            value = getattr(importlib.import_module(module), name)
        elif submodules and not name.startswith("__"):
            try:
                value = importlib.import_module(f"{package}.{name}")
            except ModuleNotFoundError as exc:
                if exc.name != f"{package}.{name}":
                    raise
                raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(namespace["__all__"]))

    return __getattr__, __dir__
