"""The updating as one call: ``update(configurations) -> UpdateResult``.

1. Formulation (`vibupdate.inverse.formulation`) with interlacing sign bounds
   (`vibupdate.inverse.interlacing`), McCormick relaxation (`vibupdate.inverse.relaxation`) and the homotopy
   (`vibupdate.inverse.homotopy`): the first stage.
2. When the relaxation's lower bound proves that nothing inside the boxes fits, the boxes of
   vector entries that come from a margin (unmeasured mode entries, adjunct entries) are
   widened tenfold and the first stage repeated (at most twice); every attempt is recorded.
   Whether the widening removed the misfit is measured, not assumed: a bound that stays
   positive points at the parameter bounds or the data.
3. The polish (`vibupdate.inverse.polish`) on the full model, default on.
4. Verification (`vibupdate.inverse.verify`): the status is ``success`` only when every check of the
   returned model against the data passes, ``not_verified`` when the path reached
   ``lam = 1`` but a check failed.

The result is a frozen record of the updated model and of how it was found.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.correlation import frequency_rows, model_frequencies, sensitivity, shape_mac
from vibupdate.inverse.formulation import BilinearProblem, FormulationOptions, formulate
from vibupdate.inverse.homotopy import HomotopyResult, SolverOptions, StepRecord, solve_homotopy
from vibupdate.inverse.interlacing import sign_bounds
from vibupdate.data.measured import Configuration
from vibupdate.model.parameters import Parameter
from vibupdate.inverse.polish import PolishOptions, PolishResult, polish as run_polish
from vibupdate.inverse.reduction import reduce_configurations, wants_reduction
from vibupdate.inverse.status import Status
from vibupdate.inverse.verify import Check, VerifyOptions, consistency_allowance, verify

__all__ = ["UpdateResult", "update", "prepare", "Prepared", "prepare_first_stage"]

#: Tenfold widenings of the vector boxes at most, when the relaxation proves they exclude every fit.
MAX_WIDENINGS = 2


@dataclass(frozen=True)
class UpdateResult:
    """Updated model and the record of the first stage.

    Attributes
    ----------
    status : Status
    message : str
    parameters : tuple of Parameter
    xbar : ndarray, shape (n_x,)
        Updated normalized parameters (Eq. 12).
    values : ndarray, shape (n_x,)
        Updated physical parameters, in each parameter's unit.
    matrices : dict of str to (csr_matrix, csr_matrix)
        Updated ``(M, K)`` per configuration name.
    frequencies : tuple of dict
        Rows measured / nominal / updated with errors (``results.json`` contract, Hz).
    mac : dict of str to ndarray
        Per configuration, MAC of each updated mode with its measured shape (NaN where no
        shape was measured).
    vectors : tuple of ndarray
        Identified mode / adjunct vectors (physical units, normalization of the formulation),
        in the order of ``problem.blocks``.
    problem_size : dict
    steps : tuple of StepRecord
    objective : float
        Exact objective at the answer.
    relaxation_lower_bound : float or None
        Optimum of the convex ``lam = 0`` relaxation, a lower bound of the global minimum.
    seconds : float
    sensitivity : dict
        Singular values, condition number, rank and null directions of the exact relative
        frequency sensitivity at the answer (`vibupdate.inverse.correlation.sensitivity`).
    checks : tuple of Check
        Verification of the returned model (`vibupdate.inverse.verify`); empty when the path failed.
    warnings : tuple of str
        Every failed check and warning, in words, with its figures.
    first_stage_xbar : ndarray, shape (n_x,)
        The homotopy's answer before the polish.
    polish : PolishResult or None
        What the polish did (None when it was off or the path failed).
    attempts : tuple of dict
        One entry per first-stage attempt: margins of the vector boxes, lower bound,
        objective and status (more than one when the boxes were widened).
    modal : dict of str to ModelFrequencies
        Modal data of each configuration's updated model, as correlation, verification and
        sensitivity used them (modes, every mode on the dense path in ``spectrum``, zeros and
        their derivatives): later stages (damping, results) read them instead of solving the
        same matrices again.
    """

    status: Status
    message: str
    parameters: tuple[Parameter, ...]
    xbar: np.ndarray
    values: np.ndarray
    matrices: dict
    frequencies: tuple[dict, ...]
    mac: dict
    vectors: tuple[np.ndarray, ...]
    problem_size: dict
    steps: tuple[StepRecord, ...]
    objective: float
    relaxation_lower_bound: float | None
    seconds: float
    sensitivity: dict
    checks: tuple[Check, ...] = ()
    warnings: tuple[str, ...] = ()
    first_stage_xbar: np.ndarray | None = None
    polish: PolishResult | None = None
    attempts: tuple[dict, ...] = ()
    modal: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def success(self) -> bool:
        """True only for a verified answer (every error check passed)."""
        return self.status.ok

    @property
    def verified(self) -> bool:
        return self.status.ok and all(c.passed for c in self.checks if c.severity == "error")

    def mean_error(self, which: str = "updated") -> float:
        """Mean absolute frequency error in per cent over all measured frequencies."""
        key = f"error_{which}_pct"
        return float(np.mean([r[key] for r in self.frequencies]))

    def solver_record(self) -> dict:
        """The ``solver`` section of ``results.json``."""
        return {
            "status": self.status.value,
            "message": self.message,
            "steps": [s.as_dict() for s in self.steps],
            "objective": self.objective,
            "relaxation_lower_bound": self.relaxation_lower_bound,
            "seconds": self.seconds,
            "verified": self.verified,
            "checks": [c.as_dict() for c in self.checks],
            "warnings": list(self.warnings),
            "first_stage_xbar": None if self.first_stage_xbar is None else self.first_stage_xbar.tolist(),
            "polish": None if self.polish is None else self.polish.as_dict(),
            "attempts": list(self.attempts),
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

    def matches(self, configurations, formulation) -> bool:
        return (self.formulation == formulation and len(configurations) == len(self.configurations)
                and all(a is b for a, b in zip(configurations, self.configurations)))


def prepare_first_stage(configurations: Sequence[Configuration],
                        formulation: FormulationOptions | None = None) -> Prepared:
    """Reduce where wanted and build the problem; no solve (raises ValueError on bad data)."""
    configurations = tuple(configurations)
    formulation = formulation or FormulationOptions()
    solved, bases = configurations, None
    if wants_reduction(list(configurations), formulation):
        solved, bases = reduce_configurations(list(configurations), formulation.reduction_modes)
        solved, bases = tuple(solved), tuple(bases)
    return Prepared(configurations, formulation, tuple(solved), bases, prepare(list(solved), formulation))


def _message(status: Status, lam: float, steps, checks=()) -> str:
    if status == Status.NOT_VERIFIED:
        failed = [c.name for c in checks if c.severity == "error" and not c.passed]
        return "solved (lambda = 1) but not verified: failed " + ", ".join(failed)
    if status == Status.SUCCESS:
        return "homotopy reached lambda = 1; the updated model passed every verification check"
    if status == Status.ACCEPTABLE:
        return ("homotopy reached lambda = 1 at IPOPT's acceptable (looser) tolerance; the updated model passed "
                "every verification check")
    last = steps[-1] if steps else None
    detail = f"; last solve at lambda = {last.lam:.4f}: {last.status.value}" if last else ""
    return f"homotopy stopped at lambda = {lam:.4f} ({status.value}){detail}"


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


def _first_stage(solved, formulation, solver, allowance_tol, say, nominal=None, problem=None):
    """The homotopy, repeated with wider vector boxes while the relaxation proves that the
    current boxes exclude every fit (module docstring, item 2). ``problem``: the first
    attempt's problem, when already built."""
    attempts, steps, attempt = [], [], 0
    while True:
        if problem is None or attempt > 0:
            problem = prepare(solved, formulation, nominal)
        if attempt == 0:
            size = problem.sizes()
            say(f"problem: {size['n_parameters']} parameters, {size['n_mode_unknowns']} mode unknowns, "
                f"{size['n_adjunct_unknowns']} adjunct unknowns, {size['n_lifted']} lifted scalars")
        path = solve_homotopy(problem, solver, progress=say)
        steps.extend(path.steps)
        allowance = consistency_allowance(len(problem.blocks), allowance_tol)
        active = _active_bounds(problem, path)
        attempts.append({"shape_margin": formulation.shape_margin, "adjunct_margin": formulation.adjunct_margin,
                         "relaxation_lower_bound": path.lower_bound, "objective": path.objective,
                         "status": path.status.value, "active_bounds": active})
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
    """Identified vector of block ``b`` in the full model's coordinates."""
    v = problem.block_vector(b, u)
    if bases is None:
        return v
    blk = problem.blocks[b]
    k = [c.name for c in configurations].index(blk.configuration)
    if blk.kind != "natural":
        return v  # adjunct vectors stay in reduced coordinates (they live on the adjunct system)
    return bases[k] @ v


def update(configurations: Sequence[Configuration], *, formulation: FormulationOptions | None = None,
           solver: SolverOptions | None = None, polish: PolishOptions | None = None,
           verification: VerifyOptions | None = None,
           progress: Callable[[str], None] | None = None, prepared: Prepared | None = None) -> UpdateResult:
    """Update the shared parameters of ``configurations`` (Problems 1-4 and their mixes).

    Which Problem is solved follows from the data: natural frequencies with mode-shape
    intervals (1), natural frequencies alone (2), antiresonances alone (3), natural
    frequencies and antiresonances with interlacing signs (4).

    Parameters
    ----------
    configurations : sequence of Configuration
    formulation : FormulationOptions, optional
    solver : SolverOptions, optional
    polish : PolishOptions, optional
        The refinement after the homotopy (on by default).
    verification : VerifyOptions, optional
        Thresholds of the checks of the returned model.
    progress : callable, optional
        Receives one line per step.
    prepared : Prepared, optional
        The problem of these configurations and this formulation, already built
        (`prepare_first_stage`); ignored when it was built from other ones.

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
    say = progress or (lambda message: None)
    first_problem = None
    if prepared is not None and prepared.matches(configurations, formulation):
        solved, bases, first_problem = list(prepared.solved), prepared.bases, prepared.problem
    else:
        solved, bases = configurations, None
        if wants_reduction(configurations, formulation):
            solved, bases = reduce_configurations(configurations, formulation.reduction_modes)
    if bases is not None:
        say(f"Craig-Bampton reduction: {configurations[0].model.n_dofs} -> {solved[0].model.n_dofs} DOFs "
            f"(measured DOFs kept, {formulation.reduction_modes} fixed-interface modes)")
    nominal = [model_frequencies(c) for c in configurations]
    problem, path, steps, attempts, active = _first_stage(solved, formulation, solver,
                                                          verification.frequency_tolerance, say,
                                                          nominal if bases is None else None, first_problem)
    size = problem.sizes()
    if bases is not None:
        size["reduced_dofs"] = solved[0].model.n_dofs
    model = configurations[0].model
    first_xbar = np.clip(path.x, problem.x_lower, problem.x_upper)
    xbar, polished, checks = first_xbar, None, ()
    status = path.status
    if status.ok:
        if polish.enabled:
            polished = run_polish(configurations, first_xbar, polish, progress=say)
            xbar = polished.xbar
            say(f"polish: objective {polished.cost_start:.4e} -> {polished.cost:.4e} "
                f"({'kept' if polished.kept else 'not kept'}, {polished.evaluations} evaluations"
                + (f" of the full model in {polished.rounds} reduced rounds" if polished.rounds else "")
                + f", {polished.seconds:.2f} s; {polished.message})")
    updated = [model_frequencies(c, xbar, derivatives=True) for c in configurations]  # zeros with their slopes
    if status.ok:
        first = [model_frequencies(c, first_xbar) for c in configurations] if polished and polished.kept else updated
        checks = verify(configurations, xbar, nominal=nominal, updated=updated, lower_bound=path.lower_bound,
                        n_blocks=len(problem.blocks), active_bounds=active, first_stage=first,
                        options=verification)
        if any(c.severity == "error" and not c.passed for c in checks):
            status = Status.NOT_VERIFIED
    warnings = tuple(f"{c.name}: {c.message}" for c in checks if not c.passed)
    if polished is not None and polished.on_limit:   # short of the optimum, maybe: said where checks are said
        warnings += (f"polish: {polished.message}",)
    for w in warnings:
        say(f"warning: {w}")
    return UpdateResult(
        status=status,
        message=_message(status, path.lam, steps, checks),
        parameters=model.parameters,
        xbar=xbar,
        values=model.physical(xbar),
        matrices={c.name: tuple(sp.csr_matrix(A) for A in c.model.matrices(xbar)) for c in configurations},
        frequencies=tuple(frequency_rows(configurations, nominal, updated)),
        mac={c.name: shape_mac(c, f.Phi) for c, f in zip(configurations, updated)},
        vectors=tuple(_full_vector(problem, b, path.u, solved, bases) for b in range(len(problem.blocks))),
        problem_size=size,
        steps=steps,
        objective=path.objective,
        relaxation_lower_bound=path.lower_bound,
        seconds=sum(st.seconds for st in steps) + (polished.seconds if polished else 0.0),
        sensitivity=sensitivity(configurations, xbar, freqs=updated),
        checks=checks,
        warnings=warnings,
        first_stage_xbar=first_xbar,
        polish=polished,
        attempts=attempts,
        modal={c.name: f for c, f in zip(configurations, updated)},
    )
