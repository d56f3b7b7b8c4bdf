"""Fault campaigns: seeded random failure scenarios, replayable, resumable, local or on Dask.

    from adaptive_ftc.campaigns import load_campaign, run_campaign
    run = run_campaign(load_campaign("hypersonic-loe"), "out-campaign", jobs=2)

See ``docs/campaigns.md`` for the spec format and the results folder.
"""

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
