"""Running campaign chunks on a Dask distributed cluster (optional extra
``adaptive-ftc[distributed]``).

The driver sends the validated spec once, submits one task per pending chunk and writes each
part file locally as its task finishes, so workers need ``adaptive-ftc`` installed but no shared
file system. A member's random stream depends only on ``(seed, index)``, so the table equals the
local run bit for bit. A killed worker's chunk is rerun by Dask; Ctrl-C cancels the remaining
tasks and closes the connection.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any

from adaptive_ftc.campaigns.spec import CampaignError, CampaignSpec

__all__ = ["run_chunks_dask"]

#: How long to wait for the scheduler before giving up with a clear error.
CONNECT_TIMEOUT = "20s"


def _chunk_task(
    spec: CampaignSpec, chunk: int, run_chunk: Callable[..., list[dict[str, Any]]]
) -> tuple[int, list[dict[str, Any]]]:
    try:
        from distributed import get_worker

        jobs = max(1, int(get_worker().state.nthreads))
    except (ImportError, ValueError, AttributeError):
        jobs = 1
    return chunk, run_chunk(spec, chunk, jobs=jobs)


def _client(scheduler: Any):
    try:
        from distributed import Client
    except ImportError:
        raise CampaignError(
            "--scheduler needs Dask distributed: pip install 'adaptive-ftc[distributed]'."
        ) from None
    if isinstance(scheduler, Client):
        return scheduler, False
    if hasattr(scheduler, "scheduler_address"):  # a LocalCluster or another cluster object
        return Client(scheduler), True
    try:
        return Client(str(scheduler), timeout=CONNECT_TIMEOUT), True
    except (OSError, TimeoutError) as exc:
        raise CampaignError(
            f"Cannot reach the Dask scheduler at '{scheduler}': {exc}. Start one with "
            "'dask scheduler' (and workers with 'dask worker ADDRESS') or check the address."
        ) from None


def run_chunks_dask(
    spec: CampaignSpec,
    chunks: Sequence[int],
    scheduler: Any,
    run_chunk: Callable[..., list[dict[str, Any]]],
) -> Iterator[tuple[int, list[dict[str, Any]]]]:
    """Yield ``(chunk, rows)`` for each chunk as the cluster finishes it.

    ``run_chunk(spec, chunk, jobs=...)`` runs one chunk on a worker
    (:func:`adaptive_ftc.campaigns.runner.run_chunk`, passed in by the runner, so that this
    module does not import the runner that imports it).
    """
    if not chunks:
        return
    from distributed import as_completed

    client, own = _client(scheduler)
    futures = []
    try:
        spec_future = client.scatter(spec, broadcast=True)
        futures = [
            client.submit(
                _chunk_task,
                spec_future,
                c,
                run_chunk,
                key=f"aftc-{spec.digest()[:12]}-chunk-{c}",
                retries=2,
            )
            for c in chunks
        ]
        for fut in as_completed(futures):
            chunk, rows = fut.result()
            fut.release()
            yield chunk, rows
    finally:
        pending = [f for f in futures if not f.done()]
        if pending:
            client.cancel(pending)
        if own:
            client.close()
