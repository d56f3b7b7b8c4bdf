"""The record-block pool (``sim/blocks.py``): taking the last free block of a size leaves no
empty entry behind, so that evicting the oldest size when the pool is over its limit never
pops from an empty list (it did: ``IndexError`` in the finaliser of a block given back,
"Exception ignored" on stderr and the pool's byte count left wrong; found by the lane engine,
whose groups hold eight blocks at once)."""

from __future__ import annotations

from collections import OrderedDict

from adaptive_ftc.sim import blocks


def test_eviction_after_the_last_block_of_a_size_was_taken(monkeypatch):
    monkeypatch.setattr(blocks, "_pool", OrderedDict())
    monkeypatch.setattr(blocks, "_pooled", 0)
    monkeypatch.setattr(blocks, "MAX_POOLED_BYTES", 6 << 20)
    small = blocks._take(4 << 20)
    blocks._give_back(small)  # pooled: one 4 MB block
    assert blocks._take(4 << 20) is small  # the last 4 MB block taken again
    blocks._give_back(bytearray(8 << 20))  # over the limit: the oldest size goes
    assert blocks.pooled_bytes() <= blocks.MAX_POOLED_BYTES
    assert all(blocks._pool.values())  # no empty entry left
