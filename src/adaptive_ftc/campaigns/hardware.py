"""Hardware drawn per campaign member (issue 25 item 5): actuator lag, rate limit and travel,
the controller's sample time and sensor noise, from the spec's ``[hardware]`` table.

Each entry is a distribution as elsewhere in a spec (a number, ``{uniform = [a, b]}``, ...).
``lag``, ``rate_limit`` and ``travel`` take one distribution (one draw shared by every
actuator) or a list with one per actuator; ``noise`` is a table of standard deviations by
state name. The drawn values replace the matching settings of the base scenario's
:class:`~adaptive_ftc.hardware.Actuators` / :class:`~adaptive_ftc.hardware.Sensors` (the
others are kept); the sensor-noise seed is drawn per member. Drawn failures combine with them
(a rate-limited actuator can also stick).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptive_ftc.errors import ConfigurationError, did_you_mean
from adaptive_ftc.hardware import Actuators, Sensors

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ftc.campaigns.spec import Dist
    from adaptive_ftc.sim.system import ClosedLoop

__all__ = ["HARDWARE_KEYS", "HardwareSpec", "parse_hardware"]

#: Keys of the ``[hardware]`` table: what each sets and the smallest allowed value.
HARDWARE_KEYS: dict[str, str] = {
    "lag": "first-order lag time constant of each actuator (s, >= 0; 0 = none)",
    "rate_limit": "rate limit of each actuator (actuator units per second, > 0)",
    "travel": "position limit of each actuator, +/- travel (actuator units, > 0)",
    "sample_time": "controller sample time (s, >= 0; 0 = continuous)",
    "noise": "table of sensor-noise standard deviations by state name (>= 0)",
}
_PER_ACTUATOR = ("lag", "rate_limit", "travel")


@dataclass(frozen=True)
class HardwareSpec:
    """The drawn hardware of a campaign: a :class:`Dist` per setting (``None``: the base
    scenario's) and the noise per measured state (state index, name, distribution)."""

    lag: Dist | None = None
    rate_limit: Dist | None = None
    travel: Dist | None = None
    sample_time: Dist | None = None
    noise: tuple[tuple[int, str, Dist], ...] = ()

    def columns(self, m: int) -> list[str]:
        """Names of the table columns of the drawn values, in draw order."""
        cols = []
        for key in _PER_ACTUATOR:
            d = getattr(self, key)
            if d is not None:
                cols += _names(f"hw_{key}", d, m)
        if self.sample_time is not None:
            cols.append("hw_sample_time")
        cols += [f"noise_{name}" for _, name, _ in self.noise]
        return cols

    def draw(self, rng: np.random.Generator, loop: ClosedLoop) -> tuple[ClosedLoop, dict]:
        """Draw the member's hardware (in the order lag, rate limit, travel, sample time,
        noise per state in spec order, noise seed) and return its loop and table columns."""
        m = loop.plant.n_actuators
        cols: dict[str, Any] = {}
        act: dict[str, Any] = {}
        for key in _PER_ACTUATOR:
            d = getattr(self, key)
            if d is None:
                continue
            v = d.draw(rng)
            vals = tuple(float(x) for x in v) if isinstance(v, tuple) else (float(v),) * m
            names = _names(f"hw_{key}", d, m)
            cols.update(zip(names, vals[: len(names)], strict=True))
            if key == "lag":
                act["tau"] = vals
            elif key == "rate_limit":
                act["rate"] = vals
            else:
                act["lower"], act["upper"] = tuple(-x for x in vals), vals
        changes: dict[str, Any] = {}
        if act:
            changes["actuators"] = dataclasses.replace(loop.actuators or Actuators(), **act)
        if self.sample_time is not None:
            changes["sample_time"] = cols["hw_sample_time"] = float(self.sample_time.draw(rng))
        if self.noise:
            noise = {}
            for _, name, d in self.noise:
                noise[name] = cols[f"noise_{name}"] = float(d.draw(rng))
            seed = int(rng.integers(0, 2**63 - 1))
            changes["sensors"] = _with_noise(loop.sensors, noise, seed)
        return (dataclasses.replace(loop, **changes) if changes else loop), cols

    def extremes(self) -> list[dict[str, float]]:
        """The settings at each end of every distribution (to build them at validation)."""
        base = {k: _lo(getattr(self, k)) for k in (*_PER_ACTUATOR, "sample_time")}
        base.update({f"noise:{name}": _lo(d) for _, name, d in self.noise})
        cases = [base]
        for k in (*_PER_ACTUATOR, "sample_time"):
            d = getattr(self, k)
            if d is not None:
                cases.append({**base, k: _hi(d)})
        for _, name, d in self.noise:
            cases.append({**base, f"noise:{name}": _hi(d)})
        return cases

    def apply_extreme(self, case: dict[str, Any], loop: ClosedLoop) -> ClosedLoop:
        """``loop`` with the hardware of one :meth:`extremes` case (noise seed 0)."""
        m = loop.plant.n_actuators
        act: dict[str, Any] = {}

        def per(v):
            return tuple(float(x) for x in v) if isinstance(v, tuple) else (float(v),) * m

        if case["lag"] is not None:
            act["tau"] = per(case["lag"])
        if case["rate_limit"] is not None:
            act["rate"] = per(case["rate_limit"])
        if case["travel"] is not None:
            vals = per(case["travel"])
            act["lower"], act["upper"] = tuple(-x for x in vals), vals
        changes: dict[str, Any] = {}
        if act:
            changes["actuators"] = dataclasses.replace(loop.actuators or Actuators(), **act)
        if case["sample_time"] is not None:
            changes["sample_time"] = float(case["sample_time"])
        noise = {k[6:]: float(v) for k, v in case.items() if k.startswith("noise:")}
        if noise:
            changes["sensors"] = _with_noise(loop.sensors, noise, 0)
        return dataclasses.replace(loop, **changes) if changes else loop


def _with_noise(sensors: Sensors | None, noise: dict[str, float], seed: int) -> Sensors:
    """The base sensors with the drawn noise of some states (the others keep theirs)."""
    base = sensors or Sensors()
    old = base.noise
    if isinstance(old, tuple):  # one number per state: by alias, so drawn names override
        old = {f"x{i + 1}": float(v) for i, v in enumerate(old)}
    return dataclasses.replace(base, noise={**old, **noise}, seed=seed)


def _names(prefix: str, d: Dist, m: int) -> list[str]:
    if d.kind == "vector":
        return [f"{prefix}_{j + 1}" for j in range(m)]
    return [prefix]


def _lo(d: Dist | None) -> Any:
    return None if d is None else d.support()[0]


def _hi(d: Dist) -> Any:
    return d.support()[-1]


def parse_hardware(
    table: Any, loop: ClosedLoop, solver: Any, problems: list[str], parse_dist
) -> HardwareSpec | None:
    """Validate the ``[hardware]`` table against the base loop; record problems.

    Every setting is checked for its domain, then the base loop is built with the hardware at
    each end of every distribution and its run size checked, so that an impossible member is
    refused now, not in the middle of the campaign.
    """
    if table is None:
        return None
    if not isinstance(table, dict):
        problems.append(
            f"[hardware] must be a table such as {{lag = {{uniform = [0, 0.05]}}}}; got "
            f"{type(table).__name__}."
        )
        return None
    for key in table:
        if key not in HARDWARE_KEYS:
            problems.append(
                f"[hardware] unknown key {key!r}.{did_you_mean(str(key), HARDWARE_KEYS)} Allowed "
                + "; ".join(f"`{k}`: {v}" for k, v in HARDWARE_KEYS.items())
                + "."
            )
    m = loop.plant.n_actuators
    n_before = len(problems)
    dists: dict[str, Any] = {}
    for key in (*_PER_ACTUATOR, "sample_time"):
        if key not in table:
            continue
        vector = key in _PER_ACTUATOR
        d = parse_dist(table[key], f"hardware.{key}", problems, vector=vector, bounded=True)
        if d.kind == "vector" and len(d.args) != m:
            problems.append(
                f"[hardware.{key}] gives {len(d.args)} distributions; plant "
                f"'{loop.plant.name}' has {m} actuators: give one per actuator or a single one."
            )
            continue
        values = [v for e in d.support() for v in (e if isinstance(e, tuple) else (e,))]
        strict = key in ("rate_limit", "travel")
        bad = [v for v in values if not isinstance(v, (int, float)) or v < 0 or (strict and v == 0)]
        if bad:
            problems.append(f"[hardware.{key}] {HARDWARE_KEYS[key]}; the range reaches {bad[0]}.")
            continue
        dists[key] = d
    noise = []
    nt = table.get("noise", {})
    if not isinstance(nt, dict):
        problems.append(
            f"[hardware.noise] must be a table by state name, e.g. noise = {{"
            f"{loop.plant.state_names[0]} = {{uniform = [0, 1e-3]}}}}; got {type(nt).__name__}."
        )
        nt = {}
    aliases = loop.plant.aliases()
    for name, v in nt.items():
        if name not in aliases:
            problems.append(
                f"[hardware.noise] unknown state {name!r}.{did_you_mean(str(name), aliases)} "
                f"States: {', '.join(loop.plant.state_names)}."
            )
            continue
        d = parse_dist(v, f"hardware.noise.{name}", problems, bounded=True)
        if any(not isinstance(x, (int, float)) or x < 0 for x in d.support()):
            problems.append(
                f"[hardware.noise.{name}] a standard deviation must be >= 0; the range reaches "
                f"{min(d.support())}."
            )
            continue
        noise.append((aliases[name], str(name), d))
    if len(problems) > n_before:
        return None
    spec = HardwareSpec(**dists, noise=tuple(noise))
    from adaptive_ftc.sim.budget import check_run_size

    seen = set()
    for case in spec.extremes():
        try:
            check_run_size(spec.apply_extreme(case, loop), solver)
        except (ConfigurationError, ValueError, TypeError) as exc:
            msg = str(exc)
            if msg not in seen:
                seen.add(msg)
                shown = {k: v for k, v in case.items() if v is not None}
                problems.append(f"[hardware] impossible draw {shown}: {msg}")
    return spec
