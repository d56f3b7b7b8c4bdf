"""Campaign success counts tracking and control activity (issue 25 item 5): a member succeeds
only when its run completes, tracks within ``[success] rms_error_final`` over the final window,
and its command is acceptable there (:mod:`adaptive_ftc.sim.activity`, worst actuator):

- fast content (RMS above ``f_c`` = 1 Hz) ``<= max_fast_rms_relative`` (default 0.03) times
  ``reference_peak_to_peak``;
- at a rate limit during ``<= max_rate_limited_fraction`` (default 0.05) of the final window;
- peak command within the declared travel where one is declared, else
  ``<= max_peak_relative`` (default 10) times ``reference_peak_command``.

The references default to the base scenario's ideal run: the thesis law (any
``constraint_aware`` option removed) on ideal hardware (no actuator model, no sensor noise,
continuous control), the base failures kept, over the campaign's duration; its largest
command peak to peak and peak ``|u|`` over the final window, over the actuators. A command
that is flat there (peak to peak below 1e-3 of the run's peak ``|u|``, e.g. a settled
regulation) gives no reference: the spec must state both numbers. It is run
once per process and campaign (about one run's time) unless the spec states both numbers.
``[success] activity = false`` judges tracking only (as before issue 25).

Members run with records fine enough to judge the activity (``record_dt`` lowered to
:func:`adaptive_ftc.sim.activity.max_record_dt` of the smallest sample time the campaign can
draw); the trajectories are reduced to their metrics row as before.
"""

from __future__ import annotations

import dataclasses
import math
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ftc.campaigns.spec import CampaignSpec

__all__ = ["ACTIVITY_SUCCESS_KEYS", "ActivityCriterion", "parse_activity"]

#: Keys of ``[success]`` that set the activity criterion, with their meaning.
ACTIVITY_SUCCESS_KEYS: dict[str, str] = {
    "activity": "judge the control activity too (true/false, default true)",
    "max_fast_rms_relative": "fast content (RMS above 1 Hz) / reference peak to peak (> 0, "
    "default 0.03)",
    "reference_peak_to_peak": "command peak to peak of the ideal run (> 0; default measured)",
    "max_rate_limited_fraction": "fraction of the final window at a rate limit (>= 0, "
    "default 0.05)",
    "max_peak_relative": "peak |command| / reference peak where no travel is declared (> 0, "
    "default 10)",
    "reference_peak_command": "peak |command| of the ideal run (> 0; default measured)",
}


@dataclass(frozen=True)
class ActivityCriterion:
    """The activity part of a campaign's success criterion (see the module docstring)."""

    max_fast_rms_relative: float = 0.03
    reference_peak_to_peak: float | None = None
    max_rate_limited_fraction: float = 0.05
    max_peak_relative: float = 10.0
    reference_peak_command: float | None = None

    def thresholds(self, spec: CampaignSpec) -> tuple[float, float]:
        """``(fast-content threshold, peak threshold without a travel)``, the references
        measured on the base's ideal run where the spec does not state them."""
        p2p, peak = self.reference_peak_to_peak, self.reference_peak_command
        if p2p is None or peak is None:
            m_p2p, m_peak = ideal_reference(spec)
            p2p = m_p2p if p2p is None else p2p
            peak = m_peak if peak is None else peak
        return self.max_fast_rms_relative * p2p, self.max_peak_relative * peak

    def judge(
        self,
        row: dict[str, Any],
        spec: CampaignSpec,
        *,
        thresholds: tuple[float, float] | None = None,
    ) -> tuple[bool, str]:
        """Whether the outcome ``row`` meets the criterion, and why not (``""`` when it does).
        ``thresholds``: :meth:`thresholds` of ``spec`` when the caller has them already (they
        are cached per campaign digest, but the digest hashes the whole spec)."""
        fast_max, peak_max = self.thresholds(spec) if thresholds is None else thresholds
        if not row.get("activity_record_ok", False):
            return False, "record too coarse to judge the activity"
        why = []
        fast = row.get("fast_rms_max", math.nan)
        if not fast <= fast_max:
            why.append(f"fast content {fast:.3g} > {fast_max:.3g}")
        rate = row.get("rate_limited_fraction_max", math.nan)
        if not math.isnan(rate) and rate > self.max_rate_limited_fraction:
            why.append(f"at a rate limit {rate:.3g} > {self.max_rate_limited_fraction:g}")
        travel = row.get("peak_command_travel_ratio_max", math.nan)
        # the ratio is 0 where no travel is declared (sim/activity.py), not nan: a member
        # without a travel is held to the peak bound (a 0 ratio with a travel: a zero
        # command, which meets the bound too)
        if travel > 0.0:
            if travel > 1.0:
                why.append(f"peak command {travel:.3g} x the travel")
        else:
            peak = row.get("peak_command_final", math.nan)
            if not peak <= peak_max:
                why.append(f"peak command {peak:.3g} > {peak_max:.3g}")
        return not why, "; ".join(why)

    def describe(self, spec: CampaignSpec) -> str:
        """The criterion in words, with its numbers."""
        fast_max, peak_max = self.thresholds(spec)
        return (
            f"fast command content (RMS above 1 Hz, worst actuator) <= {fast_max:.3g} "
            f"({self.max_fast_rms_relative:g} x the ideal run's peak to peak), "
            f"<= {self.max_rate_limited_fraction:g} of the window at a rate limit, peak command "
            f"within the declared travel (else <= {peak_max:.3g}, {self.max_peak_relative:g} x "
            "the ideal peak)"
        )


_CACHE: dict[str, tuple[float, float]] = {}
_LOCK = threading.Lock()


def ideal_reference(spec: CampaignSpec) -> tuple[float, float]:
    """``(largest command peak to peak, largest peak |command|)`` over the actuators in the
    final window of the base scenario's ideal run (see the module docstring); cached per
    campaign digest in this process."""
    key = spec.digest()
    with _LOCK:
        if key in _CACHE:
            return _CACHE[key]
        import warnings

        import numpy as np

        from adaptive_ftc.errors import DivergenceWarning
        from adaptive_ftc.sim.engine import simulate

        loop = spec.loop
        ctrl = loop.controller
        if getattr(ctrl, "constraint_aware", None) is not None:
            ctrl = dataclasses.replace(ctrl, constraint_aware=None)
        ideal = dataclasses.replace(
            loop, controller=ctrl, actuators=None, sensors=None, sample_time=0.0
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DivergenceWarning)
            r = simulate(ideal, spec.base.solver)
        t_end = float(r.time[-1])
        w = r.window(t_end - spec.final_window)
        u = r.u_cmd[w]
        from adaptive_ftc.errors import CampaignError

        if r.status != "completed" or u.size == 0:
            raise CampaignError(
                f"Campaign '{spec.name}': the base scenario's ideal run ({r.status}: "
                f"{r.message}) gives no reference for the activity criterion; state "
                "`reference_peak_to_peak` and `reference_peak_command` in [success] or set "
                "`activity = false`."
            )
        p2p = float(np.max(np.ptp(u, axis=0)))
        peak = float(np.max(np.abs(u)))
        # flat: below 1e-3 of the run's own peak |command| (a regulation that has settled)
        if not p2p > 1e-3 * float(np.max(np.abs(r.u_cmd))) or not peak > 0:
            raise CampaignError(
                f"Campaign '{spec.name}': the base scenario's ideal command is flat over the "
                f"final window (peak to peak {p2p:.3g}, peak {peak:.3g}; e.g. a regulation to "
                "0): no reference for the activity criterion. State `reference_peak_to_peak` "
                "and `reference_peak_command` in [success] (e.g. the ideal run's peak |command| "
                "over the whole run) or set `activity = false`."
            )
        _CACHE[key] = (p2p, peak)
        return p2p, peak


def parse_activity(table: dict[str, Any], problems: list[str]) -> ActivityCriterion | None:
    """The activity criterion of a ``[success]`` table (``None`` for ``activity = false``);
    problems are recorded, one line each."""
    on = table.get("activity", True)
    if not isinstance(on, bool):
        problems.append(f"[success] `activity` must be true or false; got {on!r}.")
        on = True
    kw: dict[str, Any] = {}
    for key in ACTIVITY_SUCCESS_KEYS:
        if key == "activity" or key not in table:
            continue
        v = table[key]
        ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        zero_ok = key == "max_rate_limited_fraction"
        if not ok or v < 0 or (v == 0 and not zero_ok):
            problems.append(f"[success] `{key}`: {ACTIVITY_SUCCESS_KEYS[key]}; got {v!r}.")
            continue
        kw[key] = float(v)
    if not on:
        if kw:
            problems.append(
                f"[success] `activity = false` judges tracking only: remove "
                f"{', '.join(f'`{k}`' for k in kw)} or set `activity = true`."
            )
        return None
    return ActivityCriterion(**kw)
