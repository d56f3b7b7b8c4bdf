"""Checks of campaign specs that protect the machine and the results: size limits (with the
size in the message), the inlined base scenario (checked before anything is written), kept vs
drawn failure windows, and the structural substitution of ``{name}`` placeholders."""

from __future__ import annotations

import math
import re
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from adaptive_ftc.errors import did_you_mean
from adaptive_ftc.expressions import MAX_LENGTH
from adaptive_ftc.scenarios.loader import MAX_FILE_BYTES, Scenario, load_scenario

if TYPE_CHECKING:  # pragma: no cover
    from adaptive_ftc.campaigns.spec import Dist

__all__ = ["MAX_CHUNKS", "MAX_CHUNK_SIZE", "MAX_RUNS", "safe_name"]

#: Most members of one campaign (each design of each member is one simulation).
MAX_RUNS: int = 10_000_000
#: Most members per chunk: a chunk's closed loops and rows are held in memory together.
MAX_CHUNK_SIZE: int = 10_000
#: Most chunks (part files) of one campaign.
MAX_CHUNKS: int = 100_000
#: Bytes per table cell, for the size estimate of a campaign's results (float64/int64).
_CELL_BYTES = 8
#: Cells of a results row without failure slots or drawn columns (for the size estimate).
_ROW_CELLS = 25
#: A scenario name usable as a file name: letters, digits, ``. _ -``, not starting with a dot.
_SAFE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9._-]{0,99}")
#: A ``{name}`` placeholder of a drawn parameter in an expression field.
_PLACEHOLDER = re.compile(r"\{([A-Za-z_][A-Za-z0-9_]*)\}")


def safe_name(name: Any) -> bool:
    """Whether ``name`` can name a file: 1-100 letters, digits, ``.``, ``_`` or ``-``, not
    starting with ``.`` or ``-`` (no folders, no ``..``)."""
    return isinstance(name, str) and _SAFE_NAME.fullmatch(name) is not None


def _short(value: Any, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters (a spec value can be megabytes long)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _fill(value: Any, params: dict[str, Any], where: str = "failures.models") -> Any:
    """Substitute ``{name}`` placeholders of an expression string with drawn params.

    The substitution is structural: each ``{name}`` (a drawn param) is replaced by the
    parenthesised number; any other brace (format specs such as ``{a:>9}``, positional
    ``{0}``, ``{{``) is refused, and the length limit of expressions is checked first, so a
    spec cannot make the text grow before it is checked.

    Raises
    ------
    CampaignError
        Naming the field, for an unknown placeholder, a stray brace or a too-long text.
    """
    from adaptive_ftc.errors import CampaignError

    if isinstance(value, str) and ("{" in value or "}" in value):
        if len(value) > MAX_LENGTH:
            raise CampaignError(
                f"[{where}] the expression has {len(value)} characters; the limit is "
                f"{MAX_LENGTH}. Shorten it."
            )
        stray = _PLACEHOLDER.sub("", value)
        if "{" in stray or "}" in stray:
            raise CampaignError(
                f"[{where}] {_short(value)}: braces are only allowed around the name of a drawn "
                "param, e.g. '{a}*u' with params = {a = {uniform = [0.5, 1]}} (no format specs, "
                "no positions)."
            )
        unknown = sorted({n for n in _PLACEHOLDER.findall(value) if n not in params})
        if unknown:
            names = ", ".join(sorted(params)) or "none"
            raise CampaignError(
                f"[{where}] unknown placeholder {{{unknown[0]}}}: the drawn params are {names}. "
                f"Declare it in `params`, e.g. params = {{{unknown[0]} = {{uniform = [0, 1]}}}}."
            )
        text = _PLACEHOLDER.sub(lambda mt: f"({float(params[mt.group(1)])!r})", value)
        if len(text) > MAX_LENGTH:
            raise CampaignError(
                f"[{where}] the expression has {len(text)} characters once its params are "
                f"substituted; the limit is {MAX_LENGTH}. Shorten it."
            )
        return text
    if isinstance(value, (list, tuple)):
        return tuple(_fill(v, params, where) for v in value)
    return value


def _check_kept_overlap(
    scenario: Scenario,
    acts: list[int],
    onset: Dist,
    duration: Dist,
    recovery_probability: float,
    problems: list[str],
) -> None:
    """With ``keep_base``, a drawn failure must not overlap a kept base failure on the same
    actuator (the failure schedule refuses overlaps, which would make members invalid)."""
    lo = float(min(onset.support()))
    hi = float(max(onset.support()))
    if recovery_probability < 1:
        end = math.inf
    else:
        end = hi + float(max(duration.support()))
    for f in scenario.loop.failures.failures:
        if f.actuator not in acts:
            continue
        b_end = float(f.end)
        if f.onset < end and lo < b_end:
            drawn = f"[{lo:g}, {'end of run' if math.isinf(end) else f'{end:g} s'})"
            kept = f"[{f.onset:g}, {'end of run' if math.isinf(b_end) else f'{b_end:g} s'})"
            problems.append(
                f"[failures] keep_base = true keeps the base's {type(f).__name__} on actuator "
                f"{f.actuator} over {kept}, and drawn failures on actuator {f.actuator} can act "
                f"over {drawn}: they would overlap and every such member would be invalid. "
                f"Remove actuator {f.actuator} from `actuators`, move the `onset` range out of "
                "the kept window (with recovery_probability = 1 and a bounded `duration` if the "
                "drawn failure comes first), or set keep_base = false."
            )


def _top_numbers(
    data: dict[str, Any], problems: list[str], available: Iterable[str]
) -> tuple[int, int, int, list[str]]:
    """``runs``, ``seed``, ``chunk_size`` and ``designs`` (among ``available``), with the
    campaign's size limits."""
    available = list(available)

    def integer(key: str, default: Any, lo: int, hi: int | None = None) -> int | None:
        v = data.get(key, default)
        if v is None or isinstance(v, bool) or not isinstance(v, int) or v < lo:
            problems.append(f"[top] `{key}` must be a whole number >= {lo}; got {_short(v)}.")
            return None
        return v

    designs = data.get("designs", ["adaptive"])
    if not isinstance(designs, list) or not designs:
        problems.append(f"[top] `designs` must be a non-empty list; got {_short(designs)}.")
        designs = ["adaptive"]
    ok = []
    for d in designs:
        if not isinstance(d, str):
            problems.append(f"[top] `designs` lists names (texts); got {_short(d)}.")
        elif d not in available:
            problems.append(
                f"[top] unknown design {_short(d)}.{did_you_mean(d, available)} "
                f"Available: {', '.join(available)}."
            )
        elif d in ok:
            problems.append(f"[top] design '{d}' is listed twice in `designs`.")
        else:
            ok.append(d)
    designs = ok or ["adaptive"]
    runs = integer("runs", None, 1)
    seed = integer("seed", None, 0)
    chunk = integer("chunk_size", 50, 1)
    n_designs = len(designs)
    if runs is not None and runs > MAX_RUNS:
        sims = runs * n_designs
        rows = _human_bytes(sims * _ROW_CELLS * _CELL_BYTES)
        problems.append(
            f"[top] `runs = {runs}` x {n_designs} design(s) = {sims:.3g} simulations (a results "
            f"table of about {rows}); the limit is {MAX_RUNS} members. Lower `runs`."
        )
        runs = None
    if chunk is not None and chunk > MAX_CHUNK_SIZE:
        problems.append(
            f"[top] `chunk_size = {chunk}` holds {chunk * n_designs:.3g} closed loops and their "
            f"rows in memory at once; the limit is {MAX_CHUNK_SIZE} members per chunk. Lower "
            "`chunk_size` (50-1000 suits most campaigns)."
        )
        chunk = None
    if runs is not None and chunk is not None and -(-runs // chunk) > MAX_CHUNKS:
        need = -(-runs // MAX_CHUNKS)
        problems.append(
            f"[top] `runs = {runs}` with `chunk_size = {chunk}` makes {-(-runs // chunk)} part "
            f"files; the limit is {MAX_CHUNKS} chunks. Raise `chunk_size` to at least {need}."
        )
        chunk = None
    return runs or 1, seed or 0, chunk or 1, designs


def _human_bytes(n: float) -> str:
    for unit, scale in (("PiB", 1024**5), ("TiB", 1024**4), ("GiB", 1024**3), ("MiB", 1024**2)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n / 1024:.3g} KiB"


def _inline_base(base: dict[str, Any], problems: list[str]) -> Scenario | None:
    """Load a base scenario inlined as ``{name, text}`` (the form saved in campaign.json).

    The table is checked before anything is written: exactly the keys ``name`` (a safe file
    name) and ``text`` (at most the scenario file size limit). The text is then loaded from a
    private temporary folder (created 0700 by :func:`tempfile.mkdtemp`) under that name, and
    the folder is removed.
    """
    keys = set(map(str, base))
    if keys != {"name", "text"}:
        problems.append(
            "[base] an inlined base scenario is a table with exactly the keys `name` and `text` "
            f"(as saved in campaign.json); got keys {sorted(keys)}. Or give a catalogue name or "
            "a .toml path."
        )
        return None
    name, text = base["name"], base["text"]
    bad = False
    if not safe_name(name):
        problems.append(
            f"[base] `name` of the inlined scenario must be 1-100 letters, digits, '.', '_' or "
            f"'-' (a file name, no folders); got {_short(name)}."
        )
        bad = True
    try:
        size = len(text.encode("utf-8")) if isinstance(text, str) else None
    except UnicodeEncodeError:
        size = None
    if size is None or size > MAX_FILE_BYTES:
        problems.append(
            f"[base] `text` of the inlined scenario must be UTF-8 TOML text of at most "
            f"{MAX_FILE_BYTES} bytes; got {_short(text, 40)}."
        )
        bad = True
    if bad:
        return None
    with tempfile.TemporaryDirectory(prefix="aftc-base-") as tmp:
        path = Path(tmp) / f"{name}.toml"
        path.write_text(text, encoding="utf-8")
        return load_scenario(path)
