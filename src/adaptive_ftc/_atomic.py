"""Atomic, non-clobbering output files.

Every file the command-line tool writes goes first to a temporary name in the same folder and
is then renamed over the target with :func:`os.replace` (atomic on POSIX and Windows), so an
interrupted or failed write never leaves a truncated or empty file where a complete one was.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import socket
import tempfile
from collections.abc import Iterator
from pathlib import Path

from adaptive_ftc.errors import ConfigurationError

__all__ = [
    "atomic_path",
    "atomic_write_text",
    "check_output_dir",
    "commit_staged",
    "discard_staged",
    "inside",
    "owner_gone",
    "owner_tag",
    "remove_stale_staging",
    "safe_stem",
    "staging_dir",
]

#: Prefix of temporary files and staging folders (left-overs of a killed process can go).
TMP_PREFIX = ".aftc-tmp-"


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it to ``path``.

    On any exception (or interruption) the temporary file is removed and ``path`` keeps its
    earlier content.

    Examples
    --------
    >>> with atomic_path(tmp / "a.txt") as p:            # doctest: +SKIP
    ...     p.write_text("complete")
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=TMP_PREFIX, suffix=path.suffix, dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the usual permissions
        yield tmp
        _fsync(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


def _fsync(path: Path) -> None:
    with contextlib.suppress(OSError), open(path, "rb") as fh:
        os.fsync(fh.fileno())


def check_output_dir(path: str | Path) -> Path:
    """Check that ``path`` is (or can be made) a writable folder; raise a clear error if not.

    Raises
    ------
    ConfigurationError
        When ``path`` is an existing file, or the folder cannot be created or written.
    """
    path = Path(path)
    for parent in (path, *path.parents):
        if parent.exists():
            if not parent.is_dir():
                raise ConfigurationError(
                    f"--out '{path}': '{parent}' is a file, not a folder. Give a folder path "
                    "(it is created if missing)."
                )
            break
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=TMP_PREFIX, dir=path)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ConfigurationError(
            f"--out '{path}': cannot write there ({exc.strerror or exc}). Choose a folder you "
            "can write to."
        ) from None
    return path


def safe_stem(label: str, default: str = "scenario") -> str:
    """A file-name stem derived from a label (a scenario's ``name``): runs of characters
    other than letters, digits, ``.``, ``_`` and ``-`` become ``_``, leading dots and dashes go,
    at most 100 characters. A catalogue name is its own stem.

    Examples
    --------
    >>> safe_stem("hypersonic-direct-s1")
    'hypersonic-direct-s1'
    >>> safe_stem("../../../../tmp/x")
    'tmp_x'
    """
    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", str(label)).lstrip("._-")[:100].rstrip(".")
    return stem or default


def inside(root: str | Path, path: str | Path) -> Path:
    """``path`` resolved, after checking that it lies inside ``root`` (resolved).

    Raises
    ------
    ConfigurationError
        When ``path`` would be written outside ``root`` (a name with ``..``, an absolute path,
        a symbolic link leading out).
    """
    root_r, path_r = Path(root).resolve(), Path(path).resolve()
    if not path_r.is_relative_to(root_r):
        raise ConfigurationError(
            f"Refusing to write '{path}': it resolves to '{path_r}', outside the output folder "
            f"'{root_r}'. Output names are derived from labels; report this as a bug."
        )
    return path_r


def _host() -> str:
    return re.sub(r"[^A-Za-z0-9.]", "_", socket.gethostname())[:64] or "host"


#: ``.aftc-tmp-<pid>@<host>-<random>``: a staging folder and the process that owns it.
_STAGE = re.compile(re.escape(TMP_PREFIX) + r"(\d+)@([A-Za-z0-9._]+)-[A-Za-z0-9_]+")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError, OverflowError):
        return True  # someone else's process, or cannot tell: keep its folder
    return True


def owner_tag() -> str:
    """``<pid>@<host>``: recorded in temporary names so that a later run can tell whether the
    process that made them is gone (:func:`owner_gone`)."""
    return f"{os.getpid()}@{_host()}"


def owner_gone(pid: str | int, host: str) -> bool:
    """Whether the process ``pid`` that wrote a temporary name on ``host`` is gone (only
    decidable on this host: another host's files are never judged stale)."""
    return host == _host() and not _alive(int(pid))


def remove_stale_staging(out: str | Path) -> list[Path]:
    """Remove the staging folders in ``out`` left by killed runs on this machine (their owning
    process, recorded in the folder name, is gone). Folders of live processes, of other
    machines (a shared file system) and of unknown form are kept. Returns the removed paths."""
    removed: list[Path] = []
    try:
        entries = list(os.scandir(out))
    except OSError:
        return removed
    for entry in entries:
        hit = _STAGE.fullmatch(entry.name)
        if not hit or not owner_gone(hit.group(1), hit.group(2)):
            continue
        with contextlib.suppress(OSError):
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
                removed.append(Path(entry.path))
    return removed


def staging_dir(out: str | Path) -> Path:
    """A fresh hidden folder inside ``out`` where a run writes everything before committing.

    Its name records the owning process (``.aftc-tmp-<pid>@<host>-...``), so that a later run
    into the same folder removes the staging folders of runs that were killed (kill -9, power
    loss) before they could clean up (:func:`remove_stale_staging`).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    remove_stale_staging(out)
    prefix = f"{TMP_PREFIX}{owner_tag()}-"
    return Path(tempfile.mkdtemp(prefix=prefix, dir=out))


def commit_staged(stage: Path, out: Path) -> list[Path]:
    """Move every file of ``stage`` to the same relative place under ``out`` (``os.replace``
    each, so every target is either its old complete version or the new complete one), then
    remove ``stage``. Returns the target paths."""
    moved = []
    for src in sorted(p for p in stage.rglob("*") if p.is_file()):
        dst = inside(out, out / src.relative_to(stage))
        dst.parent.mkdir(parents=True, exist_ok=True)
        os.replace(src, dst)
        moved.append(dst)
    shutil.rmtree(stage, ignore_errors=True)
    return moved


def discard_staged(stage: Path) -> None:
    """Remove a staging folder (the run failed or was interrupted)."""
    shutil.rmtree(stage, ignore_errors=True)
