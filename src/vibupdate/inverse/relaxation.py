"""How the problem is relaxed: lifting (Section 3.3), homotopy map (Eq. 18), McCormick (Eq. 19).

Each bilinear product ``xbar_i u_j`` of a `BilinearProblem` gets a lifted scalar ``t``, bounded
by the four McCormick rows of its box; the homotopy map replaces the product by
``lam xbar_i u_j + (1 - lam) t`` (docs/method.md, section 5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.formulation.problem import BilinearProblem


@dataclass(frozen=True)
class McCormick:
    """Eq. 19 as linear rows ``lower <= G [xbar; u; t] <= upper``.

    Attributes
    ----------
    G : csr_matrix, shape (4 n_b, n_x + n_u + n_b)
    lower, upper : ndarray, shape (4 n_b,)
        ``-inf`` / ``+inf`` where a row is one-sided.
    t_lower, t_upper : ndarray, shape (n_b,)
        The interval hull of each product over its box (implied by the rows, given to the
        solver as simple bounds).
    """

    G: sp.csr_matrix
    lower: np.ndarray
    upper: np.ndarray
    t_lower: np.ndarray
    t_upper: np.ndarray


def mccormick(problem: BilinearProblem) -> McCormick:
    """The McCormick envelope of every lifted product of ``problem``."""
    px, pu = problem.prod_x, problem.prod_u
    xL, xU = problem.x_lower[px], problem.x_upper[px]
    uL, uU = problem.u_lower[pu], problem.u_upper[pu]
    n_b, n_x, n_u = problem.n_b, problem.n_x, problem.n_u
    k = np.arange(n_b)
    # Row r of inequality q:  t - a_q * u - b_q * x  (>= or <=)  -a_q * b_q
    a = np.concatenate([xL, xU, xU, xL])   # coefficient of u
    b = np.concatenate([uL, uU, uL, uU])   # coefficient of x
    rows = np.arange(4 * n_b)
    cols_t = n_x + n_u + np.tile(k, 4)
    cols_u = n_x + np.tile(pu, 4)
    cols_x = np.tile(px, 4)
    G = sp.coo_matrix(
        (np.concatenate([np.ones(4 * n_b), -a, -b]),
         (np.concatenate([rows, rows, rows]), np.concatenate([cols_t, cols_u, cols_x]))),
        shape=(4 * n_b, n_x + n_u + n_b),
    ).tocsr()
    rhs = -a * b
    lower = np.where(rows < 2 * n_b, rhs, -np.inf)
    upper = np.where(rows < 2 * n_b, np.inf, rhs)
    corners = np.stack([xL * uL, xL * uU, xU * uL, xU * uU])
    return McCormick(G, lower, upper, corners.min(axis=0), corners.max(axis=0))


def lifted_values(problem: BilinearProblem, x, u) -> np.ndarray:
    """The products ``xbar[prod_x] * u[prod_u]``: the lifted variables of a point of the
    original problem, shape (n_b,)."""
    return np.asarray(x)[problem.prod_x] * np.asarray(u)[problem.prod_u]
