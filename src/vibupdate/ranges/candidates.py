"""Which parameters to update: the smallest sets of candidates that let the data fit (the rule as
the user reads it: docs/polish-and-verification.md, 7.9).

A model that ends ``not_verified`` may lack a parameter rather than hold a wrong datum. The
case lists what might be missing as candidates (``[[candidate]]``, held at their nominal values
in a run); `suggest_sets` screens every set of them, smallest first, by a polish and a
verification (`_screen`), up to `MAX_SETS` sets or `MAX_SECONDS`; ranks them (`_ranked`: passed,
smaller, determined, then by objective, ties within `TIE_RTOL` in declaration order); and updates
the top `CHECKED` in full (`_full_update`): a set is *suggested* only when that update is
``success``. Cost: one polish and one verification per set screened, one update per set checked.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from vibupdate.data.measured import Configuration
from vibupdate.inverse.correlation import declared_errors, mean_max, model_frequencies
from vibupdate.inverse.data_map import sensitivity
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.homotopy import SolverOptions
from vibupdate.inverse.polish import PolishOptions, polish as run_polish
from vibupdate.inverse.update import update
from vibupdate.inverse.admissible import Admissible
from vibupdate.inverse.verify import VerifyOptions, verify
from vibupdate.model.affine import restricted


#: Sets screened at most (the rest are counted as untried).
MAX_SETS = 200
#: Seconds of screening at most; the set under way is finished.
MAX_SECONDS = 300.0
#: Top sets checked by a full update.
CHECKED = 3
#: Objectives within this relative difference are ties: equally good fits. The objective of
#: a set that fits carries the model-form error no set removes exactly, and sets that differ
#: by this little say nothing about which parameter is missing (`benchmarks/RESULTS.md`,
#: "Which parameters to update: `benchmarks/suggest_bar.py`").
TIE_RTOL = 0.01


@dataclass(frozen=True)
class SetTrial:
    """One set of candidates, screened and perhaps checked.

    Attributes
    ----------
    names : tuple of str
        The candidates added to the case's parameters, in declaration order.
    objective : float
        Polish objective on the data at the screened answer (the misfit).
    passed : bool
        Every screened check passed.
    failed : tuple of str
        The failed checks of the screening.
    errors : dict
        Relative errors of the screened answer (per cent): ``natural_mean_pct``,
        ``natural_max_pct``, ``antiresonance_mean_pct``, ``antiresonance_max_pct`` (NaN without
        antiresonances).
    rank, condition : int, float
        Numerical rank and condition number of the data's sensitivity to the free parameters
        at the screened answer: a rank below the number of free parameters means a
        combination of them the data do not determine.
    values : dict of str to float
        Physical values of the free parameters at the screened answer.
    seconds : float
    tied_with : tuple of tuple of str
        Other sets whose objective equals this one's within `TIE_RTOL`.
    update : dict or None
        The full update of a checked set: ``status``, ``success``, ``message``, ``values``,
        ``units``, the errors as ``errors`` has them, ``failed``, ``limited_by``, ``range_pct``
        (linearized range width of each parameter, per cent of its reference, at a verified
        answer), ``seconds``; None when not checked.
    """

    names: tuple[str, ...]
    objective: float
    passed: bool
    failed: tuple[str, ...]
    errors: dict
    rank: int
    condition: float
    values: dict
    seconds: float
    n_free: int = 0
    """Free parameters: the case's own and the set's."""
    tied_with: tuple[tuple[str, ...], ...] = ()
    update: dict | None = None
    order: int = field(default=0, repr=False)

    @property
    def determined(self) -> bool:
        """The data determine every free parameter (a sensitivity of full rank)."""
        return self.rank >= self.n_free

    @property
    def verified(self) -> bool:
        """The set's full update ended ``success``."""
        return bool(self.update and self.update.get("success"))

    @property
    def label(self) -> str:
        return " + ".join(self.names)

    def as_dict(self) -> dict:
        return {"candidates": list(self.names), "objective": self.objective, "passed": self.passed,
                "failed": list(self.failed), **self.errors, "rank": self.rank, "free": self.n_free,
                "condition": self.condition, "determined": self.determined, "values": dict(self.values),
                "tied_with": [list(t) for t in self.tied_with], "update": self.update, "seconds": self.seconds}


@dataclass(frozen=True)
class Suggestion:
    """The ranked sets of candidates (module docstring).

    Attributes
    ----------
    own : tuple of str
        The case's own parameters, free in every set.
    candidates : tuple of str
        The pool, in declaration order.
    nominal : dict
        The model with the case's own parameters alone, screened as the sets are (``objective``,
        ``passed``, ``failed`` and the errors of `SetTrial`); empty when it has none.
    trials : tuple of SetTrial
        Every set screened, ranked.
    sizes : tuple of int
        The set sizes screened.
    untried : int
        Sets of those sizes not screened because of the limits (or whose fit failed).
    seconds : float
    untried_sets : tuple of tuple of str
        Those sets, each by its candidates' names, in the order they would have been screened.
    """

    own: tuple[str, ...]
    candidates: tuple[str, ...]
    nominal: dict
    trials: tuple[SetTrial, ...]
    sizes: tuple[int, ...]
    untried: int
    seconds: float
    untried_sets: tuple[tuple[str, ...], ...] = ()

    @property
    def best(self) -> SetTrial | None:
        """The top set whose full update is ``success`` (None when none is)."""
        return next((t for t in self.trials if t.verified), None)

    @property
    def screened_best(self) -> SetTrial | None:
        """The top set of the screening alone (passed or not); None when nothing was screened."""
        return min(self.trials, key=lambda t: t.order) if self.trials else None

    def message(self) -> str:
        """One line: the suggested set, or the best screened one."""
        best = self.best
        if best is not None:
            return (f"suggested: add {best.label} (verified: natural frequencies within "
                    f"{best.update['natural_max_pct']:.3g} %"
                    + (f"; ties with {', '.join(' + '.join(t) for t in best.tied_with)}" if best.tied_with else "")
                    + ")")
        top = self.screened_best
        if top is None:
            return "no set of candidates could be screened"
        verdict = "passes the screening" if top.passed else f"fails {', '.join(top.failed)}"
        checked = " (no checked set verified)" if any(t.update for t in self.trials) else ""
        return (f"best set screened: add {top.label}, {verdict}, natural frequencies within "
                f"{top.errors['natural_max_pct']:.3g} %{checked}")

    def record(self) -> dict:
        """The suggestion as plain data (``suggestion.json``, ``results.json``)."""
        best = self.best
        return {"own": list(self.own), "candidates": list(self.candidates), "nominal": self.nominal,
                "sizes": list(self.sizes), "untried": self.untried, "seconds": self.seconds,
                "untried_sets": [list(names) for names in self.untried_sets],
                "best": list(best.names) if best is not None else None,
                "screened_best": list(self.screened_best.names) if self.trials else None,
                "message": self.message(), "trials": [t.as_dict() for t in self.trials],
                "limits": {"sets": MAX_SETS, "seconds": MAX_SECONDS, "tie_rtol": TIE_RTOL}}


def configurations_with(pool: Sequence[Configuration], free: Sequence[str]) -> list[Configuration]:
    """The pool's configurations with only the parameters ``free`` free (the others at their
    nominal values, `vibupdate.model.affine.restricted`)."""
    return [replace(c, model=restricted(c.model, free)) for c in pool]


def _frequency_errors(by_kind: dict) -> dict:
    """Mean and max of the relative errors (per cent) of each kind, ``natural`` (the declared
    modes) and ``antiresonance`` (NaN without any): ``natural_mean_pct``, ``natural_max_pct``, ..."""
    return {f"{kind}_{what}_pct": value for kind, errors in by_kind.items()
            for what, value in zip(("mean", "max"), mean_max(errors))}


def _screen(configurations, start: dict, polish: PolishOptions, verification: VerifyOptions):
    """Polish ``configurations`` from ``start`` (normalized values by name, 0 where not given)
    and verify the answer (the screening, module docstring). Returns the answer, its objective,
    the failed checks, the frequency errors, the rank and condition of the sensitivity."""
    model = configurations[0].model
    start = np.clip(np.array([float(start.get(n, 0.0)) for n in model.parameter_names]), *model.bounds())
    nominal = [model_frequencies(c) for c in configurations]
    contract = Admissible.of(configurations, verification)
    polished = run_polish(configurations, start, replace(polish, enabled=True), contract=contract)   # as update
    x = np.asarray(polished.xbar, dtype=float)
    updated = [model_frequencies(c, x, derivatives=True) for c in configurations]
    checks = verify(configurations, x, nominal=nominal, updated=updated, lower_bound=None, n_blocks=0,
                    options=verification, contract=contract)
    failed = tuple(c.name for c in checks if c.severity == "error" and not c.passed)
    s = sensitivity(configurations, x, freqs=updated)
    errors = _frequency_errors(declared_errors(configurations, updated))
    return x, float(polished.cost), failed, errors, int(s.rank), float(s.condition)


def _rank_key(trial: SetTrial) -> tuple:
    return (not trial.passed, len(trial.names), not trial.determined, trial.objective)


def _ranked(trials: list[SetTrial]) -> list[SetTrial]:
    """Sorted by `_rank_key`, ties (equal but for the objective within `TIE_RTOL`) in
    declaration order and naming each other."""
    trials = sorted(trials, key=_rank_key)
    groups: list[list[SetTrial]] = []
    for t in trials:
        last = groups[-1][-1] if groups else None
        if last is not None and _rank_key(last)[:3] == _rank_key(t)[:3] and \
                abs(t.objective - groups[-1][0].objective) <= TIE_RTOL * max(abs(groups[-1][0].objective), 1e-300):
            groups[-1].append(t)
        else:
            groups.append([t])
    out = []
    for group in groups:
        group.sort(key=lambda t: t.order)
        for t in group:
            others = tuple(o.names for o in group if o is not t)
            out.append(replace(t, tied_with=others))
    return [replace(t, order=k) for k, t in enumerate(out)]


def _full_update(configurations, names, options: dict, frequency_tolerance: float, say) -> dict:
    """The full update of one set (the check, module docstring), as a plain record."""
    from vibupdate.ranges.identifiability import parameter_ranges

    t0 = time.perf_counter()
    result = update(configurations, probe=False, **options)
    failed = [c.name for c in result.checks if c.severity == "error" and not c.passed]
    fit = next((c for c in result.checks if c.name == "fit"), None)
    record = {"status": result.status.value, "success": bool(result.success), "message": result.message,
              "values": {p.name: float(v) for p, v in zip(result.parameters, result.values)},
              "units": {p.name: p.unit for p in result.parameters},
              **_frequency_errors({kind: result.correlation.errors(kind) for kind in ("natural", "antiresonance")}),
              "failed": failed, "limited_by": fit.as_dict().get("limited_by") if fit is not None else None,
              "range_pct": None}
    if result.success:   # the ranges mean something only at a verified answer
        ranges = parameter_ranges(configurations, result.xbar, frequency_tolerance=frequency_tolerance)
        record["range_pct"] = {n: float(w) for n, w in zip(ranges.names, ranges.width_pct)}
    record["seconds"] = time.perf_counter() - t0
    say(f"suggest: full update with {' + '.join(names)}: {record['status']}, natural frequencies within "
        f"{record['natural_max_pct']:.3g} % ({record['seconds']:.1f} s)")
    return record


def suggest_sets(pool: Sequence[Configuration], own: Sequence[str], candidates: Sequence[str], *,
                 max_size: int = 3, checked: int = CHECKED, formulation: FormulationOptions | None = None,
                 solver: SolverOptions | None = None, polish: PolishOptions | None = None,
                 verification: VerifyOptions | None = None, frequency_tolerance: float = 0.0, start=None,
                 progress: Callable[[str], None] | None = None, max_sets: int = MAX_SETS,
                 max_seconds: float = MAX_SECONDS) -> Suggestion:
    """Screen, rank and check sets of candidates (module docstring).

    Parameters
    ----------
    pool : sequence of Configuration
        The data, on models with the case's own parameters and every candidate free.
    own : sequence of str
        The case's own parameters: free in every set.
    candidates : sequence of str
        The pool of candidates, in declaration order (the order of ties).
    max_size : int
        Largest set tried.
    checked : int
        Top sets updated in full (0: the screening alone, as the run's report does).
    formulation, solver, polish, verification : options, optional
        The case's: the screening polishes and verifications and the full updates use them.
    frequency_tolerance : float
        The case's, for the linearized ranges of a verified set.
    start : mapping of str to float, optional
        Normalized start value of a free parameter (default 0: the nominal point), e.g. the
        run's answer for the case's own parameters.
    progress : callable, optional
        Receives one line per set.
    max_sets, max_seconds : int, float
        Limits of the screening.

    Returns
    -------
    Suggestion
    """
    own, candidates = tuple(own), tuple(candidates)
    if not candidates:
        raise ValueError("the case declares no [[candidate]]: nothing to suggest from")
    if isinstance(max_size, bool) or not isinstance(max_size, int) or max_size < 1:
        raise ValueError(f"the largest set size must be an integer >= 1, got {max_size!r}")
    if not max_sets >= 1 or not max_seconds > 0 or checked < 0:
        raise ValueError(f"the suggestion needs max_sets >= 1, max_seconds > 0 and checked >= 0, got {max_sets!r}, "
                         f"{max_seconds!r} and {checked!r}")
    t0 = time.perf_counter()
    say = progress or (lambda message: None)
    polish = polish or PolishOptions()
    verification = verification or VerifyOptions()
    start = dict(start or {})
    pool = list(pool)
    nominal = _nominal(pool, own, start, polish, verification)
    sizes = range(1, min(max_size, len(candidates)) + 1)
    total = sum(len(list(itertools.combinations(candidates, k))) for k in sizes)
    say(f"suggest: {len(candidates)} candidates ({', '.join(candidates)}), sets of 1 to {max(sizes)}, {total} sets at "
        f"most, each fitted from the nominal point and verified")
    trials, screened, stopped = [], [], False
    for size in sizes:
        for names in itertools.combinations(candidates, size):
            if len(trials) >= max_sets or time.perf_counter() - t0 > max_seconds:
                stopped = True
                break
            trial = _trial(pool, own, names, start, polish, verification, len(trials), say)
            if trial is not None:
                trials.append(trial)
        screened.append(size)
        if stopped:
            say(f"suggest: stopped after {len(trials)} sets on the limit of {max_sets} sets or {max_seconds:g} s")
            break
        if any(t.passed for t in trials):
            break   # the smallest sets that pass are found: larger ones add nothing the data ask for
    done = {tuple(t.names) for t in trials}
    untried = tuple(names for k in screened for names in itertools.combinations(candidates, k) if names not in done)
    trials = _ranked(trials)
    options = {"formulation": formulation, "solver": solver, "polish": polish, "verification": verification}
    for k, trial in enumerate(trials[:checked]):
        configurations = configurations_with(pool, own + trial.names)
        try:
            record = _full_update(configurations, trial.names, options, frequency_tolerance, say)
        except (ValueError, np.linalg.LinAlgError) as exc:   # one set's update is not worth the ranking
            record = {"status": "failed", "success": False, "message": str(exc), "failed": [], "values": {},
                      "natural_max_pct": float("nan"), "seconds": 0.0}
            say(f"suggest: full update with {trial.label} failed: {exc}")
        trials[k] = replace(trial, update=record)
    # checked sets first, verified before the others; then the screening's order
    trials.sort(key=lambda t: (t.update is None, not t.verified, t.order))
    suggestion = Suggestion(own, candidates, nominal, tuple(trials), tuple(screened), len(untried),
                            time.perf_counter() - t0, untried)
    say(suggestion.message() + f" ({suggestion.seconds:.1f} s)")
    return suggestion


def _trial(pool, own, names, start, polish, verification, order, say) -> SetTrial | None:
    """Screen one set; None (said) when its fit fails."""
    t0 = time.perf_counter()
    configurations = configurations_with(pool, own + names)
    label = " + ".join(names)
    try:
        x, objective, failed, errors, rank, condition = _screen(configurations, start, polish, verification)
    except (ValueError, np.linalg.LinAlgError) as exc:
        say(f"suggest: with {label}: the fit failed ({exc}); left out of the ranking")
        return None
    model = configurations[0].model
    trial = SetTrial(names, objective, not failed, failed, errors, rank, condition,
                     {p.name: float(v) for p, v in zip(model.parameters, model.physical(x))},
                     time.perf_counter() - t0, n_free=model.n_parameters, order=order)
    say(f"suggest {order + 1}: with {label}: objective {objective:.3g}, natural frequencies within "
        f"{errors['natural_max_pct']:.3g} %, "
        + ("passes" if trial.passed else f"fails {', '.join(failed)}")
        + ("" if trial.determined else ", a combination not determined") + f" ({trial.seconds:.2f} s)")
    return trial


def _nominal(pool, own, start, polish, verification) -> dict:
    """The case's own parameters alone, screened as a set is (empty without any)."""
    if not own:
        return {}
    configurations = configurations_with(pool, own)
    try:
        _, objective, failed, errors, _, _ = _screen(configurations, start, polish, verification)
    except (ValueError, np.linalg.LinAlgError):
        return {}
    return {"objective": objective, "passed": not failed, "failed": list(failed), **errors}
