"""Exports of a closed loop's controller beyond Python: a C99 library (:func:`export_c`)."""

from adaptive_ftc.export.c import ExportedC, export_c

__all__ = ["ExportedC", "export_c"]
