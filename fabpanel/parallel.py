"""Worker processes for per-panel and per-part work.

Each worker runs one task at a time, so its BLAS (OpenBLAS, through numpy and scipy) must run on
one thread: left at its default of one thread per core, two workers on two cores each start two
BLAS threads for every small sparse solve and they spend their time waiting for each other
(measured: unrolling 100 sheets took 6.0 s on 2 workers against 1.3 s with one BLAS thread each).

Stopping: the parent owns the workers. They ignore SIGINT (Ctrl-C reaches the whole process
group; the parent decides), die with SIGTERM, and the kernel kills them when the parent dies,
even by SIGKILL (Linux ``PR_SET_PDEATHSIG``), so no worker outlives a run. When the code inside
``with worker_pool(...)`` raises (an error, Ctrl-C, SIGTERM), queued tasks are cancelled and the
running ones terminated at once instead of being waited for.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import warnings
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager

from threadpoolctl import threadpool_limits

_limits = None

#: prctl option: signal delivered to this process when its parent dies (linux/prctl.h)
_PR_SET_PDEATHSIG = 1
#: how long terminated workers get to exit before they are killed, s
_TERMINATE_WAIT = 2.0


def _die_with_parent(parent: int | None) -> None:
    """Killed when the parent dies. ``parent``: its pid, or None for a worker started by a
    fork server (which dies with the run: it exits when the run's end of its pipe closes)."""
    if not sys.platform.startswith("linux"):
        return
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if parent is not None and os.getppid() != parent:  # died before prctl took effect
        os._exit(1)


def _init_worker(parent: int | None) -> None:
    global _limits
    _die_with_parent(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    # library warnings in workers would reach the user's terminal unasked; the stage checks
    # and the issues are what report a panel's problems
    warnings.simplefilter("ignore")
    _limits = threadpool_limits(limits=1)


def terminate_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel the queued tasks and stop the workers now (terminate, then kill)."""
    processes = list(getattr(pool, "_processes", {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(_TERMINATE_WAIT)
        if process.is_alive():
            process.kill()
            process.join(_TERMINATE_WAIT)


@contextmanager
def worker_pool(workers: int, fresh: bool = False) -> Iterator[ProcessPoolExecutor]:
    """A process pool whose workers use one BLAS thread each and never outlive the run.

    fresh : start the workers from a fresh server process ("forkserver") instead of forking
        this one. Needed once this process has run spyrrow: its Rust thread pool does not
        survive a fork, and a forked worker packing with it waits forever.
    """
    context = multiprocessing.get_context("forkserver") if fresh else None
    pool = ProcessPoolExecutor(
        max_workers=workers,
        mp_context=context,
        initializer=_init_worker,
        initargs=(None if fresh else os.getpid(),),
    )
    try:
        yield pool
    except BaseException:
        terminate_pool(pool)
        raise
    pool.shutdown(wait=True)


def child_preexec() -> None:
    """``preexec_fn`` for external programs (CalculiX): killed when fabpanel dies, even by
    SIGKILL (a stopped run kills its child itself: ``subprocess.run`` does on any exception)."""
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)


__all__ = ["child_preexec", "terminate_pool", "worker_pool"]
