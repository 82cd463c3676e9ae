"""The updating as one call: ``update(configurations) -> UpdateResult``.

The first stage (formulation with interlacing signs, McCormick relaxation, homotopy: docs/method.md
sections 4-6; the vector boxes widened tenfold, at most twice, while the relaxation proves they
exclude every fit), then the polish on the full model, the minimum change along undetermined
directions, the verification against the admissible data, and the search for further starts
and other answers (docs/polish-and-verification.md, sections 7.2-7.7). The status is ``success``
only for a verified answer; when nothing verifies, the answer of lowest misfit of the admissible
data is returned, never above the nominal model's. The result is a frozen record of the updated
model and of how it was found.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.correlation import Correlation, model_frequencies
from vibupdate.inverse.data_map import Sensitivity, data_map, sensitivity
from vibupdate.inverse.formulation import formulate
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.formulation.problem import BilinearProblem
from vibupdate.inverse.homotopy import HomotopyResult, SolverOptions, StepRecord, solve_homotopy
from vibupdate.inverse.interlacing import sign_bounds
from vibupdate.inverse.minimum_change import (MinimumChange, minimum_change, onto_data, undetermined, valley_curve,
                                              valley_ends)
from vibupdate.data.measured import Configuration
from vibupdate.model.parameters import Parameter
from vibupdate.inverse.polish import PolishOptions, PolishResult, polish as run_polish
from vibupdate.inverse.reduction import (derivative_vectors, kept_dofs, reduce_configurations, ritz_reduction,
                                         wants_reduction)
from vibupdate.inverse.status import Status, Verdict
from vibupdate.inverse.admissible import Admissible, evaluate, misses, weighted
from vibupdate.inverse.search import Alternative, Search, SearchRecord, Sought, Start
from vibupdate.inverse.verify import Check, VerifyOptions, consistency_allowance, verify


#: Tenfold widenings of the vector boxes at most, when the relaxation proves they exclude every fit.
MAX_WIDENINGS = 2


@dataclass(frozen=True)
class UpdateResult:
    """Updated model and the record of the first stage.

    Attributes
    ----------
    status : Status
        How the first stage ended: ``SUCCESS`` (``ACCEPTABLE`` when the last solve met only
        IPOPT's looser tolerance) for a verified answer, ``NOT_VERIFIED`` when a check failed,
        a solver status when the path failed.
    message : str
        How the path ended and what the answer passed or failed, in words.
    parameters : tuple of Parameter
        The updated parameters, in the order of ``xbar`` and ``values``.
    xbar : ndarray, shape (n_x,)
        Updated normalized parameters (Eq. 12).
    values : ndarray, shape (n_x,)
        Updated physical parameters, in each parameter's unit.
    vectors : tuple of ndarray
        Identified mode / adjunct vectors of the answer (physical units, normalization of the
        formulation), in the order of ``problem.blocks``: the homotopy's own where the answer is
        its point, else those that fit best at ``xbar`` (`BilinearProblem.unknowns_at`).
    problem_size : dict of str to int
        Counts of the first stage's problem (`BilinearProblem.sizes`; ``reduced_dofs`` after a
        reduction).
    steps : tuple of StepRecord
        One per solve on the homotopy path, in order (``lam``, objective, iterations, status,
        wall seconds).
    objective : float
        The first stage's exact objective at the answer with ``vectors`` (the homotopy's end is
        ``steps[-1].objective``).
    relaxation_lower_bound : float or None
        Optimum of the convex ``lam = 0`` relaxation, a lower bound of the global minimum.
    seconds : float
        Wall time of the path's solves and of the further starts, s.
    sensitivity : Sensitivity
        The exact relative sensitivity of the data at the answer
        (`vibupdate.inverse.data_map.sensitivity`).
    checks : tuple of Check
        Verification of the returned model (`vibupdate.inverse.verify`); empty when the path failed.
    warnings : tuple of str
        Every failed check and warning, in words, with its figures.
    first_stage_xbar : ndarray, shape (n_x,)
        The homotopy's answer before the polish (``polish.xbar_start`` is the start of the
        returned answer, which differs when a further start gave it: ``sought``).
    polish : PolishResult or None
        What the polish did (None when it was off or the path failed).
    attempts : tuple of Attempt
        One per first-stage attempt (more than one when the boxes were widened).
    sought : Sought or None
        What was sought (`vibupdate.inverse.search.Sought`): every start tried, in order, and
        whether the uniqueness of a verified answer was searched, and why. Ctrl-C during the
        uniqueness search ends it and returns the best verified answer found
        (``sought.interrupted``); at any other stage it raises ``KeyboardInterrupt``.
    alternatives : tuple of Alternative
        Other verified answers (`vibupdate.inverse.search.Alternative`); not empty makes the
        verdict ``not_unique``.
    minimum_change : MinimumChange or None
        Where the data leave directions undetermined, the move of the answer along them to the
        point nearest the nominal model with the same data (`vibupdate.inverse.minimum_change`).
    valley : tuple of ndarray or None
        The ends and turns of the set of answers with exactly the answer's data, normalized
        (docs/polish-and-verification.md 7.7; the consistent ranges read them). Empty when the
        data determine every parameter; None when the set was not explored.
    correlation : Correlation
        The nominal and updated models' modal data paired with each configuration's data, as
        verification and sensitivity used them; later stages read it instead of solving again.
    """

    status: Status
    message: str
    parameters: tuple[Parameter, ...]
    xbar: np.ndarray
    values: np.ndarray
    vectors: tuple[np.ndarray, ...]
    problem_size: dict[str, int]
    steps: tuple[StepRecord, ...]
    objective: float
    relaxation_lower_bound: float | None
    seconds: float
    sensitivity: Sensitivity
    correlation: Correlation = field(compare=False, repr=False)
    checks: tuple[Check, ...] = ()
    warnings: tuple[str, ...] = ()
    first_stage_xbar: np.ndarray | None = None
    polish: PolishResult | None = None
    attempts: tuple[Attempt, ...] = ()
    sought: Sought | None = None
    minimum_change: MinimumChange | None = None
    alternatives: tuple[Alternative, ...] = ()
    valley: tuple[np.ndarray, ...] | None = None

    @property
    def matrices(self) -> dict[str, tuple[sp.csr_matrix, sp.csr_matrix]]:
        """Updated ``(M, K)`` per configuration name, assembled at ``xbar`` on each access."""
        return {c.name: tuple(sp.csr_matrix(A) for A in c.model.matrices(self.xbar))
                for c in self.correlation.configurations}

    @property
    def success(self) -> bool:
        """True only for a verified answer (every error check passed)."""
        return self.status.ok

    @property
    def verdict(self) -> Verdict:
        """What was proved (`vibupdate.inverse.status.Verdict`), apart from how the solver ended."""
        if not self.success:
            return Verdict.NOT_VERIFIED
        return Verdict.NOT_UNIQUE if self.alternatives else Verdict.VERIFIED

    @property
    def restarts(self) -> tuple[Start, ...]:
        """The starts tried after the homotopy's (`sought`)."""
        return () if self.sought is None else tuple(s for s in self.sought.starts if s.start != "homotopy")

    def mean_error(self, which: str = "updated") -> float:
        """Mean absolute frequency error over all measured frequencies, in per cent.

        Parameters
        ----------
        which : {"updated", "nominal"}
            The model whose frequencies are compared with the measured ones.

        Returns
        -------
        float
            The mean of the absolute relative errors of the paired natural frequencies, %.
        """
        return float(np.mean(self.correlation.errors(which=which, finite=False)))

    def solver_record(self) -> dict:
        """The ``solver`` section of ``results.json``.

        Returns
        -------
        dict
            Status, message, steps, objective, checks, warnings, polish, attempts, verdict and
            the search's record, as plain JSON values (docs/outputs.md).
        """
        return {
            "status": self.status.value,
            "message": self.message,
            "steps": [s.as_dict() for s in self.steps],
            "objective": self.objective,
            "relaxation_lower_bound": self.relaxation_lower_bound,
            "seconds": self.seconds,
            "verified": self.success,
            "checks": [c.as_dict() for c in self.checks],
            "warnings": list(self.warnings),
            "first_stage_xbar": None if self.first_stage_xbar is None else self.first_stage_xbar.tolist(),
            "polish": None if self.polish is None else self.polish.as_dict(),
            "attempts": [a.as_dict() for a in self.attempts],
            "verdict": self.verdict.value,
            "sought": None if self.sought is None else self.sought.as_dict(),
            "minimum_change": None if self.minimum_change is None else self.minimum_change.as_dict(),
            "alternatives": [a.as_dict() for a in self.alternatives],
        }


def prepare(configurations: Sequence[Configuration], options: FormulationOptions | None = None,
            nominal: Sequence | None = None) -> BilinearProblem:
    """Validate the data and build the problem (with interlacing signs); no solve. ``nominal``:
    the nominal `model_frequencies` of ``configurations`` when the caller has them."""
    return formulate(configurations, options, transforms=[sign_bounds], nominal=nominal)


@dataclass(frozen=True)
class Prepared:
    """The first stage's input, built once (`prepare_first_stage`) and handed to `update` so
    that a caller which validated a case by building its problem does not build it again.

    Attributes
    ----------
    configurations : tuple of Configuration
        What it was prepared from (`update` uses it only for these very objects).
    formulation : FormulationOptions
    solved : tuple of Configuration
        The configurations the first stage solves (Craig-Bampton reduced where wanted).
    bases : tuple of ndarray or None
        Reduction bases, one per configuration (None without reduction).
    problem : BilinearProblem
        The problem of ``solved`` with the formulation's margins.
    """

    configurations: tuple
    formulation: FormulationOptions
    solved: tuple
    bases: tuple | None
    problem: BilinearProblem
    verification: VerifyOptions = VerifyOptions()

    def matches(self, configurations, formulation, verification) -> bool:
        return (self.formulation == formulation and self.verification == verification
                and len(configurations) == len(self.configurations)
                and all(a is b for a, b in zip(configurations, self.configurations)))


def prepare_first_stage(configurations: Sequence[Configuration], formulation: FormulationOptions | None = None,
                        verification: VerifyOptions | None = None) -> Prepared:
    """Weigh the data as the admissible data do (`vibupdate.inverse.admissible.weighted`),
    reduce where wanted and build the problem; no solve (raises ValueError on bad data)."""
    configurations = tuple(configurations)
    formulation = formulation or FormulationOptions()
    verification = verification or VerifyOptions()
    solved, bases = _weighed(configurations, formulation, Admissible.of(configurations, verification))
    return Prepared(configurations, formulation, tuple(solved), None if bases is None else tuple(bases),
                    prepare(solved, formulation), verification)


def _weighed(configurations, formulation: FormulationOptions, contract: Admissible) -> tuple[list, list | None]:
    """The configurations the first stage solves, each datum weighed as the contract does, and
    their Craig-Bampton bases where a reduction is wanted (else None)."""
    solved = weighted(configurations, contract)
    if wants_reduction(solved, formulation):
        return reduce_configurations(solved, formulation.reduction_modes)
    return solved, None


def _message(status: Status, path: HomotopyResult, steps, best: _Finish, direct: _Finish | None,
             tie: float) -> str:
    """How the path ended and which start gave the returned answer, and what it passed or failed."""
    failed = "failed " + ", ".join(best.failed)
    if best.label == "homotopy" and status.ok:
        looser = " at IPOPT's acceptable (looser) tolerance" if status == Status.ACCEPTABLE else ""
        return f"homotopy reached lambda = 1{looser}; the updated model passed every verification check"
    if best.label == "homotopy" and status == Status.NOT_VERIFIED:
        return f"solved (lambda = 1) but not verified: {failed}"
    head = f"homotopy stopped at lambda = {path.lam:.4f} ({path.status.value})"
    if best.label == "homotopy":   # the path failed and no start verified
        return head + (f"; last solve at lambda = {steps[-1].lam:.4f}: {steps[-1].status.value}" if steps else "")
    if direct is not None and direct.status.ok:
        head = (f"the homotopy's answer verified with objective {direct.cost:.3e}; "
                + (f"a lower one, {best.cost:.3e}, was found" if best.cost < (1 - tie) * direct.cost else
                   f"an answer that fits as well ({best.cost:.3e}) lies nearer the nominal model"))
    elif path.status.ok:
        head = "homotopy reached lambda = 1 but its answer did not verify"
    if best.label == "nominal model":
        return (f"{head}; every polished answer missed the data by more than the nominal model, which is returned "
                f"unchanged ({failed})")
    return f"{head}; the answer polished from the {best.label} " + ("passed every verification check" if status.ok
                                                                     else failed)


def _active_bounds(problem: BilinearProblem, path: HomotopyResult) -> list[str]:
    """Bounds of parameters and of margin-bounded vector entries at which the relaxation's
    optimum sits, named for the user."""
    if path.relaxed_x is None:
        return []
    names = []
    span = np.where(problem.x_upper > problem.x_lower, problem.x_upper - problem.x_lower, 1.0)
    for p, v, lo, hi, s in zip(problem.parameters, path.relaxed_x, problem.x_lower, problem.x_upper, span):
        if v - lo <= 1e-6 * s:
            names.append(f"lower bound of {p.name}")
        elif hi - v <= 1e-6 * s:
            names.append(f"upper bound of {p.name}")
    for b, blk in enumerate(problem.blocks):
        free = ~blk.fixed
        ub = path.relaxed_u[problem.u_offsets[b]:problem.u_offsets[b + 1]]
        lo, hi = blk.lower[free], blk.upper[free]
        near = (ub - lo <= 1e-3 * (hi - lo)) | (hi - ub <= 1e-3 * (hi - lo))
        if np.any(near & _margin_entries(blk)[free]):
            option = "shape_margin" if blk.kind == "natural" else "adjunct_margin"
            names.append(f"entries of {blk.kind} vector {blk.index} of configuration {blk.configuration!r} "
                         f"({option})")
    return names


def _margin_entries(blk) -> np.ndarray:
    """Entries whose box comes from a margin, not from a measured interval."""
    return np.ones(blk.lower.size, dtype=bool) if blk.measured is None else ~blk.measured


def _reduction_error(solved, nominal) -> float:
    """Largest relative difference between the natural frequencies of the reduced models
    (Craig-Bampton, ``solved``) and the full ones (``nominal``) at the nominal point, over the
    declared modes: the first stage's relaxation bounds the reduced problem, which misses even
    exact data by about this much."""
    worst = 0.0
    for cfg, full in zip(solved, nominal):
        reduced, f = model_frequencies(cfg).natural, full.natural
        ok = np.isfinite(reduced) & np.isfinite(f) & (f > 0)
        worst = max([worst, *(np.abs(reduced[ok] - f[ok]) / f[ok]).tolist()])
    return worst


@dataclass(frozen=True)
class Attempt(SearchRecord):
    """One attempt of the first stage, with its vector boxes (module docstring, item 2).

    Attributes
    ----------
    shape_margin : float
        Unmeasured mode entries were bounded by ``+- shape_margin`` times the largest entry of
        the nominal mode in its block's normalization
        (`vibupdate.inverse.formulation.FormulationOptions`).
    adjunct_margin : float
        Adjunct vector entries were bounded by ``+- adjunct_margin`` around their fixed unit
        entry.
    relaxation_lower_bound : float or None
        Optimum of the ``lam = 0`` relaxation (dimensionless, as ``objective``), None where it
        was not solved.
    objective : float
        Exact objective ``sum_k w_k R_k^2`` at the path's last accepted point (dimensionless).
    status : Status
        How the path ended.
    active_bounds : tuple of str
        The bounds of parameters and of margin-bounded vector entries at which the
        relaxation's optimum sits, named for the user.
    """

    shape_margin: float
    adjunct_margin: float
    relaxation_lower_bound: float | None
    objective: float
    status: Status
    active_bounds: tuple[str, ...]


def _first_stage(solved, formulation, solver, allowance_tol, say, nominal=None, problem=None):
    """The homotopy, repeated with wider vector boxes while the relaxation proves that the
    current boxes exclude every fit (module docstring, item 2). ``problem``: the first
    attempt's problem, when already built."""
    attempts, steps, attempt = [], [], 0
    while True:
        if problem is None or attempt > 0:
            problem = prepare(solved, formulation, nominal)
        if attempt == 0:
            say("problem: {n_parameters} parameters, {n_mode_unknowns} mode unknowns, {n_adjunct_unknowns} adjunct "
                "unknowns, {n_lifted} lifted scalars".format(**problem.sizes()))
        path = solve_homotopy(problem, solver, progress=say)
        steps.extend(path.steps)
        allowance = consistency_allowance(len(problem.blocks), allowance_tol)
        active = _active_bounds(problem, path)
        attempts.append(Attempt(formulation.shape_margin, formulation.adjunct_margin, path.lower_bound,
                                path.objective, path.status, tuple(active)))
        inconsistent = path.lower_bound is not None and path.lower_bound > allowance
        margins = any(np.any(_margin_entries(b) & ~b.fixed) for b in problem.blocks)
        if not (inconsistent and margins) or attempt == MAX_WIDENINGS:
            if inconsistent and attempt > 0:
                active = active + [f"(vector boxes of unmeasured entries already widened {10 ** attempt}x "
                                   "without removing the misfit: look at the parameter bounds and the data)"]
            return problem, path, tuple(steps), tuple(attempts), active
        formulation = replace(formulation, shape_margin=10 * formulation.shape_margin,
                              adjunct_margin=10 * formulation.adjunct_margin)
        say(f"relaxation lower bound {path.lower_bound:.3g} > {allowance:.3g}: the vector boxes exclude every fit; "
            f"widening them tenfold (shape_margin {formulation.shape_margin:g}) and solving again")
        attempt += 1


def _full_vector(problem: BilinearProblem, b: int, u, configurations, bases) -> np.ndarray:
    """Identified vector of block ``b`` in the full model's coordinates (adjunct vectors stay in
    reduced coordinates: they live on the adjunct system)."""
    v, blk = problem.block_vector(b, u), problem.blocks[b]
    if bases is None or blk.kind != "natural":
        return v
    return bases[[c.name for c in configurations].index(blk.configuration)] @ v


@dataclass(frozen=True)
class _Finish:
    """One candidate answer: a start, polished, moved to the minimum change and verified."""

    label: str
    xbar: np.ndarray
    polished: PolishResult | None
    minimum: MinimumChange | None
    updated: list
    sensitivity: Sensitivity
    checks: tuple
    status: Status
    misfit: float = 0.0

    @property
    def failed(self) -> list[str]:
        return _failed(self.checks)

    @property
    def cost(self) -> float:
        return self.polished.cost if self.polished is not None else float("inf")

    def record(self, purpose: str, seconds: float) -> Start:
        """This candidate as a `Start` of the result."""
        return Start(self.label, purpose, "verified" if self.status.ok else "not_verified", tuple(self.failed),
                     self.cost, seconds)


def _failed(checks) -> list[str]:
    """The names of the failed error checks."""
    return [c.name for c in checks if c.severity == "error" and not c.passed]


def _finish(configurations, start, label, path, problem, active, nominal, polish, verification, contract, say,
            reduction_error: float = 0.0, answers=None, discarded_above: float = np.inf) -> _Finish | None:
    """Polish ``start``, take the minimum change along undetermined directions, verify. None
    when the polish reached one of the known ``answers`` again (`polish`). A polished point
    that fails verification with an objective above ``discarded_above`` (a uniqueness start
    that cannot fit as well as the answer: `_choose` never keeps it) is not moved to the
    minimum change: the move keeps its data and its objective, so it could not be kept either."""
    xbar, polished, minimum = start, None, None
    if polish.enabled:
        polished = run_polish(configurations, start, polish, progress=say, answers=answers, contract=contract)
        if polished.stopped_on == "known answer":
            say(f"polish ({label}): {polished.message}")
            return None
        xbar = polished.xbar
        say(f"polish ({label}): objective {polished.cost_start:.4e} -> {polished.cost:.4e} "
            f"({'kept' if polished.kept else 'not kept'}, {polished.evaluations} evaluations"
            + (f" of the full model in {polished.rounds} reduced rounds" if polished.rounds else "")
            + f", {polished.seconds:.2f} s; {polished.message})")
    updated = [model_frequencies(c, xbar, derivatives=True) for c in configurations]  # zeros with their slopes
    sens = sensitivity(configurations, xbar, freqs=updated)
    origin = start if polished is None else polished.xbar_start   # where the polish started: its modes solved
    first = updated if np.array_equal(xbar, origin) else [model_frequencies(c, origin) for c in configurations]

    def checked(x, at):
        out = verify(configurations, x, nominal=nominal, updated=at, lower_bound=path.lower_bound,
                     n_blocks=len(problem.blocks), active_bounds=active, first_stage=first, options=verification,
                     reduction_error=reduction_error, contract=contract)
        return tuple(out)

    checks = checked(xbar, updated)
    discarded = bool(_failed(checks)) and polished is not None and polished.cost > discarded_above
    if polish.enabled and sens.rank < xbar.size and not discarded:   # the data leave directions undetermined
        minimum = minimum_change(configurations, xbar)
        if minimum.kept:
            moved = [model_frequencies(c, minimum.xbar, derivatives=True) for c in configurations]
            again = checked(minimum.xbar, moved)
            if _failed(again) and not _failed(checks):   # moved within DATA_TOL, but the intervals allow less
                minimum = replace(minimum, kept=False, message=f"not kept: the moved answer failed "
                                  f"{', '.join(_failed(again))} where the polished one passes")
            else:
                xbar, updated, checks = minimum.xbar, moved, again
                sens = sensitivity(configurations, xbar, freqs=updated)
            say(f"minimum change: {minimum.message}")
    ok = not _failed(checks)
    status = (path.status if path.status.ok else Status.SUCCESS) if ok else Status.NOT_VERIFIED
    return _Finish(label, xbar, polished, minimum, updated, sens, tuple(checks), status,
                   0.0 if ok else misfit(configurations, contract, xbar))


def misfit(configurations, contract: Admissible, xbar) -> float:
    """The contract's misfit of the model at ``xbar``: the sum of squares of every datum's
    distance outside its admissible interval, in its half-widths (`vibupdate.inverse.admissible.misses`;
    0 when every datum is admissible, inf when a declared zero is lost)."""
    maps = [data_map(c, xbar, jacobian=False, shapes=bool(s or m))
            for c, s, m in zip(configurations, contract.shapes, contract.masses)]
    return float(sum(m.miss ** 2 for m in misses(contract, maps)))


def _better(a: _Finish | None, b: _Finish) -> bool:
    """Whether ``b`` is a better answer than ``a``: verified over not, then the lower `misfit`
    (not the polish's objective, whose pull toward the midpoints may favour a model that misses
    more), then the lower objective."""
    return a is None or (b.status.ok, -b.misfit, -b.cost) > (a.status.ok, -a.misfit, -a.cost)


def _search(configurations, problem, solver, best, finish, search: Search, starts: list, say):
    """The starts tried when the direct path's answer did not verify or the path failed
    (`vibupdate.inverse.search`, in its order), until one verifies. Returns the best candidate
    (None when none could be polished) and the homotopy steps of the stepped path."""
    lo, hi = configurations[0].model.bounds()
    solver = solver or SolverOptions()
    todo = [("stepped homotopy path", None)] if solver.n_lambda == 1 else []
    todo += search.box_starts(lo, hi, search.random_starts)
    if best is not None:
        say(f"the answer did not verify (failed {', '.join(best.failed)}): trying {len(todo)} further starts")
    found, steps = ([] if best is None else [best]), ()
    for label, x0 in todo:
        t0 = time.perf_counter()
        if x0 is None:   # the stepped path: its solves count in ``steps``, not in the start's seconds
            say("restart: the stepped homotopy path (n_lambda = 10)")
            path = solve_homotopy(problem, replace(solver, n_lambda=10), progress=say)
            steps, t0 = path.steps, t0 + sum(s.seconds for s in path.steps)
            if not path.status.ok:
                starts.append(Start(label, "fit", "path failed", seconds=time.perf_counter() - t0))
                continue
            x0 = np.clip(path.x, problem.x_lower, problem.x_upper)
        candidate = finish(x0, label, None, [c.xbar for c in found])
        if candidate is None:   # it reached an answer tried already
            starts.append(Start(label, "fit", "same answer", seconds=time.perf_counter() - t0))
            say(f"restart from the {label}: the same answer again")
            continue
        found.append(candidate)
        starts.append(candidate.record("fit", time.perf_counter() - t0))
        say(f"restart from the {label}: {candidate.status.value}"
            + (f" (failed {', '.join(candidate.failed)})" if candidate.failed else ""))
        if _better(best, candidate):
            best = candidate
        if best.status.ok:
            break
    return best, steps


def _no_worse_than_nominal(configurations, contract: Admissible, best: _Finish | None, finish, polish: PolishOptions,
                           say) -> _Finish | None:
    """When no answer verifies, a best answer further outside the admissible intervals than the
    nominal model (`misfit`) is replaced by the nominal model, verified as it is
    (docs/polish-and-verification.md 7.6)."""
    if best is None or best.status.ok:
        return best
    lo, hi = configurations[0].model.bounds()
    at = np.clip(np.zeros(lo.size), lo, hi)
    own = misfit(configurations, contract, at)
    if best.misfit <= own:
        say(f"no answer verified; the best misses the admissible intervals by {best.misfit:.4g} (sum of squared "
            f"half-widths) against the nominal model's {own:.4g}")
        return best
    say(f"no answer verified, and the best ({best.misfit:.4g}) misses more than the nominal model ({own:.4g}): "
        "the nominal model is returned")
    return finish(at, "nominal model", replace(polish, enabled=False))


def _uniqueness(configurations, finish, tried: list[_Finish], answer: _Finish, search: Search, starts: list, say,
                options: PolishOptions, contract: Admissible, probes: tuple[list, np.ndarray] | None,
                as_well: float = np.inf) -> None:
    """Polish from the nominal point, the weakest-direction starts and the random box starts not
    tried yet (docs/polish-and-verification.md 7.7). Given ``probes`` (`_probe_model`), each start
    is first polished on the reduced model: one that reaches the answer there is the same answer.
    ``as_well``: the objective above which a start's answer cannot fit as well as the answer
    (`_choose`); one that also fails verification is not moved to the minimum change."""
    lo, hi = configurations[0].model.bounds()
    done = {c.label for c in tried}
    boxed = search.box_starts(lo, hi, search.probe_random_starts)
    todo = [(label, x) for label, x in boxed[:1] + search.weak_starts(answer.xbar, answer.sensitivity, lo, hi)
            + boxed[1:] if label not in done]
    if not todo:
        return
    reduced, reference = probes or (None, None)
    say(f"uniqueness: polishing from {len(todo)} further starts"
        + (f", first on a {reduced[0].model.n_dofs}-DOF reduced model" if reduced else ""))
    followed = 0
    while todo:
        label, x0 = todo.pop(0)
        t0 = time.perf_counter()
        answers = [c.xbar for c in tried if c.status.ok]
        x = x0 if reduced is None else _reduced_answer(reduced, x0, options, contract, [reference])
        same = x is None or (reduced is not None and not search.new(x, [reference]))
        candidate = None if same else finish(x0, label, options, answers, as_well)
        starts.append(Start(label, "uniqueness", "same answer", seconds=time.perf_counter() - t0) if candidate is None
                      else candidate.record("uniqueness", time.perf_counter() - t0))
        if (candidate is not None and candidate.status.ok and followed < search.follow
                and candidate.sensitivity.rank == candidate.xbar.size   # isolated, not a point of a valley
                and search.new(candidate.xbar, answers)):
            followed += 1   # a new answer: its own weakest direction, across its fold (`Search.follow`)
            todo += [(f"{weak} from answer {followed + 1}", x)
                     for weak, x in search.weak_starts(candidate.xbar, candidate.sensitivity, lo, hi)]


def _probe_model(configurations, xbar, contract: Admissible, options: PolishOptions, models=None):
    """The configurations on a reduced model, and the answer ``xbar`` as that model has it
    (`_reduced_answer`): the first stage's Craig-Bampton ``models`` when it has them,
    else a Ritz model built at ``xbar`` (docs/polish-and-verification.md 7.7, the paragraph on
    ``probe_dofs``)."""
    if models is None:
        basis, maps = [], []
        evaluate(configurations, contract, xbar, basis=basis, maps=maps)
        models = [ritz_reduction(c.model, kept_dofs(c),   # m.vectors[0]: the modes solved for
                                 np.hstack([V, derivative_vectors(c.model, xbar, m.vectors[0])]))[0]
                  for c, V, m in zip(configurations, basis, maps)]
    reduced = [replace(c, model=r) for c, r in zip(configurations, models)]
    return reduced, _reduced_answer(reduced, xbar, options, contract)


def _reduced_answer(reduced, x0, options: PolishOptions, contract: Admissible, answers=None) -> np.ndarray | None:
    """``x0`` polished on the ``reduced`` configurations and moved to the minimum change there,
    as `_finish` does on the full model; None when the polish reached one of the ``answers``."""
    probe = run_polish(reduced, x0, options, answers=answers, contract=contract)
    if probe.stopped_on == "known answer":
        return None
    moved = minimum_change(reduced, probe.xbar)
    return moved.xbar if moved.kept else probe.xbar


def _choose(tried: list[_Finish], best: _Finish, search: Search, model,
            exact: float) -> tuple[_Finish, tuple[Alternative, ...]]:
    """The verified answer of lowest objective (ties, within ``search.tie`` or below ``exact``: the
    nearest the nominal model), and every other distinct verified answer that fits about as well
    (``search.as_well``) as an `Alternative` (docs/polish-and-verification.md 7.7)."""
    verified = [c for c in tried if c.status.ok]
    if not verified:
        return best, ()
    low = min(c.cost for c in verified)
    ties = [c for c in verified if c.cost <= max(low * (1.0 + search.tie), exact)]
    nearest = min(ties, key=lambda c: float(np.linalg.norm(c.xbar)))
    chosen = next(c for c in ties if not search.new(c.xbar, [nearest.xbar]))  # the first found
    others: list[_Finish] = []
    close = [c for c in verified if c.cost <= max(low * search.as_well, exact)]
    for c in sorted(close, key=lambda c: float(np.linalg.norm(c.xbar))):
        if search.new(c.xbar, [d.xbar for d in [chosen, *others]]):
            others.append(c)
    return chosen, tuple(_alternative(c.label, c.cost, c.xbar, chosen.xbar, model, search) for c in others)


def _alternative(label: str, cost: float, x: np.ndarray, answer: np.ndarray, model, search: Search) -> Alternative:
    """The verified answer ``x`` as an `Alternative` to the returned ``answer`` (normalized)."""
    names = model.parameter_names
    return Alternative(label, cost, tuple(x.tolist()), dict(zip(names, model.physical(x).tolist())),
                       tuple(n for n, a, b in zip(names, x, answer) if abs(a - b) > search.distinct))


def _valley(configurations, chosen: _Finish, alternatives: tuple[Alternative, ...], search: Search, model, starts: list,
            say, reduced=None) -> tuple[tuple[Alternative, ...], tuple[np.ndarray, ...] | None]:
    """Where the data leave directions undetermined at the chosen answer, the ends and turns of the
    set of answers with exactly its data (docs/polish-and-verification.md 7.7), each an
    `Alternative` with the chosen answer's objective; followed on the ``reduced`` configurations
    when given, each point then moved onto the full model's data. Returns the alternatives and every
    point found (`UpdateResult.valley`)."""
    if not search.valley_ends:
        return alternatives, None
    if chosen.sensitivity.rank >= chosen.xbar.size:
        return alternatives, ()
    t0 = time.perf_counter()
    where = reduced or configurations
    found = undetermined(where, chosen.xbar)   # one evaluation at the answer, for both
    ends = valley_curve(where, chosen.xbar, found) + valley_ends(where, chosen.xbar, found)
    known = [chosen.xbar, *(np.asarray(a.xbar) for a in alternatives)]

    if reduced:   # only the distinct points of the reduced model's set are moved onto the full model's data
        kept: list = []
        for end in ends:
            if search.new(end[2], known + [e[2] for e in kept]):
                kept.append(end)
        ends = onto_data(configurations, chosen.xbar, kept)
    added = []
    for sense, i, x in ends:
        if search.new(x, known):
            known.append(x)
            kind = "end" if sense in ("lowest", "highest") else "turn"
            added.append(_alternative(f"valley {kind} ({sense} {model.parameter_names[i]})", chosen.cost, x,
                                      chosen.xbar, model, search))
    starts.append(Start("valley ends", "uniqueness", "same data" if added else "same answer", (), chosen.cost,
                        time.perf_counter() - t0))
    say(f"uniqueness: the data leave {chosen.xbar.size - chosen.sensitivity.rank} direction(s) undetermined; "
        f"{len(added)} point(s) of the set of answers with the same data differ from the answer")
    return alternatives + tuple(added), tuple(x for _, _, x in ends)


#: Other answers named in the warning, at most (every one is in ``UpdateResult.alternatives``).
NAMED_ALTERNATIVES = 3


def _alternatives_text(records: tuple[Alternative, ...], mine: dict) -> str:
    """The other answers in words: which parameters differ, in their units (``mine``: the
    returned answer's physical values by name), the first `NAMED_ALTERNATIVES` of them."""
    parts = [f"from the {a.start} (objective {a.objective:.3g}): "
             + ", ".join(f"{n} = {a.values[n]:.5g} (here {mine[n]:.5g})" for n in a.differs[:6])
             + (f" and {len(a.differs) - 6} more" if len(a.differs) > 6 else "") for a in records[:NAMED_ALTERNATIVES]]
    if len(records) > NAMED_ALTERNATIVES:
        parts.append(f"and {len(records) - NAMED_ALTERNATIVES} more (solver.alternatives in results.json)")
    return (f"uniqueness: {len(records)} other answer(s) fit every datum within its admissible interval and pass "
            "every check (not unique), so the data do not single out the parameters that differ; "
            + "; ".join(parts))


def update(configurations: Sequence[Configuration], *, formulation: FormulationOptions | None = None,
           solver: SolverOptions | None = None, polish: PolishOptions | None = None,
           verification: VerifyOptions | None = None,
           progress: Callable[[str], None] | None = None, prepared: Prepared | None = None,
           probe: bool = True, search: Search | None = None) -> UpdateResult:
    """Update the shared parameters of ``configurations`` (Problems 1-4 and their mixes).

    Which Problem is solved follows from the data: natural frequencies with mode-shape
    intervals (1), natural frequencies alone (2), antiresonances alone (3), natural
    frequencies and antiresonances with interlacing signs (4).

    Parameters
    ----------
    configurations : sequence of Configuration
        The measured configurations; their models share the parameters to update.
    formulation : FormulationOptions, optional
        How the problem is built (margins, weighting, interlacing, reduction); the defaults
        when None.
    solver : SolverOptions, optional
        The homotopy and its solver (steps, tolerances, time limit); the defaults when None.
    polish : PolishOptions, optional
        The refinement after the homotopy (on by default).
    verification : VerifyOptions, optional
        Thresholds of the checks of the returned model.
    progress : callable, optional
        Receives one line per step.
    prepared : Prepared, optional
        The problem of these configurations and this formulation, already built
        (`prepare_first_stage`); ignored when it was built from other ones.
    probe : bool
        Test a verified answer for uniqueness (`vibupdate.inverse.search`); a sampling sweep,
        which starts each sample at a random point of its own, turns it off.
    search : Search, optional
        The starts and budgets of the search (`vibupdate.inverse.search.Search`).

    Returns
    -------
    UpdateResult
        ``status`` is ``success`` only for a verified answer, ``not_verified`` when the path
        reached ``lam = 1`` but a check failed (``checks`` and ``warnings`` say which, with
        figures), a solver status when the path failed; a failed solve is a status, not an
        exception. Bad input raises ValueError before any solve.
    """
    configurations = list(configurations)
    formulation = formulation or FormulationOptions()
    polish = polish or PolishOptions()
    verification = verification or VerifyOptions()
    search = search or Search()
    say = progress or (lambda message: None)
    contract = Admissible.of(configurations, verification)
    if prepared is not None and prepared.matches(configurations, formulation, verification):
        solved, bases, first_problem = list(prepared.solved), prepared.bases, prepared.problem
    else:
        (solved, bases), first_problem = _weighed(configurations, formulation, contract), None
    if bases is not None:
        say(f"Craig-Bampton reduction: {configurations[0].model.n_dofs} -> {solved[0].model.n_dofs} DOFs "
            f"(measured DOFs kept, {formulation.reduction_modes} fixed-interface modes)")
    nominal = [model_frequencies(c) for c in configurations]
    reduction_error = 0.0 if bases is None else _reduction_error(solved, nominal)
    problem, path, steps, attempts, active = _first_stage(solved, formulation, solver,
                                                          max(verification.frequency_tolerance, reduction_error), say,
                                                          nominal if bases is None else None, first_problem)
    size = problem.sizes()
    if bases is not None:
        size["reduced_dofs"] = solved[0].model.n_dofs
    model = configurations[0].model

    tried: list[_Finish] = []

    def finish(start: np.ndarray, label: str, options: PolishOptions | None = None, answers=None,
               discarded_above: float = np.inf) -> _Finish | None:
        candidate = _finish(configurations, start, label, path, problem, active, nominal, options or polish,
                            verification, contract, say, reduction_error, answers, discarded_above)
        if candidate is not None:
            tried.append(candidate)
        return candidate

    first_xbar = np.clip(path.x, problem.x_lower, problem.x_upper)
    best = finish(first_xbar, "homotopy") if path.status.ok else None
    direct = best
    starts = [] if best is None else [best.record("fit", best.polished.seconds if best.polished else 0.0)]
    if polish.enabled and (best is None or not best.status.ok):
        best, more_steps = _search(configurations, problem, solver, best, finish, search, starts, say)
        steps = steps + more_steps
        best = _no_worse_than_nominal(configurations, contract, best, finish, polish, say)
    unique, reason = search.uniqueness(model.n_dofs, model.n_parameters, probe and polish.enabled)
    alternatives, valley, interrupted = (), None, False
    if best is not None and best.status.ok and unique:
        options = replace(polish, max_evaluations=min(polish.max_evaluations or np.inf,
                                                      search.probe_evaluations * (model.n_parameters + 1)))
        probes = None
        exact = contract.exact_fit(verification.exact_half_width)
        try:   # Ctrl-C ends the search and keeps what it found: the verified answer is returned
            probes = None if model.n_dofs <= search.probe_dofs else _probe_model(
                configurations, best.xbar, contract, options, None if bases is None else [c.model for c in solved])
            _uniqueness(configurations, finish, tried, best, search, starts, say, options, contract, probes,
                        max(search.as_well * best.cost, exact))
        except KeyboardInterrupt:
            interrupted = True
        best, alternatives = _choose(tried, best, search, model, exact)
        try:
            if not interrupted:
                alternatives, valley = _valley(configurations, best, alternatives, search, model, starts, say,
                                               probes[0] if probes else None)
        except KeyboardInterrupt:
            interrupted = True
        if interrupted:
            unique, reason = False, (f"uniqueness search interrupted (Ctrl-C) after {len(starts)} start(s): the best "
                                     "verified answer found is returned, its uniqueness not established")
    elif best is not None and best.status.ok:
        reason = f"uniqueness not searched: {reason}"
    else:
        unique, reason = False, "uniqueness not searched: no answer verified"
    status = best.status if best is not None else path.status
    if best is None:   # the path failed and no start verified: the first stage's point, unpolished
        updated = [model_frequencies(c, first_xbar, derivatives=True) for c in configurations]
        best = _Finish("homotopy", first_xbar, None, None, updated,
                       sensitivity(configurations, first_xbar, freqs=updated), (), status)
    xbar, polished, checks, updated = best.xbar, best.polished, best.checks, best.updated
    # the vectors and objective of the model returned, wherever the polish moved it from the path's point
    u = path.u if np.array_equal(xbar, path.x) else problem.unknowns_at(xbar)
    warnings = tuple(note.message for note in problem.notes)   # what the formulation set aside
    warnings += tuple(f"{c.name}: {c.message}" for c in checks if not c.passed)
    if alternatives:
        warnings += (_alternatives_text(alternatives, dict(zip(model.parameter_names, model.physical(xbar)))),)
    if interrupted:
        warnings += (reason,)
    if polished is not None and polished.on_limit:   # short of the optimum, maybe: said where checks are said
        warnings += (f"polish: {polished.message}",)
    for w in warnings:
        say(f"warning: {w}")
    return UpdateResult(
        status=status,
        message=_message(status, path, steps, best, direct, search.tie),
        parameters=model.parameters,
        xbar=xbar,
        values=model.physical(xbar),
        vectors=tuple(_full_vector(problem, b, u, solved, bases) for b in range(len(problem.blocks))),
        problem_size=size,
        steps=steps,
        objective=problem.objective(xbar, u),
        relaxation_lower_bound=path.lower_bound,
        seconds=sum(st.seconds for st in steps) + sum(r.seconds for r in starts),
        sensitivity=best.sensitivity,
        correlation=Correlation(tuple(configurations), xbar, tuple(nominal), tuple(updated)),
        checks=checks,
        warnings=warnings,
        first_stage_xbar=first_xbar,
        polish=polished,
        attempts=attempts,
        sought=Sought(search, tuple(starts), unique, reason, interrupted),
        minimum_change=best.minimum,
        valley=valley,
        alternatives=alternatives,
    )
