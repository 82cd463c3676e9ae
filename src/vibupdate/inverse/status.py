"""Solver outcomes: one enum for every backend, mapped from each backend by a table."""

from __future__ import annotations

from enum import Enum

__all__ = ["Status", "IPOPT_STATUS", "from_ipopt"]


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


#: IPOPT's ``return_status`` strings (as CasADi reports them) -> Status.
IPOPT_STATUS = {
    "Solve_Succeeded": Status.SUCCESS,
    "Solved_To_Acceptable_Level": Status.ACCEPTABLE,
    "Feasible_Point_Found": Status.ACCEPTABLE,
    "Infeasible_Problem_Detected": Status.INFEASIBLE,
    "Maximum_Iterations_Exceeded": Status.MAX_ITERATIONS,
    "Maximum_CpuTime_Exceeded": Status.TIME_LIMIT,
    "Maximum_WallTime_Exceeded": Status.TIME_LIMIT,
    "Restoration_Failed": Status.NUMERICAL_ERROR,
    "Error_In_Step_Computation": Status.NUMERICAL_ERROR,
    "Search_Direction_Becomes_Too_Small": Status.NUMERICAL_ERROR,
    "Diverging_Iterates": Status.NUMERICAL_ERROR,
    "Invalid_Number_Detected": Status.NUMERICAL_ERROR,
    "Not_Enough_Degrees_Of_Freedom": Status.INFEASIBLE,
    "Invalid_Problem_Definition": Status.NUMERICAL_ERROR,
    "Invalid_Option": Status.NUMERICAL_ERROR,
    "Internal_Error": Status.NUMERICAL_ERROR,
    "Unrecoverable_Exception": Status.NUMERICAL_ERROR,
    "Insufficient_Memory": Status.NUMERICAL_ERROR,
    "User_Requested_Stop": Status.NOT_SOLVED,
}


def from_ipopt(return_status: str) -> Status:
    """Map an IPOPT return status; unknown strings count as a numerical error."""
    return IPOPT_STATUS.get(return_status, Status.NUMERICAL_ERROR)
