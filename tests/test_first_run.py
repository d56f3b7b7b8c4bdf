"""Time to first result (issue 29): what ``aftc run`` imports and computes on its warm path, and
that the faster path writes what the slower one did."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.signal import butter, sosfilt_zi, sosfiltfilt

from adaptive_ftc.sim import zerophase


@pytest.mark.parametrize("fs", [1000.0, 200.0, 1234.5])
def test_the_compiled_zero_phase_lowpass_is_scipys_bit_for_bit(fs):
    rng = np.random.default_rng(int(fs))
    sos, zi = zerophase.lowpass_design(4, 1.0, fs)
    truth = butter(4, 1.0, btype="low", fs=fs, output="sos")
    assert np.array_equal(sos, truth)
    assert np.array_equal(zi, sosfilt_zi(truth))
    for n, pad in ((5000, 3000), (400, 399), (100, 27)):
        u = np.cumsum(rng.standard_normal((n, 3)), axis=0) * 1e-3 + 1e-2 * rng.standard_normal(
            (n, 3)
        )
        expected = sosfiltfilt(truth, u, axis=0, padtype="odd", padlen=pad)
        assert np.array_equal(zerophase.sosfiltfilt_odd(sos, zi, u, pad), expected)


def test_a_lowpass_design_is_read_back_from_the_cache_folder_not_redesigned(tmp_path, monkeypatch):
    monkeypatch.setenv("ADAPTIVE_FTC_CACHE_DIR", str(tmp_path))
    zerophase.lowpass_design.cache_clear()
    sos, zi = zerophase.lowpass_design(4, 1.0, 977.0)
    (stored,) = (tmp_path / "loops").glob("lowpass_*.json")
    # a later process reads the file: make it say something scipy would not, to see it used
    data = json.loads(stored.read_text())
    data["sos"][0][0] = 0.5
    stored.write_text(json.dumps(data))
    zerophase.lowpass_design.cache_clear()
    again, _ = zerophase.lowpass_design(4, 1.0, 977.0)
    assert again[0, 0] == 0.5 and np.array_equal(again[1:], sos[1:])
    # a damaged file is redesigned (and rewritten), never an error
    stored.write_text("{not json")
    zerophase.lowpass_design.cache_clear()
    fresh, fresh_zi = zerophase.lowpass_design(4, 1.0, 977.0)
    assert np.array_equal(fresh, sos) and np.array_equal(fresh_zi, zi)
    assert json.loads(stored.read_text())["sos"] == sos.tolist()
    zerophase.lowpass_design.cache_clear()
