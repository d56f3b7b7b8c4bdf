"""No write outside the output folder, nothing written before a spec is validated, a private
compile cache, no staging folders left by killed runs (issue 26, "Security" and "Leftovers")."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import warnings

import pytest

from adaptive_ftc import _atomic
from adaptive_ftc._atomic import inside, remove_stale_staging, safe_stem, staging_dir
from adaptive_ftc.campaigns import CampaignError, load_campaign
from adaptive_ftc.cli import main
from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim import codegen

SPEC = {
    "name": "inline",
    "runs": 2,
    "seed": 1,
    "duration": 1.0,
    "success": {"rms_error_final": 0.01, "final_window": 0.5},
    "failures": {
        "count": 1,
        "onset": {"uniform": [0.2, 0.5]},
        "models": {"loss_of_effectiveness": {"effectiveness": {"uniform": [0.2, 0.8]}}},
    },
}


def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


# ---------------------------------------------------------------------- output file stems
@pytest.mark.parametrize("evil", ["../../../x", "{victim}/x", "..", ".hidden/../x"])
def test_a_scenario_name_never_leads_aftc_run_outside_its_output_folder(tmp_path, evil):
    victim = tmp_path / "victim"
    victim.mkdir()
    name = evil.format(victim=victim)
    src = tmp_path / "s.toml"
    src.write_text(
        f'extends = "wingrock-free-1deg"\nname = {name!r}\nduration = 0.3\n'.replace("'", '"')
    )
    out = tmp_path / "work" / "out"
    assert main(["run", str(src), "--out", str(out), "--quiet", "--no-baselines", "--csv"]) == 0
    assert _files(victim) == []  # nothing written beside or above the output folder
    assert _files(tmp_path / "work") == [f"out/{p}" for p in _files(out)]
    stem = safe_stem(name)
    assert "/" not in stem and not stem.startswith(".")
    assert {f"data/{stem}.nc", f"data/{stem}.csv", "metrics.json"} <= set(_files(out))


def test_safe_stem_keeps_catalogue_names_and_strips_paths():
    assert safe_stem("hypersonic-direct-s1") == "hypersonic-direct-s1"
    assert safe_stem("/etc/passwd") == "etc_passwd"
    assert safe_stem("../..") == "scenario"
    assert safe_stem("a b\x00c") == "a_b_c"


def test_inside_refuses_paths_that_resolve_out_of_the_folder(tmp_path):
    assert inside(tmp_path, tmp_path / "a" / "b.nc") == (tmp_path / "a" / "b.nc").resolve()
    with pytest.raises(ConfigurationError, match="outside the output folder"):
        inside(tmp_path / "out", tmp_path / "out" / ".." / "x.nc")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "link").symlink_to(tmp_path)
    with pytest.raises(ConfigurationError, match="outside the output folder"):
        inside(tmp_path / "out", tmp_path / "out" / "link" / "x.nc")


# ---------------------------------------------------------------------- inline base scenario
@pytest.mark.parametrize("name", ["{tmp}/evil", "../evil", ".evil", "a/b"])
def test_an_inline_base_with_a_path_as_name_writes_nothing(tmp_path, name):
    name = name.format(tmp=tmp_path)
    spec = {**SPEC, "base": {"name": name, "text": 'extends = "wingrock-free-1deg"\n'}}
    with pytest.raises(CampaignError, match="inlined scenario must be"):
        load_campaign(spec, base_dir=tmp_path)
    assert _files(tmp_path) == []
    assert not (tmp_path.parent / "evil.toml").exists()


@pytest.mark.parametrize(
    "base, match",
    [
        ({"name": "x"}, "exactly the keys `name` and `text`"),
        ({"name": "x", "text": 3}, "must be UTF-8 TOML text"),
        ({"name": "x", "text": "\ud800"}, "must be UTF-8 TOML text"),
        ({"name": "x", "text": "a" * 1_000_001}, "at most 1000000 bytes"),
        ({"name": "x", "text": "", "path": "/tmp"}, "exactly the keys"),
    ],
)
def test_a_malformed_inline_base_is_a_spec_error(base, match):
    with pytest.raises(CampaignError, match=match):
        load_campaign({**SPEC, "base": base})


def test_a_well_formed_inline_base_loads_and_is_removed_afterwards(tmp_path, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    text = 'extends = "wingrock-free-1deg"\nname = "mine"\n'
    spec = load_campaign({**SPEC, "base": {"name": "mine", "text": text}})
    assert (
        spec.base.loop.plant.name
        == load_campaign({**SPEC, "base": "wingrock-free-1deg"}).base.loop.plant.name
    )
    assert list(tmp_path.iterdir()) == []  # the private folder is gone


# ---------------------------------------------------------------------- compile cache
def _point_cache(monkeypatch, tmp_path, first):
    monkeypatch.setenv("ADAPTIVE_FTC_CACHE_DIR", str(first))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.setattr(codegen, "_warned", set())


def test_a_new_cache_folder_is_created_private(tmp_path, monkeypatch):
    _point_cache(monkeypatch, tmp_path, tmp_path / "new")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = codegen.cache_dir()
    assert d == tmp_path / "new" / "loops"
    for folder in (d, d.parent):
        assert folder.stat().st_mode & 0o777 == 0o700


@pytest.mark.parametrize("mode", [0o777, 0o775, 0o757])
def test_a_group_or_world_writable_cache_folder_is_skipped_with_a_warning(
    tmp_path, monkeypatch, mode
):
    shared = tmp_path / "shared"
    (shared / "loops").mkdir(parents=True)
    os.chmod(shared, mode)
    _point_cache(monkeypatch, tmp_path, shared)
    with pytest.warns(UserWarning, match="writable by group or others"):
        d = codegen.cache_dir()
    assert d == tmp_path / "xdg" / "adaptive-ftc" / "loops"  # the next candidate


def test_a_cache_folder_owned_by_someone_else_is_never_used(tmp_path, monkeypatch):
    """Another local user pre-creating /tmp/adaptive-ftc-<uid>: every candidate is someone
    else's here, so loops compile in memory."""
    _point_cache(monkeypatch, tmp_path, tmp_path / "a")
    monkeypatch.setattr(codegen.tempfile, "gettempdir", lambda: str(tmp_path / "tmp"))
    real = os.getuid()
    monkeypatch.setattr(codegen.os, "getuid", lambda: real + 4242)
    with pytest.warns(UserWarning, match="owned by user id"):
        assert codegen.cache_dir() is None


def test_a_symlinked_cache_folder_is_skipped(tmp_path, monkeypatch):
    target = tmp_path / "elsewhere"
    (target / "loops").mkdir(parents=True)
    (tmp_path / "link").symlink_to(target)
    _point_cache(monkeypatch, tmp_path, tmp_path / "link")
    with pytest.warns(UserWarning, match="symbolic link"):
        assert codegen.cache_dir() == tmp_path / "xdg" / "adaptive-ftc" / "loops"


# ---------------------------------------------------------------------- staging leftovers
def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_staging_folders_of_killed_runs_are_removed_by_the_next_run(tmp_path):
    host = _atomic._host()
    dead = tmp_path / f".aftc-tmp-{_dead_pid()}@{host}-abc123"
    alive = tmp_path / f".aftc-tmp-{os.getppid()}@{host}-def456"
    remote = tmp_path / f".aftc-tmp-{_dead_pid()}@not{host}-ghi789"
    legacy = tmp_path / ".aftc-tmp-k2j4h5"  # no owner recorded: kept
    for d in (dead, alive, remote, legacy):
        (d / "data").mkdir(parents=True)
        (d / "data" / "x.nc").write_bytes(b"0" * 1000)
    stage = staging_dir(tmp_path)
    assert stage.name.startswith(f".aftc-tmp-{os.getpid()}@{host}-")
    assert not dead.exists()
    assert alive.exists() and remote.exists() and legacy.exists() and stage.exists()
    assert remove_stale_staging(tmp_path) == []  # the live stage is kept too


def test_aftc_run_after_a_kill_leaves_no_staging_folder(tmp_path):
    out = tmp_path / "out"
    src = tmp_path / "s.toml"
    src.write_text('extends = "wingrock-free-1deg"\nname = "s"\nduration = 0.3\n')
    stale = out / f".aftc-tmp-{_dead_pid()}@{_atomic._host()}-zzzzzz"
    (stale / "data").mkdir(parents=True)
    (stale / "data" / "s.nc").write_bytes(b"0" * 1000)
    assert main(["run", str(src), "--out", str(out), "--quiet", "--no-baselines"]) == 0
    assert not [p for p in out.iterdir() if p.name.startswith(".aftc-tmp-")]


def test_the_hostname_in_staging_names_cannot_inject_separators(monkeypatch):
    monkeypatch.setattr(socket, "gethostname", lambda: "a-b/../c@d")
    assert _atomic._host() == "a_b_.._c_d"


def test_atomic_docstring_examples():
    import doctest

    failures, _ = doctest.testmod(_atomic, optionflags=doctest.ELLIPSIS)
    assert failures == 0


def test_a_resumed_campaign_removes_the_temporary_files_of_a_killed_run(tmp_path):
    from adaptive_ftc.campaigns import run_campaign
    from adaptive_ftc.campaigns.store import finished_chunks

    spec = load_campaign(
        {
            **SPEC,
            "base": "wingrock-free-1deg",
            "runs": 2,
            "chunk_size": 1,
            "duration": 0.6,
            # an open loop: no command whose activity could be judged
            "success": {**SPEC["success"], "activity": False},
        }
    )
    out = tmp_path / "c"
    run_campaign(spec, out, max_chunks=1, progress=False)
    host = _atomic._host()
    stale = out / "parts" / f".part-00001.parquet.{_dead_pid()}@{host}.k3j4l5.tmp"
    live = out / "parts" / f".part-00001.parquet.{os.getppid()}@{host}.m6n7o8.tmp"
    stale_manifest = out / f".manifest.json.{_dead_pid()}@{host}.p9q0r1.tmp"
    for p in (stale, live, stale_manifest):
        p.write_bytes(b"0" * 100)
    run = run_campaign(spec, out, progress=False, summary=False)
    assert run.complete and finished_chunks(spec, out) == {0, 1}
    assert not stale.exists() and not stale_manifest.exists()
    assert live.exists()  # its process is alive: maybe still writing


def test_a_folder_left_with_only_a_dead_runs_temporary_file_is_usable(tmp_path):
    from adaptive_ftc.campaigns.store import prepare_folder

    spec = load_campaign({**SPEC, "base": "wingrock-free-1deg"})
    out = tmp_path / "c"
    out.mkdir()
    (out / f".campaign.json.{_dead_pid()}@{_atomic._host()}.a1b2c3.tmp").write_text("{")
    assert prepare_folder(spec, out) == out
    assert sorted(p.name for p in out.iterdir()) == ["campaign.json", "manifest.json"]
