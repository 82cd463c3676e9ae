"""The first stage as one call: ``update(configurations) -> UpdateResult``.

Formulation (`vibupdate.formulation`), interlacing sign bounds (`vibupdate.interlacing`),
McCormick relaxation (`vibupdate.relaxation`) and the homotopy (`vibupdate.homotopy`) are
composed here; the result is a frozen record of the updated model and of how it was found.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from vibupdate.correlation import frequency_rows, model_frequencies, sensitivity, shape_mac
from vibupdate.formulation import BilinearProblem, FormulationOptions, formulate
from vibupdate.homotopy import SolverOptions, StepRecord, solve_homotopy
from vibupdate.interlacing import sign_bounds
from vibupdate.measured import Configuration
from vibupdate.parameters import Parameter
from vibupdate.reduction import reduce_configurations, wants_reduction
from vibupdate.status import Status

__all__ = ["UpdateResult", "update", "prepare"]


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
        Singular values, condition number and rank of the relative frequency sensitivity at
        the answer (`vibupdate.correlation.sensitivity`).
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

    @property
    def success(self) -> bool:
        return self.status.ok

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
        }


def prepare(configurations: Sequence[Configuration],
            options: FormulationOptions | None = None) -> BilinearProblem:
    """Validate the data and build the problem (with interlacing signs); no solve."""
    return formulate(configurations, options, transforms=[sign_bounds])


def _message(status: Status, lam: float, steps) -> str:
    if status == Status.SUCCESS:
        return "homotopy reached lambda = 1"
    if status == Status.ACCEPTABLE:
        return "homotopy reached lambda = 1 at IPOPT's acceptable (looser) tolerance"
    last = steps[-1] if steps else None
    detail = f"; last solve at lambda = {last.lam:.4f}: {last.status.value}" if last else ""
    return f"homotopy stopped at lambda = {lam:.4f} ({status.value}){detail}"


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
           solver: SolverOptions | None = None,
           progress: Callable[[str], None] | None = None) -> UpdateResult:
    """Update the shared parameters of ``configurations`` (Problems 1-4 and their mixes).

    Which Problem is solved follows from the data: natural frequencies with mode-shape
    intervals (1), natural frequencies alone (2), antiresonances alone (3), natural
    frequencies and antiresonances with interlacing signs (4).

    Parameters
    ----------
    configurations : sequence of Configuration
    formulation : FormulationOptions, optional
    solver : SolverOptions, optional
    progress : callable, optional
        Receives one line per homotopy step.

    Returns
    -------
    UpdateResult
        Its ``status`` says whether the path reached ``lam = 1``; a failed solve is a status,
        not an exception. Bad input raises ValueError before any solve.
    """
    configurations = list(configurations)
    formulation = formulation or FormulationOptions()
    say = progress or (lambda message: None)
    solved, bases = configurations, None
    if wants_reduction(configurations, formulation):
        solved, bases = reduce_configurations(configurations, formulation.reduction_modes)
        say(f"Craig-Bampton reduction: {configurations[0].model.n_dofs} -> {solved[0].model.n_dofs} DOFs "
            f"(measured DOFs kept, {formulation.reduction_modes} fixed-interface modes)")
    problem = prepare(solved, formulation)
    size = problem.sizes()
    if bases is not None:
        size["reduced_dofs"] = solved[0].model.n_dofs
    say(f"problem: {size['n_parameters']} parameters, {size['n_mode_unknowns']} mode unknowns, "
        f"{size['n_adjunct_unknowns']} adjunct unknowns, {size['n_lifted']} lifted scalars")
    path = solve_homotopy(problem, solver, progress=say)
    xbar = np.clip(path.x, problem.x_lower, problem.x_upper)
    model = configurations[0].model
    nominal = [model_frequencies(c) for c in configurations]
    updated = [model_frequencies(c, xbar) for c in configurations]
    return UpdateResult(
        status=path.status,
        message=_message(path.status, path.lam, path.steps),
        parameters=model.parameters,
        xbar=xbar,
        values=model.physical(xbar),
        matrices={c.name: tuple(sp.csr_matrix(A) for A in c.model.matrices(xbar)) for c in configurations},
        frequencies=tuple(frequency_rows(configurations, nominal, updated)),
        mac={c.name: shape_mac(c, f.Phi) for c, f in zip(configurations, updated)},
        vectors=tuple(_full_vector(problem, b, path.u, configurations, bases) for b in range(len(problem.blocks))),
        problem_size=size,
        steps=path.steps,
        objective=path.objective,
        relaxation_lower_bound=path.lower_bound,
        seconds=path.seconds,
        sensitivity=sensitivity(configurations, xbar),
    )
