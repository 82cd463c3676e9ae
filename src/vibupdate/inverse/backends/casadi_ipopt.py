"""CasADi + IPOPT backend for the homotopy steps (IPOPT and MUMPS ship in the casadi wheel).

The NLP of one step is that of `vibupdate.inverse.backends`, each residual its own variable.
Everything that changes with the data is an NLP parameter, so the compiled solver depends only
on a problem's structure and is kept in a process-level cache (`CACHE`); every ``lam = 1`` step
is solved without ``t`` and the McCormick rows (`_compile`); the cold ``lam = 0`` step goes to
PIQP (`vibupdate.inverse.backends.piqp_relaxation`) unless ``relaxation_solver = "nlp"``;
warm steps re-use the previous point and multipliers; each IPOPT iteration calls a `Monitor`
that stops a solve at the time budget's deadline and says the progress of long ones. The
rules in full: docs/method.md, section 6, and docs/notes/homotopy.md. IPOPT's return codes
map to `Status` by `IPOPT_STATUS`.
"""

from __future__ import annotations

import hashlib
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.backends import StepOutcome
from vibupdate.inverse.formulation.problem import BilinearProblem
from vibupdate.inverse.interrupt import watch_sigint
from vibupdate.inverse.relaxation import McCormick
from vibupdate.inverse.status import Status


#: What may solve the cold ``lam = 0`` step (module docstring).
RELAXATION_SOLVERS = ("piqp", "nlp")

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


def _pattern(A) -> sp.csc_matrix:
    """``A`` as CSC with sorted, summed indices; explicit zeros are kept (part of the pattern)."""
    A = sp.csc_matrix(A, dtype=float, copy=True)
    A.sum_duplicates()
    A.sort_indices()
    return A


#: Seconds a solve runs before its progress is said, and between two progress lines.
PROGRESS_AFTER, PROGRESS_EVERY = 3.0, 5.0


class Monitor:
    """What the iteration callback of a compiled NLP does in the current solve: set by `start`
    before each solve, under the compiled NLP's lock."""

    def __init__(self):
        self.start(None, None, "")

    def start(self, deadline: float | None, say, stage: str) -> None:
        self.deadline, self.say, self.stage = deadline, say, stage
        self.iterations, self.expired = 0, False
        self.began = self.said = time.perf_counter()

    def iteration(self, objective: float) -> bool:
        """Called after each IPOPT iteration; True stops the solve."""
        self.iterations += 1
        now = time.perf_counter()
        if self.say is not None and now - self.began >= PROGRESS_AFTER and now - self.said >= PROGRESS_EVERY:
            self.said = now
            left = "" if self.deadline is None else f", {max(self.deadline - now, 0.0):.0f} s left of the time budget"
            self.say(f"    {self.stage}: iteration {self.iterations}, objective {objective:.4e}, "
                     f"{now - self.began:.0f} s in this solve{left}")
        if self.deadline is not None and now >= self.deadline:
            self.expired = True
            return True
        return False


def _iteration_callback(name: str, nx: int, ng: int, monitor: Monitor):
    """A CasADi callback with the inputs of an NLP solver's outputs that hands the objective to
    ``monitor`` and returns 1 (stop) when it says so."""
    import casadi as ca

    class IterationCallback(ca.Callback):
        def __init__(self):
            ca.Callback.__init__(self)
            self.construct(name, {})

        def get_n_in(self):
            return ca.nlpsol_n_out()

        def get_n_out(self):
            return 1

        def get_name_in(self, i):
            return ca.nlpsol_out(i)

        def get_name_out(self, i):
            return "ret"

        def get_sparsity_in(self, i):
            which = ca.nlpsol_out(i)
            if which == "f":
                return ca.Sparsity.scalar()
            if which in ("x", "lam_x"):
                return ca.Sparsity.dense(nx)
            if which in ("g", "lam_g"):
                return ca.Sparsity.dense(ng)
            return ca.Sparsity(0, 0)

        def eval(self, arg):
            return [1 if monitor.iteration(float(arg[1])) else 0]

    return IterationCallback()


@dataclass
class _Compiled:
    """The compiled step NLPs of one structure: the lifted one (any ``lam``) and the exact one
    (``lam = 1`` without ``t`` and the McCormick rows), each with a cold and a warm IPOPT
    instance built on first use."""

    nlps: dict
    options: dict
    solvers: dict = field(default_factory=dict)
    monitor: Monitor = field(default_factory=Monitor)
    callbacks: dict = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)
    build_lock: threading.Lock = field(default_factory=threading.Lock)

    def solver(self, nlp: str, start: str):
        """The IPOPT instance of NLP ``"lifted"`` or ``"exact"`` with ``"cold"`` or ``"warm"`` options."""
        key = (nlp, start)
        with self.build_lock:
            if key not in self.solvers:
                import casadi as ca

                if nlp not in self.callbacks:
                    sizes = self.nlps[nlp]
                    self.callbacks[nlp] = _iteration_callback(f"vibupdate_{nlp}_iterations", sizes["x"].numel(),
                                                              sizes["g"].numel(), self.monitor)
                options = {**self.options[start], "iteration_callback": self.callbacks[nlp]}
                with watch_sigint():  # CasADi would turn a Ctrl-C while building into a RuntimeError
                    self.solvers[key] = ca.nlpsol(f"vibupdate_{nlp}_{start}", "ipopt", self.nlps[nlp], options)
            return self.solvers[key]


class SolverCache:
    """Process-level cache of compiled step NLPs, keyed by a problem's structure.

    At most ``maxsize`` structures are kept (least recently used dropped). ``builds`` counts
    the compilations and ``hits`` the re-uses since the process started (or `clear`).
    """

    def __init__(self, maxsize: int = 8):
        self.maxsize = maxsize
        self.builds = 0
        self.hits = 0
        self._entries: OrderedDict[str, _Compiled] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: str, make) -> _Compiled:
        """The entry of ``key``, compiled by ``make()`` when absent."""
        with self._lock:
            entry = self._entries.get(key)
            if entry is not None:
                self._entries.move_to_end(key)
                self.hits += 1
                return entry
            entry = make()
            self.builds += 1
            self._entries[key] = entry
            while len(self._entries) > self.maxsize:
                self._entries.popitem(last=False)
            return entry

    def clear(self) -> None:
        """Drop every entry and reset the counters."""
        with self._lock:
            self._entries.clear()
            self.builds = 0
            self.hits = 0


#: The cache every `CasadiIpopt` uses unless given another.
CACHE = SolverCache()


def _structure_key(mats, problem: BilinearProblem, expand: bool, settings: dict) -> str:
    digest = hashlib.blake2b(digest_size=20)
    digest.update(repr((problem.n_x, problem.n_u, problem.n_b, problem.n_r, expand,
                        sorted(settings.items()))).encode())
    for A in mats:
        digest.update(repr(A.shape).encode())
        digest.update(np.ascontiguousarray(A.indptr, dtype=np.int64).tobytes())
        digest.update(np.ascontiguousarray(A.indices, dtype=np.int64).tobytes())
    digest.update(np.ascontiguousarray(problem.prod_x, dtype=np.int64).tobytes())
    digest.update(np.ascontiguousarray(problem.prod_u, dtype=np.int64).tobytes())
    return digest.hexdigest()


def _compile(mats, problem: BilinearProblem, expand: bool, settings: dict) -> _Compiled:
    """Build the parametric step NLPs, the lifted one and the exact one (``lam = 1``, over
    ``[xbar, u, R]``: the same minimizers, docs/notes/homotopy.md); their IPOPT instances are
    built on first use (`_Compiled.solver`)."""
    import casadi as ca

    n_x, n_u, n_b, n_r = problem.n_x, problem.n_u, problem.n_b, problem.n_r
    Sym = ca.SX if expand else ca.MX
    x, u, t, R = Sym.sym("x", n_x), Sym.sym("u", n_u), Sym.sym("t", n_b), Sym.sym("R", n_r)
    lam, prox_weight = Sym.sym("lam"), Sym.sym("prox_weight")
    x_prev, u_prev = Sym.sym("x_prev", n_x), Sym.sym("u_prev", n_u)
    row_weight, r0 = Sym.sym("row_weight", n_r), Sym.sym("r0", n_r)
    nonzeros, symbolic = [], []
    for name, A in zip(("A_u", "A_x", "A_b", "G"), mats):
        nz = Sym.sym(name, A.nnz)
        nonzeros.append(nz)
        symbolic.append(Sym(ca.Sparsity(A.shape[0], A.shape[1], A.indptr.tolist(), A.indices.tolist()), nz))
    A_u, A_x, A_b, G = symbolic
    px, pu = problem.prod_x.tolist(), problem.prod_u.tolist()
    # vec(): indexing a 1 x 1 symbol (a single parameter) with a list gives a row vector.
    products = ca.vec(x[px]) * ca.vec(u[pu]) if n_b else Sym(0, 1)
    linear = ca.mtimes(A_u, u) + ca.mtimes(A_x, x) + r0
    lifted = linear + (ca.mtimes(A_b, lam * products + (1 - lam) * t) if n_b else 0)
    exact = linear + (ca.mtimes(A_b, products) if n_b else 0)
    f = ca.dot(row_weight, R * R) + prox_weight * (ca.sumsqr(x - x_prev) + ca.sumsqr(u - u_prev))
    p = ca.vertcat(lam, prox_weight, x_prev, u_prev, row_weight, r0, *nonzeros)
    nlps = {
        "lifted": {"x": ca.vertcat(x, u, t, R), "p": p, "f": f,
                   "g": ca.vertcat(R - lifted, ca.mtimes(G, ca.vertcat(x, u, t)))},
        "exact": {"x": ca.vertcat(x, u, R), "p": p, "f": f, "g": R - exact},
    }
    cold = {
        "expand": expand,
        "print_time": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.max_iter": int(settings["max_iter"]),
        "ipopt.max_cpu_time": float(settings["max_cpu_time"]),
        "ipopt.tol": float(settings["tol"]),
        "ipopt.acceptable_tol": 1e-8,
        "ipopt.linear_solver": "mumps",
    }
    warm = {
        **cold,
        "ipopt.warm_start_init_point": "yes",
        "ipopt.warm_start_bound_push": 1e-9,
        "ipopt.warm_start_bound_frac": 1e-9,
        "ipopt.warm_start_slack_bound_push": 1e-9,
        "ipopt.warm_start_slack_bound_frac": 1e-9,
        "ipopt.warm_start_mult_bound_push": 1e-9,
        "ipopt.mu_init": 1e-6,
        "ipopt.mu_strategy": "adaptive",
    }
    return _Compiled(nlps=nlps, options={"cold": cold, "warm": warm})


class CasadiIpopt:
    """The step solver of one problem, on the compiled NLP of its structure.

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
        Build in SX and expand (True) or keep MX (False, the default: docs/notes/homotopy.md).
    cache : SolverCache, optional
        Where compiled NLPs are kept (default `CACHE`); ``None`` compiles a private one.
    relaxation_solver : {"piqp", "nlp"}, optional
        What solves the cold ``lam = 0`` step without a proximal term: the QP solver PIQP
        (default; IPOPT when it fails) or IPOPT on the lifted NLP (module docstring).
    """

    def __init__(self, problem: BilinearProblem, envelope: McCormick, *, max_iter: int = 3000,
                 max_cpu_time: float = 600.0, tol: float = 1e-10, expand: bool = False,
                 cache: SolverCache | None = CACHE, relaxation_solver: str = "piqp"):
        if relaxation_solver not in RELAXATION_SOLVERS:
            raise ValueError(f"relaxation_solver must be one of {sorted(RELAXATION_SOLVERS)}, "
                             f"got {relaxation_solver!r}")
        self.problem = problem
        n_x, n_u, n_b, n_r = problem.n_x, problem.n_u, problem.n_b, problem.n_r
        self.sizes = (n_x, n_u, n_b, n_r)
        self.expand = bool(expand)
        mats = [_pattern(A) for A in (problem.A_u, problem.A_x, problem.A_b, envelope.G)]
        settings = {"max_iter": int(max_iter), "max_cpu_time": float(max_cpu_time), "tol": float(tol)}
        key = _structure_key(mats, problem, self.expand, settings)
        if cache is None:
            self._compiled = _compile(mats, problem, self.expand, settings)
        else:
            self._compiled = cache.get(key, lambda: _compile(mats, problem, self.expand, settings))
        self._cold = None  # the lifted NLP's cold IPOPT instance: the first step's solver without the QP
        self._data = np.concatenate([problem.row_weight, problem.r0, *(A.data for A in mats)])
        self._row_weight = np.asarray(problem.row_weight, float)
        self._lbx = np.concatenate([problem.x_lower, problem.u_lower, envelope.t_lower, np.full(n_r, -np.inf)])
        self._ubx = np.concatenate([problem.x_upper, problem.u_upper, envelope.t_upper, np.full(n_r, np.inf)])
        self._lbg = np.concatenate([np.zeros(n_r), envelope.lower])
        self._ubg = np.concatenate([np.zeros(n_r), envelope.upper])
        self._exact_entries = np.r_[0:n_x + n_u, n_x + n_u + n_b:n_x + n_u + n_b + n_r]
        self._qp = None
        self._deadline, self._say = None, None
        if relaxation_solver == "piqp":
            from vibupdate.inverse.backends.piqp_relaxation import RelaxationQP

            self._qp = RelaxationQP(problem, envelope, self._lbx, self._ubx, max_iter=max_iter, tol=tol)
        else:
            self._cold = self._compiled.solver("lifted", "cold")

    def watch(self, deadline: float | None, say=None) -> None:
        """Stop every later solve at ``deadline`` (``time.perf_counter()`` seconds) and say the
        progress of long ones through ``say``."""
        self._deadline, self._say = deadline, say

    def split(self, z):
        """``z`` -> (xbar, u, t, R)."""
        n_x, n_u, n_b, _ = self.sizes
        return z[:n_x], z[n_x:n_x + n_u], z[n_x + n_u:n_x + n_u + n_b], z[n_x + n_u + n_b:]

    def join(self, x, u, t, R):
        """(xbar, u, t, R) -> ``z``."""
        return np.concatenate([x, u, t, R])

    def fit(self, z) -> float:
        """``sum_k w_k R_k^2`` at ``z`` (no proximal term)."""
        R = self.split(np.asarray(z, float))[3]
        return float(self._row_weight @ (R * R))

    def solve(self, z0, lam: float, *, prox_weight: float = 0.0, z_prev=None, warm: bool = False,
              mult_x=None, mult_g=None) -> StepOutcome:
        """Solve the step NLP at ``lam`` from ``z0`` (cold, or warm with the multipliers).

        The cold ``lam = 0`` step without a proximal term goes to the QP solver when one was
        chosen; at ``lam = 1`` the exact NLP's outcome is returned in the lifted layout
        (`_expand`). Raises ``KeyboardInterrupt`` when SIGINT arrives during the solve
        (`vibupdate.inverse.interrupt`).
        """
        if lam == 0.0 and prox_weight == 0.0 and not warm and self._qp is not None:
            relaxed = self._qp.solve()
            if relaxed.status.ok:
                return relaxed
            out = self._solve_nlp(z0, lam)
            return replace(out, raw_status=f"{out.raw_status} (after PIQP: {relaxed.raw_status})",
                           seconds=out.seconds + relaxed.seconds)
        return self._solve_nlp(z0, lam, prox_weight=prox_weight, z_prev=z_prev, warm=warm, mult_x=mult_x,
                               mult_g=mult_g)

    def _solve_nlp(self, z0, lam: float, *, prox_weight: float = 0.0, z_prev=None, warm: bool = False,
                   mult_x=None, mult_g=None) -> StepOutcome:
        """`solve` by IPOPT on the lifted NLP (the exact one at ``lam = 1``)."""
        n_x, n_u, n_b, n_r = self.sizes
        z0 = np.clip(np.asarray(z0, float), self._lbx, self._ubx)
        z_prev = z0 if z_prev is None else np.asarray(z_prev, float)
        p = np.concatenate([[lam, prox_weight], z_prev[:n_x], z_prev[n_x:n_x + n_u], self._data])
        exact = lam == 1.0
        keep = self._exact_entries if exact else slice(None)
        args = dict(x0=z0[keep], p=p, lbx=self._lbx[keep], ubx=self._ubx[keep],
                    lbg=self._lbg[:n_r] if exact else self._lbg, ubg=self._ubg[:n_r] if exact else self._ubg)
        start = time.perf_counter()
        try:
            if exact:
                solver = self._compiled.solver("exact", "cold")
            else:
                self._cold = self._cold or self._compiled.solver("lifted", "cold")
                solver = self._cold
            if warm and mult_x is not None and mult_g is not None:
                solver = self._compiled.solver("exact" if exact else "lifted", "warm")
                mult_x, mult_g = np.asarray(mult_x, float), np.asarray(mult_g, float)
                # CasADi's names for the multipliers
                args.update(lam_x0=mult_x[keep], lam_g0=mult_g[:n_r] if exact else mult_g)
            with self._compiled.lock, watch_sigint():
                monitor = self._compiled.monitor
                monitor.start(self._deadline, self._say, f"lambda = {lam:.4f}")
                sol = solver(**args)
                stats = solver.stats()
                expired = monitor.expired
                monitor.start(None, None, "")
        except RuntimeError as exc:  # CasADi raises on evaluation errors: a status, not an exception
            return StepOutcome(z=z0, objective=self.fit(z0), iterations=0, status=Status.NUMERICAL_ERROR,
                               raw_status=f"CasADi error: {str(exc).splitlines()[0][:200]}",
                               seconds=time.perf_counter() - start, mult_x=np.zeros(z0.size),
                               mult_g=np.zeros(self._lbg.size))
        seconds = time.perf_counter() - start
        raw = str(stats.get("return_status", "unknown"))
        status = Status.TIME_LIMIT if expired else from_ipopt(raw)
        if expired:
            raw = f"{raw} (the time budget was spent)"
        z = np.asarray(sol["x"]).ravel()
        m_x, m_g = np.asarray(sol["lam_x"]).ravel(), np.asarray(sol["lam_g"]).ravel()
        if exact:
            z, m_x, m_g = self._expand(z, m_x, m_g)
        return StepOutcome(z=z, objective=self.fit(z), iterations=int(stats.get("iter_count", -1)),
                           status=status, raw_status=raw, seconds=seconds, mult_x=m_x, mult_g=m_g)

    def _expand(self, z, m_x, m_g):
        """An exact NLP's point and multipliers in the lifted NLP's layout (``t = xbar u``)."""
        n_x, n_u, n_b, n_r = self.sizes
        x, u = z[:n_x], z[n_x:n_x + n_u]
        t = np.clip(x[self.problem.prod_x] * u[self.problem.prod_u], self._lbx[n_x + n_u:n_x + n_u + n_b],
                    self._ubx[n_x + n_u:n_x + n_u + n_b])
        full = np.concatenate([x, u, t, z[n_x + n_u:]])
        mult_x = np.zeros(full.size)
        mult_x[self._exact_entries] = m_x
        mult_g = np.concatenate([m_g, np.zeros(self._lbg.size - n_r)])
        return full, mult_x, mult_g


def build(problem: BilinearProblem, envelope: McCormick, options) -> CasadiIpopt:
    """The backend protocol's entry (`vibupdate.inverse.backends.build`)."""
    return CasadiIpopt(problem, envelope, max_iter=options.max_iter, max_cpu_time=options.max_cpu_time,
                       tol=options.tol, relaxation_solver=options.relaxation_solver)
