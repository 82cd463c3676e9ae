"""Polish: a bounded least-squares refinement of the first-stage answer on the full model.

The homotopy minimizes the weighted eigen-residual of Eqs. 7 and 9 over parameters *and*
vectors; each measured frequency there need only be *some* eigenvalue of the model, and a
reduced model (Craig-Bampton) leaves its own small error. The polish starts from that answer
and minimizes, over the normalized parameters in their box, the distance of every model value
outside its admissible interval plus a small pull toward the midpoints, both in half-widths of
those intervals (`vibupdate.inverse.admissible`: the intervals the verification holds the
answer to). The model's value of a frequency is its *declared* mode or zero
(`vibupdate.data.pairing`), so the correspondence is enforced rather than hoped for; a shape
is taken at its best scale. The model's values and their exact Jacobian come from the data map
(`vibupdate.inverse.data_map`); one eigen-solve per evaluation serves residual and Jacobian. The refined point is kept only where it lowers this objective; both
points are recorded.

After a reduced (Craig-Bampton) first stage the polish is the finish on the full model. What
it gains over the first stage, and in how many evaluations: `benchmarks/RESULTS.md`, "Figures
behind src/: the decision layer".

**Stopping.** The least squares ends on scipy's tests (``ftol``, ``xtol``, ``gtol``), or on a
stall (`vibupdate.inverse.bounded_lsq.STALL_DECREASE`); the evaluation budget (`EVALUATIONS_PER_UNKNOWN`) and the optional
time limit are backstops, and a stop on either is reported (`PolishResult.stopped_on`) and
made a warning of the update. On noisy interval shapes from a poor start the polish may need
hundreds of evaluations: where several data are held at their intervals' ends, trust-region
steps zig-zag across those ends while the objective creeps down (docs/method.md, section 7.2;
docs/polish-and-verification.md).

**Reduced rounds on large models.** Above `vibupdate.modal.eigen.DENSE_LIMIT` DOFs one full
evaluation is one shift-invert eigen-solve and one sparse LU per measured shape (its
shape-ratio derivatives), and LU fill grows faster than the DOFs. The polish therefore works in
rounds: at the current point ``x`` one full evaluation gives the residual, the Jacobian and the
vectors it computed on the way (the modes, the shape-ratio derivative solutions ``V``, the
adjunct vectors of the zeros); the model is projected on the kept DOFs plus the span of those
vectors (`vibupdate.inverse.reduction.ritz_reduction`, ~100 DOFs, no factorization), and the
same least squares runs on that reduced model (dense, milliseconds per evaluation). The
modes and their derivatives lie in the basis, so at ``x`` the reduced model has the full
model's residual *and* Jacobian, and away from it an error of second order: the rounds
converge like Newton steps. Each round's answer is evaluated on the full model and kept only
if it lowers the objective there; the rounds converge when a step moves no parameter by more
than `ROUND_XTOL`, when the reduced model sees no gain worth ``tol``, or when what is left is
below the reduced model's own accuracy (a refuted step at a negligible objective or with a
predicted gain below `ROUND_SETTLED` of it; the reduced model's best within `ROUND_SETTLED`
above the full objective). Otherwise (the reduced model's rounding floor far above the
objective, a refuted step with a large predicted gain, the round limit) the usual full-model
least squares finishes from the best point.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from vibupdate.options import check, default
from vibupdate.inverse.bounded_lsq import Monitor, Stop, bounded_least_squares, inside, stall_window
from vibupdate.inverse.admissible import PULL, Admissible, evaluate, residuals
from vibupdate.inverse.data_map import data_map
from vibupdate.data.measured import Configuration
from vibupdate.modal.eigen import DENSE_LIMIT

#: Evaluations of a reduced model in one round, at most (each a dense solve of ~100 DOFs).
REDUCED_EVALUATIONS = 200
#: A round the full model refutes although the reduced model predicted a gain below this
#: fraction of the objective ends the rounds as converged: what is left is below the reduced
#: model's own accuracy.
ROUND_SETTLED = 1e-6
#: A round whose step moves no normalized parameter by more than this (a fraction of the
#: parameter's reference value, Eq. 12) has converged.
ROUND_XTOL = 1e-10
#: Full-model evaluations of the default budget per unknown plus one (`PolishOptions`): a
#: backstop, the polish ends on convergence or on `bounded_lsq.STALL_DECREASE`.
EVALUATIONS_PER_UNKNOWN = 100
#: Every least squares of the polish (full or reduced model) starts with this weight of the
#: distance rows, ``1 / START_PULL``, to ``ftol`` `START_FTOL`, then goes on from there with
#: `vibupdate.inverse.admissible.PULL` (penalty continuation): at an interval's end a datum's
#: distance row switches on with slope ``1 / pull``, and with 0.01 from the start trust-region
#: steps crawl along the ends that hold the answer.
START_PULL = 0.1
START_FTOL = 1e-3
#: That start also holds every datum to an admissible half-width of at least this fraction of
#: its value (`vibupdate.inverse.admissible.Admissible.floored`; a shape entry: of its shape's
#: reference entry), then the finish holds the data to their own intervals (continuation in the
#: half-widths). Data known exactly beside data with a model-form tolerance weigh up to 1e4
#: times more per unit of relative change; their narrow intervals bend the least squares' valley
#: so that trust-region steps crawl along it (800 evaluations without converging, where the
#: floored start then the finish take 30 and converge: `benchmarks/RESULTS.md`, "The polish's
#: floored start").
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
        configuration); None (default) scales it with the problem,
        `EVALUATIONS_PER_UNKNOWN` ``(n_x + 1)``. The polish normally ends long before, on
        scipy's convergence tests or on a stall (`vibupdate.inverse.bounded_lsq.STALL_DECREASE`); a stop on this limit is
        reported (`PolishResult.stopped_on`) and made a warning of the update.
    max_seconds : float or None
        Wall-clock limit of the polish (None: none), checked after each full-model evaluation
        of the least squares (the reduced rounds, a few full evaluations, run to their end); a
        stop on it is reported like the evaluation limit.
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
        """Full-model evaluations allowed for ``n_x`` parameters."""
        return self.max_evaluations if self.max_evaluations is not None else EVALUATIONS_PER_UNKNOWN * (n_x + 1)


@dataclass(frozen=True)
class PolishResult:
    """Outcome of the polish.

    Attributes
    ----------
    xbar_start, xbar : ndarray, shape (n_x,)
        First-stage answer and polished point (equal when the polish was not kept).
    cost_start, cost : float
        Polish objective at both points.
    kept : bool
        Whether the polished point replaced the first-stage answer.
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
        What ended it: a convergence test, a stall (`vibupdate.inverse.bounded_lsq.STALL_DECREASE`), one of the `LIMITS`
        (then the answer may be short of the optimum), reaching one of the known ``answers``
        again (`polish`), or an error.
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
        return {"cost_start": self.cost_start, "cost": self.cost, "kept": self.kept,
                "evaluations": self.evaluations, "message": self.message, "seconds": self.seconds,
                "rounds": self.rounds, "reduced_evaluations": self.reduced_evaluations,
                "stopped_on": self.stopped_on, "budget": self.budget}


def polish_residuals(configurations: Sequence[Configuration], xbar, shape_weight: float = 1.0,
                     jacobian: bool = True):
    """Residuals of the classical fit and their exact Jacobian: each declared frequency's
    relative error times ``sqrt(weight)``, then ``shape_weight`` times each shape ratio's and
    each modal mass's signed difference from its interval's midpoint (the mass relative to it):
    the eigenvector-difference fit of `vibupdate.inverse.baseline` and the data the minimum
    change keeps (`vibupdate.inverse.minimum_change`). The polish fits the admissible data
    instead (`vibupdate.inverse.admissible.residuals`).

    Returns
    -------
    r : ndarray, shape (n_r,)
        Per configuration, in the order of the data map (`vibupdate.inverse.data_map`).
    J : ndarray, shape (n_r, n_x), or None without ``jacobian``
    """
    res, jac = [], []
    for cfg in configurations:
        d = data_map(cfg, xbar, jacobian=jacobian, shapes=shape_weight > 0)
        measured = (*cfg.natural, *cfg.antiresonances)
        w = np.array([m.omega for m in measured])
        s = np.sqrt([m.weight for m in measured])
        lost = np.isnan(d.frequency_values)   # a zero the model lost: a constant penalty, no direction to follow
        res.append(np.where(lost, s, s * (d.frequency_values - w) / w))
        if jacobian:
            jac.append(np.where(lost[:, None], 0.0, s[:, None] * d.frequency_jacobian / w[:, None]))
        for k, (shape, ratio) in enumerate(zip(d.shapes, d.ratios)):
            res.append(shape_weight * (ratio - shape.midpoint))
            if jacobian:
                jac.append(shape_weight * d.ratio_jacobians[k])
        mid = np.array([0.5 * sum(shape.mass) for shape in d.shapes if shape.mass is not None])
        if mid.size:
            res.append(shape_weight * (d.masses - mid) / mid)
            if jacobian:
                jac.append(shape_weight * d.mass_jacobian / mid[:, None])
    r = np.concatenate(res) if res else np.zeros(0)
    return r, (np.vstack(jac) if jacobian and jac else None)


def fit_least_squares(configurations: Sequence[Configuration], x0, contract: Admissible, known=None,
                      monitor=None, pull: float = PULL, memo: dict | None = None, **options):
    """`bounded_least_squares` of the admissible-data residuals
    (`vibupdate.inverse.admissible.evaluate`, with ``pull``) from ``x0``, shape (n_x,), in the
    box of the normalized parameters; ``memo``, a dict, keeps the data maps of the last four
    points evaluated (scipy's answer is among them: the next stage starts there at another
    ``pull`` with no eigen-solve)."""
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

    return bounded_least_squares(at, x0, lo, hi, known=known, monitor=monitor, **options)


@dataclass(frozen=True)
class _Converged:
    """The reduced rounds' answer in the shape of a `least_squares` result."""

    x: np.ndarray
    cost: float
    status: int
    message: str


def _reduced_rounds(configurations: list, x0, contract, options: PolishOptions, tols: dict, budget: int, say=None):
    """The reduced rounds (module docstring) from ``x0``.

    Returns ``(x, value, evaluations, rounds, reduced_evaluations, converged)``: the best
    point found, its full-model residual and Jacobian, the counts, why the rounds converged ("" when
    they did not, and the full-model finish is needed). They converge when a round's step moves
    no normalized parameter by more than `ROUND_XTOL`; when the reduced model, at least as
    accurate as the full model at ``x``, predicts a gain below ``tol`` times the objective
    (scipy's ``ftol`` test, on the prediction); when what is left is below the reduced model's
    accuracy (its best within `ROUND_SETTLED` above the full objective, or the full model
    refuting a step whose predicted gain was below `ROUND_SETTLED` of the objective); or when
    the full model refutes a step at an objective below ``tol`` times that at ``x0`` (rounding
    noise). They stop unconverged where the reduced model's best lies further above the full
    objective (its projection's rounding floor), where the full model refutes a larger predicted
    gain, or at the round limit."""
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
        x, value, cost, basis = x_new, value_new, cost_new, basis_new
        if say is not None:
            say(f"  polish round {rounds}: objective {cost:.4e} on the full model ({int(sol.nfev)} evaluations "
                f"of a {reduced[0].model.n_dofs}-DOF reduced model)")
    return x, value, evaluations, rounds, reduced_evaluations, converged


def polish(configurations: Sequence[Configuration], xbar0, options: PolishOptions | None = None,
           progress=None, answers=None, contract: Admissible | None = None) -> PolishResult:
    """Refine ``xbar0`` by bounded least squares of the admissible data ``contract`` (module
    docstring; by default `Admissible.of` the configurations with the default verification
    options). ``progress(message)``, when given, hears of each reduced round (large models).

    It ends on scipy's convergence tests (``ftol``, ``xtol``, ``gtol`` = ``tol``), on a stall
    (`STALL_DECREASE`), on a limit (`PolishOptions.budget` evaluations, ``max_seconds``), or,
    given ``answers`` (known answers, shape (n_a, n_x)), on reaching one of them again
    (`SAME_ANSWER`, stopped on "known answer"); ``PolishResult.stopped_on`` and ``message`` say
    which."""
    options = options or PolishOptions()
    configurations = list(configurations)
    lo, hi = configurations[0].model.bounds()
    budget = options.budget(lo.size)
    start = time.perf_counter()
    x0 = np.clip(np.asarray(xbar0, dtype=float), lo, hi)
    contract = contract or Admissible.of(configurations)
    # the start's objective, and where the full-model least squares starts right here, its data
    # maps with their Jacobians: the soft start's residual comes from the same eigen-solve
    reuse = not _in_rounds(configurations, options) and np.array_equal(inside(x0, lo, hi), x0)
    maps0: list | None = [] if reuse else None
    r0, _ = evaluate(configurations, contract, x0, jacobian=maps0 is not None, maps=maps0)
    cost0 = 0.5 * float(r0 @ r0)
    tols = {"ftol": options.tol, "xtol": options.tol, "gtol": options.tol}
    try:
        x, cost, evaluations, rounds, reduced_evaluations, stopped_on, message = _minimize(
            configurations, x0, contract, options, tols, budget, start, answers, progress, maps0)
    except (np.linalg.LinAlgError, ValueError) as exc:
        return PolishResult(x0, x0, cost0, cost0, False, 0, f"polish failed: {exc}", time.perf_counter() - start,
                            stopped_on="failure", budget=budget)
    kept = bool(cost < cost0)
    if not kept:
        message = f"not kept: the polish did not lower the objective ({message})"
    return PolishResult(x0, x if kept else x0, cost0, cost if kept else cost0, kept, evaluations, message,
                        time.perf_counter() - start, rounds, reduced_evaluations, stopped_on, budget)


def _cost(configurations: list, contract: Admissible, x) -> float:
    """The polish's objective at ``x``."""
    r, _ = evaluate(configurations, contract, x, jacobian=False)
    return 0.5 * float(r @ r)


def _in_rounds(configurations: list, options: PolishOptions) -> bool:
    """Whether the polish starts with reduced rounds (a model above `DENSE_LIMIT` DOFs)."""
    return bool(options.reduced_rounds) and max(c.model.n_dofs for c in configurations) > DENSE_LIMIT


def _minimize(configurations: list, x0, contract, options: PolishOptions, tols: dict, budget: int, started: float,
              answers, progress, maps0=None):
    """The reduced rounds on a large model, the full-model least squares where they did not
    converge (``maps0``: the data maps at ``x0`` with their Jacobians, when evaluated). Returns
    ``(x, cost, evaluations, rounds, reduced_evaluations, stopped_on, message)``, ``cost`` the
    objective at ``x``."""
    x, known, rounds, reduced, converged, evaluations = x0, None, 0, 0, "", 0
    if _in_rounds(configurations, options):
        try:
            x, value, evaluations, rounds, reduced, converged = _reduced_rounds(
                configurations, x0, contract, options, tols, budget, progress)
            known = (x, value)
        except (np.linalg.LinAlgError, ValueError) as exc:   # the full-model least squares alone, from x0
            x, evaluations, known = x0, 0, None
            if progress is not None:
                progress(f"  polish: the reduced rounds failed ({exc}); polishing on the full model")
    if converged or evaluations >= budget:
        cost = 0.5 * float(known[1][0] @ known[1][0])
        if converged:
            return x, cost, evaluations, rounds, reduced, "convergence", f"converged in {rounds} reduced rounds: {converged}"
        return (x, cost, evaluations, rounds, reduced, "evaluations",
                f"stopped on the limit of {budget} evaluations of the full model in {rounds} reduced rounds "
                f"(set polish.max_evaluations to allow more)")
    sol, evaluations, stopped_on = _full_model(configurations, x, contract, tols, budget, evaluations,
                                               started, options.max_seconds, answers, maps0)
    return sol.x, float(sol.cost), evaluations, rounds, reduced, stopped_on, sol.message


def _full_model(configurations: list, x, contract, tols: dict, budget: int, evaluations: int,
                started: float, max_seconds=None, answers=None, maps0=None):
    """The full-model least squares from ``x`` after ``evaluations`` of the ``budget``, its start
    with `START_PULL` first; restarted while scipy's step or cost
    test stopped it and a restart still lowers the objective: trf's trust radius collapses on
    the way to a minimum on a bound and its step test then stops it with the objective still
    falling.

    ``maps0``: the data maps at ``x`` (strictly inside the box) with their Jacobians, when the
    caller evaluated them. Returns ``(sol, evaluations, stopped_on)``: the best point in the
    shape of a `least_squares` result, the evaluations counted from the polish's start, and what
    ended it.
    """
    lo, hi = configurations[0].model.bounds()
    x = inside(x, lo, hi)
    soft = contract.floored(START_FLOOR)
    start = (x, residuals(soft, maps0, True, START_PULL) if maps0 else evaluate(configurations, soft, x,
                                                                                  pull=START_PULL))
    monitor = Monitor(x, start[1], max(budget - evaluations - 1, 1), budget, stall_window(lo.size), started,
                      max_seconds, answers)
    memo: dict = {}
    try:   # the start (`START_PULL`, `START_FLOOR`), then the objective from its answer
        first = fit_least_squares(configurations, x, soft, known=start, monitor=monitor, pull=START_PULL,
                                  memo=memo, max_nfev=budget + 1, **{**tols, "ftol": max(tols["ftol"], START_FTOL)})
        x = first.x
    except Stop as stop:
        if stop.reason != "stall":   # a limit, or a known answer reached again
            x_best = monitor.best[0]
            return (_Converged(x_best, _cost(configurations, contract, x_best), -2, stop.args[0]),
                    evaluations + 2 + monitor.count, stop.reason)
        x = monitor.best[0]
    evaluations += 1 + monitor.count
    maps = memo.get(np.asarray(x, dtype=float).tobytes())
    if maps is not None:   # the start's last evaluation was its answer: the same eigen-solve
        known = (x, residuals(contract, maps, True, PULL))
    else:
        known = (x, evaluate(configurations, contract, x))
        evaluations += 1
    monitor = Monitor(known[0], known[1], max(budget - evaluations, 1), budget, stall_window(lo.size), started,
                       max_seconds, answers)
    stopped_on = "convergence"
    try:
        sol = fit_least_squares(configurations, known[0], contract, known=known, monitor=monitor,
                                max_nfev=budget + 1, **tols)
        while sol.status in (2, 3, 4):
            again = fit_least_squares(configurations, sol.x, contract, monitor=monitor,
                                      max_nfev=budget + 1, **tols)
            if not again.cost < sol.cost:
                break
            sol = again
    except Stop as stop:
        x_best, _, cost_best = monitor.best
        sol, stopped_on = _Converged(x_best, cost_best, -2, stop.args[0]), stop.reason
    return sol, evaluations + monitor.count, stopped_on
