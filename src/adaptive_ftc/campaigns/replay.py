"""Replaying one campaign member exactly, with its full trajectory, figures and metrics."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path
from typing import Any

from adaptive_ftc.campaigns.runner import outcome
from adaptive_ftc.campaigns.sampling import draw_member
from adaptive_ftc.campaigns.spec import CampaignError, CampaignSpec, load_campaign
from adaptive_ftc.campaigns.store import check_manifest, read_results
from adaptive_ftc.errors import DivergenceWarning
from adaptive_ftc.sim.engine import simulate

__all__ = ["load_saved_spec", "replay_member"]


def load_saved_spec(folder: str | Path) -> CampaignSpec:
    """The spec saved in a campaign folder (``campaign.json``)."""
    path = Path(folder) / "campaign.json"
    if not path.is_file():
        raise CampaignError(
            f"'{folder}' is not a campaign folder (no campaign.json). Give the --out folder of "
            "'aftc campaign'."
        )
    try:
        data = json.loads(path.read_text("utf-8"))
    except (OSError, ValueError) as exc:
        raise CampaignError(f"'{path}' is unreadable ({exc}).") from None
    if not isinstance(data, dict):
        raise CampaignError(f"'{path}' does not hold a campaign spec (a JSON object).")
    spec = load_campaign(data, base_dir=Path(folder))
    check_manifest(spec, folder)  # an edited campaign.json is refused, not trusted
    return spec


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def replay_member(
    folder: str | Path,
    index: int,
    out: str | Path,
    *,
    designs: tuple[str, ...] | None = None,
    figures: bool = True,
) -> dict[str, Any]:
    """Rerun member ``index`` of the campaign in ``folder`` and write, in ``out``, its full
    trajectories (``data/*.nc``), figures and ``metrics.json`` (like ``aftc run``).

    The recomputed table row is compared with the one in the campaign's results:
    ``"matches_table"`` is True when every column is identical (bit for bit).

    Raises
    ------
    CampaignError
        When ``folder`` is not a campaign folder or ``index`` is out of range.
    """
    spec = load_saved_spec(folder)
    if isinstance(index, bool) or not 0 <= int(index) < spec.runs:
        raise CampaignError(
            f"Member index {index} is out of range: the campaign has {spec.runs} members "
            f"(0..{spec.runs - 1})."
        )
    index = int(index)
    designs = tuple(designs or spec.designs)
    for d in designs:
        if d not in spec.designs:
            raise CampaignError(
                f"Design '{d}' is not part of this campaign ({', '.join(spec.designs)})."
            )
    member = draw_member(spec, index)
    if member.loop is None:
        raise CampaignError(f"Member {index} could not be built: {member.error}")
    table = read_results(folder)
    stored = table[table["index"] == index]
    out = Path(out)
    (out / "data").mkdir(parents=True, exist_ok=True)
    results, rows = {}, {}
    matches: dict[str, bool | None] = {}  # None: the stored chunk has not run
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DivergenceWarning)
        for d in designs:
            res = simulate(member.design_loop(d), spec.solver)
            res.meta["scenario"] = f"{spec.name}[{index}]"
            res.meta["campaign_design"] = d
            results[d] = res
            row = {**member.columns, "design": d, **outcome(res, spec)}
            if spec.allocation_columns:
                row["allocator"] = spec.allocator_kind(d)
            rows[d] = row
            ref = stored[stored["design"] == d]
            if ref.empty:
                matches[d] = None  # this chunk has not run yet
            else:
                rec = ref.iloc[0].to_dict()
                matches[d] = all(_same(_py(rec[k]), _py(v)) for k, v in row.items() if k in rec)
            res.to_netcdf(out / "data" / f"{spec.name}_{index}_{d}.nc")
    written = []
    if figures:
        from adaptive_ftc import plots

        main = results[designs[0]]
        others = {k: v for k, v in results.items() if k != designs[0]}
        for i, fspec in enumerate(plots.default_figure_specs(main)):
            path = out / "figures" / f"fig_{fspec.get('number', i + 1)}.png"
            written.append(str(plots.save_figure(main, fspec, path, baselines=others or None)))
    info = {
        "campaign": spec.name,
        "index": index,
        "failures": list(member.loop.describe_failures()),
        "rows": rows,
        "matches_table": matches,
        "recovery": {d: r.recovery() for d, r in results.items()},
        "figures": written,
    }
    (out / "metrics.json").write_text(json.dumps(info, indent=2, default=_json))
    return info


def _py(v: Any) -> Any:
    """numpy scalars to Python scalars, for exact comparison."""
    return v.item() if hasattr(v, "item") else v


def _json(v: Any) -> Any:
    if hasattr(v, "item"):
        return v.item()
    return str(v)
