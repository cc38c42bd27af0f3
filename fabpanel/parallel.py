"""Worker processes for per-panel and per-part work.

Each worker runs one task at a time, so its BLAS (OpenBLAS, through numpy and scipy) must run on
one thread: left at its default of one thread per core, two workers on two cores each start two
BLAS threads for every small sparse solve and they spend their time waiting for each other
(measured: unrolling 100 sheets took 6.0 s on 2 workers against 1.3 s with one BLAS thread each).

Stopping: the parent owns the workers. They ignore SIGINT (Ctrl-C reaches the whole process
group; the parent decides), die with SIGTERM, and exit when the run dies, even by SIGKILL: the
kernel kills a forked worker with its parent (Linux ``PR_SET_PDEATHSIG``), and a fresh worker
(started by a fork server, which outlives the run) watches the run's pidfd. No worker outlives
a run. When the code inside
``with worker_pool(...)`` raises (an error, Ctrl-C, SIGTERM), queued tasks are cancelled and the
running ones terminated at once instead of being waited for.

On a Ray cluster (``[run] executor = "ray"``, :func:`executor`), the same pools hand each task
to Ray instead: only the task's arguments and result cross (numpy arrays, BREP bytes, file
contents; no file is written on a remote node), a worker process is replaced after
``[run] worker_tasks`` tasks (OCCT does not give all its memory back), and a task whose worker
died is run again up to ``[run] retries`` times. The result is the same as a local run's: the
same functions on the same arguments, gathered in the same order.
"""

from __future__ import annotations

import contextvars
import ctypes
import logging
import multiprocessing
import os
import select
import shutil
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor, ThreadPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from threadpoolctl import threadpool_limits

from .errors import WorkerError

_limits = None

#: prctl option: signal delivered to this process when its parent dies (linux/prctl.h)
_PR_SET_PDEATHSIG = 1
#: how long terminated workers get to exit before they are killed, s
_TERMINATE_WAIT = 2.0


def _die_with_parent(parent: int) -> None:
    """Killed when the parent dies (a forked worker's parent is the run)."""
    if not sys.platform.startswith("linux"):
        return
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # died before prctl took effect
        os._exit(1)


def _die_with_run(run: int) -> None:
    """A fresh worker exits when the run dies, even by SIGKILL. Its parent is the fork server,
    and that outlives the run: the server stays while any worker holds its pipe, and each
    worker holds one. So the worker watches the run itself (a pidfd, readable once the run has
    gone; Linux 5.3 or later) from a thread that does nothing else."""
    if not hasattr(os, "pidfd_open"):
        return
    try:
        watched = os.pidfd_open(run)
    except ProcessLookupError:  # the run is gone already
        os._exit(1)
    except OSError:  # a kernel without pidfds
        return

    def watch() -> None:
        select.select([watched], [], [])
        os._exit(1)

    threading.Thread(target=watch, name="fabpanel-run-watch", daemon=True).start()


def _init_worker(parent: int, fresh: bool) -> None:
    global _limits
    if fresh:
        _die_with_run(parent)
    else:
        _die_with_parent(parent)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    # library warnings in workers would reach the user's terminal unasked; the stage checks
    # and the issues are what report a panel's problems
    warnings.simplefilter("ignore")
    _limits = threadpool_limits(limits=1)


def terminate_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel the queued tasks and stop the workers now (terminate, then kill)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(_TERMINATE_WAIT)
        if process.is_alive():
            process.kill()
            process.join(_TERMINATE_WAIT)


@dataclass(frozen=True)
class RaySettings:
    """How tasks go to Ray (from ``[run]``)."""

    worker_tasks: int
    retries: int


_RAY: contextvars.ContextVar[RaySettings | None] = contextvars.ContextVar("ray", default=None)


@contextmanager
def executor(kind: str, address: str | None, workers: int, worker_tasks: int, retries: int):
    """Inside, :func:`worker_pool` gives Ray pools when ``kind`` is "ray": joins the cluster at
    ``address``, or starts a local Ray instance of ``workers`` CPUs (shut down on leaving)."""
    if kind != "ray":
        yield
        return
    ray = import_ray()
    started = not ray.is_initialized()
    if started:
        options: dict[str, Any] = {
            "log_to_driver": False,
            "include_dashboard": False,
            "logging_level": logging.ERROR,  # its start-up notes are not the user's business
        }
        if address:
            ray.init(address=address, **options)
        else:
            ray.init(num_cpus=workers, **options)
    token = _RAY.set(RaySettings(worker_tasks, retries))
    try:
        yield
    finally:
        _RAY.reset(token)
        if started:
            ray.shutdown()


def import_ray():
    """The ``ray`` module, or an :class:`~fabpanel.errors.InputError` saying how to get it."""
    try:
        import ray
    except ImportError:
        from .errors import InputError

        raise InputError(
            '[run] executor = "ray" needs Ray; install it with pip install "fabpanel[ray]"'
        ) from None
    return ray


def _ray_task(fn: Callable, args: tuple, kwargs: dict) -> Any:
    """Run one task in a Ray worker, set up as a local worker is (once per process)."""
    global _limits
    if _limits is None:
        warnings.simplefilter("ignore")
        _limits = threadpool_limits(limits=1)
    return fn(*args, **kwargs)


class RayPool(Executor):
    """A :class:`concurrent.futures.Executor` whose tasks run on Ray (see the module docstring)."""

    def __init__(self, settings: RaySettings) -> None:
        ray = import_ray()
        self._remote = ray.remote(
            num_cpus=1, max_calls=settings.worker_tasks, max_retries=settings.retries
        )(_ray_task)
        self._refs: list = []

    def submit(self, fn: Callable, /, *args: Any, **kwargs: Any) -> Future:
        ref = self._remote.remote(fn, args, kwargs)
        self._refs.append(ref)
        return ref.future()

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        if cancel_futures or not wait:
            ray = import_ray()
            for ref in self._refs:
                ray.cancel(ref, force=True)
        self._refs = []


@contextmanager
def worker_pool(workers: int, fresh: bool = False) -> Iterator[Executor]:
    """A process pool whose workers use one BLAS thread each and never outlive the run.

    fresh : start the workers from a fresh server process ("forkserver") instead of forking
        this one. Needed once this process has run spyrrow or manifold3d: their thread pools
        (Rust's, TBB's) do not survive a fork, and a forked worker that packs or builds a
        manifold with them waits forever (seen: a build worker in ``clash.to_manifold``). Inside
        :func:`shared_pool`, the shared pool's workers.
    """
    ray_settings = _RAY.get()
    if ray_settings is not None:
        ray_pool = RayPool(ray_settings)
        try:
            yield ray_pool
        except BaseException:
            ray_pool.shutdown(wait=False, cancel_futures=True)
            raise
        ray_pool.shutdown()
        return
    shared = _SHARED.get()
    if fresh and shared is not None:
        # an error goes on up to the shared pool's owner, which stops the workers
        yield shared
        return
    context = None
    if fresh:
        _start_resource_tracker_quietly()
        context = multiprocessing.get_context("forkserver")
    pool = ProcessPoolExecutor(
        max_workers=workers,
        mp_context=context,
        initializer=_init_worker,
        initargs=(os.getpid(), fresh),
    )
    try:
        yield pool
    except BrokenProcessPool as err:
        terminate_pool(pool)
        raise WorkerError(_broken_pool_message(fresh)) from err
    except BaseException:
        terminate_pool(pool)
        raise
    pool.shutdown(wait=True)


def _start_resource_tracker_quietly() -> None:
    """Start multiprocessing's resource tracker (if not running) with its stderr on /dev/null.

    Fresh workers' queues use named semaphores, which the tracker removes when a run stops
    before its pools are closed (Ctrl-C, SIGTERM, a crash); it then also prints a warning about
    each "leaked" one, after fabpanel's last line, to the user's terminal. The removal is the
    point, the warnings are noise: the tracker inherits stderr when it starts, so it starts
    with /dev/null there."""
    from multiprocessing import resource_tracker

    sys.stderr.flush()
    try:
        saved = os.dup(2)
    except OSError:  # no stderr at all: nothing to keep quiet
        resource_tracker.ensure_running()
        return
    quiet = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(quiet, 2)
        resource_tracker.ensure_running()
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(quiet)


def _broken_pool_message(fresh: bool) -> str:
    """Why a pool's workers may have stopped: killed, out of memory, a crash in a native
    library; and for fresh workers started from a script of the user's, a missing main guard
    (each fresh worker imports the script that started the run, and without the guard runs it
    again, which cannot start workers of its own)."""
    message = (
        "a worker process stopped before its task was done (killed, out of memory, or a "
        "crash in OCCT)"
    )
    script = os.path.abspath(getattr(sys.modules.get("__main__"), "__file__", None) or "")
    package = os.path.dirname(os.path.abspath(__file__))
    # a script of the user's: not the console script, fabpanel itself or an installed tool's
    users = script.endswith(".py") and not script.startswith(package)
    if fresh and users and "site-packages" not in script:
        message += (
            f"; or {os.path.basename(script)} calls fabpanel at its top level: fresh workers "
            f'import it again, so put the calls under `if __name__ == "__main__":`'
        )
    return message


#: the pool :func:`shared_pool` lends to every fresh ``worker_pool`` opened inside it
_SHARED: contextvars.ContextVar[Executor | None] = contextvars.ContextVar(
    "fabpanel_shared_pool", default=None
)


@contextmanager
def shared_pool(workers: int) -> Iterator[None]:
    """One pool of fresh workers for every ``worker_pool(..., fresh=True)`` opened inside
    (the write stage's files): starting fresh workers costs about 3 s on 2 cores (a server
    process, then each worker importing OCCT and build123d), and the stage opened five pools.
    Nothing changes on Ray, with one worker, or inside another shared pool."""
    if workers <= 1 or _RAY.get() is not None or _SHARED.get() is not None:
        yield
        return
    with worker_pool(workers, fresh=True) as pool:
        token = _SHARED.set(pool)
        try:
            yield
        finally:
            _SHARED.reset(token)


class SideBySide:
    """Blocking writers started side by side, each in a thread of this process (with this
    thread's context: the shared pool, Ray) while the starting thread goes on with its own.

    The write stage's writers mostly wait on worker processes, or run in compiled code
    (OCCT, rhino3dm, Agg); one after another they left a core idle half the time. With one
    worker everything runs inline, at once, in the order started."""

    def __init__(self, workers: int) -> None:
        self._threads = (
            ThreadPoolExecutor(max_workers=8, thread_name_prefix="fabpanel-write")
            if workers > 1
            else None
        )
        self._started: list[Future] = []

    def start(self, fn: Callable[..., Any], *args: Any) -> Future:
        """``fn(*args)`` started; its future (inline: done, or raising at once)."""
        if self._threads is None:
            done: Future = Future()
            done.set_result(fn(*args))
            return done
        future = self._threads.submit(contextvars.copy_context().run, fn, *args)
        self._started.append(future)
        return future

    def join(self) -> None:
        """Wait for every writer; raise the first error."""
        for future in self._started:
            future.result()

    def stop(self) -> None:
        """Stop the shared worker pool (the writers' waits on it end at once), then wait for
        the writers, whatever they raise: nothing of theirs outlives the stage."""
        shared = _SHARED.get()
        if isinstance(shared, ProcessPoolExecutor):
            terminate_pool(shared)
        for future in self._started:
            future.cancel()
        wait(self._started)

    def close(self) -> None:
        if self._threads is not None:
            self._threads.shutdown(wait=True)


@contextmanager
def side_by_side(workers: int) -> Iterator[SideBySide]:
    """A :class:`SideBySide` whose writers have all finished on leaving; when the body or a
    writer raises (an error, Ctrl-C, SIGTERM), the workers are stopped and the writers waited
    for before the error goes on."""
    lanes = SideBySide(workers)
    try:
        yield lanes
        lanes.join()
    except BaseException:
        lanes.stop()
        raise
    finally:
        lanes.close()


def remove_temp_dir() -> None:
    """Remove multiprocessing's temporary folder of this process (``pymp-*``, the fork
    server's socket): it goes at the interpreter's exit, which a run stopped by a signal skips
    (:func:`os._exit`, after the run's own clean-up). The folder's path is kept only in
    multiprocessing's private process config; nothing happens if it is not there."""
    config = getattr(multiprocessing.current_process(), "_config", {})
    folder = config.get("tempdir") if isinstance(config, dict) else None
    if isinstance(folder, str) and os.path.basename(folder).startswith("pymp-"):
        shutil.rmtree(folder, ignore_errors=True)


def child_preexec() -> None:
    """``preexec_fn`` for external programs (CalculiX): killed when fabpanel dies, even by
    SIGKILL (a stopped run kills its child itself: ``subprocess.run`` does on any exception)."""
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)


def ray_active() -> bool:
    """Whether the pools of this run go to Ray."""
    return _RAY.get() is not None


__all__ = [
    "child_preexec",
    "executor",
    "ray_active",
    "remove_temp_dir",
    "shared_pool",
    "side_by_side",
    "terminate_pool",
    "worker_pool",
]


def map_chunks(work: Callable[[list], list], items: list, workers: int) -> list:
    """``work(chunk)`` over ``items`` cut into about four chunks a worker, in ``workers`` fresh
    worker processes (inline for one worker or few items); the results in order. Fresh workers:
    this process may have run threads (spyrrow's nests, OCCT) whose locks a forked worker would
    inherit held, and then wait on forever (seen in the demo)."""
    if workers <= 1 or len(items) < 16:
        return work(items)
    size = -(-len(items) // (4 * workers))
    chunks = [items[i : i + size] for i in range(0, len(items), size)]
    with worker_pool(workers, fresh=True) as pool:
        return [found for chunk in pool.map(work, chunks) for found in chunk]
