"""The results folder of a campaign: Parquet part files, a manifest, the saved spec.

Layout of ``DIR``::

    campaign.json         the self-contained spec (base scenario inlined when it is a file)
    manifest.json         spec digest, chunking, finished chunks
    parts/part-00000.parquet ...   one file per finished chunk, written atomically
    results.parquet       every run, one row per (member, design), when the campaign is complete

Part files are written to a temporary name and renamed, so a file under ``parts/`` is always
complete: an interruption at any moment loses at most the chunks in flight.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import re
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from adaptive_ftc import _version
from adaptive_ftc._atomic import owner_gone, owner_tag
from adaptive_ftc.campaigns.spec import CampaignError, CampaignSpec

__all__ = [
    "OUTCOME_COLUMNS",
    "check_manifest",
    "code_fingerprint",
    "column_units",
    "finished_chunks",
    "prepare_folder",
    "read_results",
    "remove_stale_temporaries",
    "schema",
    "to_table",
    "write_part",
    "write_results",
]

#: Columns filled from the simulation of one (member, design), with their Arrow type names.
OUTCOME_COLUMNS: dict[str, str] = {
    "design": "string",
    "status": "string",
    "success": "bool",
    "message": "string",
    "divergence_time": "float64",
    "divergence_signal": "string",
    "rms_error": "float64",
    "max_error": "float64",
    "rms_error_final": "float64",
    "max_error_final": "float64",
    "peak_command": "float64",
    "peak_applied": "float64",
    "t_end": "float64",
    "worst_recovery_time": "float64",
    "worst_recovery_rms": "float64",
    # control activity over the final window, worst actuator (runner.ACTIVITY_COLUMNS)
    "fast_rms_max": "float64",
    "tv_per_s_max": "float64",
    "peak_rate_max": "float64",
    "rate_limited_fraction_max": "float64",
    "peak_command_travel_ratio_max": "float64",
    "activity_record_ok": "bool",
    # the success criterion's parts (campaigns/activity.py): success = tracking_ok and
    # activity_ok; activity_why says which activity threshold a run missed
    "peak_command_final": "float64",
    "tracking_ok": "bool",
    "activity_ok": "bool",
    "activity_why": "string",
}


def install_hint(extra: str = "campaigns", package: str = "pyarrow") -> str:
    """How to install an optional dependency, for the way adaptive-ftc was installed: from a
    clone (an editable install) or from a package index."""
    clone = f'pip install -e ".[{extra}]"'
    index = f'pip install "adaptive-ftc[{extra}]"'
    editable = False
    try:
        import json
        from importlib.metadata import distribution

        direct = distribution("adaptive-ftc").read_text("direct_url.json")
        editable = bool(direct and json.loads(direct).get("dir_info", {}).get("editable"))
    except Exception:  # noqa: BLE001 - not installed (PYTHONPATH): a clone
        editable = True
    first, second = (clone, index) if editable else (index, clone)
    where = (
        ("in your clone", "installed from an index")
        if editable
        else ("installed from an index", "in a clone")
    )
    return f"{first} ({where[0]}), or {second} ({where[1]}), or just pip install {package}"


def require_pyarrow() -> None:
    """Raise :class:`CampaignError` with the install command when pyarrow is missing (checked
    before a campaign writes anything)."""
    _pa()


def _pa():
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:  # installed by the `campaigns` extra
        raise CampaignError(
            "Campaign results are Parquet files and need pyarrow, which is not installed: "
            f"{install_hint()}."
        ) from None
    return pa, pq


def schema(spec: CampaignSpec):
    """The Arrow schema of the results table of ``spec`` (fixed, so every part matches)."""
    pa, _ = _pa()
    types = {
        "string": pa.string(),
        "float64": pa.float64(),
        "int64": pa.int64(),
        "bool": pa.bool_(),
    }
    cols: list[tuple[str, str]] = [
        ("index", "int64"),
        ("seed", "int64"),
        ("n_failures", "int64"),
        ("models", "string"),
        ("severity", "float64"),
    ]
    for j in range(1, spec.max_failures + 1):
        cols += [
            (f"f{j}_actuator", "int64"),
            (f"f{j}_model", "string"),
            (f"f{j}_onset", "float64"),
            (f"f{j}_recovery", "float64"),
            (f"f{j}_ramp", "float64"),
            (f"f{j}_severity", "float64"),
            (f"f{j}_params", "string"),
        ]
        if spec.allocation_columns:
            cols.append((f"f{j}_annunciated", "bool"))
    names = spec.loop.plant.state_names
    cols += [(f"x0_{names[i]}", "float64") for i, _ in spec.initial_state]
    if spec.reference_amplitude is not None:
        cols.append(("reference_amplitude", "float64"))
    cols += [(f"gain_{k}", "float64") for k, _ in spec.gains]
    if spec.hardware is not None:
        cols += [(c, "float64") for c in spec.hardware.columns(spec.loop.plant.n_actuators)]
    cols += [("compensable", "bool"), ("compensability", "string")]
    if spec.allocation_columns:  # issue 31: annunciated failures, allocators, reachability
        cols += [("annunciated", "int64"), ("detection_delay", "float64")]
        cols += [("false_alarm", "int64"), ("false_alarm_time", "float64")]
        cols += [("reachable", "bool"), ("reachability", "string"), ("allocator", "string")]
    cols += list(OUTCOME_COLUMNS.items())
    units = column_units(spec)
    return pa.schema(
        [
            pa.field(name, types[t], metadata={"units": units[name]} if name in units else None)
            for name, t in cols
        ]
    )


def column_units(spec: CampaignSpec) -> dict[str, str]:
    """UDUNITS unit (:mod:`adaptive_ftc._units`) of each numeric column of the results table
    whose unit is known, by column name; stored as the ``units`` metadata of the Parquet
    fields (``pyarrow.parquet.read_schema(path).field(name).metadata[b"units"]``). Strings,
    flags, the drawn ``severity`` (a unit of its own per spec) and the gains have none;
    counts and fractions are ``"1"``. Output and actuator units come from the plant class
    (``"1"`` where it declares none)."""
    from adaptive_ftc._units import per_second, udunits
    from adaptive_ftc.sim.result import _common, _declared_units, _output_units, _unit

    plant = spec.loop.plant
    n, p, m = plant.n_states, plant.n_outputs, plant.n_actuators
    state_u = _declared_units(plant, ("state_units", "units"), n)
    out_u = _declared_units(plant, ("output_units",), p) or _output_units(
        tuple(plant.state_names), tuple(plant.output_names), state_u
    )
    y = _common([_unit(out_u, i) for i in range(p)])
    u = _common([_unit(_declared_units(plant, ("actuator_units",), m), j) for j in range(m)])
    units = {"n_failures": "1"}
    if spec.allocation_columns:
        units.update(annunciated="1", detection_delay="s", false_alarm_time="s")
    for j in range(1, spec.max_failures + 1):
        units.update({f"f{j}_onset": "s", f"f{j}_recovery": "s", f"f{j}_ramp": "s"})
    for i, _ in spec.initial_state:
        units[f"x0_{plant.state_names[i]}"] = _unit(state_u, i)
    if spec.reference_amplitude is not None:
        units["reference_amplitude"] = y
    if spec.hardware is not None:
        for col in spec.hardware.columns(m):
            if col.startswith("hw_lag") or col == "hw_sample_time":
                units[col] = "s"
            elif col.startswith("hw_rate_limit"):
                units[col] = per_second(u)
            elif col.startswith("hw_travel"):
                units[col] = u
            elif col.startswith("noise_") and col[len("noise_") :] in plant.state_names:
                units[col] = _unit(state_u, plant.state_names.index(col[len("noise_") :]))
    units.update(
        divergence_time="s",
        rms_error=y,
        max_error=y,
        rms_error_final=y,
        max_error_final=y,
        peak_command=u,
        peak_applied=u,
        t_end="s",
        worst_recovery_time="s",
        worst_recovery_rms=y,
        fast_rms_max=u,
        tv_per_s_max=per_second(u),
        peak_rate_max=per_second(u),
        rate_limited_fraction_max="1",
        peak_command_travel_ratio_max="1",
        peak_command_final=u,
    )
    return {k: udunits(v) for k, v in units.items()}


_MISSING = {"string": "", "float64": np.nan, "int64": 0, "bool": False}


def to_table(rows: list[dict[str, Any]], spec: CampaignSpec):
    """Rows (dicts) to an Arrow table with the campaign's schema (missing cells filled)."""
    pa, _ = _pa()
    sch = schema(spec)
    data = {}
    for fld in sch:
        fill = _MISSING[str(fld.type).replace("double", "float64")]
        data[fld.name] = [r.get(fld.name, fill) for r in rows]
    return pa.Table.from_pydict(data, schema=sch)


def _atomic_write(path: Path, write) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    prefix = f".{path.name}.{owner_tag()}."  # the owner: a killed run's file can go later
    fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _write_json(path: Path, data: dict[str, Any]) -> None:
    def write(tmp: str) -> None:
        Path(tmp).write_text(json.dumps(data, indent=2, default=str), "utf-8")

    _atomic_write(path, write)


_TMP = re.compile(r"\..+\.(\d+)@([A-Za-z0-9._]+)\.[A-Za-z0-9_]+\.tmp")


def remove_stale_temporaries(out: str | Path) -> list[Path]:
    """Remove the temporary files of killed runs (kill -9 while a part, the manifest or the
    results were being written) from ``out`` and ``out/parts``: those whose owning process,
    recorded in the name, is gone. Returns the removed paths."""
    removed = []
    for folder in (Path(out), Path(out) / "parts"):
        try:
            entries = list(os.scandir(folder))
        except OSError:
            continue
        for entry in entries:
            hit = _TMP.fullmatch(entry.name)
            if hit and owner_gone(hit.group(1), hit.group(2)) and entry.is_file():
                try:
                    os.unlink(entry.path)
                except OSError:
                    continue
                removed.append(Path(entry.path))
    return removed


def part_path(out: Path, chunk: int) -> Path:
    """Path of the part file of one chunk."""
    return Path(out) / "parts" / f"part-{chunk:05d}.parquet"


@functools.cache
def code_fingerprint() -> str:
    """SHA-256 over the package's own source and data files (``*.py``, ``*.toml``, sorted by
    path): the version string does not change while the code does (a development checkout,
    an edited install), and a resumed campaign must not mix rows of two codes."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for path in sorted(root.rglob("*")):
        if path.suffix in (".py", ".toml") and "__pycache__" not in path.parts:
            h.update(path.relative_to(root).as_posix().encode() + b"\0")
            h.update(path.read_bytes() + b"\0")
    return h.hexdigest()


def prepare_folder(spec: CampaignSpec, out: str | Path) -> Path:
    """Create ``out`` for ``spec`` or check that it holds the same campaign (to resume).

    Raises
    ------
    CampaignError
        When ``out`` holds the results of a different spec.
    """
    out = Path(out)
    manifest = out / "manifest.json"
    if manifest.is_file():
        try:
            old = json.loads(manifest.read_text("utf-8"))
        except (OSError, ValueError) as exc:
            raise CampaignError(
                f"{manifest} is unreadable ({exc}); delete the folder or choose another --out."
            ) from None
        if old.get("digest") != spec.digest():
            written_by = old.get("version", "an earlier version (none recorded)")
            if written_by != _version.__version__:
                raise CampaignError(
                    f"'{out}' holds results written by adaptive-ftc {written_by}; this is "
                    f"{_version.__version__}. Resuming would mix the results of two code "
                    f"versions in one table. To start fresh, delete '{out}' (or choose another "
                    f"--out folder); to finish the old campaign, use adaptive-ftc {written_by}."
                )
            raise CampaignError(
                f"'{out}' holds the results of a different campaign spec "
                f"('{old.get('name', '?')}'). Use another --out folder, or delete '{out}' to "
                "start again."
            )
        written_code = old.get("code")
        if written_code != code_fingerprint():
            what = (
                "before the code fingerprint was recorded"
                if written_code is None
                else "by other library code"
            )
            raise CampaignError(
                f"'{out}' holds results written {what} (same version "
                f"{_version.__version__}, different source files of adaptive_ftc). Resuming "
                "would mix the results of two codes in one table. Delete "
                f"'{out}' (or choose another --out folder) to run the campaign again with this "
                "code."
            )
        remove_stale_temporaries(out)
        return out
    if out.is_dir():
        remove_stale_temporaries(out)  # e.g. a manifest.json being written when killed
    if out.exists() and any(out.iterdir()):
        raise CampaignError(
            f"'{out}' exists and is not a campaign folder (no manifest.json). Choose an empty "
            "or new --out folder."
        )
    out.mkdir(parents=True, exist_ok=True)
    _write_json(out / "campaign.json", spec.data)
    _write_json(
        manifest,
        {
            "name": spec.name,
            "version": _version.__version__,
            "digest": spec.digest(),
            "code": code_fingerprint(),
            "runs": spec.runs,
            "designs": list(spec.designs),
            "chunk_size": spec.chunk_size,
            "n_chunks": spec.n_chunks,
        },
    )
    return out


def check_manifest(spec: CampaignSpec, out: str | Path) -> None:
    """Check that ``spec`` (e.g. loaded from the folder's ``campaign.json``) is the campaign
    recorded in ``out/manifest.json`` by the same package version.

    Raises
    ------
    CampaignError
        When the manifest is missing or unreadable, was written by another version, or
        records another digest (``campaign.json`` was edited).
    """
    out = Path(out)
    manifest = out / "manifest.json"
    try:
        old = json.loads(manifest.read_text("utf-8"))
        recorded = old["digest"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise CampaignError(
            f"'{out}' has no usable manifest.json ({type(exc).__name__}); it cannot be checked "
            "against its campaign.json. Rerun the campaign into a new folder."
        ) from None
    if recorded == spec.digest():
        return
    written_by = old.get("version", "an earlier version (none recorded)")
    if written_by != _version.__version__:
        raise CampaignError(
            f"'{out}' was written by adaptive-ftc {written_by}; this is {_version.__version__}, "
            f"so a replay would not reproduce its table. Use adaptive-ftc {written_by}, or "
            "rerun the campaign into a new folder."
        )
    raise CampaignError(
        f"'{out}/campaign.json' does not match the digest recorded in its manifest.json: the "
        "spec was edited after the campaign ran, so its table does not come from it. Restore "
        "campaign.json, or run the edited spec into a new folder with 'aftc campaign'."
    )


def finished_chunks(spec: CampaignSpec, out: Path) -> set[int]:
    """Chunks whose part file is present (part files are only ever complete)."""
    # one listing of parts/, not one stat per chunk (a campaign may have 1e5 chunks)
    parts = Path(out) / "parts"
    done: set[int] = set()
    try:
        entries = list(os.scandir(parts))
    except FileNotFoundError:
        return done
    for entry in entries:
        hit = _PART.fullmatch(entry.name)
        if hit and int(hit.group(1)) < spec.n_chunks and entry.is_file():
            done.add(int(hit.group(1)))
    return done


_PART = re.compile(r"part-(\d{5,})\.parquet")


def write_part(table, out: Path, chunk: int) -> Path:
    """Write one chunk's table atomically."""
    _, pq = _pa()
    path = part_path(out, chunk)
    _atomic_write(path, lambda tmp: pq.write_table(table, tmp))
    return path


#: Rows per row group of ``results.parquet``. The parts are small (one chunk each); copied one
#: row group per part, a 100,000-member table had 2,000 row groups, and reading it (the summary)
#: cost about 4 KiB per member in per-group overhead, ten times the rows' own size. Parts are
#: gathered into groups of this many rows instead (a bounded buffer: ~30 MB of rows).
RESULTS_ROW_GROUP = 65_536


def write_results(spec: CampaignSpec, out: Path) -> Path:
    """Concatenate the part files into ``results.parquet``: streamed, a few parts at a time,
    into row groups of :data:`RESULTS_ROW_GROUP` rows."""
    pa, pq = _pa()
    path = Path(out) / "results.parquet"
    sch = schema(spec)

    def write(tmp: str) -> None:
        with pq.ParquetWriter(tmp, sch) as writer:
            pending: list[Any] = []
            rows = 0
            for c in range(spec.n_chunks):
                table = pq.read_table(part_path(out, c), schema=sch)
                pending.append(table)
                rows += table.num_rows
                if rows >= RESULTS_ROW_GROUP or c == spec.n_chunks - 1:
                    group = pa.concat_tables(pending).combine_chunks()
                    writer.write_table(group, row_group_size=max(1, group.num_rows))
                    pending, rows = [], 0

    _atomic_write(path, write)
    return path


def read_results(out: str | Path):
    """The results table of a campaign folder as a pandas DataFrame (complete or partial)."""
    import pandas as pd

    out = Path(out)
    full = out / "results.parquet"
    if full.is_file():
        return pd.read_parquet(full)
    parts = sorted((out / "parts").glob("part-*.parquet"))
    if not parts:
        raise CampaignError(
            f"'{out}' holds no campaign results (no results.parquet, no parts/). Run "
            f"'aftc campaign SPEC --out {out}' first."
        )
    return pd.concat([pd.read_parquet(p) for p in parts], ignore_index=True)
