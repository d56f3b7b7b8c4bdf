"""Every catalogue trajectory is bit-identical to the fingerprints stored before a refactoring.

The fingerprints (``tests/data/trajectory_hashes.json``, written by
``python scripts/trajectory_hashes.py``) cover each catalogue scenario's own run, the thesis law
beside every constraint-aware design, and the fixed-gain, nominal-inverse and oracle baselines on
a short horizon. On the CPU that recorded them the SHA-256 of every recorded array must match;
on another CPU (where LLVM may fuse or vectorise differently) the arrays' sums must agree to 1e-9
of their scale. A change of a trajectory that is meant (a new design option's default, a bug fix)
re-records the file in the same commit, and the commit message says why.
"""

from __future__ import annotations

import json
import warnings

from trajectory_fingerprints import OUT, compare, fingerprints


def test_every_catalogue_trajectory_matches_its_stored_fingerprint():
    stored = json.loads(OUT.read_text())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        now = fingerprints()
    assert len(now["runs"]) >= 100
    problems = compare(stored, now)
    assert not problems, "trajectories changed:\n" + "\n".join(problems)


def test_the_comparison_catches_a_one_ulp_change():
    stored = json.loads(OUT.read_text())
    key = "hypersonic-direct-s1"
    changed = json.loads(json.dumps(stored))
    changed["runs"][key]["sha256"] = "0" * 64
    assert any(key in p for p in compare(stored, changed))
    other_cpu = dict(changed, host="elsewhere")
    x, scale = other_cpu["runs"][key]["sums"]["u0"]
    other_cpu["runs"][key]["sums"]["u0"] = [x + 1e-6 * scale, scale]
    assert any(key in p for p in compare(stored, other_cpu))
