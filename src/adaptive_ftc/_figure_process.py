"""Draw a run's figures in a second process while the first simulates and writes the data.

On a warm cache ``aftc run hypersonic-direct-s1`` spends about as long on its two figures
(importing matplotlib 0.35 s of CPU, drawing and encoding 0.7 s) as on everything else
(loading the compiled loops, six runs, six netCDF files). :class:`FigureProcess` forks a child
before the runs start: the child imports matplotlib and draws a small warm-up figure (fonts,
the Agg backend, the PNG writer) while the parent simulates, then draws the figures it is sent
while the parent writes the netCDF files. The child draws with the same code on a copy of the
same process, so the files are the ones the parent would have drawn (tests/test_first_run.py
compares the bytes).

Only where ``fork`` is the platform's process start (Linux) and more than one CPU is available
to the process; elsewhere :meth:`FigureProcess.start` returns ``None`` and the caller draws the
figures itself, one after another, as before. The child ignores Ctrl-C (the parent handles it
and ends the child) and never writes outside the paths it is given.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Iterator, Mapping, Sequence
from multiprocessing.reduction import ForkingPickler
from pathlib import Path
from typing import Any

__all__ = ["FigureError", "FigureProcess"]


class FigureError(RuntimeError):
    """The figure process failed in a way that cannot be sent back as the exception itself."""


def _usable_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - no affinity call (macOS)
        return os.cpu_count() or 1


class FigureProcess:
    """A forked child that draws :func:`adaptive_ftc.plots.save_figure` calls it is sent.

    ``start()`` (``None`` where unavailable), then ``draw(...)`` once, then iterate
    :meth:`finished` for the index of each figure as it is written (the child's exception is
    raised here), and ``close()`` in a ``finally`` (ends the child if it is still running).
    """

    def __init__(self, process: Any, conn: Any) -> None:
        self._process = process
        self._conn = conn
        self._n = 0

    @classmethod
    def start(cls) -> FigureProcess | None:
        """Fork the child now (call it before threads are started); ``None`` when figures
        should be drawn in this process."""
        import multiprocessing

        if not sys.platform.startswith("linux") or _usable_cpus() < 2:
            return None
        for stream in (sys.stdout, sys.stderr):  # or the child writes its copy again at exit
            stream.flush()
        try:
            ctx = multiprocessing.get_context("fork")
            parent, child = ctx.Pipe()
            process = ctx.Process(target=_serve, args=(child,), daemon=True, name="aftc-figures")
            process.start()
        except (OSError, ValueError):  # no fork here (or no resources): draw in this process
            return None
        child.close()
        return cls(process, parent)

    def draw(
        self,
        result: Any,
        jobs: Sequence[Mapping[str, Any]],
        *,
        baselines: Mapping[str, Any] | None,
        formats: Sequence[str],
        dpi: int | None,
    ) -> bool:
        """Send the figures to draw: ``save_figure(result, job["spec"], job["path"],
        zoom_result=job["zoom"], baselines=..., formats=..., dpi=...)`` for each job.
        ``False`` when they cannot be sent (a result holding an object that cannot be pickled,
        e.g. from a user's notebook): the caller draws them itself."""
        request = (result, dict(baselines) if baselines else None, list(jobs), tuple(formats), dpi)
        try:
            payload = ForkingPickler.dumps(request)
        except Exception:  # noqa: BLE001 - whatever pickling raises: draw in the caller
            return False
        self._conn.send_bytes(payload)
        self._n = len(jobs)
        return True

    def finished(self) -> Iterator[int]:
        """The index of each figure as the child finishes it, in order."""
        for _ in range(self._n):
            try:
                message = self._conn.recv()
            except EOFError:
                self._process.join(timeout=5)  # it is gone: its exit status, once reaped
                code = self._process.exitcode
                raise FigureError(
                    f"the figure process ended without drawing the figures (exit status {code}); "
                    "run again, and report it if it repeats"
                ) from None
            if message[0] == "error":
                raise message[1]
            yield message[1]

    def close(self) -> None:
        """End the child (it has nothing left to do, or its work is being thrown away) and
        reap it."""
        end_child(self._process)
        self._conn.close()


def end_child(process: Any) -> None:
    """End a forked helper process if it still runs, and reap it."""
    if process.is_alive():
        process.terminate()
    process.join()


def child_signals() -> None:  # pragma: no cover - runs in a forked child
    """In a forked helper: Ctrl-C is the parent's to handle (it ends us); SIGTERM ends us."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _serve(conn: Any) -> None:  # pragma: no cover - runs in the forked child
    child_signals()
    try:
        _warm_up()
    except Exception:  # noqa: BLE001 - a failed warm-up shows again on the real figure
        pass
    try:
        request = conn.recv()  # the bytes of ForkingPickler.dumps: what recv() reads
    except EOFError:
        return
    if request is None:
        return
    result, baselines, jobs, formats, dpi = request
    from adaptive_ftc import plots

    for i, job in enumerate(jobs):
        try:
            plots.save_figure(
                result,
                job["spec"],
                Path(job["path"]),
                baselines=baselines,
                zoom_result=job["zoom"],
                formats=formats,
                dpi=dpi,
            )
        except BaseException as exc:  # noqa: BLE001 - sent to the parent, which raises it
            try:
                conn.send(("error", exc))
            except Exception:  # noqa: BLE001 - not picklable: say what it was
                conn.send(("error", FigureError(f"{type(exc).__name__}: {exc}")))
            return
        conn.send(("done", i))


def _warm_up() -> None:  # pragma: no cover - runs in the forked child
    """What every figure needs first: matplotlib, its Agg backend, fonts and the PNG writer."""
    import io

    from adaptive_ftc import plots

    fig = plots.new_figure(1.0, 1.0)
    ax = fig.subplots()
    ax.plot([0.0, 1.0], [0.0, 1.0])
    ax.set_title("$e$ (rad)")
    with plots.figure_style():
        fig.savefig(io.BytesIO(), format="png", dpi=20)
