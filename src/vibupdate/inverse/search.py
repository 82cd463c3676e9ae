"""The search for the answer, as typed records: which starts, in which order, with which budgets.

An update polishes the first stage's answer (`vibupdate.inverse.update`). When that answer
is not verified, or the path failed, further starts are polished in a fixed order: the stepped
homotopy path (when the direct jump was taken), the nominal point, then `Search.random_starts`
points of the parameter box drawn with `Search.seed` (the same input gives the same answer).
The first verified answer ends that part.

A verified answer is then tested for uniqueness. Two kinds of other answers are sought, each by
the structure that makes it:

* **Across a fold.** Where the map from parameters to data folds over, a second isolated
  answer lies across the fold, along the direction the data see least. The nominal point, the
  answer moved along the data's weakest determined direction out to the box in both senses
  (`Search.weak_starts`) and `Search.probe_random_starts` random points of the box, those not
  tried yet, are polished with at most `Search.probe_evaluations` evaluations per unknown plus
  one. An answer that verifies, fits about as well (`Search.as_well`) and differs from the
  returned one by more than `Search.distinct` (a normalized parameter) is an `Alternative`.
* **Along a valley.** Where the data leave directions undetermined at the answer (fewer
  independent data than parameters), the answers with its data form a set, and every start
  would be moved to the same point of it (the minimum change,
  `vibupdate.inverse.minimum_change`). The set is explored instead (`Search.valley_ends`): where
  each parameter that moves is lowest and highest on it, and, where it is a curve, every point
  where a parameter turns along it (`vibupdate.inverse.minimum_change.valley_ends`,
  `~.valley_curve`). Those that differ from the answer are Alternatives.

Above `Search.probe_dofs` DOFs the starts are first polished on a reduced model
(`vibupdate.inverse.update`: the first stage's, or one built at the answer): one that reaches the answer there costs no full-model polish, the
others are polished on the full model; the set of answers is followed on the reduced model and
its points moved onto the full model's data.

Any Alternative makes the verdict ``not_unique``. Where the uniqueness search is not run (the
polish off, a sampling sweep, a model above `Search.probe_parameters` parameters), the result
says so and why (`Sought`).

Every start tried is a `Start` in the result (`vibupdate.inverse.update.UpdateResult.sought`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from vibupdate.inverse.minimum_change import numerical_rank
from vibupdate.modal.analysis import DENSE_LIMIT


@dataclass(frozen=True)
class Search:
    """The search's starts and budgets (module docstring).

    Attributes
    ----------
    random_starts : int
        Random points of the box polished when the answer does not verify.
    probe_random_starts : int
        Random points of the box polished to test a verified answer for uniqueness, after the
        weakest-direction starts: a second isolated fit usually lies along the weakest
        determined direction, which those starts follow, and the random starts cover the rest
        (and find better answers than the one verified, an exact fit where the first answer
        only lay inside its intervals). Each start costs the cantilever's update about 0.15
        times the classical fit (`benchmarks/RESULTS.md`, "The uniqueness search by the
        structure of the problem").
    probe_evaluations : int
        Evaluations of each uniqueness polish, per unknown plus one: a start that has not
        converged by then is not an answer that fits as well.
    probe_dofs : int
        Above this many DOFs the uniqueness search polishes its starts on a reduced model
        first (module docstring): the dense models, where a full polish costs a
        fraction of a second, are searched on the full model.
    probe_parameters : int
        The uniqueness search runs on models up to this many parameters (the bundled
        29-parameter frame took 36 s for four starts, its answer unchanged).
    distinct : float
        Two answers differ when a normalized parameter differs by more than this.
    tie : float
        Verified answers whose objectives lie within this relative margin of the lowest tie:
        the one nearest the nominal model is returned.
    as_well : float
        Another verified answer "fits as well" when its objective is at most this times the
        lowest (or an exact fit): every verified answer lies in the admissible intervals, and
        with model-form tolerances of 2 % many do; one whose pull toward the midpoints is far
        weaker is not an alternative to the answer.
    seed : int
        Of the random starts.
    weak_direction : bool
        Polish, besides the box starts, from the answer moved along the data's weakest
        determined direction out to the box, in both senses (`weak_starts`).
    valley_ends : bool
        Where the data leave directions undetermined at a verified answer, find where each
        parameter that moves is lowest and highest among the answers with the same data, and
        report those points as alternatives (module docstring).
    """

    random_starts: int = 2
    probe_random_starts: int = 2
    probe_evaluations: int = 20
    probe_dofs: int = DENSE_LIMIT
    probe_parameters: int = 12
    distinct: float = 1e-3
    tie: float = 1e-3
    as_well: float = 2.0
    seed: int = 0
    valley_ends: bool = True
    weak_direction: bool = True

    def box_starts(self, lo: np.ndarray, hi: np.ndarray, n_random: int) -> list[tuple[str, np.ndarray]]:
        """The nominal point and ``n_random`` random points of the box ``[lo, hi]``, in this
        order (the first points are the same whatever ``n_random``)."""
        rng = np.random.default_rng(self.seed)
        return [("nominal point", np.clip(np.zeros(lo.size), lo, hi))] + [
            (f"random start {k + 1}", rng.uniform(lo, hi)) for k in range(n_random)]

    def weak_starts(self, xbar: np.ndarray, sensitivity, lo: np.ndarray,
                    hi: np.ndarray) -> list[tuple[str, np.ndarray]]:
        """The answer ``xbar`` moved along the data's weakest determined direction (the right
        singular vector of the smallest nonzero singular value of ``sensitivity.matrix``,
        `vibupdate.inverse.data_map.sensitivity`) in each sense, out to the box ``[lo, hi]``:
        a second answer across a fold (module docstring). Parameters the answer holds at a
        bound stay there (the direction is that of the others: along it, the bound would stop
        both senses at once); ``weak_direction`` off or no determined direction gives none."""
        S = sensitivity.matrix
        if not self.weak_direction or S is None or not S.size:
            return []
        span = hi - lo
        free = (xbar > lo + 1e-9 * span) & (xbar < hi - 1e-9 * span)
        _, sv, Vt = np.linalg.svd(S[:, free]) if free.any() else (None, np.zeros(0), None)
        rank = numerical_rank(sv)
        if not rank:
            return []
        v = np.zeros(xbar.size)
        v[free] = Vt[rank - 1]
        out = []
        for sense, d in (("+", v), ("-", -v)):
            with np.errstate(divide="ignore", invalid="ignore"):
                reach = np.where(d > 0, (hi - xbar) / d, np.where(d < 0, (lo - xbar) / d, np.inf))
            t = float(np.min(reach))
            if np.isfinite(t) and t > 0:
                out.append((f"weakest direction {sense}", np.clip(xbar + t * d, lo, hi)))
        return out

    def uniqueness(self, n_dofs: int, n_parameters: int, asked: bool) -> tuple[bool, str]:
        """Whether a verified answer is tested for uniqueness on a model of this size, and why."""
        if not asked:
            return False, "not asked for (polish off or a sampling sweep)"
        if n_parameters > self.probe_parameters:
            return False, (f"the model has {n_parameters} parameters, above the {self.probe_parameters} of the "
                           "uniqueness search")
        return True, (f"the nominal point, {self.probe_random_starts} random start(s)"
                      + (" and the answer moved along the weakest direction" if self.weak_direction else "")
                      + " polished" + (f", first on a reduced model (above {self.probe_dofs} DOFs)"
                                       if n_dofs > self.probe_dofs else "")
                      + (", and the ends of the set of answers with the same data where the data leave directions "
                         "undetermined" if self.valley_ends else ""))


@dataclass(frozen=True)
class Start:
    """One start tried: its label, why (``purpose`` "fit" or "uniqueness"), the verdict of its
    answer ("verified", "not_verified", "path failed", "same answer": it reached a known answer
    again, "same data": points with the answer's data to 1e-9, the valley's ends), the failed checks, its polish objective and seconds."""

    start: str
    purpose: str
    status: str
    failed: tuple[str, ...] = ()
    cost: float | None = None
    seconds: float = 0.0

    def as_dict(self) -> dict:
        return {**asdict(self), "failed": list(self.failed)}

    def __getitem__(self, key):      # read like the dict of ``results.json``
        return getattr(self, key)


@dataclass(frozen=True)
class Alternative:
    """Another verified answer: its start, objective, ``xbar``, physical ``values`` by name and
    the parameters that differ from the returned answer (``differs``)."""

    start: str
    objective: float
    xbar: tuple[float, ...]
    values: dict
    differs: tuple[str, ...]

    def as_dict(self) -> dict:
        return {"start": self.start, "objective": self.objective, "xbar": list(self.xbar),
                "values": dict(self.values), "differs": list(self.differs)}

    def __getitem__(self, key):      # read like the dict of ``results.json``
        return getattr(self, key)


@dataclass(frozen=True)
class Sought:
    """What the update sought: the search it ran, every start in order, and whether the
    uniqueness of a verified answer was searched, and why (or why not)."""

    search: Search
    starts: tuple[Start, ...]
    uniqueness: bool = field(metadata={"key": "uniqueness_searched"})
    reason: str

    def as_dict(self) -> dict:
        return {"search": asdict(self.search), "starts": [s.as_dict() for s in self.starts],
                "uniqueness_searched": self.uniqueness, "reason": self.reason}
