"""Where tasks run: Dask's local schedulers or a ``dask.distributed`` cluster.

:class:`Runner` is a thin wrapper over Dask: it owns the client (an existing
cluster at ``address``, or a ``LocalCluster`` it starts), ships large shared
inputs once, runs a list of independent task calls and hands each result to a
callback on the calling thread *as it completes*, so results can be saved
incrementally.

=============  ============================================================
scheduler      what runs the tasks
=============  ============================================================
``sync``       the calling thread, one task at a time (debugging, baselines)
``threads``    a thread pool of ``workers`` threads (the numba kernels
               release the GIL; HDF5 reads are serialised by h5py)
``processes``  a process pool of ``workers`` processes
``distributed``  ``address`` (``tcp://host:port``) of a running
               ``dask scheduler``; without it a ``LocalCluster`` of
               ``workers`` single-threaded worker processes (or threads,
               ``processes=False``).  The dashboard address is printed.
=============  ============================================================

Every worker of a ``distributed`` cluster (started here or at ``address``, and
any worker joining later) first runs :class:`~auralize.distributed.worker_setup.WorkerSetup`
once: it loads the numba kernels and undoes the allocator setting of Dask's
nanny that makes every large array page-fault anew (see
:mod:`auralize.distributed.worker_setup`; ``setup_workers=False`` skips it).  The
time this took is ``Runner.setup_seconds``.

A worker that dies mid-run is replaced by the cluster and its tasks are
re-run elsewhere (Dask's ``distributed.scheduler.allowed-failures``, default
3); when a task has killed too many workers the run stops with
:class:`RunError`, after everything finished so far has been handed to the
callback.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

from auralize.distributed._dask import require
from auralize.errors import AuralizeError, ParameterError

SCHEDULERS = ("sync", "threads", "processes", "distributed")
#: seconds to wait for a scheduler at ``--address`` before giving up
CONNECT_TIMEOUT_S = 5.0


class SchedulerError(AuralizeError, ConnectionError):
    """A Dask scheduler could not be reached or started."""


class RunError(AuralizeError, RuntimeError):
    """A distributed run stopped (a worker died too often, a pool broke)."""


#: interface a local cluster (scheduler, workers, dashboard) binds by default
LOOPBACK = "127.0.0.1"


def default_workers() -> int:
    """Cores available to this process."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


class Runner:
    """Run independent tasks on a Dask scheduler; results arrive as they complete.

    Parameters
    ----------
    scheduler : {"sync", "threads", "processes", "distributed"}
        See the module docstring.  ``address`` implies ``distributed``.
    address : str, optional
        ``tcp://host:port`` of a running Dask scheduler.
    workers : int, optional
        Threads, processes or local-cluster workers (default: the cores).
    processes : bool
        Local cluster of processes (True) or of threads in this process.
    timeout : float
        Seconds to wait for the scheduler at ``address``.
    log : callable, optional
        Called with one-line messages (the dashboard address); default print.
    setup_workers : bool
        Register :class:`~auralize.distributed.worker_setup.WorkerSetup` on the
        cluster's workers (``distributed`` only).
    profile : bool
        Keep the statistical profiler of the local cluster's workers (the
        dashboard's *Profile* page).  Off by default: it walks the stacks of
        the worker's threads every 10 ms in Python, which costs ~9 % of the
        CPU time of the synthesis and detection tasks (60 s ring8
        from the 256³ explosion, 1 worker, worker user time 111 s with it,
        101 s without).  Clusters given by ``address`` keep their own setting.
    dashboard_address : str, optional
        ``HOST:PORT`` the local cluster's dashboard listens on.  Default
        ``127.0.0.1:0`` (loopback, a free port): the dashboard has no login, so
        it is only reachable from other machines when an address such as
        ``0.0.0.0:8787`` is asked for.  The local scheduler and workers always
        listen on loopback.

    Examples
    --------
    >>> with Runner("threads", workers=2) as run:
    ...     got = {}
    ...     run.run([(pow, (2, k)) for k in range(4)], lambda i, r: got.update({i: r}))
    >>> [got[i] for i in range(4)]
    [1, 2, 4, 8]
    """

    def __init__(
        self,
        scheduler: str = "sync",
        *,
        address: str | None = None,
        workers: int | None = None,
        processes: bool = True,
        timeout: float = CONNECT_TIMEOUT_S,
        log: Callable[[str], None] | None = print,
        setup_workers: bool = True,
        profile: bool = False,
        dashboard_address: str | None = None,
    ) -> None:
        if address:
            if scheduler not in ("distributed", "sync"):
                raise ParameterError(
                    f"--address {address} needs --scheduler distributed, not {scheduler!r}"
                )
            scheduler = "distributed"
        if scheduler not in SCHEDULERS:
            raise ParameterError(f"unknown scheduler {scheduler!r}; choose one of {SCHEDULERS}")
        if workers is not None and (not isinstance(workers, int) or workers < 1):
            raise ParameterError(f"workers must be a positive integer, got {workers!r}")
        if not (timeout > 0):
            raise ParameterError(f"timeout must be > 0 seconds, got {timeout!r}")
        if address is not None and "://" not in address and ":" not in address:
            raise ParameterError(
                f"--address {address!r} is not a scheduler address; give tcp://HOST:PORT"
            )
        self.scheduler = scheduler
        self.address = address
        #: where a local cluster's dashboard listens: loopback unless asked otherwise
        self.dashboard_address = dashboard_address or f"{LOOPBACK}:0"
        self.workers = workers
        self.processes = processes
        self.timeout = float(timeout)
        self.log = log or (lambda _msg: None)
        self.client: Any = None
        self._cluster: Any = None
        self.dashboard_link: str | None = None
        self.setup_workers = bool(setup_workers)
        self.profile = bool(profile)
        #: seconds spent starting/connecting and setting up the workers
        self.setup_seconds = 0.0
        #: what each worker's set-up reported (pid, seconds, error)
        self.worker_setup: list[dict[str, Any]] = []
        require("dask")

    # ------------------------------------------------------------ life cycle
    def __enter__(self) -> Runner:
        if self.scheduler == "distributed":
            self._start_distributed()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the client and the local cluster this runner started."""
        if self.client is not None:
            with contextlib.suppress(Exception):
                self.client.close()
            self.client = None
        if self._cluster is not None:
            with contextlib.suppress(Exception):
                self._cluster.close()
            self._cluster = None

    def _start_distributed(self) -> None:
        distributed = require("distributed")
        t0 = time.perf_counter()
        if self.address:
            try:
                self.client = distributed.Client(self.address, timeout=self.timeout)
            except (OSError, TimeoutError, ValueError) as exc:
                raise SchedulerError(
                    f"no Dask scheduler answered at {self.address} within {self.timeout:g} s "
                    f"({type(exc).__name__}: {exc}); start one with 'dask scheduler' (and "
                    f"'dask worker {self.address}'), check the address, or leave out "
                    f"--address to start a local cluster (--workers N)"
                ) from None
        else:
            n = self.workers or default_workers()
            dask = require("dask")
            try:
                # (the nannies hand this configuration to the worker processes)
                with dask.config.set({"distributed.worker.profile.enabled": self.profile}):
                    self._cluster = distributed.LocalCluster(
                        n_workers=n,
                        threads_per_worker=1,
                        processes=self.processes,
                        dashboard_address=self.dashboard_address,
                        worker_dashboard_address=f"{LOOPBACK}:0",
                        silence_logs=logging.ERROR,
                        **({"host": LOOPBACK} if self.processes else {}),
                    )
                self.client = distributed.Client(self._cluster)
            except Exception as exc:  # pragma: no cover - depends on the machine
                self.close()
                raise SchedulerError(
                    f"could not start a local Dask cluster of {n} workers "
                    f"({type(exc).__name__}: {exc})"
                ) from None
        if self.setup_workers:
            self._setup_workers()
        self.setup_seconds = time.perf_counter() - t0
        self.dashboard_link = _dashboard(self.client)
        if self._cluster is not None and self.dashboard_address.startswith(f"{LOOPBACK}:"):
            # the link names the machine's address; the dashboard listens on loopback only
            self.dashboard_link = re.sub(
                r"//[^/:]+:", f"//{LOOPBACK}:", self.dashboard_link, count=1
            )
        n_workers = len(self.client.scheduler_info(n_workers=-1).get("workers", {}))
        where = self.address or f"local cluster ({'processes' if self.processes else 'threads'})"
        self.log(f"dask: {where}, {n_workers} workers; dashboard: {self.dashboard_link}")

    def _setup_workers(self) -> None:
        """Register the worker set-up plugin; it runs on every worker before this returns."""
        from auralize.distributed.worker_setup import WorkerSetup, setup_report

        self.client.register_plugin(WorkerSetup())
        self.worker_setup = sorted(
            self.client.run(setup_report).values(), key=lambda r: r.get("pid", 0)
        )
        for rep in self.worker_setup:
            if rep.get("error"):
                self.log(
                    f"dask: worker {rep.get('pid')} could not load the kernels ahead "
                    f"({rep['error']}); it will load them in its first task"
                )

    @property
    def n_workers(self) -> int:
        """How many tasks run at once."""
        if self.client is not None:
            info = self.client.scheduler_info(n_workers=-1).get("workers", {})
            return max(1, sum(int(w.get("nthreads", 1)) for w in info.values()))
        if self.scheduler == "sync":
            return 1
        return self.workers or default_workers()

    @property
    def threads_per_task(self) -> int | None:
        """numba threads a task should use (None: leave numba's default)."""
        return None if self.scheduler == "sync" else 1

    # ------------------------------------------------------------------ work
    def share(self, obj: Any) -> Any:
        """Ship a large input once to every worker; pass the result as a task argument."""
        if self.client is not None:
            return self.client.scatter(obj, broadcast=True, hash=False)
        return obj

    def place(self, objs: Sequence[Any]) -> list[Any]:
        """Send each of several large inputs to the cluster once, spread over the
        workers (not to every worker, unlike :meth:`share`); pass the results as
        task arguments.  A task runs where its input is (or Dask moves it)."""
        if self.client is not None and len(objs):
            return list(self.client.scatter(list(objs), hash=False))
        return list(objs)

    def place_each(self, objs: Iterable[Any]) -> Iterator[Any]:
        """:meth:`place`, one input at a time as ``objs`` produces them (each to
        the next worker in turn): work on the first can start while the next
        are still being prepared in this process."""
        if self.client is None:
            yield from objs
            return
        workers = sorted(self.client.scheduler_info(n_workers=-1).get("workers", {}))
        for i, obj in enumerate(objs):
            yield self.client.scatter(
                obj, hash=False, workers=[workers[i % len(workers)]] if workers else None
            )

    def call(self, fn: Callable[..., Any], *args: Any) -> Any:
        """A lazy ``fn(*args)`` (a ``dask.delayed``); ``args`` may hold other calls' results.

        Pass such calls to :meth:`compute`: a call that depends on others
        runs as soon as they are done, on a worker, without a round trip
        through this client.
        """
        dask = require("dask")
        return dask.delayed(fn, pure=False)(*args)

    def run(
        self,
        calls: Iterable[tuple[Callable[..., Any], tuple[Any, ...]]],
        on_result: Callable[[int, Any], None],
    ) -> None:
        """Run ``fn(*args)`` for every call; ``on_result(i, result)`` as each completes.

        ``on_result`` runs on the calling thread.  If it raises, the remaining
        tasks are cancelled and the exception propagates.  ``calls`` may be
        a generator: on a ``distributed`` cluster each call is submitted as
        soon as it is produced (the others schedulers take them all first).

        Raises
        ------
        RunError
            A worker died too often on one task, or the process pool broke.
        """
        if self.client is not None:
            self._compute_distributed((self.call(fn, *args) for fn, args in calls), on_result)
            return
        outputs = [self.call(fn, *args) for fn, args in calls]
        if outputs:
            self._compute_local(outputs, on_result)

    def compute(self, outputs: Sequence[Any], on_result: Callable[[int, Any], None]) -> None:
        """Compute lazy calls (:meth:`call`) and everything they depend on.

        ``on_result(i, result)`` is called on the calling thread as
        ``outputs[i]`` completes (an output other calls depend on is
        delivered too, and still used by them).  Otherwise as :meth:`run`.
        """
        if not outputs:
            return
        if self.client is not None:
            self._compute_distributed(outputs, on_result)
        else:
            self._compute_local(outputs, on_result)

    def _compute_local(self, outputs: Sequence[Any], on_result: Callable[[int, Any], None]) -> None:
        dask = require("dask")
        from dask.callbacks import Callback

        index = {t.key: i for i, t in enumerate(outputs)}
        # a tiny task after each output lets Dask free a result once it was delivered
        # (its input is replaced by None as soon as the result was handed over)
        tails = [dask.delayed(_nothing, pure=False)(t) for t in outputs]
        tail_keys = {t.key for t in tails}

        class _Deliver(Callback):
            def _posttask(
                self, key: Any, result: Any, dsk: Any, state: Any, worker_id: Any
            ) -> None:
                i = index.get(key)
                if i is not None:
                    on_result(i, result)
                    # delivered: do not keep it in the scheduler's cache until its tail
                    # runs (Dask's local order may run many tasks first), so the
                    # results held here stay bounded by the tasks in flight -- unless
                    # other tasks still need it
                    if not isinstance(state, dict):
                        return
                    cache = state.get("cache")
                    needed_by = state.get("dependents", {}).get(key, set())
                    if cache is not None and key in cache and set(needed_by) <= tail_keys:
                        cache[key] = None

        kw: dict[str, Any] = {"scheduler": self.scheduler}
        if self.scheduler != "sync":
            kw["num_workers"] = self.n_workers
        try:
            with _Deliver():
                dask.compute(*tails, **kw)
        except Exception as exc:
            if type(exc).__name__ == "BrokenProcessPool":
                raise RunError(
                    f"a worker process of the 'processes' scheduler died ({exc}); what finished "
                    f"is saved, run again to resume"
                ) from exc
            raise

    def _compute_distributed(
        self, outputs: Iterable[Any], on_result: Callable[[int, Any], None]
    ) -> None:
        distributed = require("distributed")
        futures: list[Any] = []
        index: dict[Any, int] = {}
        done = distributed.as_completed()
        try:
            # submitted one by one: the first run while the next are prepared
            for out in outputs:
                fut = self.client.compute(out)
                index[fut.key] = len(futures)
                futures.append(fut)
                done.add(fut)
            for fut in done:
                try:
                    result = fut.result()
                except (
                    distributed.scheduler.KilledWorker,
                    distributed.client.FutureCancelledError,
                ) as exc:
                    raise RunError(
                        f"task {index[fut.key]} of {len(futures)} killed the workers it ran on "
                        f"or was lost with them ({type(exc).__name__}: {exc}); what finished "
                        f"is saved, run again to resume"
                    ) from exc
                on_result(index[fut.key], result)
                fut.release()
        finally:
            self.client.cancel([f for f in futures if not f.done()])


def _nothing(_result: Any) -> None:
    return None


def _dashboard(client: Any) -> str:
    link = str(getattr(client, "dashboard_link", "") or "")
    try:
        import bokeh  # noqa: F401
    except ImportError:
        return f"{link} (pages need bokeh: pip install bokeh)" if link else "unavailable"
    return link or "unavailable"


@contextlib.contextmanager
def numba_threads(n: int | None) -> Iterator[None]:
    """Run numba kernels with ``n`` threads in this thread (None: unchanged)."""
    if n is None:
        yield
        return
    import numba

    old = numba.get_num_threads()
    limit = int(numba.config.NUMBA_NUM_THREADS)  # type: ignore[attr-defined]
    numba.set_num_threads(max(1, min(int(n), limit)))
    try:
        yield
    finally:
        numba.set_num_threads(old)
