"""Ctrl-C with what a command kept of its output."""

from __future__ import annotations


class Interrupted(KeyboardInterrupt):
    """A KeyboardInterrupt that says what the interrupted command kept (``kept``: the rest of
    the command line's one line, e.g. ``"kept 3 sample rows in out/samples.csv"``)."""

    def __init__(self, kept: str):
        super().__init__(kept)
        self.kept = kept
