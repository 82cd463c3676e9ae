"""Plots drawn by a second process that starts with the run.

Importing matplotlib and drawing a first figure (fonts, the Agg canvas) cost about 0.5 s, a
sixth of the bundled cantilever's run with the ``[plots]`` extra and as much as a third of
what its solve takes (benchmarks/RESULTS.md, "`vibupdate example cantilever`: where the time
goes"). The machines this runs on have a second core, idle while the solve runs. So, where
the operating system forks (Linux), `plot_process` forks a child when the run starts; the
child imports matplotlib and draws a throw-away figure while the parent solves, then draws
each plot it is sent. `vibupdate.io.outputs.drawn` sends a plot there when a child is up, and
keeps its meaning: True when the file was written, a warning naming the file otherwise; the
child's own warnings are issued again in the parent.

A plot whose arguments cannot be sent (pickled), a child that died, or a platform without
``fork``, a run inside a daemon process (a batch's worker) or a process that has imported
pyplot already (its cost paid) draws in the run's own process, as without this module. The child is a daemon: an
interrupted run does not wait for it. Threads and ``fork``: the child is forked before any
solve, and draws with numpy and matplotlib only.
"""

from __future__ import annotations

import contextlib
import pickle
import sys
import warnings

__all__ = ["plot_process", "active", "draw"]

_WORKER = None


def active():
    """The running child's connection, or None."""
    return _WORKER


@contextlib.contextmanager
def plot_process(wanted: bool = True):
    """Start the plotting child for the duration of a run (module docstring); nothing when
    ``wanted`` is false, matplotlib is not installed, one is already up, or the platform does
    not fork."""
    global _WORKER
    # with pyplot already imported (a second run in one process: tests, batches, notebooks) the
    # cost this saves is paid, and a child would only spend a core on its warm-up
    if (not wanted or _WORKER is not None or not sys.platform.startswith("linux") or "matplotlib.pyplot" in sys.modules
            or not _has_matplotlib()):
        yield None
        return
    import multiprocessing

    if multiprocessing.current_process().daemon:   # a batch's worker process may have no children
        yield None
        return
    context = multiprocessing.get_context("fork")
    parent, child = context.Pipe()
    process = context.Process(target=_serve, args=(child,), daemon=True, name="vibupdate-plots")
    try:
        process.start()
    except OSError:   # no process to spare: draw in this one
        yield None
        return
    child.close()
    _WORKER = (parent, process)
    try:
        yield _WORKER
    finally:   # every plot was waited for: nothing is lost by stopping the child at once
        _WORKER = None
        process.terminate()
        process.join(timeout=5)
        parent.close()


def _has_matplotlib() -> bool:
    from vibupdate._extras import installed

    return installed("plots")   # found, not imported: the child imports it


def draw(path, plot, args, kwargs) -> tuple[bool, str | None] | None:
    """Have the child call ``plot(path, *args, **kwargs)``: ``(True, None)`` when it wrote the
    file, ``(False, reason)`` when the plot failed there; None when it could not be asked (no
    child, arguments that do not pickle, a child that died), and the caller draws itself."""
    if _WORKER is None:
        return None
    parent, process = _WORKER
    try:
        message = pickle.dumps((plot, path, args, kwargs))
    except Exception:  # a closure or an open handle among the arguments: drawn here instead
        return None
    try:
        parent.send_bytes(message)
        ok, why, caught = parent.recv()
    except (OSError, EOFError, BrokenPipeError):
        return None
    for category, text in caught:
        warnings.warn(text, category, stacklevel=3)
    return ok, why


def _serve(connection) -> None:
    """The child: warm matplotlib up, then draw what it is sent until told to stop."""
    try:
        _warm_up()
    except Exception:  # each plot will say what fails
        pass
    while True:
        try:
            message = connection.recv_bytes()
        except (EOFError, OSError):
            return
        job = pickle.loads(message)
        if job is None:
            return
        connection.send(_call(*job))


def _warm_up() -> None:
    """Import matplotlib and draw one small figure to memory: fonts, the Agg canvas."""
    import io

    from vibupdate._extras import require

    require("plots", "drawing plots")
    import matplotlib

    matplotlib.use("Agg")   # as the plots do (vibupdate.report.plots)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(2, 1.5))
    ax.plot([0.0, 1.0], [0.0, 1.0], label="warm-up")
    ax.set_xlabel("x [Hz]")
    ax.legend()
    fig.savefig(io.BytesIO(), format="png", dpi=50)
    plt.close(fig)


def _call(plot, path, args, kwargs):
    """One plot, as `vibupdate.io.outputs.drawn` draws it: ``(ok, reason, warnings)``."""
    from vibupdate.io.outputs import draw_here

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ok, why = draw_here(path, plot, args, kwargs)
    return ok, why, [(w.category, str(w.message)) for w in caught]
