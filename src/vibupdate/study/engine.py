"""The distributed engine: a Dask client on a local cluster or an existing scheduler
(``docs/cli.md``, "What the data allow").

Sweeps, batches and multistarts submit one task per sample, case or start. `open_client`
starts a ``LocalCluster`` of single-threaded worker processes (the NLP solves are
single-threaded; processes avoid the GIL) or connects to ``scheduler``. dask is imported inside
the functions: importing vibupdate does not import it.
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Iterator

from vibupdate.extras import require


def case_digest(case) -> str:
    """Content hash of an in-memory case (its data, model matrices and options): the key under
    which workers cache what they build from it."""
    import hashlib
    import pickle

    blob = pickle.dumps((case.configurations, case.formulation, case.solver, case.damping, case.frequency_tolerance))
    return hashlib.sha256(blob).hexdigest()


def default_workers() -> int:
    """One worker per core available to this process."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def open_client(workers: int | None = None, scheduler: str | None = None, *,
                client=None) -> Iterator[object]:
    """A ``distributed.Client``, closed (with its local cluster) on exit.

    Parameters
    ----------
    workers : int, optional
        Worker processes of the local cluster; default one per core. Ignored with a
        scheduler or a client.
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:port``).
    client : distributed.Client, optional
        An open client to use as is (not closed on exit).
    """
    if client is not None:
        yield client
        return
    require("study", "running on Dask")
    from distributed import Client, LocalCluster

    cluster = None
    if scheduler is not None:
        try:
            c = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise ValueError(f"cannot connect to the Dask scheduler at {scheduler!r}: {exc}") from None
    else:
        n = default_workers() if workers is None else workers
        if not isinstance(n, int) or n < 1:
            raise ValueError(f"the number of workers must be an integer >= 1, got {workers!r}")
        with _sigint_ignored():
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                                   silence_logs=40)
        c = Client(cluster)
    try:
        yield c
    finally:
        c.close()
        if cluster is not None:
            cluster.close()


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored while the local cluster starts its worker processes, which inherit it:
    Ctrl-C at a terminal (the whole process group) then interrupts only this process, which
    closes the cluster and so ends the workers, none with a traceback of its own. A Ctrl-C
    during the cluster's start is dropped; outside the main thread nothing changes."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


class Progress:
    """One progress line: done / total, failed, estimated time left.

    Parameters
    ----------
    total : int
        Tasks of this run.
    say : callable
        Receives the line.
    already : int
        Tasks finished before this run (a resumed sweep); counted as done, not in the rate.
    every : float
        Seconds between lines (the last line is always said).
    """

    def __init__(self, total: int, say: Callable[[str], None], already: int = 0, every: float = 2.0):
        self.total, self.say, self.already, self.every = total, say, already, every
        self.done = self.failed = 0
        self.start = self.last = time.perf_counter()

    def line(self) -> str:
        elapsed = time.perf_counter() - self.start
        n = self.already + self.done
        left = self.total - n
        if self.done and left:
            eta = f", ~{_duration(elapsed / self.done * left)} left"
        else:
            eta = "" if left else f", finished in {_duration(elapsed)}"
        return f"{n}/{self.total} done, {self.failed} failed{eta}"

    def tick(self, failed: bool = False) -> None:
        self.done += 1
        self.failed += bool(failed)
        now = time.perf_counter()
        if now - self.last >= self.every or self.already + self.done == self.total:
            self.last = now
            self.say(self.line())


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    minutes, s = divmod(seconds, 60)
    if minutes < 60:
        return f"{minutes} min {s:02d} s"
    hours, m = divmod(minutes, 60)
    return f"{hours} h {m:02d} min"
