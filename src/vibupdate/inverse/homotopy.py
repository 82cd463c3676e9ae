"""How the problem is solved: the homotopy path from lam = 0 to lam = 1 (Section 3.4).

The convex McCormick relaxation (``lam = 0``, cold from the nominal point; its optimum is the
``relaxation_lower_bound``), then steps of ``lam``, the first ``1 / n_lambda`` and each accepted
one ``step_growth`` times longer than the last, warm and with a proximal term, to ``lam = 1``
without it. A failed step is retried cold, then the step as tried is halved down to
``min_step``. A spent time budget (``SolverOptions.time_budget``, watched by the backend
between its iterations when it can: ``watch(deadline, say)``) ends the path at its last
accepted point with status ``time_limit``, without retry or halving. The rules and why:
docs/method.md, section 6, and docs/notes/homotopy.md.

Every solve is recorded; a failed path is a status, never an exception. The steps are solved
by a backend chosen by name (`SolverOptions.backend`, `vibupdate.inverse.backends`).
"""

from __future__ import annotations

import threading
import time
import weakref
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from vibupdate.options import check, default
from vibupdate.inverse.backends import BACKENDS, StepOutcome, build
from vibupdate.inverse.formulation.problem import BilinearProblem
from vibupdate.inverse.relaxation import lifted_values, mccormick
from vibupdate.inverse.status import Status


@dataclass(frozen=True)
class SolverOptions:
    """Options of the homotopy solver.

    Attributes
    ----------
    n_lambda : int
        The first step is ``1 / n_lambda`` (the paper's ``n_lambda`` steps when
        ``step_growth = 1``). The default 1 is the direct jump from the relaxation to
        ``lam = 1``, which falls back to halved steps when it fails (docs/method.md, section
        6); 10 with ``step_growth = 2`` walks 0, 0.1, 0.3, 0.7, 1.
    step_growth : float
        Factor by which an accepted step lengthens the next one (>= 1).
    min_step : float
        Smallest step of ``lam`` after halving.
    proximal : float
        Proximal weight on intermediate steps, relative to the nominal objective.
    max_iter : int
        IPOPT iterations per solve.
    max_cpu_time : float
        Seconds per solve.
    tol : float
        The backend's convergence tolerance (IPOPT's ``tol``).
    time_budget : float
        Seconds the whole path may take, the relaxation included. When it is spent (checked
        between solves, and by the backend between its iterations) the path stops at its last
        accepted point with status ``time_limit``, said in the progress and the result, and
        the caller goes on with what it has.
    backend : str
        Name of the step solver (`vibupdate.inverse.backends.BACKENDS`).
    relaxation_solver : {"piqp", "nlp"}
        What solves the ``lam = 0`` relaxation, a convex QP: the QP solver PIQP (the default;
        the backend's NLP solver when PIQP fails) or the backend's NLP solver
        (docs/method.md, section 6).
    """

    n_lambda: int = default("solver", "n_lambda")
    step_growth: float = default("solver", "step_growth")
    min_step: float = default("solver", "min_step")
    proximal: float = default("solver", "proximal")
    max_iter: int = default("solver", "max_iter")
    max_cpu_time: float = default("solver", "max_cpu_time")
    tol: float = default("solver", "tol")
    time_budget: float = default("solver", "time_budget")
    backend: str = "casadi-ipopt"
    relaxation_solver: str = default("solver", "relaxation_solver")

    def __post_init__(self):
        check("solver", self)       # types and ranges: vibupdate.options
        if self.backend not in BACKENDS:
            raise ValueError(f"solver.backend: must be one of {sorted(BACKENDS)}, got {self.backend!r}")


@dataclass(frozen=True)
class StepRecord:
    """One solve on the homotopy path.

    Attributes
    ----------
    lam : float
        The homotopy parameter of the solve, in [0, 1] (0: the relaxation); written as
        ``lambda``.
    objective : float
        Weighted residual ``sum_k w_k R_k^2`` at the solve's point, without the proximal term
        (dimensionless).
    iterations : int
        Iterations of the step solver (IPOPT's, or the QP solver's for the relaxation).
    status : Status
        How the solve ended.
    seconds : float
        Wall time of the solve, s (0 when ``reused``).
    cold : bool
        Solved from a cold start: the relaxation, or the retry of a failed warm step.
    reused : bool
        The outcome of the identical relaxation solved before in this process, not solved
        again (`RELAXATIONS`).
    """

    lam: float = field(metadata={"key": "lambda"})
    objective: float
    iterations: int
    status: Status
    seconds: float
    cold: bool
    reused: bool = False

    def as_dict(self) -> dict:
        """The record as its ``results.json`` document.

        Returns
        -------
        dict
            Each field under its name (``lam`` as ``lambda``), ``status`` as its value.
        """
        return {"lambda": self.lam, "objective": self.objective, "iterations": self.iterations,
                "status": self.status.value, "seconds": self.seconds, "cold": self.cold,
                "reused": self.reused}


class RelaxationCache:
    """The ``lam = 0`` outcomes solved in this process, by the problem's identity
    (`BilinearProblem.identity`) and the solver settings that shape the outcome, each re-used
    while a problem it was solved for is alive (docs/notes/homotopy.md, "The relaxation solved
    once per run"); at most ``maxsize`` kept, the least recently used dropped."""

    def __init__(self, maxsize: int = 4):
        self.maxsize = maxsize
        self._entries: OrderedDict[tuple, tuple[weakref.ref, StepOutcome]] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, problem, key: tuple, solve: Callable[[], StepOutcome]) -> tuple[StepOutcome, bool]:
        """The outcome of ``key`` and True when it was re-used, else ``solve()`` and False."""
        with self._lock:
            entry = self._entries.get(key)
            if entry is not None and entry[0]() is not None:
                self._entries.move_to_end(key)
                return entry[1], True
        outcome = solve()
        with self._lock:
            self._entries[key] = (weakref.ref(problem), outcome)
            while len(self._entries) > self.maxsize:
                self._entries.popitem(last=False)
        return outcome, False


#: The cache `solve_homotopy` uses.
RELAXATIONS = RelaxationCache()


@dataclass(frozen=True)
class HomotopyResult:
    """Outcome of the path.

    Attributes
    ----------
    x : ndarray, shape (n_x,)
        Normalized parameters at the last accepted point.
    u : ndarray, shape (n_u,)
        Free vector entries at the last accepted point.
    t : ndarray, shape (n_b,)
    lam : float
        ``lam`` of the last accepted point (1 on success).
    status : Status
    objective : float
        Exact objective (``lam = 1``) at ``(x, u)``.
    lower_bound : float or None
        Optimum of the ``lam = 0`` relaxation.
    steps : tuple of StepRecord
    seconds : float
        Wall time of the path, building included.
    build_seconds : float
    relaxed_x, relaxed_u : ndarray or None
        Optimum of the ``lam = 0`` relaxation (shapes (n_x,) and (n_u,)), where solved.
    """

    x: np.ndarray
    u: np.ndarray
    t: np.ndarray
    lam: float
    status: Status
    objective: float
    lower_bound: float | None
    steps: tuple[StepRecord, ...]
    seconds: float
    build_seconds: float
    relaxed_x: np.ndarray | None = None
    relaxed_u: np.ndarray | None = None


def solve_homotopy(problem: BilinearProblem, options: SolverOptions | None = None,
                   progress: Callable[[str], None] | None = None) -> HomotopyResult:
    """Walk the homotopy path of ``problem`` (module docstring)."""
    options = options or SolverOptions()
    say = progress or (lambda message: None)
    start = time.perf_counter()
    envelope = mccormick(problem)
    backend = build(problem, envelope, options)
    build_seconds = time.perf_counter() - start
    say(f"  step solver ready ({options.backend}, {build_seconds:.2f} s)")
    x0 = np.clip(np.zeros(problem.n_x), problem.x_lower, problem.x_upper)
    u0 = problem.u_start
    z = backend.join(x0, u0, lifted_values(problem, x0, u0), problem.residual(x0, u0))
    deadline = start + options.time_budget
    watch = getattr(backend, "watch", None)
    if watch is not None:
        watch(deadline, say)
    f_nominal = problem.objective(x0, u0)
    prox_weight = options.proximal * max(f_nominal, 1e-12)
    steps: list[StepRecord] = []

    def record(lam, out: StepOutcome, cold: bool, reused: bool = False):   # the path moves where status.ok
        steps.append(StepRecord(lam, out.objective, out.iterations, out.status, out.seconds, cold, reused))
        say(f"  lambda = {lam:6.4f}  objective = {out.objective:.4e}  iterations = {out.iterations:4d}  "
            f"{out.status.value}{' (cold retry)' if cold and lam > 0 else ''}"
            + ("  (the identical relaxation solved before: re-used)" if reused else f"  {out.seconds:.2f} s"))

    key = (problem.identity(), options.backend, options.relaxation_solver, options.tol, options.max_iter,
           options.max_cpu_time, options.time_budget)
    first, reused = RELAXATIONS.get(problem, key, lambda: backend.solve(z, 0.0))
    if reused:
        first = replace(first, seconds=0.0)
    record(0.0, first, True, reused)
    if not first.status.ok:
        x, u, t, _ = backend.split(z)
        return HomotopyResult(x, u, t, 0.0, first.status, problem.objective(x, u), None,
                              tuple(steps), time.perf_counter() - start, build_seconds)
    lower_bound = first.objective
    relaxed_x, relaxed_u, _, _ = backend.split(first.z)
    current, lam, base = first, 0.0, 1.0 / options.n_lambda
    step, status = base, Status.SUCCESS
    while lam < 1.0:
        if time.perf_counter() >= deadline:
            status = Status.TIME_LIMIT
            say(f"  time budget of {options.time_budget:g} s spent: the path stops at lambda = {lam:.4f}")
            break
        target = min(1.0, lam + step)
        if 1.0 - target < 1e-12:
            target = 1.0
        weight = 0.0 if target == 1.0 else prox_weight
        out = backend.solve(current.z, target, prox_weight=weight, z_prev=current.z, warm=True,
                            mult_x=current.mult_x, mult_g=current.mult_g)
        record(target, out, False)
        if not out.status.ok and out.status != Status.TIME_LIMIT:
            out = backend.solve(current.z, target, prox_weight=weight, z_prev=current.z)
            record(target, out, True)
        if out.status == Status.TIME_LIMIT:
            status = Status.TIME_LIMIT
            say(f"  time budget of {options.time_budget:g} s spent in the step to lambda = {target:.4f}: the path "
                f"stops at lambda = {lam:.4f}")
            break
        if out.status.ok:
            current, lam = out, target
            step = max(base, step * options.step_growth)
            continue
        # halve the step that was tried: one clipped at lam = 1 is shorter than ``step``, and
        # halving ``step`` itself would try the same target (the same failed solves) again
        step = (target - lam) / 2.0
        if step < options.min_step:
            status = Status.STEP_FAILED
            say(f"  step failed at lambda = {target:.4f}: {out.raw_status}; stopped at lambda = {lam:.4f}")
            break
    x, u, t, _ = backend.split(current.z)
    if status == Status.SUCCESS and current.status == Status.ACCEPTABLE:
        status = Status.ACCEPTABLE  # lambda = 1 reached at IPOPT's looser tolerance
    return HomotopyResult(x, u, t, lam, status, problem.objective(x, u), lower_bound, tuple(steps),
                          time.perf_counter() - start, build_seconds, relaxed_x, relaxed_u)
