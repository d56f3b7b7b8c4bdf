"""Fault campaigns on a Dask LocalCluster (issue 13): the table equals the local run."""

from __future__ import annotations

import pandas as pd
import pytest

from adaptive_ftc.campaigns import load_campaign, read_results, run_campaign

distributed = pytest.importorskip("distributed")

from test_campaign import tiny  # noqa: E402


@pytest.mark.parametrize("processes", [False, True])
def test_dask_local_cluster_gives_the_same_table_as_local_threads(tmp_path, processes):
    spec = load_campaign(tiny())
    run_campaign(spec, tmp_path / "local", jobs=2, progress=False, summary=False)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=processes, dashboard_address=None
    ) as cluster:
        run = run_campaign(
            spec,
            tmp_path / "dask",
            scheduler=cluster.scheduler_address,
            progress=False,
            summary=False,
        )
    assert run.complete and run.runs_done_now == 12
    pd.testing.assert_frame_equal(
        read_results(tmp_path / "dask"), read_results(tmp_path / "local"), check_exact=True
    )


def test_unreachable_scheduler_is_a_clear_error(tmp_path, monkeypatch):
    from adaptive_ftc.campaigns import CampaignError
    from adaptive_ftc.campaigns import dask as campaign_dask

    monkeypatch.setattr(campaign_dask, "CONNECT_TIMEOUT", "2s")

    with pytest.raises(CampaignError, match="Cannot reach the Dask scheduler"):
        run_campaign(
            load_campaign(tiny()),
            tmp_path / "c",
            scheduler="tcp://127.0.0.1:1",
            progress=False,
        )
