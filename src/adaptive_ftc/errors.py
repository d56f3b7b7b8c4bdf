"""Error and warning types of adaptive-ftc.

Every user-facing failure is one of these, with a message that names the culprit and the fix.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

__all__ = [
    "CampaignError",
    "ConfigurationError",
    "DivergenceWarning",
    "ExpressionError",
    "ScenarioError",
    "did_you_mean",
]


class ConfigurationError(ValueError):
    """A component (plant, failure, controller, solver) was given an invalid setting."""


class ExpressionError(ValueError):
    """A failure or reference expression could not be parsed or is not allowed."""


class ScenarioError(ValueError):
    """A scenario file or scenario name is invalid."""


class CampaignError(ScenarioError):
    """A campaign spec is invalid (the message lists every problem, one per line)."""


class DivergenceWarning(RuntimeWarning):
    """A simulation stopped early because a signal became non-finite or exploded."""


def did_you_mean(name: str, choices: Iterable[str]) -> str:
    """Return ``" Did you mean 'x'?"`` for the closest choice, or an empty string."""
    close = difflib.get_close_matches(str(name), [str(c) for c in choices], n=1, cutoff=0.5)
    return f" Did you mean '{close[0]}'?" if close else ""
