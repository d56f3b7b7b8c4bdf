"""Campaign spec robustness (issue 26, "Campaign specs"; issue 25 item 5): every malformed or
absurd spec is a :class:`CampaignError` listing its problems, before anything runs; resuming
and replaying check the code version and the saved spec."""

from __future__ import annotations

import copy
import json
import time

import pytest

from adaptive_ftc import _version
from adaptive_ftc.campaigns import CampaignError, draw_member, load_campaign, run_campaign, store
from adaptive_ftc.campaigns.checks import _fill
from adaptive_ftc.campaigns.replay import load_saved_spec
from adaptive_ftc.campaigns.spec import MAX_CHUNKS, MAX_RUNS
from adaptive_ftc.cli import main as aftc
from adaptive_ftc.scenarios.expressions import MAX_LENGTH

BASE = {
    "name": "spec",
    "base": "hypersonic-direct-s1",
    "designs": ["adaptive"],
    "runs": 4,
    "seed": 3,
    "chunk_size": 2,
    "duration": 2.0,
    "success": {"rms_error_final": 0.01, "final_window": 0.5},
    "failures": {
        "count": 1,
        "onset": {"uniform": [0.5, 1.5]},
        "models": {
            "loss_of_effectiveness": {"effectiveness": {"uniform": [0.2, 0.9]}},
            "nonaffine": {
                "output": "{a}*u**3 + {c}",
                "params": {"a": {"uniform": [0.3, 1.0]}, "c": {"uniform": [-0.1, 0.1]}},
            },
        },
    },
}


def spec(**top):
    data = copy.deepcopy(BASE)
    for path, value in top.items():
        keys = path.split("__")
        parent = data
        for k in keys[:-1]:
            parent = parent.setdefault(k, {})
        parent[keys[-1]] = value
    return data


def problems(data) -> list[str]:
    with pytest.raises(CampaignError) as err:
        load_campaign(data)
    msg = str(err.value)
    assert "nothing was run" in msg
    return [ln[4:] for ln in msg.splitlines() if ln.startswith("  - ")]


# ---------------------------------------------------------------- the six internal errors
@pytest.mark.parametrize(
    "change, culprit",
    [
        ({"designs": [["adaptive"]]}, "`designs` lists names"),
        ({"base": {"name": "x"}}, "exactly the keys `name` and `text`"),
        ({"failures__models__nonaffine__output": "{0}*u"}, "braces are only allowed"),
        ({"failures__ramp": []}, "[failures.ramp] must be one number"),
        ({"failures__onset": [{"uniform": [1, 2]}]}, "[failures.onset] must be one number"),
        ({"failures__duration": []}, "[failures.duration] must be one number"),
    ],
)
def test_former_internal_errors_are_spec_errors_naming_the_key(change, culprit):
    assert any(culprit in p for p in problems(spec(**change)))


# ---------------------------------------------------------------- limits with a size estimate
def test_absurd_sizes_are_refused_with_the_estimate():
    (p,) = problems(spec(runs=2**63 - 1))
    assert "simulations" in p and "PiB" in p and str(MAX_RUNS) in p
    (p,) = problems(spec(chunk_size=10**15))
    assert "closed loops" in p and "in memory" in p
    (p,) = problems(spec(chunk_size=1e15))  # a float is not a whole number
    assert "`chunk_size` must be a whole number" in p
    (p,) = problems(spec(duration=1e300))
    assert "recorded samples" in p and "TiB" in p


def test_the_chunk_count_is_bounded_and_the_fix_named():
    (p,) = problems(spec(runs=10**8, chunk_size=1))
    assert "limit is 10000000 members" in p
    (p,) = problems(spec(runs=10**6, chunk_size=1))
    assert f"limit is {MAX_CHUNKS} chunks" in p and "at least 10" in p
    assert load_campaign(spec(runs=10**6, chunk_size=10)).n_chunks == MAX_CHUNKS


def test_a_huge_campaign_starts_its_first_chunk_without_listing_every_part(tmp_path, monkeypatch):
    """runs = 1e6 in 1e5 chunks: resume detection lists parts/ once (no stat per chunk) and
    the pending chunks are produced lazily."""
    data = spec(runs=10**6, chunk_size=10, duration=0.5)
    data["success"]["final_window"] = 0.1
    data["failures"]["onset"] = {"uniform": [0.1, 0.3]}
    calls = []
    real = store.part_path
    monkeypatch.setattr(store, "part_path", lambda out, c: calls.append(c) or real(out, c))
    start = time.process_time()
    run = run_campaign(load_campaign(data), tmp_path / "c", max_chunks=1, progress=False)
    assert run.runs_done_now == 10 and not run.complete
    assert calls == [0]  # only the written part, not one stat per chunk
    assert store.finished_chunks(load_campaign(data), tmp_path / "c") == {0}
    assert time.process_time() - start < 60  # not a measurement: a hang would never finish


def test_finished_chunks_ignores_foreign_and_out_of_range_files(tmp_path):
    sp = load_campaign(spec())  # 2 chunks
    parts = tmp_path / "parts"
    parts.mkdir()
    for name in ("part-00000.parquet", "part-00007.parquet", "x.parquet", ".part-00001.tmp"):
        (parts / name).write_text("")
    (parts / "part-00001.parquet").mkdir()
    assert store.finished_chunks(sp, tmp_path) == {0}
    assert store.finished_chunks(sp, tmp_path / "none") == set()


# ---------------------------------------------------------------- domains of drawn values
@pytest.mark.parametrize("amp", [0, -1.0, {"uniform": [-1.0, 1.0]}, {"choice": [1.0, 0.0]}])
def test_a_reference_amplitude_of_zero_or_below_is_refused(amp):
    (p,) = problems(spec(ranges={"reference_amplitude": amp}))
    assert "[ranges.reference_amplitude]" in p and "must be > 0" in p


@pytest.mark.parametrize(
    "where, value",
    [
        ("failures__models__loss_of_effectiveness__effectiveness", {"normal": [0.5, 0.3]}),
        ("failures__models__nonaffine__params__a", {"normal": [0.5, 0.3]}),
        ("ranges__gains__gamma", {"normal": [1.0, 0.3]}),
        ("ranges__reference_amplitude", {"normal": [1.0, 0.3]}),
    ],
)
def test_an_unclipped_normal_feeding_a_model_is_refused(where, value):
    found = problems(spec(**{where: value}))
    assert any("`normal` without `clip`" in p and "clip = [" in p for p in found)


def test_a_clipped_normal_draws_inside_its_clip():
    sp = load_campaign(
        spec(
            failures__models={
                "loss_of_effectiveness": {"effectiveness": {"normal": [0.5, 2.0], "clip": [0, 1]}}
            },
            runs=200,
        )
    )
    drawn = [draw_member(sp, i).params[0]["effectiveness"] for i in range(200)]
    assert min(drawn) == 0.0 and max(drawn) == 1.0  # sd 2: both clip ends are reached
    assert all(0.0 <= v <= 1.0 for v in drawn)


def test_a_param_is_checked_at_both_ends_of_its_range():
    """The param of a nonaffine output is tried at its upper end too (only the lower end was)."""
    found = problems(
        spec(
            failures__models={
                "affine": {
                    "effectiveness": 0.5,
                    "bias": "{b}",
                    "params": {"b": {"uniform": [0, 1e300]}},
                }
            }
        )
    )
    assert any("impossible draw" in p for p in found)


# ---------------------------------------------------------------- keys and types
@pytest.mark.parametrize(
    "change, culprit",
    [
        ({"ranges": {"gains": 1}}, "[ranges.gains] must be a table"),
        ({"failures__keep_base": "no"}, "`keep_base` must be true or false"),
        ({"failures__keep_base": 1}, "`keep_base` must be true or false"),
        ({"title": 3}, "`title` must be a text"),
        ({"name": "../x"}, "`name` '../x' is used in file names"),
        ({"designs": ["adaptive", "adaptive"]}, "listed twice"),
        ({"base": 3}, "`base` must be a catalogue scenario name"),
        ({"failures__onset": {"uniform": [0.5, 1.5], "weights": [1, 1]}}, "`weights` only"),
        ({"failures__models__nonaffine__params__9x": 1.0}, "not a usable placeholder"),
    ],
)
def test_wrongly_typed_keys_are_refused_not_ignored(change, culprit):
    assert any(culprit in p for p in problems(spec(**change)))


def test_every_problem_is_listed_at_once_even_with_a_broken_base():
    found = problems(
        spec(
            base="hypersonc-direct-s1",
            runs=0,
            designs=["adaptive", 3],
            frobnicate=1,
            title=[],
        )
    )
    assert len(found) == 5
    assert any(p.startswith("[base] Unknown scenario") for p in found)
    assert any("unknown key 'frobnicate'" in p for p in found)
    assert any("`runs` must be a whole number" in p for p in found)


# ---------------------------------------------------------------- kept and drawn failures
def test_a_drawn_failure_that_can_overlap_a_kept_one_is_refused_naming_actuator_and_windows():
    """hypersonic-direct-s1 keeps a stuck elevator 2 from 40 s and an affine elevator 1 from
    80 s: drawing on both actuators from 10 s would make every member invalid (0 %)."""
    data = spec(duration=120.0, failures__keep_base=True)
    data["success"]["final_window"] = 20.0
    data["failures"]["onset"] = {"uniform": [10.0, 30.0]}
    found = problems(data)
    assert len(found) == 2
    assert any("actuator 2 over [40, end of run)" in p and "[10, end of run)" in p for p in found)
    assert any("actuator 1 over [80, end of run)" in p for p in found)
    assert all("keep_base = false" in p for p in found)


def test_drawn_failures_that_end_before_the_kept_one_are_accepted_and_valid():
    data = spec(duration=120.0, failures__keep_base=True)
    data["success"]["final_window"] = 20.0
    data["failures"].update(
        onset={"uniform": [10.0, 20.0]}, recovery_probability=1.0, duration={"uniform": [1, 5]}
    )
    sp = load_campaign(data)
    members = [draw_member(sp, i) for i in range(sp.runs)]
    assert all(m.loop is not None and m.error == "" for m in members)
    assert all(len(m.loop.failures.failures) == 3 for m in members)  # 2 kept + 1 drawn


# ---------------------------------------------------------------- structural placeholders
def test_placeholders_are_substituted_as_before_and_nothing_else_is_formatted():
    params = {"a": 0.5, "c": -0.1}
    old = "{a}*u**3 + {c}".format(**{k: f"({float(v)!r})" for k, v in params.items()})
    assert _fill("{a}*u**3 + {c}", params) == old == "(0.5)*u**3 + (-0.1)"
    for bad in ("{a:>3000000000}*u", "{0}*u", "{{a}}*u", "u}", "{a!r}", "{ a }"):
        start = time.process_time()
        with pytest.raises(CampaignError, match="braces are only allowed"):
            _fill(bad, params)
        assert time.process_time() - start < 1  # no 3 GB padding was built first
    with pytest.raises(CampaignError, match=r"unknown placeholder \{b\}.*drawn params are a, c"):
        _fill("{b}*u", params)


def test_the_length_limit_is_checked_before_substitution():
    long = "{a}+" * (MAX_LENGTH // 4) + "u"
    with pytest.raises(CampaignError, match=f"{len(long)} characters; the limit is {MAX_LENGTH}"):
        _fill(long, {"a": 1.0})
    grows = "{a}+" * 300 + "u"  # 1201 characters, 300 x '(0.30000000000000004)'
    with pytest.raises(CampaignError, match="once its params are substituted"):
        _fill(grows, {"a": 0.1 + 0.2})


def test_a_format_spec_in_a_spec_file_is_a_spec_error():
    found = problems(spec(failures__models__nonaffine__output="{a:>3000000000}*u"))
    assert any("braces are only allowed" in p and "nonaffine.output" in p for p in found)


# ---------------------------------------------------------------- version and saved spec
def test_resuming_after_an_upgrade_is_refused_with_how_to_start_fresh(tmp_path, monkeypatch):
    data = spec(runs=2, chunk_size=1, duration=0.5)
    data["success"]["final_window"] = 0.1
    data["failures"]["onset"] = {"uniform": [0.1, 0.3]}
    out = tmp_path / "c"
    run_campaign(load_campaign(data), out, max_chunks=1, progress=False)
    assert json.loads((out / "manifest.json").read_text())["version"] == _version.__version__
    before = _version.__version__
    monkeypatch.setattr(_version, "__version__", "99.0.0")
    with pytest.raises(CampaignError) as err:
        run_campaign(load_campaign(data), out, progress=False)
    msg = str(err.value)
    assert f"written by adaptive-ftc {before}; this is 99.0.0" in msg
    assert "mix" in msg and "delete" in msg
    assert store.finished_chunks(load_campaign(data), out) == {0}  # nothing was added


def test_replay_refuses_an_edited_campaign_json(tmp_path, capsys):
    data = spec(runs=2, chunk_size=1, duration=0.5)
    data["success"]["final_window"] = 0.1
    data["failures"]["onset"] = {"uniform": [0.1, 0.3]}
    out = tmp_path / "c"
    run_campaign(load_campaign(data), out, progress=False, summary=False)
    assert load_saved_spec(out).digest() == load_campaign(data).digest()
    saved = json.loads((out / "campaign.json").read_text())
    saved["success"]["rms_error_final"] = 1.0  # every member would now "succeed"
    (out / "campaign.json").write_text(json.dumps(saved))
    with pytest.raises(CampaignError, match="does not match the digest"):
        load_saved_spec(out)
    assert aftc(["campaign", "replay", str(out), "0", "--out", str(tmp_path / "r")]) == 2
    assert "was edited" in capsys.readouterr().err
    (out / "manifest.json").unlink()
    with pytest.raises(CampaignError, match="no usable manifest.json"):
        load_saved_spec(out)


@pytest.mark.parametrize(
    "content, match",
    [
        (b"\xff\xfe bad", "not UTF-8 text"),
        (b"runs = [", "not valid TOML"),
        (b"# " + b"x" * 1_000_001, "limited to 1000000 bytes"),
    ],
)
def test_an_unreadable_spec_file_is_a_spec_error(tmp_path, content, match):
    path = tmp_path / "spec.toml"
    path.write_bytes(content)
    with pytest.raises(CampaignError, match=match):
        load_campaign(path)


def test_a_folder_of_a_version_that_recorded_none_is_refused_on_resume(tmp_path):
    data = spec(runs=2, chunk_size=1, duration=0.5)
    data["success"]["final_window"] = 0.1
    data["failures"]["onset"] = {"uniform": [0.1, 0.3]}
    sp = load_campaign(data)
    out = store.prepare_folder(sp, tmp_path / "c")
    manifest = json.loads((out / "manifest.json").read_text())
    del manifest["version"]
    manifest["digest"] = "0" * 64  # what the digest without the version would differ by
    (out / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(CampaignError, match=r"an earlier version \(none recorded\)"):
        store.prepare_folder(sp, out)


def test_resuming_after_a_code_change_at_the_same_version_is_refused(tmp_path, monkeypatch):
    """The version string stays while a checkout's code changes: the manifest records a
    fingerprint of the package's source files, and a resume with other code is refused
    (session 12 noticed a fair-oracle change would have mixed old and new oracle rows)."""
    data = spec(runs=2, chunk_size=1, duration=0.5)
    data["success"]["final_window"] = 0.1
    data["failures"]["onset"] = {"uniform": [0.1, 0.3]}
    out = tmp_path / "c"
    run_campaign(load_campaign(data), out, max_chunks=1, progress=False)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["code"] == store.code_fingerprint()
    # the fingerprint is of the files: recomputed from scratch it is the same
    store.code_fingerprint.cache_clear()
    assert store.code_fingerprint() == manifest["code"]
    monkeypatch.setattr(store, "code_fingerprint", lambda: "f" * 64)
    with pytest.raises(CampaignError) as err:
        run_campaign(load_campaign(data), out, progress=False)
    msg = str(err.value)
    assert "other library code" in msg and "mix" in msg and "Delete" in msg
    assert store.finished_chunks(load_campaign(data), out) == {0}  # nothing was added
    del manifest["code"]  # a folder written before the fingerprint existed
    (out / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(CampaignError, match="before the code fingerprint was recorded"):
        store.prepare_folder(load_campaign(data), out)
    monkeypatch.undo()
    manifest["code"] = store.code_fingerprint()  # the same code resumes
    (out / "manifest.json").write_text(json.dumps(manifest))
    done = run_campaign(load_campaign(data), out, progress=False, summary=False)
    assert done.complete and done.runs_resumed == 1
