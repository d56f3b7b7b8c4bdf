"""SI units of the signals of each plant, for figure axes, claim values and reports.

Units follow the plant modules: angles in rad (the wing-rock aileron deflections too: the gains
``b_j`` of (2.101) are per rad), rates in rad/s, torques in N·m, wheel momenta in N·m·s and the
flexible spacecraft's modal coordinates ``eta`` in √kg·m (the coupling matrix ``delta`` of
(3.67) is in √kg·m, so ``delta^T w'`` is in 1/s^2 per unit of ``eta``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["PLANT_UNITS", "actuator_unit", "output_unit", "rate_unit", "state_unit"]

#: plant -> (output position, output rate, actuator signal)
PLANT_UNITS: dict[str, tuple[str, str, str]] = {
    "hypersonic": ("rad", "rad/s", "rad"),
    "wingrock": ("rad", "rad/s", "rad"),
    "manipulator": ("rad", "rad/s", "N·m"),
    "spacecraft": ("rad", "rad/s", "N·m"),
}

_STATE_PREFIX_UNITS: tuple[tuple[str, str], ...] = (
    ("eta", "√kg·m"),
    ("h", "N·m·s"),
)


def _plant(meta: Mapping[str, Any]) -> str:
    return str(meta.get("plant", ""))


def output_unit(meta: Mapping[str, Any]) -> str:
    """Unit of the outputs (and tracking errors) of a run with this ``meta``; ``""`` if unknown."""
    return PLANT_UNITS.get(_plant(meta), ("", "", ""))[0]


def rate_unit(meta: Mapping[str, Any]) -> str:
    """Unit of the output rates (and rate errors); ``""`` if unknown."""
    return PLANT_UNITS.get(_plant(meta), ("", "", ""))[1]


def actuator_unit(meta: Mapping[str, Any]) -> str:
    """Unit of the actuator signals; ``""`` if unknown."""
    return PLANT_UNITS.get(_plant(meta), ("", "", ""))[2]


def state_unit(meta: Mapping[str, Any], name: str) -> str:
    """Unit of one plant state by name (``"eta1_dot"`` -> ``"√kg·m/s"``); ``""`` if unknown."""
    plant = _plant(meta)
    if plant not in PLANT_UNITS:
        return ""
    dot = name.endswith("_dot")
    base = name[: -len("_dot")] if dot else name
    if plant == "hypersonic" and name == "q":  # pitch rate
        return "rad/s"
    unit = "rad"
    if plant == "spacecraft":
        for prefix, u in _STATE_PREFIX_UNITS:
            if base.startswith(prefix) and base[len(prefix) :].isdigit():
                unit = u
                break
    return f"{unit}/s" if dot else unit
