"""Ctrl-C inside compiled solvers.

CasADi checks for a pending SIGINT between IPOPT iterations, stops the solve and returns the
status ``NonIpopt_Exception_Thrown`` (or raises ``RuntimeError`` while building a function),
and clears Python's ``KeyboardInterrupt`` on the way: left alone, a Ctrl-C would look like a
failed step, retried cold. `watch_sigint` records the signal during a solve, passes it on to
the handler it replaced (Python's default raises ``KeyboardInterrupt``, which makes CasADi stop
promptly) and raises ``KeyboardInterrupt`` after the solve, whatever CasADi returned.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager


@contextmanager
def watch_sigint():
    """Record SIGINT during the block and raise it as ``KeyboardInterrupt`` on leaving it.

    Outside the main thread, or where SIGINT is ignored or not handled by Python, the block
    runs unchanged (no signal can be recorded there). On leaving the block the previous
    handler is restored, and a recorded signal is raised even if the block returned normally.
    """
    previous = signal.getsignal(signal.SIGINT)
    # SIG_IGN, SIG_DFL or a handler installed outside Python: nothing to pass the signal on to
    if threading.current_thread() is not threading.main_thread() or not callable(previous):
        yield
        return
    interrupted = []

    def handler(signum, frame):
        interrupted.append(signum)
        previous(signum, frame)

    signal.signal(signal.SIGINT, handler)
    try:
        yield
    except Exception:
        if interrupted:  # e.g. CasADi's RuntimeError after it caught the interrupt
            raise KeyboardInterrupt from None
        raise
    finally:
        signal.signal(signal.SIGINT, previous)
    if interrupted:
        raise KeyboardInterrupt
