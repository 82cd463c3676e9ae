"""Solver outcomes: one enum for every backend.

Each backend maps its own outcome codes to `Status` by a table that it owns (IPOPT's:
`vibupdate.inverse.backends.casadi_ipopt.IPOPT_STATUS`).
"""

from __future__ import annotations

from enum import Enum


class Status(str, Enum):
    """Outcome of a solve or of the whole homotopy."""

    SUCCESS = "success"                  # lambda = 1 reached and the returned model verified
    ACCEPTABLE = "acceptable"            # as success, at IPOPT's looser acceptable tolerance
    NOT_VERIFIED = "not_verified"        # lambda = 1 reached, but a check of the model failed
    STEP_FAILED = "step_failed"          # a homotopy step failed down to the minimum step
    INFEASIBLE = "infeasible"
    MAX_ITERATIONS = "max_iterations"
    TIME_LIMIT = "time_limit"
    NUMERICAL_ERROR = "numerical_error"
    NOT_SOLVED = "not_solved"

    @property
    def ok(self) -> bool:
        return self in (Status.SUCCESS, Status.ACCEPTABLE)
