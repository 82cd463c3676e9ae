"""Solver outcomes: one enum for every backend, which maps its own codes to it by its own table.
"""

from __future__ import annotations

from enum import Enum


class Status(str, Enum):
    """Outcome of a solve or of the whole homotopy.

    The value of each member is the word ``results.json`` writes.

    Attributes
    ----------
    SUCCESS
        ``lam = 1`` reached and the returned model verified.
    ACCEPTABLE
        As ``SUCCESS``, at IPOPT's looser acceptable tolerance.
    NOT_VERIFIED
        ``lam = 1`` reached, but a check of the returned model failed.
    STEP_FAILED
        A homotopy step failed down to the minimum step.
    INFEASIBLE
        The solver found the problem infeasible.
    MAX_ITERATIONS
        The solver stopped at its iteration limit.
    TIME_LIMIT
        The solver or the homotopy stopped at its time limit.
    NUMERICAL_ERROR
        The solver stopped on a numerical failure (a restoration failure, an invalid number,
        an unknown return status).
    NOT_SOLVED
        The solver stopped without an answer (a stop on request, an unsolved QP).
    """

    SUCCESS = "success"
    ACCEPTABLE = "acceptable"
    NOT_VERIFIED = "not_verified"
    STEP_FAILED = "step_failed"
    INFEASIBLE = "infeasible"
    MAX_ITERATIONS = "max_iterations"
    TIME_LIMIT = "time_limit"
    NUMERICAL_ERROR = "numerical_error"
    NOT_SOLVED = "not_solved"

    @property
    def ok(self) -> bool:
        """True for ``SUCCESS`` and ``ACCEPTABLE``, the outcomes that reached their goal."""
        return self in (Status.SUCCESS, Status.ACCEPTABLE)


class Verdict(str, Enum):
    """What the update proved about its answer, apart from how the solver ended (`Status`).

    The value of each member is the word ``results.json`` writes.

    Attributes
    ----------
    VERIFIED
        Every datum lies in its admissible interval and every check passed, and no other
        answer that does was found (`vibupdate.inverse.search.Sought` says whether one was
        sought).
    NOT_UNIQUE
        Verified, and a different answer fits as well (both reported).
    NOT_VERIFIED
        A check failed, or the path failed.
    REFUSED
        The input was refused before any solve.
    """

    VERIFIED = "verified"
    NOT_UNIQUE = "not_unique"
    NOT_VERIFIED = "not_verified"
    REFUSED = "refused"

    @property
    def ok(self) -> bool:
        """True for ``VERIFIED`` and ``NOT_UNIQUE``, the verdicts of an answer that verified."""
        return self in (Verdict.VERIFIED, Verdict.NOT_UNIQUE)
