"""Streaming campaigns (issue 29): ``results.parquet`` is gathered from the per-chunk parts into
large row groups (one per part made a 100,000-member table 2,000 row groups of 50 rows: 10 s
and 560 MiB to read for the summary, against 0.3 s and 130 MiB), with the same rows.
benchmarks/bench_campaign_memory.py measures the memory against the number of members."""

from __future__ import annotations

import pandas as pd
import pyarrow.parquet as pq
import pytest

from adaptive_ftc.campaigns import load_campaign, run_campaign, store

SPEC = {
    "name": "streaming",
    "base": "hypersonic-direct-s1",
    "designs": ["adaptive"],
    "runs": 7,
    "seed": 3,
    "chunk_size": 2,
    "duration": 1.0,
    "success": {"rms_error_final": 0.01, "final_window": 0.5},
    "failures": {
        "count": {"integers": [1, 1]},
        "onset": {"uniform": [0.2, 0.8]},
        "models": {"loss_of_effectiveness": {"effectiveness": {"uniform": [0.2, 0.9]}}},
    },
}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    spec = load_campaign(SPEC)
    out = tmp_path_factory.mktemp("stream") / "c"
    run_campaign(spec, out, jobs=1, progress=False, summary=False)
    return spec, out


def _parts(spec, out) -> pd.DataFrame:
    frames = [pd.read_parquet(store.part_path(out, c)) for c in range(spec.n_chunks)]
    return pd.concat(frames, ignore_index=True)


@pytest.mark.parametrize(("group", "sizes"), [(3, [4, 3]), (5, [6, 1]), (100, [7])])
def test_results_gather_parts_into_row_groups(campaign, monkeypatch, group, sizes):
    """Parts of 2 rows (the last of 1) gathered until a group holds ``group`` rows or the parts
    end; the table is the parts' rows in order, with the campaign's schema."""
    spec, out = campaign
    monkeypatch.setattr(store, "RESULTS_ROW_GROUP", group)
    path = store.write_results(spec, out)
    meta = pq.ParquetFile(path).metadata
    assert [meta.row_group(i).num_rows for i in range(meta.num_row_groups)] == sizes
    assert pq.read_schema(path).equals(store.schema(spec), check_metadata=False)
    pd.testing.assert_frame_equal(pd.read_parquet(path), _parts(spec, out))


def test_default_row_group_holds_the_whole_small_campaign(campaign):
    spec, out = campaign
    path = store.write_results(spec, out)
    assert pq.ParquetFile(path).metadata.num_row_groups == 1
    assert store.read_results(out)["index"].tolist() == list(range(SPEC["runs"]))
