"""Fault campaigns: seeded random failure scenarios, replayable, resumable, local or on Dask.

    from adaptive_ftc.campaigns import load_campaign, run_campaign
    run = run_campaign(load_campaign("hypersonic-loe"), "out-campaign", jobs=2)

See ``docs/campaigns.md`` for the spec format and the results folder.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from adaptive_ftc._lazy import lazy_attributes

if TYPE_CHECKING:
    from adaptive_ftc.campaigns.replay import replay_member
    from adaptive_ftc.campaigns.runner import CampaignRun, outcome, run_campaign, run_chunk
    from adaptive_ftc.campaigns.sampling import Member, draw_member, severity
    from adaptive_ftc.campaigns.spec import (
        DESIGN_VARIANTS,
        CampaignError,
        CampaignSpec,
        Dist,
        list_campaigns,
        load_campaign,
        register_design,
    )
    from adaptive_ftc.campaigns.store import read_results

#: ``{public name: module that defines it}``: imported on first use (PEP 562), so that the
#: ``aftc`` command line can build its parser without importing numpy, pandas or the compiler
_LAZY: dict[str, str] = {
    "replay_member": "adaptive_ftc.campaigns.replay",
    "CampaignRun": "adaptive_ftc.campaigns.runner",
    "outcome": "adaptive_ftc.campaigns.runner",
    "run_campaign": "adaptive_ftc.campaigns.runner",
    "run_chunk": "adaptive_ftc.campaigns.runner",
    "Member": "adaptive_ftc.campaigns.sampling",
    "draw_member": "adaptive_ftc.campaigns.sampling",
    "severity": "adaptive_ftc.campaigns.sampling",
    "DESIGN_VARIANTS": "adaptive_ftc.campaigns.spec",
    "CampaignError": "adaptive_ftc.campaigns.spec",
    "CampaignSpec": "adaptive_ftc.campaigns.spec",
    "Dist": "adaptive_ftc.campaigns.spec",
    "list_campaigns": "adaptive_ftc.campaigns.spec",
    "load_campaign": "adaptive_ftc.campaigns.spec",
    "register_design": "adaptive_ftc.campaigns.spec",
    "read_results": "adaptive_ftc.campaigns.store",
}

__all__ = [
    "DESIGN_VARIANTS",
    "CampaignError",
    "CampaignRun",
    "CampaignSpec",
    "Dist",
    "Member",
    "draw_member",
    "list_campaigns",
    "load_campaign",
    "outcome",
    "read_results",
    "register_design",
    "replay_member",
    "run_campaign",
    "run_chunk",
    "severity",
]


__getattr__, __dir__ = lazy_attributes(globals(), _LAZY)
