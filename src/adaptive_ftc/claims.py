"""Evaluate the thesis's claims (the ``[[claims]]`` tables of a scenario) on recorded runs.

The claim kinds and their keys are specified in ``docs/claims.md``. Every claim yields a
:class:`ClaimResult` with a verdict, the measured number with its unit and the threshold it was
held to, so that a report can show a failure honestly with its number.

Verdicts
--------
``PASS`` / ``FAIL``
    The recorded data support / contradict the claim.
``NOT EVALUATED``
    The judged window lies beyond the end of a run that completed but was shortened (quick
    mode): nothing was measured there, which is not a failure.
``NOT REPRODUCED``
    The claim carries ``not_reproduced = "<reason>"`` (the catalogue knows that our runs do not
    show it) and the data indeed contradict it: reported with the measured number and the
    reason, counted apart from FAIL. If such a claim passes, the verdict is PASS and the detail
    says that the note is stale.
``FINDING``
    The claim carries ``finding = "<name>"``: an expected, named finding of the project (e.g.
    "the thesis law chatters at 16 Hz under 200 Hz sampling"), judged like any claim. When
    the data contradict the claim it is reported as FINDING with its measured number and the
    name, never as PASS and never counted as FAIL (exit codes); if it passes, the verdict is
    PASS and the detail says that the finding no longer shows.

The thesis law beside a constraint-aware design
-----------------------------------------------
A scenario whose controller declares ``constraint_aware`` judges its claims on that design;
:func:`evaluate_thesis_law_claims` judges the same claims on the thesis law's companion run
(the option removed) and reports every claim it does not meet as FINDING, named by the claim's
``thesis_law_finding`` (e.g. "the thesis law chatters at 7-10 Hz behind a 20 ms lag"), never
as PASS and never as a FAIL of the exit codes. ``not_reproduced`` and ``finding`` belong to
the scenario's own run and are not applied to the companion.

Conventions
-----------
- "The last ``window`` seconds" ends at the scenario's duration (``duration=`` of
  :func:`evaluate_claims`, else ``result.meta["t_final"]``) and starts no earlier than the run's
  start (windows are never negative).
- A run that diverged before the end of a judged window FAILs.
- Tracking errors are judged per output; the measured number is the worst output.
- A window ``[a, b)`` "before ``time``" excludes ``time`` itself (the recorded sample at a
  failure time already shows the failed actuator).
- An ``activity`` claim judges the command of every actuator (or of ``actuators``) over the
  last ``window`` seconds (:mod:`adaptive_ftc.sim.activity`); it refuses (:class:`ClaimError`)
  a record too coarse for its cut-off frequency (the aliasing rule of that module).
- ``bounded`` holds the command and applied signals of an actuator with a declared travel
  (``Actuators(lower=..., upper=...)``) within that travel, the rest within ``bound``; the
  measured number is then the largest ``|.|`` relative to its own limit (threshold 1).
- ``baseline_ratio`` is held against the *best* (smallest RMS error) non-oracle baseline run
  given (fixed-gain, nominal inverse, frozen adaptation; :mod:`adaptive_ftc.baselines`); a
  diverged baseline counts as infinitely worse. The oracle's ratio is reported, not judged.

Examples
--------
>>> from adaptive_ftc import load_scenario                                 # doctest: +SKIP
>>> sc = load_scenario("hypersonic-direct-s1")                             # doctest: +SKIP
>>> from adaptive_ftc.baselines import run_baselines                       # doctest: +SKIP
>>> r, base = sc.run(), run_baselines(sc)                                  # doctest: +SKIP
>>> for c in evaluate_claims(sc.claims, r, baselines=base):                # doctest: +SKIP
...     print(c.verdict, c.kind, c.measured, c.unit, c.threshold)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptive_ftc._units import actuator_unit, output_unit, rate_unit, state_unit
from adaptive_ftc.errors import did_you_mean

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ftc.sim.result import SimResult

__all__ = [
    "CLAIM_KINDS",
    "FAIL",
    "FINDING",
    "NOT_EVALUATED",
    "NOT_REPRODUCED",
    "PASS",
    "THESIS_LAW_FINDING",
    "VERDICTS",
    "ClaimError",
    "ClaimResult",
    "evaluate_claim",
    "evaluate_claims",
    "evaluate_thesis_law_claims",
    "thesis_law_claim",
    "unjudged_activity",
]

PASS = "PASS"
FAIL = "FAIL"
NOT_EVALUATED = "NOT EVALUATED"
NOT_REPRODUCED = "NOT REPRODUCED"
FINDING = "FINDING"
#: Every verdict a :class:`ClaimResult` can carry.
VERDICTS: tuple[str, ...] = (PASS, FAIL, NOT_EVALUATED, NOT_REPRODUCED, FINDING)


class ClaimError(ValueError):
    """A ``[[claims]]`` table is malformed (unknown kind, missing or invalid key)."""


@dataclass(frozen=True)
class ClaimResult:
    """Verdict on one claim.

    Attributes
    ----------
    kind, text
        The claim's kind and the thesis's words.
    passed
        Whether the recorded data support the claim.
    measured, threshold
        The number measured on the data and the value it was compared with (see
        ``docs/claims.md`` for the direction of the comparison of each kind).
    detail
        One line saying what was measured and why the verdict.
    status
        One of :data:`VERDICTS`; derived from ``passed`` when left empty.
    unit
        SI unit of ``measured`` and ``threshold`` (``""`` for ratios and fractions).
    baselines
        For a claim with ``baseline_ratio``: ``(baseline, RMS error, RMS error / measured)``
        of every baseline run given, the oracle included (``inf`` for a diverged run).
    finding
        The name of the expected finding of a claim marked ``finding`` (``""``: none).
    """

    kind: str
    text: str
    passed: bool
    measured: float
    threshold: float
    detail: str
    status: str = ""
    unit: str = ""
    baselines: tuple[tuple[str, float, float], ...] = ()
    finding: str = ""

    def __post_init__(self) -> None:
        status = self.status or (PASS if self.passed else FAIL)
        if status not in VERDICTS:
            raise ClaimError(
                f"`status` of ClaimResult must be one of {', '.join(VERDICTS)}; got {status!r}."
            )
        if (status == PASS) != bool(self.passed):
            raise ClaimError(
                f"`status` {status!r} of ClaimResult contradicts passed={self.passed!r}."
            )
        object.__setattr__(self, "status", status)

    @property
    def verdict(self) -> str:
        """``"PASS"``, ``"FAIL"``, ``"NOT EVALUATED"``, ``"NOT REPRODUCED"`` or ``"FINDING"``."""
        return self.status

    @property
    def evaluated(self) -> bool:
        """Whether the claim was measured (every verdict but ``NOT EVALUATED``)."""
        return self.status != NOT_EVALUATED


# ---------------------------------------------------------------------------- key handling
_NONE = None
#: kind -> (required keys, optional keys with defaults)
_KEYS: dict[str, tuple[tuple[str, ...], dict[str, Any]]] = {
    "tracking": (("threshold",), {"window": 20.0, "baseline_ratio": _NONE}),
    "rate_tracking": (("threshold",), {"window": 20.0}),
    "recovery": (("window", "threshold"), {}),
    "bounded": (("bound",), {}),
    "parameter_bounded": (("bound",), {"parameters": _NONE}),
    "redistribution": (("time", "healthy", "window"), {"settle": 0.0, "factor": 1.1}),
    "recovered_used": (("actuator", "time", "window", "min_level"), {}),
    "fault_indicator": (("time", "window", "threshold"), {}),
    "modal_decay": (("states", "window", "fraction"), {}),
    "sign": (("window",), {}),
    "limit_cycle": (("state", "window", "amplitude", "period"), {"tolerance": 0.05}),
    "transient": (
        ("measure", "max_duration"),
        {"after": _NONE, "until": _NONE, "threshold": _NONE},
    ),
    "estimate_change": (("start", "end", "min_change"), {}),
    "activity": (
        (),
        {
            "window": 20.0,
            "f_c": 1.0,
            "actuators": _NONE,
            "max_fast_rms": _NONE,
            "max_fast_rms_relative": _NONE,
            "reference_peak_to_peak": _NONE,
            "max_tv_per_s": _NONE,
            "max_peak_rate": _NONE,
            "max_rate_limited_fraction": _NONE,
            "max_travel_limited_fraction": _NONE,
            "max_peak_command": _NONE,
            "within_travel": _NONE,
        },
    ),
}
#: keys every kind accepts
_COMMON = {"not_reproduced": _NONE, "finding": _NONE, "thesis_law_finding": _NONE}
_NON_NUMERIC = {
    "kind",
    "text",
    "healthy",
    "states",
    "actuator",
    "state",
    "measure",
    "parameters",
    "actuators",
    "within_travel",
    # a number or one per actuator (checked by the activity claim)
    "max_fast_rms",
    "reference_peak_to_peak",
    "max_peak_command",
}
_POSITIVE = {
    "window",
    "threshold",
    "bound",
    "min_level",
    "fraction",
    "amplitude",
    "period",
    "tolerance",
    "max_duration",
    "min_change",
    "f_c",
    "max_fast_rms_relative",
    "max_tv_per_s",
    "max_peak_rate",
}

#: The claim kinds of ``docs/claims.md``.
CLAIM_KINDS: tuple[str, ...] = tuple(_KEYS)


def _name(claim: Mapping[str, Any]) -> str:
    text = str(claim.get("text", "")).strip().replace("\n", " ")
    short = text if len(text) <= 60 else text[:57] + "..."
    return f"claim '{claim.get('kind', '?')}' ({short!r})" if short else "claim"


def _params(claim: Mapping[str, Any]) -> dict[str, Any]:
    """Validated keys of a claim, defaults filled in."""
    if not isinstance(claim, Mapping):
        raise ClaimError(f"A claim must be a table; got {type(claim).__name__}.")
    if "kind" not in claim:
        raise ClaimError(
            f"A claim is missing the key 'kind' (one of {', '.join(CLAIM_KINDS)}): {dict(claim)}."
        )
    kind = claim["kind"]
    if kind not in _KEYS:
        raise ClaimError(
            f"Unknown claim kind '{kind}' in {_name(claim)}.{did_you_mean(str(kind), CLAIM_KINDS)}"
            f" Valid kinds: {', '.join(CLAIM_KINDS)}."
        )
    required, optional = _KEYS[kind]
    allowed = {"kind", "text", *required, *optional, *_COMMON}
    for key in claim:
        if key not in allowed:
            raise ClaimError(
                f"Unknown key '{key}' in {_name(claim)}.{did_you_mean(key, allowed)} "
                f"Keys of a '{kind}' claim: {', '.join(sorted(allowed))}."
            )
    for key in ("text", *required):
        if key not in claim:
            raise ClaimError(f"{_name(claim)} is missing the key '{key}'.")
    out = {**_COMMON, **optional, **dict(claim)}
    for key, what in (
        ("not_reproduced", "the reason"),
        ("finding", "the finding's name"),
        ("thesis_law_finding", "the thesis law's finding"),
    ):
        reason = out[key]
        if reason is not None and (not isinstance(reason, str) or not reason.strip()):
            raise ClaimError(
                f"Key '{key}' of {_name(claim)} must be a non-empty text giving {what}; "
                f"got {reason!r}."
            )
    if out["not_reproduced"] is not None and out["finding"] is not None:
        raise ClaimError(
            f"{_name(claim)} has both 'not_reproduced' and 'finding': a claim is either a thesis "
            "statement our runs do not show or a named finding of ours; keep one."
        )
    for key, value in out.items():
        if key in _NON_NUMERIC or key in _COMMON or value is None:
            continue
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise ClaimError(
                f"Key '{key}' of {_name(claim)} must be a finite number; got {value!r}."
            )
        if key in _POSITIVE and value <= 0:
            if not (key == "min_level" and value == 0):
                raise ClaimError(f"Key '{key}' of {_name(claim)} must be positive; got {value!r}.")
        if key in _FRACTIONS and not 0 <= value <= 1:
            raise ClaimError(
                f"Key '{key}' of {_name(claim)} is a fraction of the window: it must be in "
                f"[0, 1]; got {value!r}."
            )
    for key in _PER_ACTUATOR:  # a positive number, or one per actuator
        value = out.get(key)
        if value is None:
            continue
        values = value if isinstance(value, (list, tuple)) else [value]
        if not values or not all(
            not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) and v > 0
            for v in values
        ):
            raise ClaimError(
                f"Key '{key}' of {_name(claim)} must be a positive number or a list of positive "
                f"numbers (one per actuator); got {value!r}."
            )
    if out.get("within_travel") is not None and not isinstance(out["within_travel"], bool):
        raise ClaimError(
            f"Key 'within_travel' of {_name(claim)} must be true or false; "
            f"got {out['within_travel']!r}."
        )
    return out


_FRACTIONS = {"max_rate_limited_fraction", "max_travel_limited_fraction"}
#: activity thresholds given as one number or one per actuator
_PER_ACTUATOR = ("max_fast_rms", "reference_peak_to_peak", "max_peak_command")


def _actuator_index(claim: Mapping[str, Any], key: str, value: Any, m: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= m:
        raise ClaimError(
            f"Key '{key}' of {_name(claim)} must give actuator numbers from 1 to {m}; "
            f"got {value!r}."
        )
    return int(value) - 1


def _state_index(claim: Mapping[str, Any], key: str, name: Any, r: SimResult) -> int:
    if name not in r.state_names:
        raise ClaimError(
            f"Key '{key}' of {_name(claim)} names '{name}', which is not a state of this run."
            f"{did_you_mean(str(name), r.state_names)} States: {', '.join(r.state_names)}."
        )
    return r.state_names.index(name)


# ---------------------------------------------------------------------------- helpers
def _t0(result: SimResult) -> float:
    t0 = result.meta.get("t0")
    if t0 is not None:
        return float(t0)
    return float(result.time[0]) if result.time.size else 0.0


def _run_end(result: SimResult) -> float:
    """Duration the run was asked for (``meta["t_final"]``), else its last sample."""
    t_final = result.meta.get("t_final")
    if t_final is not None:
        return float(t_final)
    return float(result.time[-1]) if result.time.size else 0.0


def _mask(result: SimResult, start: float, end: float, *, right_open: bool = False) -> np.ndarray:
    t = result.time
    lo = t >= start - 1e-9
    hi = t < end - 1e-9 if right_open else t <= end + 1e-9
    return lo & hi


def _diverged(result: SimResult) -> str:
    if result.status == "completed":
        return ""
    stop = f"{result.time[-1]:.4g} s" if result.time.size else "the start"
    return f"run {result.status} at t = {stop}" + (f" ({result.message})" if result.message else "")


def _last(result: SimResult) -> float:
    return float(result.time[-1]) if result.time.size else -math.inf


def _uncovered(c: Mapping[str, Any], r: SimResult, end: float) -> str:
    """Why ``[.., end]`` cannot be judged (``""`` if it can): a divergence FAILs (prefixed
    ``"fail:"``), a completed run that stops before ``end`` is NOT EVALUATED."""
    if why := _diverged(r):
        return "fail:" + why
    if _last(r) < end - 1e-6:
        return (
            f"the run ends at t = {_last(r):.4g} s, before the judged window ends at {end:.4g} s "
            "(a shortened run, e.g. quick mode): not measured"
        )
    return ""


def _result(
    c: Mapping[str, Any],
    passed: bool,
    measured: float,
    threshold: float,
    detail: str,
    unit: str = "",
) -> ClaimResult:
    status = PASS if passed else FAIL
    reason = c.get("not_reproduced")
    if reason:
        if passed:
            detail += f" [the catalogue expected this not to reproduce ({reason}): stale note]"
        elif math.isfinite(measured) or math.isinf(measured):
            status = NOT_REPRODUCED
            detail += f" [not reproduced: {reason}]"
    finding = c.get("finding") or ""
    if finding:
        if passed:
            detail += f" [the catalogue expected the finding '{finding}': it no longer shows]"
        else:
            status = FINDING
            detail += f" [finding: {finding}]"
    return ClaimResult(
        kind=str(c["kind"]),
        text=str(c.get("text", "")),
        passed=bool(passed),
        measured=float(measured),
        threshold=float(threshold),
        detail=detail,
        status=status,
        unit=unit,
        finding=str(finding),
    )


def _skip(c: Mapping[str, Any], threshold: float, why: str, unit: str = "") -> ClaimResult:
    """FAIL (``why`` starts with ``"fail:"``; FINDING for a claim marked ``finding``) or NOT
    EVALUATED, with nothing measured."""
    failed = why.startswith("fail:")
    finding = str(c.get("finding") or "")
    detail = why.removeprefix("fail:")
    status = FAIL if failed else NOT_EVALUATED
    if failed and finding:
        status = FINDING
        detail += f" [finding: {finding}]"
    return ClaimResult(
        kind=str(c["kind"]),
        text=str(c.get("text", "")),
        passed=False,
        measured=math.nan,
        threshold=float(threshold),
        detail=detail,
        status=status,
        unit=unit,
        finding=finding,
    )


def _window_rms(signal: np.ndarray, result: SimResult, start: float, end: float):
    mask = _mask(result, start, end)
    if not mask.any():
        return None
    return np.sqrt(np.mean(signal[mask] ** 2, axis=0))


def _fmt(x: float, unit: str = "") -> str:
    return f"{x:.4g} {unit}" if unit else f"{x:.4g}"


def _last_window(c: Mapping[str, Any], r: SimResult) -> tuple[float, float]:
    end = float(c["_end"])
    return max(_t0(r), end - float(c["window"])), end


# ---------------------------------------------------------------------------- kinds
#: Baselines a ``baseline_ratio`` is never held against (they know the true failure).
ORACLES: frozenset[str] = frozenset({"oracle"})


def _baseline_rows(c, r, baselines, start: float, end: float, worst: float):
    """``(name, RMS error, RMS / worst)`` of every baseline run, in the given order; a run
    that diverged, or has no samples in the window, counts as infinitely worse. Also returns
    notes on the runs that could not be judged."""
    rows, notes = [], []
    for name, b in baselines.items():
        if b is None:
            notes.append(f"{name} baseline not run")
            continue
        if _diverged(b):
            rms, why = math.inf, "diverged"
        elif (brms := _window_rms(b.e, b, start, end)) is None:
            rms, why = math.inf, "no samples in the window"
        else:
            rms, why = float(np.max(brms)), ""
        if why:
            notes.append(f"{name} baseline {why} (infinitely worse)")
        rows.append((name, rms, rms / worst if worst > 0 else math.inf))
    return tuple(rows), notes


def _error_claim(c, r, baselines, signal: np.ndarray, what: str, unit: str) -> ClaimResult:
    thr = float(c["threshold"])
    start, end = _last_window(c, r)
    if why := _uncovered(c, r, end):
        return _skip(c, thr, why, unit)
    rms = _window_rms(signal, r, start, end)
    if rms is None:
        return _skip(c, thr, f"fail:no samples in [{start:g}, {end:g}] s", unit)
    worst = float(np.max(rms))
    ok = bool(np.all(rms <= thr))
    names = ", ".join(f"{n} {_fmt(v, unit)}" for n, v in zip(r.output_names, rms, strict=True))
    detail = f"RMS {what} over [{start:g}, {end:g}] s: {names} (<= {_fmt(thr, unit)} required)"
    ratio_req = c.get("baseline_ratio")
    rows: tuple = ()
    if ratio_req is not None:
        rows, notes = _baseline_rows(c, r, baselines, start, end, worst)
        fair = [row for row in rows if row[0] not in ORACLES]
        if notes:
            detail += "; " + "; ".join(notes)
        detail += "; baseline RMS: " + ", ".join(
            f"{n} {_fmt(v, unit)} = {_fmt(q)} x adaptive" for n, v, q in rows
        )
        if fair:
            name, _, ratio = min(fair, key=lambda row: row[1])
            detail += (
                f"; best non-oracle baseline: {name}, {_fmt(ratio)} x adaptive "
                f"(>= {_fmt(float(ratio_req))} x required)"
            )
        else:  # only an oracle was run (or nothing could be judged)
            ratio = math.inf
            detail += "; no non-oracle baseline was run"
        ok = ok and ratio >= float(ratio_req)
    res = _result(c, ok, worst, thr, detail, unit)
    return dataclasses.replace(res, baselines=rows) if rows else res


def _tracking(c, r, baselines):
    if c["baseline_ratio"] is not None and not any(
        b is not None and n not in ORACLES for n, b in baselines.items()
    ):
        raise ClaimError(
            f"{_name(c)} has 'baseline_ratio' and needs a non-oracle baseline run: pass "
            "baselines=run_baselines(scenario) (or at least frozen=scenario.run(adapt=False))."
        )
    return _error_claim(c, r, baselines, r.e, "tracking error", output_unit(r.meta))


def _rate_tracking(c, r, frozen):
    return _error_claim(c, r, {}, r.edot, "rate error e'", rate_unit(r.meta))


def _recovery(c, r, frozen):
    window, thr, unit = float(c["window"]), float(c["threshold"]), output_unit(r.meta)
    end = float(c["_end"])
    if why := _diverged(r):
        return _skip(c, thr, "fail:" + why, unit)
    events = [t for t in r.failure_times if t < end]
    if not events:
        return _skip(c, thr, "fail:the run has no failure/recovery events to recover from", unit)
    ends = events[1:] + [end]
    worst, parts, ok, missing = 0.0, [], True, []
    for t, nxt in zip(events, ends, strict=True):
        if _last(r) < nxt - 1e-6:
            missing.append(f"t={t:g}")
            continue
        rms = _window_rms(r.e, r, max(t, nxt - window), nxt)
        if rms is None:
            return _skip(c, thr, f"fail:no samples before the event after t = {t:g} s", unit)
        value = float(np.max(rms))
        worst = max(worst, value)
        ok = ok and bool(np.all(rms <= thr))
        parts.append(f"t={t:g}: {_fmt(value, unit)}")
    detail = (
        f"RMS error over the last {window:g} s before the next event, per event: "
        f"{'; '.join(parts) or 'none measured'} (<= {_fmt(thr, unit)} required)"
    )
    if missing:
        return _skip(
            c,
            thr,
            f"{detail}; events {', '.join(missing)} not reached: the run ends at "
            f"t = {_last(r):.4g} s (a shortened run): not measured",
            unit,
        )
    return _result(c, ok, worst, thr, detail, unit)


def _declared_travel(r: SimResult) -> list[tuple[float, float]] | None:
    """``(lower, upper)`` per actuator when the run's Actuators declare a finite travel for
    at least one actuator, else ``None``."""
    from adaptive_ftc.sim.activity import limits_of

    limits = limits_of(r)
    if not limits:
        return None
    declared = limits.get("declared", {})
    pairs = [
        (float(lo), float(hi))
        for lo, hi in zip(declared.get("lower", ()), declared.get("upper", ()), strict=False)
    ]
    if len(pairs) != len(r.actuator_names):
        return None
    if not any(math.isfinite(lo) or math.isfinite(hi) for lo, hi in pairs):
        return None
    return pairs


def _travel_fraction(u: np.ndarray, lo: float, hi: float) -> float:
    """Largest use of the travel ``[lo, hi]``: ``u / hi`` above zero, ``u / lo`` below (1 at
    a limit; ``inf`` for a non-zero value beyond a limit at or across zero)."""
    if u.size == 0:
        return 0.0
    top, bottom = float(np.max(u)), float(np.min(u))
    up = 0.0 if top <= 0 or math.isinf(hi) else (top / hi if hi > 0 else math.inf)
    down = 0.0 if bottom >= 0 or math.isinf(lo) else (bottom / lo if lo < 0 else math.inf)
    return max(up, down)


def _bounded(c, r, frozen):
    bound = float(c["bound"])
    if why := _uncovered(c, r, float(c["_end"])):
        return _skip(c, bound, why)
    signals = {"plant state": r.states, "commanded": r.u_cmd, "applied": r.u_applied}
    peaks = {k: float(np.max(np.abs(v))) if v.size else 0.0 for k, v in signals.items()}
    finite = all(np.all(np.isfinite(v)) for v in signals.values())
    travel = _declared_travel(r)
    if travel is None:
        worst = max(peaks.values()) if finite else math.inf
        detail = "largest |.| (SI units of each signal): " + ", ".join(
            f"{k} {_fmt(v)}" for k, v in peaks.items()
        )
        return _result(c, finite and worst <= bound, worst, bound, f"{detail} (<= {_fmt(bound)})")
    # a declared travel: each actuator's command and applied output within it, the plant
    # states within the bound; measured: the largest |.| relative to its own limit
    unit = actuator_unit(r.meta)
    worst = peaks["plant state"] / bound
    parts = [f"plant state {_fmt(peaks['plant state'])} (<= {_fmt(bound)})"]
    for key, sig in (("commanded", r.u_cmd), ("applied", r.u_applied)):
        for j, name in enumerate(r.actuator_names):
            lo, hi = travel[j]
            col = sig[:, j]
            if math.isinf(lo) and math.isinf(hi):
                peak = float(np.max(np.abs(col))) if col.size else 0.0
                frac = peak / bound
                parts.append(f"{key} {name} {_fmt(peak, unit)} (<= {_fmt(bound)})")
            else:
                frac = _travel_fraction(col, lo, hi)
                span = f"{_fmt(float(np.min(col)))} to {_fmt(float(np.max(col)), unit)}"
                parts.append(
                    f"{key} {name} {span}: {_fmt(frac)} x its travel [{_fmt(lo)}, {_fmt(hi)}]"
                )
            worst = max(worst, frac)
    if not finite:
        worst = math.inf
    detail = (
        "largest |.| relative to its limit (the declared travel for the actuator signals, "
        f"{_fmt(bound)} for the plant states): {_fmt(worst)} (<= 1 required); " + "; ".join(parts)
    )
    return _result(c, finite and worst <= 1.0, worst, 1.0, detail)


def _parameter_bounded(c, r, frozen):
    bound = float(c["bound"])
    prefixes = c["parameters"]
    if isinstance(prefixes, str):
        prefixes = [prefixes]
    if prefixes is not None and (not isinstance(prefixes, Sequence) or not prefixes):
        raise ClaimError(
            f"Key 'parameters' of {_name(c)} must be a list of adaptive-state name prefixes "
            f"such as ['theta', 'kappa']; got {prefixes!r}."
        )
    idx = [
        i
        for i, n in enumerate(r.adaptive_names)
        if prefixes is None or any(n.startswith(str(p)) for p in prefixes)
    ]
    if not idx:
        raise ClaimError(
            f"Key 'parameters' of {_name(c)} selects no adaptive state of this run; its "
            f"adaptive states are {', '.join(r.adaptive_names) or 'none'}."
        )
    if why := _uncovered(c, r, float(c["_end"])):
        return _skip(c, bound, why)
    values = r.adaptive[:, idx]
    finite = bool(np.all(np.isfinite(values)))
    peak = float(np.max(np.abs(values))) if finite else math.inf
    j = int(np.argmax(np.max(np.abs(values), axis=0))) if finite else 0
    half = _mask(r, _t0(r) + 0.5 * (float(c["_end"]) - _t0(r)), float(c["_end"]))
    late = float(np.max(np.abs(values[half]))) if finite and half.any() else math.nan
    detail = (
        f"largest |parameter| over the run: {_fmt(peak)} ({r.adaptive_names[idx[j]]}); over the "
        f"second half: {_fmt(late)}; {len(idx)} adaptive states checked (<= {_fmt(bound)})"
    )
    return _result(c, finite and peak <= bound, peak, bound, detail)


def _redistribution(c, r, frozen):
    m = len(r.actuator_names)
    healthy = c["healthy"]
    if isinstance(healthy, (int, np.integer)) and not isinstance(healthy, bool):
        healthy = [healthy]
    if not isinstance(healthy, Sequence) or isinstance(healthy, str) or not healthy:
        raise ClaimError(f"Key 'healthy' of {_name(c)} must be a list of actuator numbers.")
    idx = [_actuator_index(c, "healthy", j, m) for j in healthy]
    t, window, settle, factor = (float(c[k]) for k in ("time", "window", "settle", "factor"))
    a0, b1 = max(_t0(r), t - window), t + settle + window
    if why := _uncovered(c, r, b1):
        return _skip(c, factor, why)
    before = _mask(r, a0, t, right_open=True)
    after = _mask(r, t + settle, b1)
    if not before.any() or not after.any():
        return _skip(c, factor, f"fail:no samples around t = {t:g} s")
    lvl_before = float(np.mean(np.abs(r.u_applied[np.ix_(before, idx)])))
    lvl_after = float(np.mean(np.abs(r.u_applied[np.ix_(after, idx)])))
    ratio = lvl_after / lvl_before if lvl_before > 0 else (math.inf if lvl_after > 0 else 0.0)
    names = ", ".join(r.actuator_names[j] for j in idx)
    unit = actuator_unit(r.meta)
    detail = (
        f"mean |applied| of {names}: {_fmt(lvl_before, unit)} over [{a0:g}, {t:g}) s, "
        f"{_fmt(lvl_after, unit)} over [{t + settle:g}, {b1:g}] s: "
        f"ratio {_fmt(ratio)} (> {_fmt(factor)} required)"
    )
    return _result(c, ratio > factor, ratio, factor, detail)


def _recovered_used(c, r, frozen):
    j = _actuator_index(c, "actuator", c["actuator"], len(r.actuator_names))
    t, window, level = float(c["time"]), float(c["window"]), float(c["min_level"])
    unit = actuator_unit(r.meta)
    if why := _uncovered(c, r, t + window):
        return _skip(c, level, why, unit)
    mask = _mask(r, t, t + window)
    if not mask.any():
        return _skip(c, level, f"fail:no samples in [{t:g}, {t + window:g}] s", unit)
    used = float(np.mean(np.abs(r.u_applied[mask, j])))
    detail = (
        f"mean |applied| of {r.actuator_names[j]} over [{t:g}, {t + window:g}] s: "
        f"{_fmt(used, unit)} (>= {_fmt(level, unit)} required)"
    )
    return _result(c, used >= level, used, level, detail, unit)


def _fault_indicator(c, r, frozen):
    t, window, thr = float(c["time"]), float(c["window"]), float(c["threshold"])
    unit = actuator_unit(r.meta)
    if why := _uncovered(c, r, t + window):
        return _skip(c, thr, why, unit)
    before = np.flatnonzero(r.time < t - 1e-9)
    mask = _mask(r, t, t + window)
    if before.size == 0 or not mask.any():
        return _skip(c, thr, f"fail:no samples around t = {t:g} s", unit)
    ref = float(r.u_f[before[-1]])
    move = float(np.max(np.abs(r.u_f[mask] - ref)))
    detail = (
        f"compensator u_f moves by {_fmt(move, unit)} within [{t:g}, {t + window:g}] s from "
        f"{_fmt(ref, unit)} just before (>= {_fmt(thr, unit)} required)"
    )
    return _result(c, move >= thr, move, thr, detail, unit)


def _modal_decay(c, r, frozen):
    states = c["states"]
    if isinstance(states, str):
        states = [states]
    if not isinstance(states, Sequence) or not states:
        raise ClaimError(f"Key 'states' of {_name(c)} must be a list of state names.")
    idx = [_state_index(c, "states", name, r) for name in states]
    fraction = float(c["fraction"])
    start, end = _last_window(c, r)
    if why := _uncovered(c, r, end):
        return _skip(c, fraction, why)
    mask = _mask(r, start, end)
    disp = np.abs(r.states[:, idx])
    peak = float(np.max(disp))
    last = float(np.max(disp[mask]))
    ratio = last / peak if peak > 0 else 0.0
    unit = state_unit(r.meta, states[0])
    detail = (
        f"largest |{', '.join(states)}| over [{start:g}, {end:g}] s: {_fmt(last, unit)}, over "
        f"the run: {_fmt(peak, unit)}: ratio {_fmt(ratio)} (<= {_fmt(fraction)} required)"
    )
    return _result(c, ratio <= fraction, ratio, fraction, detail)


def _sign(c, r, frozen):
    start, end = _last_window(c, r)
    if why := _uncovered(c, r, end):
        return _skip(c, 1.0, why)
    mask = _mask(r, start, end)
    est, true = np.sign(r.gain[mask]), np.sign(r.control_gain[mask])
    agree = float(np.mean((est == true) & (true != 0)))
    wrong = np.flatnonzero(est != true)
    detail = (
        f"sign of the direction estimate equals the true control direction at "
        f"{agree:.2%} of the samples in [{start:g}, {end:g}] s (100% required)"
    )
    if wrong.size:
        detail += f"; first mismatch at t = {r.time[mask][wrong[0]]:.4g} s"
    else:
        detail += f"; true direction {int(true[-1]):+d}"
    return _result(c, agree == 1.0, agree, 1.0, detail)


def _limit_cycle(c, r, frozen):
    i = _state_index(c, "state", c["state"], r)
    amp_req, per_req, tol = float(c["amplitude"]), float(c["period"]), float(c["tolerance"])
    unit = state_unit(r.meta, str(c["state"]))
    start, end = _last_window(c, r)
    if why := _uncovered(c, r, end):
        return _skip(c, amp_req, why, unit)
    mask = _mask(r, start, end)
    x, t = r.states[mask, i], r.time[mask]
    amp = 0.5 * float(np.max(x) - np.min(x))
    z = x - 0.5 * (np.max(x) + np.min(x))
    up = np.flatnonzero((z[:-1] < 0) & (z[1:] >= 0))
    if up.size >= 2:  # linear interpolation of the upward crossings
        tc = t[up] - z[up] * (t[up + 1] - t[up]) / (z[up + 1] - z[up])
        period = float(np.mean(np.diff(tc)))
    else:
        period = math.nan
    amp_ok = abs(amp - amp_req) <= tol * amp_req
    per_ok = math.isfinite(period) and abs(period - per_req) <= tol * per_req
    deg = f" ({math.degrees(amp):.4g} deg)" if unit == "rad" else ""
    detail = (
        f"over [{start:g}, {end:g}] s: amplitude of {c['state']} {_fmt(amp, unit)}{deg} "
        f"(expected {_fmt(amp_req, unit)} ± {tol:.0%}), period {_fmt(period, 's')} over "
        f"{max(up.size - 1, 0)} cycles (expected {_fmt(per_req, 's')} ± {tol:.0%})"
    )
    return _result(c, amp_ok and per_ok, amp, amp_req, detail, unit)


def _transient(c, r, frozen):
    measure = c["measure"]
    if measure not in ("sign", "error"):
        raise ClaimError(
            f"Key 'measure' of {_name(c)} must be 'sign' (direction estimate) or 'error' "
            f"(tracking error below 'threshold'); got {measure!r}."
        )
    if measure == "error" and c["threshold"] is None:
        raise ClaimError(f"{_name(c)} measures 'error' and needs the key 'threshold'.")
    max_d = float(c["max_duration"])
    after = _t0(r) if c["after"] is None else float(c["after"])
    until = float(c["_end"]) if c["until"] is None else float(c["until"])
    if why := _uncovered(c, r, until):
        return _skip(c, max_d, why, "s")
    mask = _mask(r, after, until)
    if not mask.any():
        return _skip(c, max_d, f"fail:no samples in [{after:g}, {until:g}] s", "s")
    t = r.time[mask]
    if measure == "sign":
        true = np.sign(r.control_gain[mask])
        good = (np.sign(r.gain[mask]) == true) & (true != 0)
        what = "the sign of the direction estimate equals the true control direction"
    else:
        thr = float(c["threshold"])
        good = np.max(np.abs(r.e[mask]), axis=1) <= thr
        what = f"|e| <= {_fmt(thr, output_unit(r.meta))}"
    bad = np.flatnonzero(~good)
    if bad.size == 0:
        settle = after
    elif bad[-1] == good.size - 1:
        detail = f"{what} does not hold at the end of [{after:g}, {until:g}] s"
        return _result(c, False, math.inf, max_d, detail, "s")
    else:
        settle = float(t[bad[-1] + 1])
    duration = settle - after
    n_switch = int(np.count_nonzero(np.diff(good.astype(np.int8)) != 0))
    detail = (
        f"{what} from t = {settle:.4g} s on, i.e. {_fmt(duration, 's')} after t = {after:g} s "
        f"({n_switch} changes before settling; <= {_fmt(max_d, 's')} required)"
    )
    return _result(c, duration <= max_d, duration, max_d, detail, "s")


def _estimate_change(c, r, frozen):
    start, end, need = float(c["start"]), float(c["end"]), float(c["min_change"])
    if end <= start:
        raise ClaimError(f"Key 'end' of {_name(c)} must exceed 'start'; got {start:g}, {end:g}.")
    if why := _uncovered(c, r, end):
        return _skip(c, need, why)
    mask = _mask(r, start, end)
    g = r.gain[mask]
    scale = float(np.max(np.abs(g))) if g.size else 0.0
    change = float(np.max(g) - np.min(g)) / scale if scale > 0 else 0.0
    events = [f"{t:g}" for t in r.failure_times if start <= t <= end]
    detail = (
        f"direction estimate over [{start:g}, {end:g}] s (failure events at "
        f"{', '.join(events) or 'none'} s): from {_fmt(float(np.min(g)))} to "
        f"{_fmt(float(np.max(g)))}, relative change {_fmt(change)} (>= {_fmt(need)} required)"
    )
    return _result(c, change >= need, change, need, detail)


#: ``activity`` criteria: claim key, metric of :class:`~adaptive_ftc.sim.activity.
#: ActuatorActivity`, words, unit kind ("u": actuator unit, "u/s": per second, "": none)
_ACTIVITY_CRITERIA = (
    ("max_fast_rms", "fast_rms", "fast command content", "u"),
    ("max_tv_per_s", "tv_per_s", "command total variation per second", "u/s"),
    ("max_peak_rate", "peak_rate", "peak command rate", "u/s"),
    ("max_rate_limited_fraction", "rate_limited_fraction", "fraction at the rate limit", ""),
    ("max_travel_limited_fraction", "travel_limited_fraction", "fraction at a travel limit", ""),
    ("max_peak_command", "peak_command", "peak |command|", "u"),
    ("within_travel", "peak_command_travel_ratio", "peak |command| / declared travel", ""),
)


def _per_actuator_numbers(c: Mapping[str, Any], key: str, m: int) -> list[float]:
    """A number, or one positive number per actuator, as a list of ``m`` numbers."""
    value = c[key]
    values = list(value) if isinstance(value, (list, tuple)) else [value] * m
    ok = len(values) == m and all(
        not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) and v > 0
        for v in values
    )
    if not ok:
        raise ClaimError(
            f"Key '{key}' of {_name(c)} must be a positive number or one positive number per "
            f"actuator ({m}); got {value!r}."
        )
    return [float(v) for v in values]


def _activity_thresholds(c, r) -> list[tuple[str, str, str, str, list[float]]]:
    """``(key, metric, words, unit kind, threshold per actuator)`` of every criterion the
    claim states."""
    m = len(r.actuator_names)
    if c["max_fast_rms"] is not None and c["max_fast_rms_relative"] is not None:
        raise ClaimError(
            f"{_name(c)} has both 'max_fast_rms' and 'max_fast_rms_relative': give one."
        )
    out = []
    for key, metric, words, kind in _ACTIVITY_CRITERIA:
        if key == "max_fast_rms" and c["max_fast_rms_relative"] is not None:
            if c["reference_peak_to_peak"] is None:
                raise ClaimError(
                    f"{_name(c)} has 'max_fast_rms_relative' and needs "
                    "'reference_peak_to_peak' (the ideal run's command peak to peak, one "
                    "number or one per actuator)."
                )
            ref = _per_actuator_numbers(c, "reference_peak_to_peak", m)
            rel = float(c["max_fast_rms_relative"])
            out.append((key, metric, words, kind, [rel * v for v in ref]))
            continue
        if c[key] is None:
            continue
        if key == "within_travel":
            if not isinstance(c[key], bool):
                raise ClaimError(f"Key 'within_travel' of {_name(c)} must be true or false.")
            if c[key]:
                out.append((key, metric, words, kind, [1.0] * m))
        elif key in ("max_fast_rms", "max_peak_command"):
            out.append((key, metric, words, kind, _per_actuator_numbers(c, key, m)))
        else:
            out.append((key, metric, words, kind, [float(c[key])] * m))
    if not out:
        keys = ", ".join(k for k, *_ in _ACTIVITY_CRITERIA) + ", max_fast_rms_relative"
        raise ClaimError(f"{_name(c)} states no criterion: give at least one of {keys}.")
    return out


def _activity(c, r, baselines):
    from adaptive_ftc.sim.activity import activity, limits_of, max_record_dt

    m = len(r.actuator_names)
    chosen = c["actuators"]
    if chosen is None:
        idx = list(range(m))
    else:
        if isinstance(chosen, (int, np.integer)) and not isinstance(chosen, bool):
            chosen = [chosen]
        if not isinstance(chosen, Sequence) or isinstance(chosen, str) or not chosen:
            raise ClaimError(f"Key 'actuators' of {_name(c)} must be a list of actuator numbers.")
        idx = [_actuator_index(c, "actuators", j, m) for j in chosen]
    criteria = _activity_thresholds(c, r)
    f_c = float(c["f_c"])
    u_unit = actuator_unit(r.meta)
    units = {"u": u_unit, "u/s": f"{u_unit}/s" if u_unit else "", "": ""}
    first_unit = units[criteria[0][3]]
    if any(key == "within_travel" for key, *_ in criteria):
        limits = limits_of(r) or {}
        declared = limits.get("declared", {})
        for j in idx:
            lo = declared.get("lower", [-math.inf] * m)[j]
            hi = declared.get("upper", [math.inf] * m)[j]
            if math.isinf(float(lo)) and math.isinf(float(hi)):
                raise ClaimError(
                    f"{_name(c)} asks for 'within_travel' but actuator {j + 1} "
                    f"({r.actuator_names[j]}) declares no travel (Actuators lower/upper): use "
                    "'max_peak_command' (e.g. 10x the ideal run's peak) instead."
                )
    start, end = _last_window(c, r)
    if why := _uncovered(c, r, end):
        return _skip(c, criteria[0][4][idx[0]], why, first_unit)
    acts = activity(r, start, end, f_c=f_c)
    sample_time = float(r.meta.get("sample_time") or 0.0)
    some = next(iter(acts.values()))
    if not some.record_ok:
        need = max_record_dt(f_c, sample_time)
        raise ClaimError(
            f"{_name(c)} cannot judge this run: it is recorded every {some.record_dt:.4g} s, "
            f"too coarse for activity above {f_c:g} Hz (aliasing; the rule in "
            f"adaptive_ftc.sim.activity needs <= {need:.4g} s here). Set record_dt = {need:g} "
            "(or less) in the scenario's [solver] table."
        )
    worst: tuple[float, float, float, str] | None = None  # (ratio, value, threshold, unit)
    ok, parts = True, []
    for _key, metric, words, kind, thresholds in criteria:
        unit = units[kind]
        items = []
        for j in idx:
            name = r.actuator_names[j]
            value = float(getattr(acts[name], metric))
            thr = thresholds[j]
            note = ""
            if math.isnan(value):
                if metric in ("rate_limited_fraction", "travel_limited_fraction"):
                    value, note = 0.0, " (no such limit declared)"
                else:
                    value, note = math.inf, " (not measurable: record too short)"
            ratio = value / thr if thr > 0 else (math.inf if value > 0 else 0.0)
            ok = ok and value <= thr
            if worst is None or ratio > worst[0]:
                worst = (ratio, value, thr, unit)
            items.append(f"{name} {_fmt(value, unit)}{note} (<= {_fmt(thr, unit)})")
        parts.append(f"{words}: {', '.join(items)}")
    assert worst is not None
    detail = (
        f"command activity over [{start:g}, {end:g}] s (fast content above {f_c:g} Hz, "
        f"records every {some.record_dt:.3g} s): " + "; ".join(parts)
    )
    return _result(c, ok, worst[1], worst[2], detail, worst[3])


#: kind -> evaluator(params, run, baseline runs by name: evaluate_claim's ``baselines``)
_EVALUATORS: dict[
    str, Callable[[dict[str, Any], SimResult, dict[str, SimResult | None]], ClaimResult]
] = {
    "tracking": _tracking,
    "rate_tracking": _rate_tracking,
    "recovery": _recovery,
    "bounded": _bounded,
    "parameter_bounded": _parameter_bounded,
    "redistribution": _redistribution,
    "recovered_used": _recovered_used,
    "fault_indicator": _fault_indicator,
    "modal_decay": _modal_decay,
    "sign": _sign,
    "limit_cycle": _limit_cycle,
    "transient": _transient,
    "estimate_change": _estimate_change,
    "activity": _activity,
}


# ---------------------------------------------------------------------------- public API
def evaluate_claim(
    claim: Mapping[str, Any],
    result: SimResult,
    *,
    frozen: SimResult | None = None,
    baselines: Mapping[str, SimResult | None] | None = None,
    duration: float | None = None,
) -> ClaimResult:
    """Evaluate one ``[[claims]]`` table on a recorded run.

    Parameters
    ----------
    claim
        The claim table: ``kind``, ``text`` and the keys of its kind (``docs/claims.md``).
    result
        The adaptive run with failures.
    frozen
        The same scenario with adaptation frozen (shorthand for ``baselines={"frozen": ...}``).
    baselines
        Baseline runs of the same scenario by name (:data:`adaptive_ftc.baselines.BASELINES`:
        ``"fixed-gain"``, ``"nominal-inverse"``, ``"oracle"``, ``"frozen"``; see
        :func:`adaptive_ftc.baselines.run_baselines`); ``None`` marks a run that failed. A
        ``tracking`` claim with ``baseline_ratio`` needs at least one non-oracle baseline: the
        adaptive RMS error must be ``baseline_ratio`` times smaller than that of the *best*
        non-oracle baseline given (the oracle, which knows the true failure, is reported in
        :attr:`ClaimResult.baselines` but never compared with).
    duration
        End time of the scenario as the thesis ran it (s). Windows "at the end" end there; a
        completed run that was shortened below it (quick mode) gives ``NOT EVALUATED`` for every
        window it does not reach. Default: the run's own duration.

    Returns
    -------
    ClaimResult
        Verdict, measured number with its unit, threshold and a one-line explanation. A run that
        diverged before the end of the judged window FAILs with ``measured = nan``.

    Raises
    ------
    ClaimError
        Unknown kind, missing/unknown/invalid key (the message names the claim and the key), or
        a ``baseline_ratio`` claim evaluated without a non-oracle baseline.
    """
    params = _params(claim)
    params["_end"] = _run_end(result) if duration is None else float(duration)
    runs = dict(baselines or {})
    if frozen is not None:
        runs.setdefault("frozen", frozen)
    return _EVALUATORS[params["kind"]](params, result, runs)


def evaluate_claims(
    claims: Sequence[Mapping[str, Any]],
    result: SimResult,
    *,
    frozen: SimResult | None = None,
    baselines: Mapping[str, SimResult | None] | None = None,
    duration: float | None = None,
) -> list[ClaimResult]:
    """Evaluate every claim of a scenario (see :func:`evaluate_claim`); order is kept.

    Raises
    ------
    ClaimError
        For the first malformed claim, naming its position (1-based) in the list.
    """
    out = []
    for i, claim in enumerate(claims):
        try:
            out.append(
                evaluate_claim(claim, result, frozen=frozen, baselines=baselines, duration=duration)
            )
        except ClaimError as exc:
            raise ClaimError(f"[[claims]] #{i + 1}: {exc}") from None
    return out


#: The finding's name of a claim without ``thesis_law_finding`` that the thesis law fails.
THESIS_LAW_FINDING = "the thesis law (constraint_aware off) does not meet this claim"


def thesis_law_claim(claim: Mapping[str, Any]) -> dict[str, Any]:
    """``claim`` as it judges the thesis law's companion run: its ``thesis_law_finding`` (or
    :data:`THESIS_LAW_FINDING`) becomes the ``finding``, the scenario's own ``finding`` and
    ``not_reproduced`` notes are dropped."""
    out = {
        k: v
        for k, v in dict(claim).items()
        if k not in ("finding", "not_reproduced", "thesis_law_finding")
    }
    out["finding"] = claim.get("thesis_law_finding") or THESIS_LAW_FINDING
    return out


def evaluate_thesis_law_claims(
    claims: Sequence[Mapping[str, Any]],
    result: SimResult,
    *,
    baselines: Mapping[str, SimResult | None] | None = None,
    duration: float | None = None,
) -> list[ClaimResult]:
    """The scenario's claims judged on the thesis law's companion run of a constraint-aware
    scenario: a claim it does not meet is FINDING (named by ``thesis_law_finding``), never
    FAIL and never PASS; one it meets is PASS. Order is kept."""
    out = evaluate_claims(
        [thesis_law_claim(c) for c in claims], result, baselines=baselines, duration=duration
    )
    # a claim without a named finding that the thesis law meets is a plain PASS (no stale note)
    stale = f" [the catalogue expected the finding '{THESIS_LAW_FINDING}': it no longer shows]"
    return [
        dataclasses.replace(v, detail=v.detail.replace(stale, ""), finding="")
        if v.status == PASS and v.finding == THESIS_LAW_FINDING
        else v
        for v in out
    ]


def unjudged_activity(loop: Any, claims: Sequence[Mapping[str, Any]]) -> str:
    """Where ``loop`` declares hardware (actuators, sensors or a digital controller) and has
    claims, none of which judges its command's fast content (an ``activity`` claim with
    ``max_fast_rms`` or ``max_fast_rms_relative``), a note saying so: a tracking PASS there
    says nothing of a chattering command (issue 25). Empty otherwise."""
    hardware = [
        what
        for what, declared in (
            ("actuators", getattr(loop, "actuators", None) is not None),
            ("sensors", getattr(loop, "sensors", None) is not None),
            ("a digital controller", float(getattr(loop, "sample_time", 0.0) or 0.0) > 0),
        )
        if declared
    ]
    judged = any(
        c.get("kind") == "activity" and ("max_fast_rms" in c or "max_fast_rms_relative" in c)
        for c in claims
    )
    if not claims or not hardware or judged:
        return ""
    return (
        f"note: this loop has {', '.join(hardware)} but no claim judges its command's fast "
        "content, so a PASS above says nothing of chatter: add a [[claims]] table with kind = "
        '"activity" and max_fast_rms (or max_fast_rms_relative with reference_peak_to_peak, '
        "e.g. 3 % of the ideal run's command peak to peak; docs/claims.md)"
    )
