"""Solver backends for the homotopy steps, behind one small protocol (docs/method.md, section 6).

`build` returns the step solver of a problem from the backend named by
`SolverOptions.backend`; its ``solve`` solves, for one ``lam`` in ``[0, 1]``, the NLP over
``z = [xbar, u, t, R]`` (shapes ``(n_x,)``, ``(n_u,)``, ``(n_b,)``, ``(n_R,)``)

    min  sum_k w_k R_k^2 + prox_weight (||xbar - xbar_prev||^2 + ||u - u_prev||^2)
    s.t. R = A_u u + A_x xbar + A_b (lam xbar[px] u[pu] + (1 - lam) t) + r0,
         McCormick rows (Eq. 19), boxes on xbar, u, t

and returns a `StepOutcome`. Each backend maps its own outcome codes to `Status` by its own
table. Multipliers are named ``mult_x`` (of the simple bounds) and ``mult_g`` (of the
constraints) in this API, whatever the solver library calls them.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from vibupdate.inverse.status import Status


#: Backend name -> module that provides ``build(problem, envelope, options) -> StepSolver``.
BACKENDS = {"casadi-ipopt": "vibupdate.inverse.backends.casadi_ipopt"}


@dataclass(frozen=True)
class StepOutcome:
    """Result of one step solve.

    Attributes
    ----------
    z : ndarray, shape (n_x + n_u + n_b + n_R,)
        ``[xbar, u, t, R]`` at the end of the solve.
    objective : float
        Weighted residual sum of squares ``sum_k w_k R_k^2`` (without the proximal term).
    iterations : int
    status : Status
    raw_status : str
        The backend's own outcome code, for the record.
    seconds : float
        Wall time of the solve.
    mult_x : ndarray, shape (n_x + n_u + n_b + n_R,)
        Multipliers of the simple bounds, for a warm start of the next step.
    mult_g : ndarray, shape (n_R + 4 n_b,)
        Multipliers of the constraints (residual equalities, then McCormick rows).
    """

    z: np.ndarray
    objective: float
    iterations: int
    status: Status
    raw_status: str
    seconds: float
    mult_x: np.ndarray
    mult_g: np.ndarray


class StepSolver(Protocol):
    """What the homotopy needs from a backend: pack and unpack ``z``, and solve one step."""

    def join(self, x: np.ndarray, u: np.ndarray, t: np.ndarray, R: np.ndarray) -> np.ndarray:
        """``(xbar, u, t, R)`` -> ``z``."""

    def split(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``z`` -> ``(xbar, u, t, R)``."""

    def solve(self, z0: np.ndarray, lam: float, *, prox_weight: float = 0.0, z_prev: np.ndarray | None = None,
              warm: bool = False, mult_x: np.ndarray | None = None,
              mult_g: np.ndarray | None = None) -> StepOutcome:
        """Solve the step NLP at ``lam`` from ``z0``; warm with the multipliers when given.

        ``z_prev`` is the centre of the proximal term (default ``z0``). A failed solve is a
        `StepOutcome` with a failed status, never an exception.
        """


def build(problem, envelope, options) -> StepSolver:
    """The step solver of ``problem`` from the backend named ``options.backend``.

    Parameters
    ----------
    problem : BilinearProblem
    envelope : McCormick
        The McCormick rows of ``problem`` (`vibupdate.inverse.relaxation.mccormick`).
    options : SolverOptions
        ``backend`` names the backend; ``max_iter``, ``max_cpu_time`` and ``tol`` are its
        limits per solve.
    """
    name = options.backend
    if name not in BACKENDS:
        raise ValueError(f"solver backend must be one of {sorted(BACKENDS)}, got {name!r}")
    return importlib.import_module(BACKENDS[name]).build(problem, envelope, options)
