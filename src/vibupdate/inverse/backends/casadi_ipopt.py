"""CasADi + IPOPT backend for the homotopy steps (IPOPT and MUMPS ship in the casadi wheel).

The NLP of one step, over ``z = [xbar, u, t, R]`` with parameters ``(lam, rho, xbar_prev,
u_prev)``:

    min  sum_k w_k R_k^2 + rho (||xbar - xbar_prev||^2 + ||u - u_prev||^2)
    s.t. R = A_u u + A_x xbar + A_b (lam xbar[px] u[pu] + (1 - lam) t) + r0
         McCormick rows (Eq. 19), boxes on xbar, u, t.

Each residual is its own variable with an equality constraint (docs/method.md, section 6);
the derivatives are exact and sparse. Sparse problems are built in CasADi SX and expanded
(fastest per iteration); problems whose residual rows are dense (a reduced model, see
`vibupdate.inverse.reduction`) are built in MX without expansion, because SX differentiation of
dense linear maps costs tens of seconds where MX takes one. The solver is built once, ``lam``
and the proximal data are parameters, and two IPOPT instances share the expressions: a cold
one (default start) and a warm one that re-uses the previous primal point and multipliers.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.formulation import BilinearProblem
from vibupdate.inverse.interrupt import watch_sigint
from vibupdate.inverse.relaxation import McCormick
from vibupdate.inverse.status import Status, from_ipopt

__all__ = ["CasadiIpopt", "StepOutcome"]


@dataclass(frozen=True)
class StepOutcome:
    """Result of one NLP solve.

    Attributes
    ----------
    z : ndarray, shape (n_x + n_u + n_b + n_R,)
    objective : float
        Weighted residual sum of squares (without the proximal term).
    iterations : int
    status : Status
    raw_status : str
    seconds : float
    lam_x, lam_g : ndarray
        Multipliers, for a warm start of the next step.
    """

    z: np.ndarray
    objective: float
    iterations: int
    status: Status
    raw_status: str
    seconds: float
    lam_x: np.ndarray
    lam_g: np.ndarray


def _dm(A):
    import casadi as ca

    A = sp.csc_matrix(A)
    A.sort_indices()
    return ca.DM(ca.Sparsity(A.shape[0], A.shape[1], A.indptr.tolist(), A.indices.tolist()), A.data)


class CasadiIpopt:
    """Builds the step NLP of a problem once and solves it for any ``lam``.

    Parameters
    ----------
    problem : BilinearProblem
    envelope : McCormick
    max_iter : int
    max_cpu_time : float
        Seconds per solve.
    tol : float
        IPOPT's ``tol``.
    expand : bool, optional
        Build in SX and expand (True) or keep MX (False); by default SX unless some residual
        row has more than `DENSE_ROW` non-zeros.
    """

    #: Residual rows with more non-zeros than this make the default build MX.
    DENSE_ROW = 200

    def __init__(self, problem: BilinearProblem, envelope: McCormick, *, max_iter: int = 3000,
                 max_cpu_time: float = 600.0, tol: float = 1e-10, expand: bool | None = None):
        import casadi as ca

        self.problem = problem
        n_x, n_u, n_b, n_r = problem.n_x, problem.n_u, problem.n_b, problem.n_r
        self.sizes = (n_x, n_u, n_b, n_r)
        if expand is None:
            row_nnz = np.diff(sp.csr_matrix(problem.A_b).indptr).max(initial=0)
            expand = bool(row_nnz <= self.DENSE_ROW)
        self.expand = expand
        Sym = ca.SX if expand else ca.MX
        x = Sym.sym("x", n_x)
        u = Sym.sym("u", n_u)
        t = Sym.sym("t", n_b)
        R = Sym.sym("R", n_r)
        lam = Sym.sym("lam")
        rho = Sym.sym("rho")
        x_prev = Sym.sym("x_prev", n_x)
        u_prev = Sym.sym("u_prev", n_u)
        px, pu = problem.prod_x.tolist(), problem.prod_u.tolist()
        # vec(): indexing a 1 x 1 symbol (a single parameter) with a list gives a row vector.
        blend = lam * (ca.vec(x[px]) * ca.vec(u[pu])) + (1 - lam) * t if n_b else Sym(0, 1)
        model = (ca.mtimes(_dm(problem.A_u), u) + ca.mtimes(_dm(problem.A_x), x)
                 + (ca.mtimes(_dm(problem.A_b), blend) if n_b else 0) + ca.DM(problem.r0))
        w = ca.DM(problem.row_weight)
        f = ca.dot(w, R * R) + rho * (ca.sumsqr(x - x_prev) + ca.sumsqr(u - u_prev))
        zlin = ca.vertcat(x, u, t)
        g = ca.vertcat(R - model, ca.mtimes(_dm(envelope.G), zlin))
        nlp = {"x": ca.vertcat(x, u, t, R), "p": ca.vertcat(lam, rho, x_prev, u_prev), "f": f, "g": g}
        self._lbx = np.concatenate([problem.x_lower, problem.u_lower, envelope.t_lower, np.full(n_r, -np.inf)])
        self._ubx = np.concatenate([problem.x_upper, problem.u_upper, envelope.t_upper, np.full(n_r, np.inf)])
        self._lbg = np.concatenate([np.zeros(n_r), envelope.lower])
        self._ubg = np.concatenate([np.zeros(n_r), envelope.upper])
        self._fit = ca.Function("fit", [nlp["x"]], [ca.dot(w, R * R)])
        common = {
            "expand": expand,
            "print_time": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "ipopt.max_iter": int(max_iter),
            "ipopt.max_cpu_time": float(max_cpu_time),
            "ipopt.tol": float(tol),
            "ipopt.acceptable_tol": 1e-8,
            "ipopt.linear_solver": "mumps",
        }
        warm = {
            **common,
            "ipopt.warm_start_init_point": "yes",
            "ipopt.warm_start_bound_push": 1e-9,
            "ipopt.warm_start_bound_frac": 1e-9,
            "ipopt.warm_start_slack_bound_push": 1e-9,
            "ipopt.warm_start_slack_bound_frac": 1e-9,
            "ipopt.warm_start_mult_bound_push": 1e-9,
            "ipopt.mu_init": 1e-6,
            "ipopt.mu_strategy": "adaptive",
        }
        with watch_sigint():  # CasADi would turn a Ctrl-C while building into a RuntimeError
            self._cold = ca.nlpsol("vibupdate_cold", "ipopt", nlp, common)
            self._warm = ca.nlpsol("vibupdate_warm", "ipopt", nlp, warm)

    def split(self, z):
        """``z`` -> (xbar, u, t, R)."""
        n_x, n_u, n_b, _ = self.sizes
        return z[:n_x], z[n_x:n_x + n_u], z[n_x + n_u:n_x + n_u + n_b], z[n_x + n_u + n_b:]

    def join(self, x, u, t, R):
        return np.concatenate([x, u, t, R])

    def solve(self, z0, lam: float, *, rho: float = 0.0, z_prev=None, warm: bool = False,
              lam_x0=None, lam_g0=None) -> StepOutcome:
        """Solve the step NLP at ``lam`` from ``z0`` (cold, or warm with multipliers).

        Raises ``KeyboardInterrupt`` when SIGINT arrives during the solve (CasADi stops IPOPT
        at the next iteration and would otherwise report an ordinary failure,
        `vibupdate.inverse.interrupt`).
        """
        n_x, n_u, _, _ = self.sizes
        z_prev = z0 if z_prev is None else z_prev
        p = np.concatenate([[lam, rho], z_prev[:n_x], z_prev[n_x:n_x + n_u]])
        z0 = np.clip(z0, self._lbx, self._ubx)
        args = dict(x0=z0, p=p, lbx=self._lbx, ubx=self._ubx, lbg=self._lbg, ubg=self._ubg)
        solver = self._cold
        if warm and lam_x0 is not None and lam_g0 is not None:
            solver = self._warm
            args.update(lam_x0=lam_x0, lam_g0=lam_g0)
        start = time.perf_counter()
        try:
            with watch_sigint():
                sol = solver(**args)
        except RuntimeError as exc:  # CasADi raises on evaluation errors: a status, not an exception
            return StepOutcome(z=z0, objective=float(self._fit(z0)), iterations=0, status=Status.NUMERICAL_ERROR,
                               raw_status=f"CasADi error: {str(exc).splitlines()[0][:200]}",
                               seconds=time.perf_counter() - start, lam_x=np.zeros(z0.size),
                               lam_g=np.zeros(self._lbg.size))
        seconds = time.perf_counter() - start
        stats = solver.stats()
        raw = str(stats.get("return_status", "unknown"))
        z = np.asarray(sol["x"]).ravel()
        return StepOutcome(
            z=z,
            objective=float(self._fit(z)),
            iterations=int(stats.get("iter_count", -1)),
            status=from_ipopt(raw),
            raw_status=raw,
            seconds=seconds,
            lam_x=np.asarray(sol["lam_x"]).ravel(),
            lam_g=np.asarray(sol["lam_g"]).ravel(),
        )
