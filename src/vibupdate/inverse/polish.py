"""Polish: a bounded least-squares refinement of the first-stage answer on the full model.

The polish starts from the first stage's answer and minimizes, over the normalized parameters
in their box, the distance of every model value outside its admissible interval plus a small
pull toward the midpoints, in half-widths (`vibupdate.inverse.admissible`: the intervals the
verification holds the answer to); a frequency is its *declared* mode or zero, a shape is taken
at its best scale, and one eigen-solve gives residual and exact Jacobian
(`vibupdate.inverse.data_map`). The refined point is kept only where it lowers this objective.
It stops on scipy's tests or on a stall (`vibupdate.inverse.bounded_lsq.STALL_DECREASE`); the
evaluation budget and the optional time limit are backstops, reported
(`PolishResult.stopped_on`). Above `vibupdate.modal.eigen.DENSE_LIMIT` DOFs it first works in
reduced rounds (`_reduced_rounds`): the least squares on the model projected on the vectors of
one full evaluation, exact to first order there. The decision, its soft start and its rounds:
docs/polish-and-verification.md, section 7.2, and docs/notes/polish.md; figures:
`benchmarks/RESULTS.md`, "Figures behind src/: the decision layer".
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np

from vibupdate.options import check, default
from vibupdate.inverse.bounded_lsq import Monitor, Stop, bounded_least_squares, inside
from vibupdate.inverse.admissible import PULL, Admissible, evaluate, residuals
from vibupdate.data.measured import Configuration
from vibupdate.modal.eigen import DENSE_LIMIT

#: Evaluations of a reduced model in one round, at most (each a dense solve of ~100 DOFs).
REDUCED_EVALUATIONS = 200
#: A round the full model refutes although the reduced model predicted a gain below this
#: fraction of the objective ends the rounds as converged (below the reduced model's accuracy).
ROUND_SETTLED = 1e-6
#: A round whose step moves no normalized parameter by more than this (a fraction of the
#: parameter's reference value, Eq. 12) has converged.
ROUND_XTOL = 1e-10
#: Full-model evaluations of the default budget per unknown plus one (`PolishOptions`): a
#: backstop, the polish ends on convergence or on `bounded_lsq.STALL_DECREASE`.
EVALUATIONS_PER_UNKNOWN = 100
#: Every least squares of the polish (full or reduced model) starts with the distance rows
#: weighed by ``1 / START_PULL``, to ``ftol`` `START_FTOL`, and every admissible half-width at
#: least `START_FLOOR` of its datum's scale (`Admissible.floored`), then goes on from there with
#: `vibupdate.inverse.admissible.PULL` and the data's own intervals: the continuations of
#: docs/polish-and-verification.md, section 7.2 (without them trust-region steps crawl).
START_PULL = 0.1
START_FTOL = 1e-3
START_FLOOR = 1e-3
#: What stopped the polish, besides convergence and a stall: a limit, reported as a warning.
LIMITS = ("evaluations", "time")


@dataclass(frozen=True)
class PolishOptions:
    """Options of the polish stage.

    Attributes
    ----------
    enabled : bool
        Run the polish after the homotopy (default on).
    max_evaluations : int or None
        Residual evaluations on the full model at most (each one eigen-solve per
        configuration); None (default): `EVALUATIONS_PER_UNKNOWN` ``(n_x + 1)``. A backstop
        (module docstring), reported (`PolishResult.stopped_on`).
    max_seconds : float or None
        Wall-clock limit of the polish (None: none), checked after each full-model evaluation
        of the least squares; reported like the evaluation limit.
    tol : float
        ``ftol``, ``xtol`` and ``gtol`` of `scipy.optimize.least_squares`.
    reduced_rounds : int
        At most this many reduced rounds (module docstring) before the full-model finish, on
        models above `vibupdate.modal.eigen.DENSE_LIMIT` DOFs; 0 polishes on the full model only.
    """

    enabled: bool = default("polish", "enabled")
    max_evaluations: int | None = default("polish", "max_evaluations")
    tol: float = default("polish", "tol")
    reduced_rounds: int = default("polish", "reduced_rounds")
    max_seconds: float | None = default("polish", "max_seconds")

    def __post_init__(self):
        check("polish", self)       # types and ranges: vibupdate.options

    def budget(self, n_x: int) -> int:
        """Full-model evaluations allowed for ``n_x`` parameters.

        Parameters
        ----------
        n_x : int
            Number of updated parameters.

        Returns
        -------
        int
            ``max_evaluations`` when set, else `EVALUATIONS_PER_UNKNOWN` times ``n_x + 1``.
        """
        return self.max_evaluations if self.max_evaluations is not None else EVALUATIONS_PER_UNKNOWN * (n_x + 1)


@dataclass(frozen=True)
class PolishResult:
    """Outcome of the polish.

    Attributes
    ----------
    xbar_start, xbar : ndarray, shape (n_x,)
        The start in the box (on the full model nudged off a bound by
        `vibupdate.inverse.bounded_lsq.inside`, where its least squares starts) and the polished
        point (equal when the polish was not kept).
    cost_start, cost : float
        Polish objective at both points.
    kept : bool
        Whether the polished point replaced the first-stage answer; never when the polish
        stopped on a known answer (an answer found before: the run's own point is not evaluated).
    evaluations : int
        Evaluations of the full model (residual and Jacobian).
    message : str
        Why it stopped, in words.
    seconds : float
    rounds : int
        Reduced rounds taken (module docstring); 0 on the full model only.
    reduced_evaluations : int
        Evaluations of the reduced models in those rounds.
    stopped_on : {"convergence", "stall", "evaluations", "time", "known answer", "failure"}
        What ended it: a convergence test, a stall, one of the `LIMITS` (then the answer may
        be short of the optimum), reaching one of the known ``answers`` again, or an error.
    budget : int
        The evaluation limit it had.
    """

    xbar_start: np.ndarray
    xbar: np.ndarray
    cost_start: float
    cost: float
    kept: bool
    evaluations: int
    message: str
    seconds: float
    rounds: int = 0
    reduced_evaluations: int = 0
    stopped_on: str = "convergence"
    budget: int = 0

    @property
    def on_limit(self) -> bool:
        """Whether a limit (evaluations, time), not convergence, ended the polish."""
        return self.stopped_on in LIMITS

    def as_dict(self) -> dict:
        return {k: v for k, v in asdict(self).items() if k not in ("xbar_start", "xbar")}


def fit_least_squares(configurations: Sequence[Configuration], x0, contract: Admissible, known=None,
                      monitor=None, pull: float = PULL, memo: dict | None = None, evaluated: dict | None = None,
                      **options):
    """`bounded_least_squares` of the admissible-data residuals
    (`vibupdate.inverse.admissible.evaluate`, with ``pull``) from ``x0``, shape (n_x,), in the
    box of the normalized parameters; ``memo``, a dict, keeps the data maps of the last four
    points evaluated (scipy's answer is among them: the next stage starts there at another
    ``pull`` with no eigen-solve); ``evaluated``: as `bounded_least_squares` has it."""
    lo, hi = configurations[0].model.bounds()

    def at(x):
        if memo is None:
            return evaluate(configurations, contract, x, pull=pull)
        maps: list = []
        value = evaluate(configurations, contract, x, pull=pull, maps=maps)
        if len(memo) >= 4:
            memo.pop(next(iter(memo)))
        memo[np.asarray(x, dtype=float).tobytes()] = maps
        return value

    return bounded_least_squares(at, x0, lo, hi, known=known, monitor=monitor, evaluated=evaluated, **options)


def _reduced_rounds(configurations: list, x0, contract, options: PolishOptions, tols: dict, budget: int, say=None):
    """The reduced rounds (module docstring) from ``x0``.

    Returns ``(x, cost, evaluations, rounds, reduced_evaluations, converged)``: the best
    point found, its full-model objective, the counts, and why the rounds converged
    ("" when they did not: the full-model finish follows). They converge on a step below
    `ROUND_XTOL`, on a predicted gain below ``tol`` times the objective, where what is left is
    below the reduced model's accuracy (`ROUND_SETTLED`), or on a refuted step at an objective
    below ``tol`` times the start's (rounding noise); each case is one test below."""
    from threadpoolctl import threadpool_limits

    from vibupdate.inverse.reduction import kept_dofs, ritz_reduction

    lo, hi = configurations[0].model.bounds()
    x = inside(x0, lo, hi)
    basis: list = []
    value = evaluate(configurations, contract, x, basis=basis)
    cost = 0.5 * float(value[0] @ value[0])
    evaluations, rounds, reduced_evaluations, converged = 1, 0, 0, ""
    floor = options.tol * cost
    while rounds < options.reduced_rounds and evaluations < budget and cost > 0:
        reduced = [replace(cfg, model=ritz_reduction(cfg.model, kept_dofs(cfg), V)[0])
                   for cfg, V in zip(configurations, basis)]
        with threadpool_limits(limits=1, user_api="blas"):   # ~100-DOF dense solves: threads only contend
            first = fit_least_squares(reduced, x, contract.floored(START_FLOOR), pull=START_PULL,
                                      max_nfev=REDUCED_EVALUATIONS,
                                      **{**tols, "ftol": max(tols["ftol"], START_FTOL)})
            sol = fit_least_squares(reduced, first.x, contract, max_nfev=REDUCED_EVALUATIONS, **tols)
        rounds += 1
        reduced_evaluations += int(first.nfev) + int(sol.nfev)
        x_new = inside(sol.x, lo, hi)
        if np.max(np.abs(x_new - x)) <= ROUND_XTOL:
            converged = f"the next step moves no parameter by more than {ROUND_XTOL:g} of its reference value"
            break
        if float(sol.cost) > cost:   # the reduced model cannot get down to the full objective at x
            if float(sol.cost) - cost <= ROUND_SETTLED * cost:
                converged = (f"the reduced model, within {ROUND_SETTLED:g} of the full objective here, "
                             f"sees no gain")
            break              # else its own rounding floor is above the objective: finish on the full model
        if cost - float(sol.cost) <= options.tol * cost:
            converged = "the reduced model, exact to first order here, predicts a gain below tol x the objective"
            break
        basis_new: list = []
        value_new = evaluate(configurations, contract, x_new, basis=basis_new)
        evaluations += 1
        cost_new = 0.5 * float(value_new[0] @ value_new[0])
        if not cost_new < cost:
            if cost <= floor:   # a step refuted at a negligible objective: the evaluations' noise
                converged = "the full model refuted a further step at an objective below tol x the starting one"
            elif cost - float(sol.cost) <= ROUND_SETTLED * cost:
                converged = (f"the full model refuted a further step whose predicted gain was below "
                             f"{ROUND_SETTLED:g} of the objective")
            break
        x, cost, basis = x_new, cost_new, basis_new
        if say is not None:
            say(f"  polish round {rounds}: objective {cost:.4e} on the full model ({int(sol.nfev)} evaluations "
                f"of a {reduced[0].model.n_dofs}-DOF reduced model)")
    return x, cost, evaluations, rounds, reduced_evaluations, converged


def polish(configurations: Sequence[Configuration], xbar0, options: PolishOptions | None = None,
           progress=None, answers=None, contract: Admissible | None = None) -> PolishResult:
    """Refine ``xbar0`` by bounded least squares of the admissible data ``contract`` (module
    docstring; by default `Admissible.of` the configurations with the default verification
    options). ``progress(message)``, when given, hears of each reduced round (large models).
    Given ``answers`` (known answers, shape (n_a, n_x)), it also stops on reaching one of them
    again (`vibupdate.inverse.bounded_lsq.SAME_ANSWER`); ``PolishResult.stopped_on`` and
    ``message`` say what ended it."""
    options = options or PolishOptions()
    configurations = list(configurations)
    lo, hi = configurations[0].model.bounds()
    budget = options.budget(lo.size)
    start = time.perf_counter()
    x0 = np.clip(np.asarray(xbar0, dtype=float), lo, hi)
    contract = contract or Admissible.of(configurations)
    in_rounds = bool(options.reduced_rounds) and max(c.model.n_dofs for c in configurations) > DENSE_LIMIT
    # on the full model the start is where its least squares starts, nudged off a bound (`inside`):
    # the start's objective and the soft start's rows come from one eigen-solve with its Jacobians
    maps0: list | None = None if in_rounds else []
    x0 = x0 if in_rounds else inside(x0, lo, hi)
    r0, _ = evaluate(configurations, contract, x0, jacobian=maps0 is not None, maps=maps0)
    cost0 = 0.5 * float(r0 @ r0)
    tols = {"ftol": options.tol, "xtol": options.tol, "gtol": options.tol}
    x, rounds, reduced, converged, evaluations = x0, 0, 0, "", 0
    try:
        if in_rounds:
            try:
                x, cost, evaluations, rounds, reduced, converged = _reduced_rounds(
                    configurations, x0, contract, options, tols, budget, progress)
            except (np.linalg.LinAlgError, ValueError) as exc:   # the full-model least squares alone, from x0
                x, evaluations = x0, 0
                if progress is not None:
                    progress(f"  polish: the reduced rounds failed ({exc}); polishing on the full model")
        if converged or evaluations >= budget:
            stopped_on, message = ("convergence", f"converged in {rounds} reduced rounds: {converged}") if converged \
                else ("evaluations", f"stopped on the limit of {budget} evaluations of the full model in {rounds} "
                                     f"reduced rounds (set polish.max_evaluations to allow more)")
        else:
            x, cost, message, evaluations, stopped_on = _full_model(configurations, x, contract, tols, budget,
                                                                    evaluations, start, options.max_seconds, answers,
                                                                    maps0)
    except (np.linalg.LinAlgError, ValueError) as exc:
        return PolishResult(x0, x0, cost0, cost0, False, 0, f"polish failed: {exc}", time.perf_counter() - start,
                            stopped_on="failure", budget=budget)
    kept = bool(cost < cost0) and stopped_on != "known answer"
    if not kept and stopped_on != "known answer":
        message = f"not kept: the polish did not lower the objective ({message})"
    return PolishResult(x0, x if kept else x0, cost0, cost if kept else cost0, kept, evaluations, message,
                        time.perf_counter() - start, rounds, reduced, stopped_on, budget)


def _full_model(configurations: list, x, contract, tols: dict, budget: int, evaluations: int,
                started: float, max_seconds=None, answers=None, maps0=None):
    """The full-model least squares from ``x`` after ``evaluations`` of the ``budget``, its start
    with `START_PULL` first; restarted while scipy's step test stopped it and a restart still
    lowers the objective (trf's trust radius collapses on the way to a minimum on a bound; its
    cost test is met only on a step it accepted: converged), no point solved twice.
    ``maps0``: the data maps at ``x`` with their Jacobians, when the caller evaluated them.
    Returns ``(x, cost, message, evaluations, stopped_on)``: the best point, its objective, why
    it stopped in words, the evaluations counted from the polish's start, and what ended it."""
    lo, hi = configurations[0].model.bounds()
    x = inside(x, lo, hi)
    soft = contract.floored(START_FLOOR)
    start = (x, residuals(soft, maps0, True, START_PULL) if maps0 else evaluate(configurations, soft, x,
                                                                                  pull=START_PULL))

    def watch(x, value, left: int, ftol: float) -> Monitor:
        return Monitor(x, value, max(left, 1), budget, started, max_seconds, answers, stationary=(lo, hi, ftol))

    soft_ftol = max(tols["ftol"], START_FTOL)
    monitor = watch(x, start[1], budget - evaluations - 2, soft_ftol)   # one left for the objective at its best point
    memo: dict = {}
    try:   # the start (`START_PULL`, `START_FLOOR`), then the objective from its answer
        first = fit_least_squares(configurations, x, soft, known=start, monitor=monitor, pull=START_PULL,
                                  memo=memo, max_nfev=budget + 1, **{**tols, "ftol": soft_ftol})
        x = first.x
    except Stop as stop:
        if stop.reason == "known answer":   # the same answer again: its objective is not wanted
            return monitor.best[0], float("nan"), stop.args[0], evaluations + 1 + monitor.count, stop.reason
        if stop.reason not in ("stall", "convergence"):   # a limit
            x_best = monitor.best[0]
            r, _ = evaluate(configurations, contract, x_best, jacobian=False)
            return x_best, 0.5 * float(r @ r), stop.args[0], evaluations + 2 + monitor.count, stop.reason
        x = monitor.best[0]
    evaluations += 1 + monitor.count
    maps = memo.get(np.asarray(x, dtype=float).tobytes())   # the start's answer evaluated by it: no eigen-solve
    known = (x, residuals(contract, maps, True, PULL) if maps is not None else evaluate(configurations, contract, x))
    evaluations += int(maps is None)
    monitor = watch(*known, budget - evaluations, tols["ftol"])
    stopped_on, evaluated = "convergence", {}
    try:
        sol = fit_least_squares(configurations, known[0], contract, known=known, monitor=monitor,
                                evaluated=evaluated, max_nfev=budget + 1, **tols)
        while sol.status in (3, 4):   # scipy's step test (its cost test alone: converged)
            again = fit_least_squares(configurations, sol.x, contract, monitor=monitor, evaluated=evaluated,
                                      max_nfev=budget + 1, **tols)
            if not again.cost < sol.cost:
                break
            sol = again
        x, cost, message = sol.x, float(sol.cost), sol.message
    except Stop as stop:
        (x, _, cost), message, stopped_on = monitor.best, stop.args[0], stop.reason
    return x, cost, message, evaluations + monitor.count, stopped_on
