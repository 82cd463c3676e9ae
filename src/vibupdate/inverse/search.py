"""The search for the answer, as typed records: which starts, in which order, with which budgets.

When the first stage's answer does not verify, or the path failed, further starts are polished
in the order `Search` states until one verifies; a verified answer is then tested for uniqueness
across a fold (box and weakest-direction starts) and along a valley (the ends of the set of
answers with the same data), and any other verified answer that fits as well is an
`Alternative`, making the verdict ``not_unique``. Every start tried is a `Start`, and `Sought`
says whether uniqueness was searched and why. The rules and their measurements:
docs/polish-and-verification.md, sections 7.6 and 7.7.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, is_dataclass
from enum import Enum

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
        weakest-direction starts (each costs the cantilever about 0.15 times the classical fit:
        `benchmarks/RESULTS.md`, "The uniqueness search by the structure of the problem").
    probe_evaluations : int
        Evaluations of each uniqueness polish, per unknown plus one: a start that has not
        converged by then is not an answer that fits as well.
    probe_dofs : int
        Above this many DOFs the uniqueness search polishes its starts on a reduced model first.
    probe_parameters : int
        The uniqueness search runs on models up to this many parameters: its five starts cost
        the bundled 29-parameter frame about 0.4 s, a 30-spring chain with fewer data than
        springs about 0.5 s besides its 60 valley ends (`benchmarks/RESULTS.md`, "The uniqueness
        search on up to 40 parameters").
    distinct : float
        Two answers differ when a normalized parameter differs by more than this.
    tie : float
        Verified answers whose objectives lie within this relative margin of the lowest tie:
        the one nearest the nominal model is returned.
    as_well : float
        Another verified answer "fits as well" when its objective is at most this times the
        lowest (or an exact fit).
    seed : int
        Of the random starts.
    weak_direction : bool
        Polish, besides the box starts, from the answer moved along the data's weakest
        determined direction out to the box, in both senses (`weak_starts`).
    follow : int
        Further verified answers whose own weakest-direction starts are polished in turn, at
        most: two isolated exact fits close together lie on either side of a fold of the data,
        and the weakest direction of each points across its fold (0: only the first answer's).
        Points of a set of answers (data that leave directions undetermined) are not followed:
        the valley's ends and turns (``valley_ends``) show that set.
    valley_ends : bool
        Where the data leave directions undetermined at a verified answer, report the ends and
        turns of the set of answers with the same data as alternatives.
    """

    random_starts: int = 2
    probe_random_starts: int = 2
    probe_evaluations: int = 20
    probe_dofs: int = DENSE_LIMIT
    probe_parameters: int = 40
    distinct: float = 1e-3
    tie: float = 1e-3
    as_well: float = 2.0
    seed: int = 0
    valley_ends: bool = True
    weak_direction: bool = True
    follow: int = 2

    def new(self, x: np.ndarray, among) -> bool:
        """Whether the point ``x`` is another answer than every point of ``among``.

        Parameters
        ----------
        x : ndarray, shape (n_x,)
            A normalized point.
        among : sequence of ndarray, shape (n_x,)
            The points it is compared with.

        Returns
        -------
        bool
            True when ``x`` differs from each of them by more than `distinct` in some parameter.
        """
        return all(np.max(np.abs(np.asarray(x) - np.asarray(k))) > self.distinct for k in among)

    def box_starts(self, lo: np.ndarray, hi: np.ndarray, n_random: int) -> list[tuple[str, np.ndarray]]:
        """The nominal point and ``n_random`` random points of a box, in this order.

        The random points are drawn with `seed`, so the first ones are the same whatever
        ``n_random``.

        Parameters
        ----------
        lo, hi : ndarray, shape (n_x,)
            Lower and upper bounds of the normalized parameters.
        n_random : int
            How many random points.

        Returns
        -------
        list of (str, ndarray)
            Each start's label ("nominal point", "random start 1", ...) and its point, shape
            (n_x,); the nominal point clipped to the box.
        """
        rng = np.random.default_rng(self.seed)
        return [("nominal point", np.clip(np.zeros(lo.size), lo, hi))] + [
            (f"random start {k + 1}", rng.uniform(lo, hi)) for k in range(n_random)]

    def weak_starts(self, xbar: np.ndarray, sensitivity, lo: np.ndarray,
                    hi: np.ndarray) -> list[tuple[str, np.ndarray]]:
        """The answer moved along the data's weakest determined direction, in each sense.

        The direction is the right singular vector of the smallest nonzero singular value of
        ``sensitivity.matrix``; each start lies where it leaves the box. Parameters held at a
        bound stay there (else the bound would stop both senses at once).

        Parameters
        ----------
        xbar : ndarray, shape (n_x,)
            The answer, normalized parameters.
        sensitivity : vibupdate.inverse.data_map.Sensitivity
            The data's relative sensitivity at ``xbar`` (its ``matrix``, shape (n_data, n_x),
            may be None or empty).
        lo, hi : ndarray, shape (n_x,)
            Lower and upper bounds of the normalized parameters.

        Returns
        -------
        list of (str, ndarray)
            Labels "weakest direction +" and "weakest direction -" with their points, shape
            (n_x,): a sense that leaves the box at once gives none, and the list is empty when
            `weak_direction` is off or the data determine no direction.
        """
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
        """Whether a verified answer is tested for uniqueness, and why.

        Parameters
        ----------
        n_dofs : int
            DOFs of the model (above `probe_dofs` the starts are polished on a reduced model
            first).
        n_parameters : int
            Updating parameters (above `probe_parameters` no search).
        asked : bool
            Whether the caller asked for the search (polish on, not a sampling sweep).

        Returns
        -------
        searched : bool
            Whether the search runs.
        reason : str
            Why, in words: the starts it polishes, or why it does not run.
        """
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


class SearchRecord:
    """The base of the search's records (`Start`, `Alternative`, `Sought` and
    `vibupdate.inverse.update.Attempt`, frozen dataclasses): read like its dict of
    ``results.json`` (``record["start"]``), written by `as_dict`."""

    def as_dict(self) -> dict:
        """The record as its ``results.json`` document.

        Returns
        -------
        dict
            Each field under its name (or its metadata's ``key``): tuples as lists, records as
            dicts, enumerations as their values.
        """
        return {f.metadata.get("key", f.name): _plain(getattr(self, f.name)) for f in fields(self)}

    def __getitem__(self, key):
        return getattr(self, key)


def _plain(value):
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, SearchRecord):
        return value.as_dict()
    if isinstance(value, Enum):
        return value.value
    return asdict(value) if is_dataclass(value) else dict(value) if isinstance(value, dict) else value


@dataclass(frozen=True)
class Start(SearchRecord):
    """One start tried by the search.

    Attributes
    ----------
    start : str
        Its label ("nominal point", "random start 1", "weakest direction +", "valley ends",
        ...).
    purpose : {"fit", "uniqueness"}
        Tried because the answer did not verify, or to test a verified answer for uniqueness.
    status : {"verified", "not_verified", "path failed", "same answer", "same data"}
        What its answer was: "same answer" when it reached a known answer again, "same data"
        for points with the answer's data to 1e-9 (the valley's ends).
    failed : tuple of str
        The names of the failed error checks of its answer (`vibupdate.inverse.verify.Check`).
    cost : float or None
        Polish objective of its answer (dimensionless, `vibupdate.inverse.polish`): inf for an
        answer that was not polished, None for a start whose answer was not kept ("path
        failed", "same answer").
    seconds : float
        Wall time spent on it, s.
    """

    start: str
    purpose: str
    status: str
    failed: tuple[str, ...] = ()
    cost: float | None = None
    seconds: float = 0.0


@dataclass(frozen=True)
class Alternative(SearchRecord):
    """Another verified answer that fits the data as well as the returned one.

    Attributes
    ----------
    start : str
        The label of the `Start` that reached it.
    objective : float
        Its polish objective (dimensionless, `vibupdate.inverse.polish`).
    xbar : tuple of float
        Its normalized parameters (Eq. 12), one per parameter in the model's order.
    values : dict of str to float
        Its physical parameter values by name, each in its parameter's unit.
    differs : tuple of str
        The parameters whose normalized values differ from the returned answer's by more than
        `Search.distinct`.
    """

    start: str
    objective: float
    xbar: tuple[float, ...]
    values: dict
    differs: tuple[str, ...]


@dataclass(frozen=True)
class Sought(SearchRecord):
    """What the update sought.

    Attributes
    ----------
    search : Search
        The starts and budgets it ran with.
    starts : tuple of Start
        Every start tried, in order.
    uniqueness : bool
        Whether a verified answer was tested for uniqueness; written as
        ``uniqueness_searched``.
    reason : str
        Why it was (which starts) or why not, in words.
    interrupted : bool
        Ctrl-C ended the uniqueness search: the answer is the best verified one found by then.
    """

    search: Search
    starts: tuple[Start, ...]
    uniqueness: bool = field(metadata={"key": "uniqueness_searched"})
    reason: str
    interrupted: bool = False
