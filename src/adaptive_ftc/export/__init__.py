"""Exports of a closed loop's controller beyond Python: a C99 library (:func:`export_c`) and
an FMI 2.0 co-simulation FMU built from it (:func:`export_fmu`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from adaptive_ftc._lazy import lazy_attributes

if TYPE_CHECKING:
    from adaptive_ftc.export.c import ExportedC, export_c
    from adaptive_ftc.export.fmu import ExportedFMU, export_fmu

#: ``{public name: module that defines it}``: imported on first use (PEP 562), so that the
#: ``aftc`` command line can build its parser without importing numpy, pandas or the compiler
_LAZY: dict[str, str] = {
    "ExportedC": "adaptive_ftc.export.c",
    "export_c": "adaptive_ftc.export.c",
    "ExportedFMU": "adaptive_ftc.export.fmu",
    "export_fmu": "adaptive_ftc.export.fmu",
}

__all__ = ["ExportedC", "ExportedFMU", "export_c", "export_fmu"]


__getattr__, __dir__ = lazy_attributes(globals(), _LAZY)
