"""Worker processes for per-panel and per-part work.

Each worker runs one task at a time, so its BLAS (OpenBLAS, through numpy and scipy) must run on
one thread: left at its default of one thread per core, two workers on two cores each start two
BLAS threads for every small sparse solve and they spend their time waiting for each other
(measured: unrolling 100 sheets took 6.0 s on 2 workers against 1.3 s with one BLAS thread each).
"""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor

from threadpoolctl import threadpool_limits

_limits = None


def _one_blas_thread() -> None:
    global _limits
    _limits = threadpool_limits(limits=1)


def worker_pool(workers: int) -> ProcessPoolExecutor:
    """A process pool whose workers use one BLAS thread each."""
    return ProcessPoolExecutor(max_workers=workers, initializer=_one_blas_thread)


__all__ = ["worker_pool"]
