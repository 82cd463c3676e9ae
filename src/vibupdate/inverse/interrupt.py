"""Ctrl-C inside compiled solvers.

CasADi 3.8 checks for a pending SIGINT between IPOPT iterations, stops the solve and returns
the status ``NonIpopt_Exception_Thrown`` (or raises ``RuntimeError`` while building a
function), and clears Python's ``KeyboardInterrupt`` on the way. Left alone, a Ctrl-C would
then look like a failed step: the homotopy would retry it cold and the run would go on.

`watch_sigint` installs, for the duration of a solve, a handler that records the signal and
then calls the handler it replaced (Python's default raises ``KeyboardInterrupt``, which is
what makes CasADi stop promptly). After the solve the caller asks `raise_if_interrupted`,
which turns a recorded signal back into ``KeyboardInterrupt``, whatever CasADi returned.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager


class SigintWatch:
    """Whether SIGINT arrived while the watch was active."""

    def __init__(self):
        self.interrupted = False

    def raise_if_interrupted(self) -> None:
        """Raise ``KeyboardInterrupt`` if SIGINT arrived during the watch."""
        if self.interrupted:
            raise KeyboardInterrupt


@contextmanager
def watch_sigint():
    """Record SIGINT during the block (see the module docstring); yields a `SigintWatch`.

    Outside the main thread, or where SIGINT is ignored or not handled by Python, the block
    runs unchanged (no signal can be recorded there). On leaving the block the previous
    handler is restored, and a recorded signal is raised as ``KeyboardInterrupt`` even if the
    block returned normally.
    """
    watch = SigintWatch()
    if threading.current_thread() is not threading.main_thread():
        yield watch
        return
    previous = signal.getsignal(signal.SIGINT)
    if not callable(previous):  # SIG_IGN, SIG_DFL or a handler installed outside Python
        yield watch
        return

    def handler(signum, frame):
        watch.interrupted = True
        previous(signum, frame)

    signal.signal(signal.SIGINT, handler)
    try:
        yield watch
    except Exception:
        if watch.interrupted:  # e.g. CasADi's RuntimeError after it caught the interrupt
            raise KeyboardInterrupt from None
        raise
    finally:
        signal.signal(signal.SIGINT, previous)
    watch.raise_if_interrupted()
