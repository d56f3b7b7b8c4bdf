"""Control activity of a recorded run: how hard and how fast the actuators are driven.

Tracking error alone cannot tell a good design from one that chatters: the thesis laws track
to 1e-4 rad on a 200 Hz digital controller while the elevator command chatters at 16 Hz with
0.43 rad RMS (issue 25). These metrics judge the command itself, per actuator, over a window
``[start, end]``:

``fast_rms``
    RMS of the command minus its zero-phase low-pass at ``f_c`` (a 4th-order Butterworth run
    forwards and backwards, :func:`scipy.signal.sosfiltfilt`, the record extended by its odd
    reflection over ``3 / f_c`` seconds at both ends): the command's content above ``f_c``.
    The record is filtered first (the window and ``MARGIN / f_c`` = 10 s at 1 Hz on each
    side, to the record's ends: the same number as filtering the whole record, to 1e-9) and the
    window cut afterwards: filtering the window alone adds edge transients that dominate small
    values.
``tv_per_s``
    Total variation of the command per second, ``sum |u[k+1] - u[k]| / (end - start)``.
``peak_rate``
    Largest ``|du/dt|`` of the command (finite differences of the records).
``rate_limited_fraction``, ``travel_limited_fraction``
    Fraction of the window's record intervals in which the actuator *position* moves at its
    rate limit (``|da/dt| >= (1 - 1e-3) r``), and of its records at a travel limit (within
    ``1e-3`` of the travel span of ``lower`` or ``upper``), using the limits in effect at that
    time (a :class:`~adaptive_ftc.faults.models.RateLimited` failure changes them); both are
    fractions of the whole window. ``nan`` when no such limit is in effect anywhere in it.
``peak_command``, ``travel``, ``peak_command_travel_ratio``
    Largest ``|u|`` in the window, the declared travel ``max(|lower|, |upper|)`` (``inf``: none
    declared) and their ratio (``0`` without travel).
``peak_to_peak``
    ``max u - min u`` of the command in the window.

Records
-------
The engine records on a uniform grid (``SolverOptions.record_dt``; a last sample at the end
time may sit closer). A grid whose spacing varies by more than 1e-6 of its median spacing
(e.g. results built by hand, or cut and joined) is resampled linearly onto the median spacing
first.

Aliasing rule
-------------
Content above the record's Nyquist frequency ``1 / (2 dt)`` folds into the judged band: a
10 ms record aliases the thesis law's 10-17 Hz chatter. The chatter these metrics judge lives
below 100 Hz (the actuator limit cycles of issue 25 are at 7-17 Hz; a digital controller puts
its steps at its own sample rate), so a record is *fine enough* when its spacing

.. math:: dt \\le \\min\\Big(1\\ \\mathrm{ms},\\ \\frac{1}{100 f_c},\\ \\frac{T_s}{5}\\Big)

with ``T_s`` the sample time of a digital controller (no term without one): at least ten
records per period of 100 Hz, a hundred per period of ``f_c``, five per controller sample.
:attr:`ActuatorActivity.record_ok` says whether it is; an ``activity`` claim refuses a record
that is not (:mod:`adaptive_ftc.claims`), and ``SimResult.metrics`` reports the flag beside
the numbers (``activity_record_ok``).

Examples
--------
>>> import numpy as np
>>> t = np.arange(0, 20.0001, 1e-3)
>>> u = 0.1 * np.sin(2 * np.pi * 0.2 * t) + 0.01 * np.sin(2 * np.pi * 10 * t)
>>> a = command_activity(t, u[:, None], ("u",), start=5.0, end=15.0)["u"]
>>> round(float(a.fast_rms / (0.01 / np.sqrt(2))), 3)
1.0
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptive_ftc.errors import ConfigurationError

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ftc.sim.result import SimResult

__all__ = [
    "ACTIVITY_FIELDS",
    "DEFAULT_F_C",
    "MAX_RECORD_DT",
    "ActuatorActivity",
    "activity",
    "actuator_limits_meta",
    "command_activity",
    "limits_of",
    "max_record_dt",
]

#: Default cut-off frequency (Hz) of the fast command content.
DEFAULT_F_C = 1.0
#: Largest record spacing (s) at which activity is judged whatever ``f_c`` (see the module's
#: aliasing rule).
MAX_RECORD_DT = 1e-3
#: Seconds x ``1 / f_c`` of record filtered on each side of the window (to the record's ends):
#: the fast content then equals that of the whole record filtered to 1e-9 (measured on the
#: hypersonic runs: 4e-11 relative at 1 Hz), at a fraction of the cost on long runs.
MARGIN = 10.0
#: Relative tolerance of "at a rate limit" / "at a travel limit".
LIMIT_TOL = 1e-3
_ORDER = 4  # Butterworth order of the low-pass


@dataclass(frozen=True)
class ActuatorActivity:
    """Control activity of one actuator over a window (see the module docstring)."""

    actuator: str
    start: float
    end: float
    f_c: float
    fast_rms: float
    tv_per_s: float
    peak_rate: float
    rate_limited_fraction: float
    travel_limited_fraction: float
    peak_command: float
    travel: float
    peak_command_travel_ratio: float
    peak_to_peak: float
    record_dt: float
    record_ok: bool

    def as_dict(self) -> dict[str, Any]:
        """The fields as a plain dict (for tables and JSON)."""
        return asdict(self)


#: The numeric fields of :class:`ActuatorActivity` that ``SimResult.metrics`` reports.
ACTIVITY_FIELDS: tuple[str, ...] = (
    "fast_rms",
    "tv_per_s",
    "peak_rate",
    "rate_limited_fraction",
    "travel_limited_fraction",
    "peak_command",
    "peak_command_travel_ratio",
    "peak_to_peak",
)


def max_record_dt(f_c: float = DEFAULT_F_C, sample_time: float = 0.0) -> float:
    """Largest record spacing (s) at which activity with cut-off ``f_c`` is judged:
    ``min(1 ms, 1 / (100 f_c), sample_time / 5)`` (the last term only for a digital
    controller, ``sample_time > 0``)."""
    dt = min(MAX_RECORD_DT, 1.0 / (100.0 * f_c))
    if sample_time > 0:
        dt = min(dt, sample_time / 5.0)
    return dt


def _check_f_c(f_c: float) -> float:
    if isinstance(f_c, bool) or not isinstance(f_c, (int, float)) or not math.isfinite(f_c):
        raise ConfigurationError(f"`f_c` (cut-off frequency, Hz) must be a number; got {f_c!r}.")
    if f_c <= 0:
        raise ConfigurationError(f"`f_c` (cut-off frequency, Hz) must be positive; got {f_c!r}.")
    return float(f_c)


def reductions_loaded() -> bool:
    """Whether this process has loaded the compiled reductions of :mod:`adaptive_ftc.sim.reduce`
    (a campaign does; one ``aftc run`` reduces with numpy rather than compile them, about 4 s
    on an empty cache, to save milliseconds)."""
    reduce = sys.modules.get("adaptive_ftc.sim.reduce")
    return reduce is not None and bool(reduce._error_stats.signatures)


def _uniform(t: np.ndarray, *signals: np.ndarray) -> tuple[np.ndarray, list[np.ndarray], float]:
    """``(t, signals, dt)`` on a uniform grid: as given when it is one (a last sample closer
    than ``dt`` is dropped), else resampled linearly onto the median spacing."""
    if t.size < 2:
        return t, list(signals), math.nan
    if reductions_loaded():
        from adaptive_ftc.sim.reduce import grid_spacing

        kind, dt = grid_spacing(t)  # one compiled pass: the common cases (the same dt, exactly)
        if kind == 0:
            return t, list(signals), dt
        if kind == 1:
            return t[:-1], [s[:-1] for s in signals], dt  # the engine's closer last record
    d = np.diff(t)
    if not np.all(d > 0):  # drop repeated times
        keep = np.concatenate(([True], d > 0))
        t = t[keep]
        signals = tuple(s[keep] for s in signals)
        d = np.diff(t)
    dt = float(np.median(d))
    if np.all(np.abs(d - dt) <= 1e-6 * dt):
        return t, list(signals), dt
    if np.all(np.abs(d[:-1] - dt) <= 1e-6 * dt) and d[-1] < dt:
        return t[:-1], [s[:-1] for s in signals], dt  # the engine's closer last record
    n = int(math.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
    grid = t[0] + dt * np.arange(n)
    out = []
    for s in signals:
        res = np.empty((n, s.shape[1]))
        for j in range(s.shape[1]):
            res[:, j] = np.interp(grid, t, s[:, j])
        out.append(res)
    return grid, out, dt


def _lowpass(u: np.ndarray, f_c: float, dt: float) -> np.ndarray | None:
    """Zero-phase Butterworth low-pass of each column; ``None`` when the record is too short
    for the filter's padding or ``f_c`` is at or above its Nyquist frequency (scipy's
    ``sosfiltfilt``, bit for bit, without importing scipy.signal: sim/zerophase.py)."""
    from adaptive_ftc.sim.zerophase import lowpass_design, sosfiltfilt_odd

    fs = 1.0 / dt
    if not f_c < 0.5 * fs:
        return None
    sos, zi = lowpass_design(_ORDER, f_c, fs)
    if u.shape[0] <= 3 * (2 * len(sos) + 1):
        return None
    # odd extension (value and slope continue through the ends) over three time constants of
    # the filter: scipy's default 27 samples leave an end transient of 2e-3 rad on the ideal
    # hypersonic run's 0.3 rad, 0.03 Hz command at 1 ms records (the final window ends at the
    # record's end); three periods of f_c leave 7e-6
    pad = min(u.shape[0] - 1, max(3 * (2 * len(sos) + 1), math.ceil(3.0 / (f_c * dt))))
    return sosfiltfilt_odd(sos, zi, u, pad)


def command_activity(
    t: np.ndarray,
    u: np.ndarray,
    names: Sequence[str],
    *,
    start: float | None = None,
    end: float | None = None,
    f_c: float = DEFAULT_F_C,
    position: np.ndarray | None = None,
    limits: Mapping[str, Any] | None = None,
    sample_time: float = 0.0,
) -> dict[str, ActuatorActivity]:
    """Activity of commands ``u`` (time, actuator) recorded at times ``t``.

    Parameters
    ----------
    t, u, names
        Record times, commands (one column per actuator) and the actuators' names.
    start, end
        The judged window (default: the whole record).
    f_c
        Cut-off frequency (Hz) of the fast content.
    position
        Actuator positions (time, actuator) for the rate- and travel-limit fractions
        (default: the commands).
    limits
        Declared actuator limits as :func:`actuator_limits_meta` writes them (``None``: none).
    sample_time
        Sample time of a digital controller (0: continuous), for the aliasing rule.

    Returns
    -------
    dict
        Actuator name -> :class:`ActuatorActivity`, in the order of ``names``.
    """
    f_c = _check_f_c(f_c)
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float).reshape(t.size, -1)
    pos = u if position is None else np.asarray(position, dtype=float).reshape(t.size, -1)
    if u.shape[1] != len(names):
        raise ConfigurationError(
            f"command_activity: {u.shape[1]} command columns but {len(names)} actuator names."
        )
    grid, (u, pos), dt = _uniform(t, u, pos)
    lo_t = grid[0] if grid.size and start is None else (start if start is not None else 0.0)
    hi_t = grid[-1] if grid.size and end is None else (end if end is not None else 0.0)
    # the window's records: a span of rows (the grid increases), [i0, i1)
    i0 = int(np.searchsorted(grid, lo_t - 1e-9, side="left"))
    i1 = max(i0, int(np.searchsorted(grid, hi_t + 1e-9, side="right")))
    # (_uniform's grid increases: it drops repeated times and resamples an uneven record)
    span = float(hi_t - lo_t)
    n_win = i1 - i0
    ok = bool(math.isfinite(dt) and dt <= max_record_dt(f_c, sample_time) * (1 + 1e-9))
    # the record around the window, MARGIN / f_c seconds on each side (or to its ends), is
    # filtered, then the window cut
    a = int(np.searchsorted(grid, lo_t - MARGIN / f_c - 1e-9)) if grid.size else 0
    b = int(np.searchsorted(grid, hi_t + MARGIN / f_c + 1e-9, side="right")) if grid.size else 0
    part = u[a:b]
    lp = None  # the low-pass over the window's rows
    if grid.size >= 2 and n_win and np.all(np.isfinite(part)):
        low = _lowpass(part, f_c, dt)
        if low is not None:
            lp = low[i0 - a : i1 - a]
    # the limits in effect over the window's records only
    rate, lower, upper = _limits_at(grid[i0:i1], limits, u.shape[1])
    out: dict[str, ActuatorActivity] = {}
    for j, name in enumerate(names):
        uj, pj = np.ascontiguousarray(u[i0:i1, j]), pos[i0:i1, j]  # uj: as u[idx, j] was
        if n_win < 2:
            nan = math.nan
            fast = tv = prate = rfrac = tfrac = peak = p2p = nan
        else:
            fast = float(np.sqrt(np.mean((uj - lp[:, j]) ** 2))) if lp is not None else math.nan
            du = np.diff(uj)
            tv = float(np.sum(np.abs(du)) / span) if span > 0 else math.nan
            prate = float(np.max(np.abs(du)) / dt)
            peak = float(np.max(np.abs(uj)))
            p2p = float(np.max(uj) - np.min(uj))
            r = rate[:-1, j]
            limited = np.isfinite(r)
            if limited.any():
                moving = np.abs(np.diff(pj)) / dt
                at_rate = limited & (moving >= (1 - LIMIT_TOL) * np.where(limited, r, 0.0))
                rfrac = float(np.mean(at_rate))  # over every interval of the window
            else:
                rfrac = math.nan
            lo, hi = lower[:, j], upper[:, j]
            bounded = np.isfinite(lo) | np.isfinite(hi)
            if bounded.any():
                width = np.where(np.isfinite(hi - lo), hi - lo, np.maximum(np.abs(lo), np.abs(hi)))
                width = np.where(np.isfinite(width), width, 1.0)
                tol = LIMIT_TOL * width
                at = (pj >= hi - tol) | (pj <= lo + tol)
                tfrac = float(np.mean(at & bounded))  # over every record of the window
            else:
                tfrac = math.nan
        travel = _travel(limits, j)
        ratio = peak / travel if math.isfinite(travel) and travel > 0 else 0.0
        out[name] = ActuatorActivity(
            actuator=str(name),
            start=float(lo_t),
            end=float(hi_t),
            f_c=f_c,
            fast_rms=fast,
            tv_per_s=tv,
            peak_rate=prate,
            rate_limited_fraction=rfrac,
            travel_limited_fraction=tfrac,
            peak_command=peak,
            travel=travel,
            peak_command_travel_ratio=ratio,
            peak_to_peak=p2p,
            record_dt=dt,
            record_ok=ok,
        )
    return out


def _travel(limits: Mapping[str, Any] | None, j: int) -> float:
    """Declared travel ``max(|lower|, |upper|)`` of actuator ``j`` (``inf``: none)."""
    if not limits:
        return math.inf
    base = limits.get("declared", {})
    lo = [float(v) for v in base.get("lower", ())]
    hi = [float(v) for v in base.get("upper", ())]
    if j >= len(lo) or j >= len(hi):
        return math.inf
    return max(abs(lo[j]), abs(hi[j]))


def _limits_at(grid: np.ndarray, limits: Mapping[str, Any] | None, m: int):
    """Rate, lower and upper limit per (record, actuator) from the segments of
    :func:`actuator_limits_meta` (``inf`` where none)."""
    shape = (grid.size, m)
    rate = np.full(shape, math.inf)
    lower = np.full(shape, -math.inf)
    upper = np.full(shape, math.inf)
    for seg in (limits or {}).get("segments", ()):
        at = grid >= float(seg["start"]) - 1e-9
        for arr, key in ((rate, "rate"), (lower, "lower"), (upper, "upper")):
            vals = np.array([float(v) for v in seg[key]], dtype=float)
            arr[at] = vals[None, :]
    return rate, lower, upper


def actuator_limits_meta(loop: Any, asm: Any) -> dict[str, Any] | None:
    """The declared actuator limits of a loop for ``SimResult.meta["actuator_limits"]``:
    ``declared`` (rate, lower, upper per actuator) and ``segments`` (from each ``start`` time
    on, the limits in effect: a dynamics failure changes them); JSON-able (``inf`` as
    ``"inf"``). ``None`` for ideal actuators (no :class:`~adaptive_ftc.hardware.Actuators`,
    no dynamics failure)."""
    from adaptive_ftc.hardware import Actuators

    if not loop.has_actuator_dynamics:
        return None
    m = loop.plant.n_actuators
    base = (loop.actuators or Actuators()).table(m)
    # (interval, actuator, [rate, lower, upper]); a digital loop has one interval per sample
    table = np.asarray(asm.data.act)[:, :, 1:4]
    bps = asm.breakpoints
    changed = np.flatnonzero(np.any(table[1:] != table[:-1], axis=(1, 2))) + 1
    segments = [
        {
            "start": float(bps[k]),
            "rate": [_num(v) for v in table[k, :, 0]],
            "lower": [_num(v) for v in table[k, :, 1]],
            "upper": [_num(v) for v in table[k, :, 2]],
        }
        for k in (0, *changed.tolist())
    ]
    return {
        "declared": {
            "rate": [_num(v) for v in base[:, 1]],
            "lower": [_num(v) for v in base[:, 2]],
            "upper": [_num(v) for v in base[:, 3]],
        },
        "segments": segments,
    }


def _num(v: float) -> float | str:
    v = float(v)
    return v if math.isfinite(v) else repr(v)


def actuator_positions(loop: Any, asm: Any, Y: np.ndarray, phases: np.ndarray, u_cmd):
    """Actuator positions per record: the position state of an actuator with dynamics (a lag
    or a natural frequency in that interval), else the command clipped to its travel.
    ``None`` for ideal actuators (no actuator states)."""
    if not loop.has_actuator_dynamics or not asm.extra_names:
        return None
    names = tuple(asm.extra_names)
    if not names[0].startswith("position of "):
        return None
    m = loop.plant.n_actuators
    at = Y.shape[1] - len(names)
    state = Y[:, at : at + m]
    act = np.asarray(asm.data.act)  # (interval, actuator, [tau, rate, lower, upper, omega, .])
    dynamic = (act[:, :, 0] > 0) | (act[:, :, 4] > 0)
    if dynamic.all():  # the usual case: every position is a state (a view, as the states)
        return state
    ph = np.asarray(phases, dtype=np.int64)
    clipped = np.minimum(np.maximum(u_cmd, act[ph, :, 2]), act[ph, :, 3])
    return np.where(dynamic[ph], state, clipped)


def activity(
    result: SimResult,
    start: float | None = None,
    end: float | None = None,
    *,
    f_c: float = DEFAULT_F_C,
) -> dict[str, ActuatorActivity]:
    """Activity of a run's commands per actuator over ``[start, end]`` (default: the whole
    run); see :func:`command_activity` and the module docstring."""
    limits = limits_of(result)
    return command_activity(
        result.time,
        result.u_cmd,
        result.actuator_names,
        start=start,
        end=end,
        f_c=f_c,
        position=getattr(result, "actuator_position", None),
        limits=limits,
        sample_time=float(result.meta.get("sample_time") or 0.0),
    )


def _floats(value: Any) -> Any:
    """``"inf"``/``"-inf"`` strings (JSON) back to floats, recursively."""
    if isinstance(value, dict):
        return {k: _floats(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_floats(v) for v in value]
    if isinstance(value, str) and value in ("inf", "-inf", "nan"):
        return float(value)
    return value


def limits_of(result: Any) -> dict[str, Any] | None:
    """``result.meta["actuator_limits"]`` with its limits as floats (``None``: no declared
    actuators), also when read back from a file (JSON text, ``"inf"`` strings)."""
    limits = result.meta.get("actuator_limits")
    if isinstance(limits, str):
        limits = json.loads(limits)
    return _floats(limits) if limits else None
