"""Multistart of the point estimate: random starts of the ``lam = 1`` problem as Dask tasks.

The homotopy (Section 3.4) follows one path from the convex relaxation; here the original
problem is solved cold from random points (`random_start_solve`) and the converged answers
are grouped into distinct local minima (``docs/outputs.md``, ``identifiability.multistart``).
Every start solves the same NLP, so each worker builds the problem and the compiled solver
once (cached by the case's content hash) and reuses them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vibupdate.extras import require
from vibupdate.io.case_types import Case


#: Worker-side cache: case digest -> (problem, backend).
_SOLVERS: dict[str, tuple] = {}


@dataclass(frozen=True)
class LocalMinimum:
    """One distinct local minimum.

    Attributes
    ----------
    xbar : ndarray, shape (n_x,)
        Normalized parameters of the best start that reached it.
    values : ndarray, shape (n_x,)
        Physical parameters, each in its unit.
    objective : float
        Exact objective there.
    starts : int
        Starts that converged to it.
    """

    xbar: np.ndarray
    values: np.ndarray
    objective: float
    starts: int


@dataclass(frozen=True)
class MultistartResult:
    """Distinct local minima (best objective first) and the count of starts that failed."""

    minima: tuple[LocalMinimum, ...]
    starts: int
    failed: int
    x_tol: float

    def as_dict(self, parameters) -> dict:
        return {"starts": self.starts, "failed": self.failed, "distinct_minima": len(self.minima),
                "x_tol": self.x_tol,
                "minima": [{"objective": m.objective, "starts": m.starts,
                            "values": {p.name: float(v) for p, v in zip(parameters, m.values)}}
                           for m in self.minima]}


def _solver(case: Case, digest: str):
    if digest not in _SOLVERS:
        _SOLVERS[digest] = build_solver(case.configurations, case.formulation, case.solver)
    return _SOLVERS[digest]


def random_start_solve(problem, backend, rng: np.random.Generator, proximal: float = 0.0) -> dict:
    """A cold ``lam = 1`` solve of ``problem`` from a random point: parameters from an arcsine
    law over their boxes (``Beta(1/2, 1/2)``: denser near the bounds, so the starts reach the
    ends of what the data allow more often than uniform starts), vector entries uniform in
    their boxes, lifted products and residuals consistent with them.

    With ``proximal > 0`` the answer is then pulled towards the random parameter point: a
    second solve, warm from the first answer ``(x1, u1)``, adds ``prox_weight ||z - z_t||^2`` with
    ``z_t`` the random parameters and the vectors ``u1``, and ``prox_weight`` chosen so that the term
    is ``proximal`` times the objective at ``z_t`` when ``||x - x_t|| = ||x1 - x_t||``. Where the
    minimizers form a set (an exact symmetry), the answer is then near the minimizer closest to
    the random point, instead of the one the interior-point barrier leads to (near the centre
    of the boxes). No solve without the term follows (it would walk back to the centre). The
    returned objective is the exact one (no proximal term); the caller judges whether it is good
    enough (`vibupdate.study.sweep` compares it with the homotopy's).

    Returns a dict with ``ok``, ``status``, ``xbar`` (list, normalized) and ``objective``.
    """
    from vibupdate.inverse.relaxation import lifted_values

    def point(x, u):
        return backend.join(x, u, lifted_values(problem, x, u), problem.residual(x, u))

    x0 = problem.x_lower + (problem.x_upper - problem.x_lower) * rng.beta(0.5, 0.5, problem.n_x)
    u0 = rng.uniform(problem.u_lower, problem.u_upper)
    out = backend.solve(point(x0, u0), 1.0)
    if proximal > 0 and out.status.ok:
        x1, u1, _, _ = backend.split(out.z)
        distance = float(np.sum((x1 - x0) ** 2))
        if distance > 1e-12:
            target = point(x0, u1)
            weight = proximal * problem.objective(x0, u1) / distance
            pulled = backend.solve(out.z, 1.0, prox_weight=weight, z_prev=target, warm=True, mult_x=out.mult_x,
                                   mult_g=out.mult_g)
            if pulled.status.ok:
                out = pulled
    x, u, _, _ = backend.split(out.z)
    x = np.clip(x, problem.x_lower, problem.x_upper)
    return {"ok": bool(out.status.ok), "status": out.status.value, "xbar": x.tolist(),
            "objective": problem.objective(x, u)}


def build_solver(configurations, formulation, solver):
    """The problem and the step solver of a set of configurations (compiled once per structure
    and process, `vibupdate.inverse.backends.casadi_ipopt.CACHE`)."""
    from vibupdate.inverse.backends import build
    from vibupdate.inverse.relaxation import mccormick
    from vibupdate.inverse.update import prepare

    problem = prepare(configurations, formulation)
    backend = build(problem, mccormick(problem), solver)
    return problem, backend


def solve_start(case: Case, digest: str, seed: int, index: int) -> dict:
    """Start ``index`` of a multistart: `random_start_solve` with the generator of
    ``(seed, index)``, on the solver built once per worker."""
    from vibupdate.study.sampling import sample_rng

    problem, backend = _solver(case, digest)
    return {"index": index, **random_start_solve(problem, backend, sample_rng(seed, index, stream=1))}


def group_minima(answers, model, x_tol: float) -> tuple[LocalMinimum, ...]:
    """Group converged answers (dicts of `solve_start`) into distinct minima, best first."""
    groups: list[list[dict]] = []
    for a in sorted(answers, key=lambda a: a["objective"]):
        x = np.asarray(a["xbar"])
        for g in groups:
            if np.max(np.abs(np.asarray(g[0]["xbar"]) - x)) <= x_tol:
                g.append(a)
                break
        else:
            groups.append([a])
    return tuple(LocalMinimum(np.asarray(g[0]["xbar"]), model.physical(np.asarray(g[0]["xbar"])),
                              float(g[0]["objective"]), len(g)) for g in groups)


def multistart(case: Case, starts: int, *, seed: int = 0, x_tol: float = 1e-3, workers: int | None = None,
               scheduler: str | None = None, client=None,
               progress: Callable[[str], None] | None = None) -> MultistartResult:
    """Solve the ``lam = 1`` problem of ``case`` from ``starts`` random points on Dask.

    Parameters
    ----------
    case : Case
    starts : int
    seed : int
        Start ``i`` depends on ``(seed, i)`` only.
    x_tol : float
        Largest difference of normalized parameters (Eq. 12) within one minimum.
    workers, scheduler, client
        The engine (`vibupdate.study.engine.open_client`).
    """
    require("study", "running on Dask")
    from distributed import as_completed

    from vibupdate.study.engine import Progress, case_digest, open_client

    say = progress or (lambda message: None)
    if isinstance(starts, bool) or not isinstance(starts, int) or starts < 1:
        raise ValueError(f"the number of starts must be an integer >= 1, got {starts!r}")
    if not x_tol > 0:
        raise ValueError(f"x_tol must be > 0, got {x_tol!r}")
    digest = case_digest(case)
    answers = []
    with open_client(workers, scheduler, client=client) as c:
        [payload] = c.scatter([case], broadcast=True, hash=False)
        futures = [c.submit(solve_start, payload, digest, seed, i, pure=False, retries=2) for i in range(starts)]
        tick = Progress(starts, say)
        for f in as_completed(futures):
            try:
                a = f.result()
            except Exception as exc:  # a start lost for good: counted as failed, not raised
                a = {"index": None, "ok": False, "status": f"task_error: {type(exc).__name__}: {exc}"}
            answers.append(a)
            tick.tick(failed=not a["ok"])
    ok = [a for a in answers if a["ok"]]
    minima = group_minima(ok, case.configurations[0].model, x_tol)
    say(f"multistart: {len(minima)} distinct local minima from {len(ok)} converged of {starts} starts")
    return MultistartResult(minima, starts, starts - len(ok), x_tol)
