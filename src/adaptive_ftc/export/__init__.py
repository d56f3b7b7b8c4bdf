"""Exports of a closed loop's controller beyond Python: a C99 library (:func:`export_c`) and
an FMI 2.0 co-simulation FMU built from it (:func:`export_fmu`)."""

from adaptive_ftc.export.c import ExportedC, export_c
from adaptive_ftc.export.fmu import ExportedFMU, export_fmu

__all__ = ["ExportedC", "ExportedFMU", "export_c", "export_fmu"]
