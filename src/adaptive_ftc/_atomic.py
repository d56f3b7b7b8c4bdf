"""Atomic, non-clobbering output files.

Every file the command-line tool writes goes first to a temporary name in the same folder and
is then renamed over the target with :func:`os.replace` (atomic on POSIX and Windows), so an
interrupted or failed write never leaves a truncated or empty file where a complete one was.
"""

from __future__ import annotations

import contextlib
import os
import shutil
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


def staging_dir(out: str | Path) -> Path:
    """A fresh hidden folder inside ``out`` where a run writes everything before committing."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    return Path(tempfile.mkdtemp(prefix=TMP_PREFIX, dir=out))


def commit_staged(stage: Path, out: Path) -> list[Path]:
    """Move every file of ``stage`` to the same relative place under ``out`` (``os.replace``
    each, so every target is either its old complete version or the new complete one), then
    remove ``stage``. Returns the target paths."""
    moved = []
    for src in sorted(p for p in stage.rglob("*") if p.is_file()):
        dst = out / src.relative_to(stage)
        dst.parent.mkdir(parents=True, exist_ok=True)
        os.replace(src, dst)
        moved.append(dst)
    shutil.rmtree(stage, ignore_errors=True)
    return moved


def discard_staged(stage: Path) -> None:
    """Remove a staging folder (the run failed or was interrupted)."""
    shutil.rmtree(stage, ignore_errors=True)
