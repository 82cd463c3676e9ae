"""The ``lam = 0`` step as the convex QP it is, solved by PIQP (a sparse proximal interior-point
QP solver; docs/method.md, section 6).

At ``lam = 0`` the step NLP of `vibupdate.inverse.backends` (without a proximal term) is the
McCormick relaxation, a convex QP over ``z = [xbar, u, t, R]`` (shapes ``(n_x,)``, ``(n_u,)``,
``(n_b,)``, ``(n_R,)``)::

    min  sum_k w_k R_k^2
    s.t. R - A_x xbar - A_u u - A_b t = r0            (n_R equalities)
         lower <= G [xbar; u; t] <= upper              (4 n_b McCormick rows, Eq. 19)
         boxes on xbar, u, t

The multipliers are returned in the NLP backends' convention (CasADi's): the gradient of
``f + mult_g . g + mult_x . z`` vanishes, with ``g = [R - A_x xbar - A_u u - A_b t - r0;
G [xbar; u; t]]``; so a following step can start warm from them. PIQP's outcome codes map to
`Status` by `PIQP_STATUS`.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.backends import StepOutcome
from vibupdate.inverse.formulation.problem import BilinearProblem
from vibupdate.inverse.relaxation import McCormick
from vibupdate.inverse.status import Status


#: PIQP's status names -> Status.
PIQP_STATUS = {
    "PIQP_SOLVED": Status.SUCCESS,
    "PIQP_MAX_ITER_REACHED": Status.MAX_ITERATIONS,
    "PIQP_PRIMAL_INFEASIBLE": Status.INFEASIBLE,
    "PIQP_DUAL_INFEASIBLE": Status.NUMERICAL_ERROR,  # unbounded: impossible with finite boxes
    "PIQP_NUMERICS": Status.NUMERICAL_ERROR,
    "PIQP_UNSOLVED": Status.NOT_SOLVED,
    "PIQP_INVALID_SETTINGS": Status.NUMERICAL_ERROR,
}


class RelaxationQP:
    """The ``lam = 0`` QP of one problem (module docstring), its matrices built once.

    Parameters
    ----------
    problem : BilinearProblem
    envelope : McCormick
    lower, upper : ndarray, shape (n_x + n_u + n_b + n_R,)
        Simple bounds of ``z`` (``-inf`` / ``inf`` for ``R``).
    max_iter : int
    tol : float
        PIQP's absolute tolerance on the primal and dual residuals; its relative tolerance
        is ``tol / 10``.
    """

    def __init__(self, problem: BilinearProblem, envelope: McCormick, lower: np.ndarray, upper: np.ndarray, *,
                 max_iter: int = 3000, tol: float = 1e-10):
        n_x, n_u, n_b, n_r = problem.n_x, problem.n_u, problem.n_b, problem.n_r
        self.sizes = (n_x, n_u, n_b, n_r)
        self.row_weight = np.asarray(problem.row_weight, float)
        n_z = n_x + n_u + n_b + n_r
        self.P = sp.diags(np.r_[np.zeros(n_z - n_r), 2.0 * self.row_weight], format="csc")
        self.A = sp.hstack([-problem.A_x, -problem.A_u, -problem.A_b, sp.eye(n_r)], format="csc")
        self.b = np.asarray(problem.r0, float)
        self.G = sp.hstack([envelope.G, sp.csr_matrix((envelope.G.shape[0], n_r))], format="csc")
        self.h_l, self.h_u = np.asarray(envelope.lower, float), np.asarray(envelope.upper, float)
        self.lower, self.upper = np.asarray(lower, float), np.asarray(upper, float)
        self.max_iter = int(max_iter)
        self.tol = float(tol)

    def solve(self) -> StepOutcome:
        """Solve the QP from PIQP's own start; a failed solve is a status, never an exception."""
        import piqp

        n_r = self.sizes[3]
        start = time.perf_counter()
        solver = piqp.SparseSolver()
        solver.settings.verbose = False
        solver.settings.max_iter = self.max_iter
        solver.settings.eps_abs = self.tol
        solver.settings.eps_rel = self.tol / 10.0
        try:
            solver.setup(self.P, np.zeros(self.P.shape[0]), self.A, self.b, self.G, self.h_l, self.h_u,
                         self.lower, self.upper)
            raw = solver.solve().name
        except (ValueError, RuntimeError) as exc:  # e.g. crossed bounds: a status, not an exception
            n_z = self.P.shape[0]
            return StepOutcome(z=np.clip(np.zeros(n_z), self.lower, self.upper), objective=float("nan"),
                               iterations=0, status=Status.NUMERICAL_ERROR,
                               raw_status=f"PIQP error: {str(exc).splitlines()[0][:200]}",
                               seconds=time.perf_counter() - start, mult_x=np.zeros(n_z),
                               mult_g=np.zeros(self.A.shape[0] + self.G.shape[0]))
        result = solver.result
        z = np.array(result.x, dtype=float)
        z = np.clip(z, self.lower, self.upper)
        R = z[-n_r:]
        # PIQP's stationarity: P z + A' y + G' (z_u - z_l) + (z_bu - z_bl) = 0.
        mult_g = np.concatenate([np.asarray(result.y, float),
                                 np.asarray(result.z_u, float) - np.asarray(result.z_l, float)])
        mult_x = np.asarray(result.z_bu, float) - np.asarray(result.z_bl, float)
        return StepOutcome(z=z, objective=float(self.row_weight @ (R * R)), iterations=int(result.info.iter),
                           status=PIQP_STATUS.get(raw, Status.NUMERICAL_ERROR), raw_status=raw,
                           seconds=time.perf_counter() - start, mult_x=mult_x, mult_g=mult_g)
