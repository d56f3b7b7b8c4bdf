"""SI units of the signals of each plant: the one place where units are spelled.

Every unit is written in the UDUNITS style that CF files need (``"rad s-1"``, ``"rad s-2"``,
``"N m"``, ``"N m s"``: products with spaces, negative integer powers); :func:`display` turns one
into the typographic form of figure axes, claim values and reports (``"rad/s"``, ``"N·m"``).

Units follow the plant modules: angles in rad (the wing-rock aileron deflections too: the gains
``b_j`` of (2.101) are per rad), rates in rad s-1, torques in N m, wheel momenta in N m s and the
flexible spacecraft's modal coordinates ``eta`` in √kg·m: in (3.66)-(3.67) ``delta eta''`` is a
torque (kg m2 s-2) and ``eta'' = ... - delta^T w'``, so ``eta`` and ``delta`` share one unit whose
square is kg m2. UDUNITS has no fractional powers, so that unit is spelled :data:`SQRT_KG_M`
(``"sqrt(kg) m"``) here and a netCDF file states it in the variable's ``units_note`` instead of
its ``units`` attribute (:func:`cf_unit_attrs`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

__all__ = [
    "PLANT_UNITS",
    "SQRT_KG_M",
    "actuator_unit",
    "cf_unit_attrs",
    "display",
    "output_unit",
    "per_second",
    "rate_unit",
    "state_unit",
    "udunits",
]

#: The unit of the spacecraft's modal coordinates (√kg·m), which UDUNITS cannot express.
SQRT_KG_M = "sqrt(kg) m"

#: plant -> (output position, output rate, actuator signal), UDUNITS style
PLANT_UNITS: dict[str, tuple[str, str, str]] = {
    "hypersonic": ("rad", "rad s-1", "rad"),
    "wingrock": ("rad", "rad s-1", "rad"),
    "manipulator": ("rad", "rad s-1", "N m"),
    "spacecraft": ("rad", "rad s-1", "N m"),
    "pendulum": ("rad", "rad s-1", "N m"),
}

#: plant -> its rate states whose names do not end in ``_dot`` (tests/test_registry.py checks
#: every state's unit against the plant's own ``units``)
_RATE_STATES: dict[str, tuple[str, ...]] = {"hypersonic": ("q",), "pendulum": ("omega",)}

_STATE_PREFIX_UNITS: tuple[tuple[str, str], ...] = (
    ("eta", SQRT_KG_M),
    ("h", "N m s"),
)

#: older spellings (plant classes, user plants) -> UDUNITS
_ALIASES = {
    "rad/s": "rad s-1",
    "rad/s^2": "rad s-2",
    "rad/s2": "rad s-2",
    "rad s-1 s-1": "rad s-2",
    "N·m": "N m",
    "Nm": "N m",
    "N·m·s": "N m s",
    "Nms": "N m s",
    "√kg·m": SQRT_KG_M,
    "√kg·m/s": f"{SQRT_KG_M} s-1",
}

_TOKEN = re.compile(r"^(.*?)(-?\d+)?$")
_SUPERSCRIPT = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")


def _plant(meta: Mapping[str, Any]) -> str:
    return str(meta.get("plant", ""))


def _split(unit: str) -> list[tuple[str, int]]:
    """``"rad s-2"`` -> ``[("rad", 1), ("s", -2)]`` (a ``sqrt(kg)`` token keeps power 1)."""
    out: list[tuple[str, int]] = []
    for tok in unit.split():
        m = _TOKEN.match(tok)
        base, power = (m.group(1), m.group(2)) if m else (tok, None)
        if not base:  # a bare number ("1")
            base, power = tok, None
        out.append((base, int(power) if power else 1))
    return out


def _join(parts: list[tuple[str, int]]) -> str:
    merged: dict[str, int] = {}
    for base, power in parts:
        merged[base] = merged.get(base, 0) + power
    toks = [b if p == 1 else f"{b}{p}" for b, p in merged.items() if p != 0]
    return " ".join(toks) or "1"


def udunits(unit: str) -> str:
    """``unit`` in the UDUNITS style of this package (``"rad/s"`` -> ``"rad s-1"``); a unit
    already in that style, or unknown, comes back unchanged; ``""`` stays ``""``."""
    unit = unit.strip()
    if unit in _ALIASES:
        return _ALIASES[unit]
    unit = unit.replace("**", "").replace("^", "")  # "m/s^2" -> "m/s2"
    if unit in _ALIASES:
        return _ALIASES[unit]
    if "/" in unit and "(" not in unit:
        num, _, den = unit.partition("/")
        parts = _split(num.replace("·", " ")) + [(b, -p) for b, p in _split(den.replace("·", " "))]
        return _join([(b, p) for b, p in parts if b != "1"])
    return unit.replace("·", " ")


def per_second(unit: str) -> str:
    """The unit of the time derivative of a quantity in ``unit`` (``"rad s-1"`` ->
    ``"rad s-2"``, ``"1"`` -> ``"s-1"``)."""
    unit = udunits(unit)
    if unit in ("", "1"):
        return "s-1"
    return _join(_split(unit) + [("s", -1)])


def display(unit: str) -> str:
    """The typographic form of a UDUNITS ``unit`` for figures and reports: ``"rad s-1"`` ->
    ``"rad/s"``, ``"rad s-2"`` -> ``"rad/s²"``, ``"N m s"`` -> ``"N·m·s"``, ``"sqrt(kg) m"`` ->
    ``"√kg·m"``."""
    unit = udunits(unit)
    if not unit:
        return ""
    num, den = [], []
    for base, power in _split(unit):
        base = "√kg" if base == "sqrt(kg)" else base
        if power > 0:
            num.append(base if power == 1 else f"{base}{str(power).translate(_SUPERSCRIPT)}")
        else:
            den.append(base if power == -1 else f"{base}{str(-power).translate(_SUPERSCRIPT)}")
    text = "·".join(num) or "1"
    return f"{text}/{'·'.join(den)}" if den else text


def cf_unit_attrs(unit: str) -> dict[str, str]:
    """The netCDF attributes that state ``unit``: ``{"units": ...}`` in UDUNITS style, or, for
    a unit UDUNITS cannot express (√kg·m), ``{"units_note": ...}`` with no ``units`` (CF readers
    would otherwise parse ``kg0.5`` as a factor of 0.5)."""
    unit = udunits(unit) or "1"
    if "sqrt(" in unit:
        return {
            "units_note": (
                f"{display(unit)} ({unit}): a mass-normalised modal coordinate; UDUNITS has no "
                "fractional powers, so this variable has no 'units' attribute"
            )
        }
    return {"units": unit}


def output_unit(meta: Mapping[str, Any]) -> str:
    """Unit of the outputs (and tracking errors) of a run with this ``meta``, for display;
    ``""`` if unknown."""
    return display(PLANT_UNITS.get(_plant(meta), ("", "", ""))[0])


def rate_unit(meta: Mapping[str, Any]) -> str:
    """Unit of the output rates (and rate errors), for display; ``""`` if unknown."""
    return display(PLANT_UNITS.get(_plant(meta), ("", "", ""))[1])


def actuator_unit(meta: Mapping[str, Any]) -> str:
    """Unit of the actuator signals, for display; ``""`` if unknown."""
    return display(PLANT_UNITS.get(_plant(meta), ("", "", ""))[2])


def state_unit(meta: Mapping[str, Any], name: str) -> str:
    """Unit of one plant state by name, for display (``"eta1_dot"`` -> ``"√kg·m/s"``); ``""``
    if unknown."""
    plant = _plant(meta)
    if plant not in PLANT_UNITS:
        return ""
    dot = name.endswith("_dot")
    base = name[: -len("_dot")] if dot else name
    if name in _RATE_STATES.get(plant, ()):  # a rate whose name does not end in _dot
        return display("rad s-1")
    unit = "rad"
    if plant == "spacecraft":
        for prefix, u in _STATE_PREFIX_UNITS:
            if base.startswith(prefix) and base[len(prefix) :].isdigit():
                unit = u
                break
    return display(per_second(unit) if dot else unit)
