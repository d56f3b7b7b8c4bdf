"""Evaluate the thesis's claims (the ``[[claims]]`` tables of a scenario) on recorded runs.

The claim kinds and their keys are specified in ``docs/claims.md``. Every claim yields a
:class:`ClaimResult` with a PASS/FAIL verdict, the measured number and the threshold it was held
to, so that a report can show a failure honestly with its number.

Conventions
-----------
- "The last ``window`` seconds" ends at the scenario's duration ``result.meta["t_final"]`` (or the
  last sample when the duration is not recorded), so a run that diverged early has no samples
  there and FAILs.
- Tracking errors are judged per output; the measured number is the worst output.
- A window ``[a, b)`` "before ``time``" excludes ``time`` itself (the recorded sample at a
  failure time already shows the failed actuator).

Examples
--------
>>> from adaptive_ftc import load_scenario                                 # doctest: +SKIP
>>> sc = load_scenario("hypersonic-direct-s1")                             # doctest: +SKIP
>>> r, frozen = sc.run(), sc.run(adapt=False)                              # doctest: +SKIP
>>> for c in evaluate_claims(sc.claims, r, frozen=frozen):                 # doctest: +SKIP
...     print(c.verdict, c.kind, c.measured, c.threshold)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from adaptive_ftc.errors import did_you_mean

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ftc.sim.result import SimResult

__all__ = ["CLAIM_KINDS", "ClaimError", "ClaimResult", "evaluate_claim", "evaluate_claims"]


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
    """

    kind: str
    text: str
    passed: bool
    measured: float
    threshold: float
    detail: str

    @property
    def verdict(self) -> str:
        """``"PASS"`` or ``"FAIL"``."""
        return "PASS" if self.passed else "FAIL"


# ---------------------------------------------------------------------------- key handling
#: kind -> (required keys, optional keys with defaults)
_KEYS: dict[str, tuple[tuple[str, ...], dict[str, Any]]] = {
    "tracking": (("threshold",), {"window": 20.0, "baseline_ratio": None}),
    "recovery": (("window", "threshold"), {}),
    "bounded": (("bound",), {}),
    "redistribution": (("time", "healthy", "window"), {"settle": 0.0, "factor": 1.1}),
    "recovered_used": (("actuator", "time", "window", "min_level"), {}),
    "fault_indicator": (("time", "window", "threshold"), {}),
    "modal_decay": (("states", "window", "fraction"), {}),
    "sign": (("window",), {}),
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
    allowed = {"kind", "text", *required, *optional}
    for key in claim:
        if key not in allowed:
            raise ClaimError(
                f"Unknown key '{key}' in {_name(claim)}.{did_you_mean(key, allowed)} "
                f"Keys of a '{kind}' claim: {', '.join(sorted(allowed))}."
            )
    for key in ("text", *required):
        if key not in claim:
            raise ClaimError(f"{_name(claim)} is missing the key '{key}'.")
    out = {**optional, **dict(claim)}
    for key, value in out.items():
        if key in ("kind", "text", "healthy", "states", "actuator") or value is None:
            continue
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise ClaimError(
                f"Key '{key}' of {_name(claim)} must be a finite number; got {value!r}."
            )
        if key in ("window", "threshold", "bound", "min_level", "fraction") and value <= 0:
            if not (key == "min_level" and value == 0):
                raise ClaimError(f"Key '{key}' of {_name(claim)} must be positive; got {value!r}.")
    return out


def _actuator_index(claim: Mapping[str, Any], key: str, value: Any, m: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= m:
        raise ClaimError(
            f"Key '{key}' of {_name(claim)} must give actuator numbers from 1 to {m}; "
            f"got {value!r}."
        )
    return int(value) - 1


# ---------------------------------------------------------------------------- helpers
def _t_end(result: SimResult) -> float:
    t_final = result.meta.get("t_final")
    if t_final is not None:
        return float(t_final)
    return float(result.time[-1]) if result.time.size else 0.0


def _mask(result: SimResult, start: float, end: float, *, right_open: bool = False) -> np.ndarray:
    t = result.time
    lo = t >= start - 1e-9
    hi = t < end - 1e-9 if right_open else t <= end + 1e-9
    return lo & hi


def _uncovered(result: SimResult) -> str:
    """Why a window has no samples: the run diverged, or it ends before the window."""
    if why := _diverged(result):
        return why
    end = f"{result.time[-1]:.4g} s" if result.time.size else "its start"
    return f"the run ends at {end}"


def _diverged(result: SimResult) -> str:
    if result.status == "completed":
        return ""
    stop = f"{result.time[-1]:.4g} s" if result.time.size else "the start"
    return f"run {result.status} at t = {stop}" + (f" ({result.message})" if result.message else "")


def _fail(claim: Mapping[str, Any], threshold: float, detail: str) -> ClaimResult:
    return ClaimResult(
        kind=str(claim["kind"]),
        text=str(claim.get("text", "")),
        passed=False,
        measured=math.nan,
        threshold=float(threshold),
        detail=detail,
    )


def _verdict(
    claim: Mapping[str, Any], passed: bool, measured: float, threshold: float, detail: str
) -> ClaimResult:
    return ClaimResult(
        kind=str(claim["kind"]),
        text=str(claim.get("text", "")),
        passed=bool(passed),
        measured=float(measured),
        threshold=float(threshold),
        detail=detail,
    )


def _window_rms(result: SimResult, start: float, end: float) -> np.ndarray | None:
    mask = _mask(result, start, end)
    if not mask.any():
        return None
    return np.sqrt(np.mean(result.e[mask] ** 2, axis=0))


def _fmt(x: float) -> str:
    return f"{x:.4g}"


# ---------------------------------------------------------------------------- kinds
def _tracking(c: dict[str, Any], r: SimResult, frozen: SimResult | None) -> ClaimResult:
    window, thr, ratio_req = float(c["window"]), float(c["threshold"]), c["baseline_ratio"]
    if ratio_req is not None and frozen is None:
        raise ClaimError(
            f"{_name(c)} has 'baseline_ratio' and needs the frozen-adaptation run: "
            "pass frozen=scenario.run(adapt=False)."
        )
    end = _t_end(r)
    start = end - window
    if (why := _diverged(r)) or (rms := _window_rms(r, start, end)) is None:
        return _fail(c, thr, why or f"no samples in the last {window:g} s")
    worst = float(np.max(rms))
    ok = bool(np.all(rms <= thr))
    names = ", ".join(f"{n} {_fmt(v)}" for n, v in zip(r.output_names, rms, strict=True))
    detail = f"RMS error over [{start:g}, {end:g}] s: {names} (<= {_fmt(thr)} required)"
    if ratio_req is not None:
        if frozen is None or _diverged(frozen) or (frms := _window_rms(frozen, start, end)) is None:
            ratio = math.inf
            detail += "; frozen-adaptation baseline diverged (infinitely worse)"
        else:
            f_worst = float(np.max(frms))
            ratio = f_worst / worst if worst > 0 else math.inf
            detail += (
                f"; frozen-adaptation RMS {_fmt(f_worst)} = {_fmt(ratio)} x adaptive "
                f"(>= {_fmt(float(ratio_req))} x required)"
            )
        ok = ok and ratio >= float(ratio_req)
    return _verdict(c, ok, worst, thr, detail)


def _recovery(c: dict[str, Any], r: SimResult, frozen: SimResult | None) -> ClaimResult:
    window, thr = float(c["window"]), float(c["threshold"])
    if why := _diverged(r):
        return _fail(c, thr, why)
    events = list(r.failure_times)
    if not events:
        return _fail(c, thr, "the run has no failure/recovery events to recover from")
    ends = events[1:] + [_t_end(r)]
    worst, parts, ok = 0.0, [], True
    for t, nxt in zip(events, ends, strict=True):
        rms = _window_rms(r, max(t, nxt - window), nxt)
        if rms is None:
            return _fail(c, thr, f"no samples before the event after t = {t:g} s")
        value = float(np.max(rms))
        worst = max(worst, value)
        ok = ok and bool(np.all(rms <= thr))
        parts.append(f"t={t:g}: {_fmt(value)}")
    detail = (
        f"RMS error over the last {window:g} s before the next event, per event: "
        f"{'; '.join(parts)} (<= {_fmt(thr)} required)"
    )
    return _verdict(c, ok, worst, thr, detail)


def _bounded(c: dict[str, Any], r: SimResult, frozen: SimResult | None) -> ClaimResult:
    bound = float(c["bound"])
    if why := _diverged(r):
        return _fail(c, bound, why)
    signals = {"plant state": r.states, "commanded": r.u_cmd, "applied": r.u_applied}
    peaks = {k: float(np.max(np.abs(v))) if v.size else 0.0 for k, v in signals.items()}
    finite = all(np.all(np.isfinite(v)) for v in signals.values())
    worst = max(peaks.values()) if finite else math.inf
    detail = "largest |.|: " + ", ".join(f"{k} {_fmt(v)}" for k, v in peaks.items())
    return _verdict(c, finite and worst <= bound, worst, bound, f"{detail} (<= {_fmt(bound)})")


def _redistribution(c: dict[str, Any], r: SimResult, frozen: SimResult | None) -> ClaimResult:
    m = len(r.actuator_names)
    healthy = c["healthy"]
    if isinstance(healthy, (int, np.integer)) and not isinstance(healthy, bool):
        healthy = [healthy]
    if not isinstance(healthy, Sequence) or isinstance(healthy, str) or not healthy:
        raise ClaimError(f"Key 'healthy' of {_name(c)} must be a list of actuator numbers.")
    idx = [_actuator_index(c, "healthy", j, m) for j in healthy]
    t, window, settle, factor = (float(c[k]) for k in ("time", "window", "settle", "factor"))
    before = _mask(r, t - window, t, right_open=True)
    after = _mask(r, t + settle, t + settle + window)
    if not before.any() or not after.any():
        return _fail(c, factor, f"no samples around t = {t:g} s: {_uncovered(r)}")
    lvl_before = float(np.mean(np.abs(r.u_applied[np.ix_(before, idx)])))
    lvl_after = float(np.mean(np.abs(r.u_applied[np.ix_(after, idx)])))
    ratio = lvl_after / lvl_before if lvl_before > 0 else (math.inf if lvl_after > 0 else 0.0)
    names = ", ".join(r.actuator_names[j] for j in idx)
    detail = (
        f"mean |applied| of {names}: {_fmt(lvl_before)} over [{t - window:g}, {t:g}) s, "
        f"{_fmt(lvl_after)} over [{t + settle:g}, {t + settle + window:g}] s: "
        f"ratio {_fmt(ratio)} (> {_fmt(factor)} required)"
    )
    return _verdict(c, ratio > factor, ratio, factor, detail)


def _recovered_used(c: dict[str, Any], r: SimResult, frozen: SimResult | None) -> ClaimResult:
    j = _actuator_index(c, "actuator", c["actuator"], len(r.actuator_names))
    t, window, level = float(c["time"]), float(c["window"]), float(c["min_level"])
    mask = _mask(r, t, t + window)
    if not mask.any():
        return _fail(c, level, f"no samples in [{t:g}, {t + window:g}] s: {_uncovered(r)}")
    used = float(np.mean(np.abs(r.u_applied[mask, j])))
    detail = (
        f"mean |applied| of {r.actuator_names[j]} over [{t:g}, {t + window:g}] s: "
        f"{_fmt(used)} (>= {_fmt(level)} required)"
    )
    return _verdict(c, used >= level, used, level, detail)


def _fault_indicator(c: dict[str, Any], r: SimResult, frozen: SimResult | None) -> ClaimResult:
    t, window, thr = float(c["time"]), float(c["window"]), float(c["threshold"])
    before = np.flatnonzero(r.time < t - 1e-9)
    mask = _mask(r, t, t + window)
    if before.size == 0 or not mask.any():
        return _fail(c, thr, f"no samples around t = {t:g} s: {_uncovered(r)}")
    ref = float(r.u_f[before[-1]])
    move = float(np.max(np.abs(r.u_f[mask] - ref)))
    detail = (
        f"compensator u_f moves by {_fmt(move)} within [{t:g}, {t + window:g}] s from "
        f"{_fmt(ref)} just before (>= {_fmt(thr)} required)"
    )
    return _verdict(c, move >= thr, move, thr, detail)


def _modal_decay(c: dict[str, Any], r: SimResult, frozen: SimResult | None) -> ClaimResult:
    states = c["states"]
    if isinstance(states, str):
        states = [states]
    if not isinstance(states, Sequence) or not states:
        raise ClaimError(f"Key 'states' of {_name(c)} must be a list of state names.")
    idx = []
    for name in states:
        if name not in r.state_names:
            raise ClaimError(
                f"Key 'states' of {_name(c)} names '{name}', which is not a state of this run."
                f"{did_you_mean(str(name), r.state_names)} States: {', '.join(r.state_names)}."
            )
        idx.append(r.state_names.index(name))
    window, fraction = float(c["window"]), float(c["fraction"])
    end = _t_end(r)
    mask = _mask(r, end - window, end)
    if (why := _diverged(r)) or not mask.any():
        return _fail(c, fraction, why or f"no samples in the last {window:g} s")
    disp = np.abs(r.states[:, idx])
    peak = float(np.max(disp))
    last = float(np.max(disp[mask]))
    ratio = last / peak if peak > 0 else 0.0
    detail = (
        f"largest |{', '.join(states)}| over the last {window:g} s: {_fmt(last)}, over the run: "
        f"{_fmt(peak)}: ratio {_fmt(ratio)} (<= {_fmt(fraction)} required)"
    )
    return _verdict(c, ratio <= fraction, ratio, fraction, detail)


def _sign(c: dict[str, Any], r: SimResult, frozen: SimResult | None) -> ClaimResult:
    window = float(c["window"])
    end = _t_end(r)
    mask = _mask(r, end - window, end)
    if (why := _diverged(r)) or not mask.any():
        return _fail(c, 1.0, why or f"no samples in the last {window:g} s")
    est, true = np.sign(r.gain[mask]), np.sign(r.control_gain[mask])
    agree = float(np.mean((est == true) & (true != 0)))
    wrong = np.flatnonzero(est != true)
    detail = (
        f"sign of the direction estimate equals the true control direction at "
        f"{agree:.2%} of the samples in [{end - window:g}, {end:g}] s (100% required)"
    )
    if wrong.size:
        detail += f"; first mismatch at t = {r.time[mask][wrong[0]]:.4g} s"
    else:
        detail += f"; true direction {int(true[-1]):+d}"
    return _verdict(c, agree == 1.0, agree, 1.0, detail)


_EVALUATORS: dict[str, Callable[[dict[str, Any], SimResult, SimResult | None], ClaimResult]] = {
    "tracking": _tracking,
    "recovery": _recovery,
    "bounded": _bounded,
    "redistribution": _redistribution,
    "recovered_used": _recovered_used,
    "fault_indicator": _fault_indicator,
    "modal_decay": _modal_decay,
    "sign": _sign,
}


# ---------------------------------------------------------------------------- public API
def evaluate_claim(
    claim: Mapping[str, Any], result: SimResult, *, frozen: SimResult | None = None
) -> ClaimResult:
    """Evaluate one ``[[claims]]`` table on a recorded run.

    Parameters
    ----------
    claim
        The claim table: ``kind``, ``text`` and the keys of its kind (``docs/claims.md``).
    result
        The adaptive run with failures.
    frozen
        The same scenario with adaptation frozen; needed by ``tracking`` claims with
        ``baseline_ratio``.

    Returns
    -------
    ClaimResult
        Verdict, measured number, threshold and a one-line explanation. A run that diverged
        before the judged window FAILs (with ``measured = nan`` when nothing could be measured).

    Raises
    ------
    ClaimError
        Unknown kind, missing/unknown/invalid key (the message names the claim and the key), or
        a ``baseline_ratio`` claim evaluated without ``frozen``.
    """
    params = _params(claim)
    return _EVALUATORS[params["kind"]](params, result, frozen)


def evaluate_claims(
    claims: Sequence[Mapping[str, Any]], result: SimResult, *, frozen: SimResult | None = None
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
            out.append(evaluate_claim(claim, result, frozen=frozen))
        except ClaimError as exc:
            raise ClaimError(f"[[claims]] #{i + 1}: {exc}") from None
    return out
