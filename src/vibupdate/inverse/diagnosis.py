"""Which data conflict: leave-one-group-out after an answer that does not fit the data.

After a failed check of the fit (`MISFIT_CHECKS`), each group of the data that one fault
corrupts (`data_groups`) is screened in one bounded Gauss-Newton step without it
(`_predicted`); the best `MAX_GROUPS` are refitted without their group within `MAX_SECONDS`
and ranked, and the update is run again without the top one. The groups, the ranking and the
cost: docs/polish-and-verification.md, section 7.8.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np
from scipy.optimize import lsq_linear

from vibupdate.data.measured import Configuration, ShapeInterval
from vibupdate.data.names import mode_name, zero_name
from vibupdate.inverse.correlation import declared_errors, mean_max, model_frequencies
from vibupdate.inverse.homotopy import SolverOptions
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.polish import PolishOptions, polish as run_polish
from vibupdate.inverse.status import Status
from vibupdate.inverse.update import UpdateResult, update
from vibupdate.inverse.admissible import Admissible, evaluate, misses
from vibupdate.inverse.data_map import data_map
from vibupdate.inverse.verify import VerifyOptions, verify


#: Failed checks that say the model does not fit the data: only these start a diagnosis (not a
#: question of which model mode or zero a datum is; a modal mass is a datum: docs section 7.8).
MISFIT_CHECKS = frozenset({"fit", "shape_intervals", "modal_mass", "mac", "improvement"})
#: Groups refitted at most, the best of the one-step screening (the rest are named as untried;
#: `benchmarks/RESULTS.md`, "The diagnosis screened in one step").
MAX_GROUPS = 3
#: Seconds of screening at most; the group under way is finished.
MAX_SECONDS = 120.0


@dataclass(frozen=True)
class DataGroup:
    """Data that one fault would corrupt together.

    Attributes
    ----------
    key : str
        ``"CFG/natural/MODE"``, ``"CFG/antiresonance/R,C/INDEX"``, ``"CFG/shape/MODE"`` or
        ``"CFG/dof/DOF"``: unique within a run.
    kind : {"natural", "antiresonance", "shape", "dof"}
    configuration : str
    label : str
        The group in words.
    size : int
        Data removed with it (frequencies and shape entries).
    """

    key: str
    kind: str
    configuration: str
    label: str
    size: int


def data_groups(configurations: Sequence[Configuration]) -> list[DataGroup]:
    """Every group of the data (module docstring), configuration by configuration: natural
    frequencies, antiresonances, mode shapes, shape DOFs."""
    groups = []
    for cfg in configurations:
        where = f"configuration {cfg.name!r}"
        for k, f in enumerate(cfg.natural, start=1):
            extra = len(f.shape.bounds) if f.shape is not None else 0
            groups.append(DataGroup(f"{cfg.name}/natural/{f.mode}", "natural", cfg.name,
                                    f"natural frequency of {mode_name(f.mode, k)} at {f.freq_hz:.5g} Hz"
                                    + (" with its shape" if extra else "") + f", {where}", 1 + extra))
        for a in cfg.antiresonances:
            groups.append(DataGroup(f"{cfg.name}/antiresonance/{a.response},{a.excitation}/{a.index}",
                                    "antiresonance", cfg.name, f"{zero_name(a.response, a.excitation, a.index)} "
                                    f"at {a.freq_hz:.5g} Hz, {where}", 1))
        shaped = [f for f in cfg.natural if f.shape is not None]
        for f in shaped:
            groups.append(DataGroup(f"{cfg.name}/shape/{f.mode}", "shape", cfg.name,
                                    f"shape of mode {f.mode} ({len(f.shape.bounds)} entries), {where}",
                                    len(f.shape.bounds)))
        order = {d: i for i, d in enumerate((*cfg.model.dofs, *(s.name for s in cfg.model.sensors)))}
        for dof in sorted({d for f in shaped for d in f.shape.bounds}, key=order.__getitem__):
            modes = [f.mode for f in shaped if dof in f.shape.bounds]
            groups.append(DataGroup(f"{cfg.name}/dof/{dof}", "dof", cfg.name,
                                    f"shape entry of DOF {dof!r} in every mode (modes "
                                    f"{', '.join(map(str, modes))}), {where}", len(modes)))
    return groups


def _drop_dof(shape: ShapeInterval | None, dof: str) -> ShapeInterval | None:
    if shape is None or dof not in shape.bounds:
        return shape
    rest = {d: b for d, b in shape.bounds.items() if d != dof}
    if not rest:
        return None
    try:   # a mass-normalized shape stays so: its other entries keep their scale
        return ShapeInterval(rest, shape.mass_normalized)
    except ValueError:   # its new largest entry may be zero: no modal mass left to measure
        return ShapeInterval(rest)


def without(configurations: Sequence[Configuration], group: DataGroup) -> list[Configuration] | None:
    """The configurations without ``group``: a configuration left with no data is dropped
    (its parameters are shared with the others); None when no data would be left at all."""
    kept = []
    for cfg in configurations:
        if cfg.name != group.configuration:
            kept.append(cfg)
            continue
        natural, zeros, interlacing = cfg.natural, cfg.antiresonances, cfg.interlacing
        part = group.key[len(cfg.name) + 1:].split("/")
        if group.kind == "natural":
            natural = tuple(f for f in natural if f.mode != int(part[1]))
        elif group.kind == "antiresonance":   # interlacing asserts that every zero between two poles is listed
            zeros = tuple(a for a in zeros if f"{a.response},{a.excitation}/{a.index}" != "/".join(part[1:]))
            interlacing = False
        elif group.kind == "shape":
            natural = tuple(replace(f, shape=None) if f.mode == int(part[1]) else f for f in natural)
        elif group.kind == "dof":
            natural = tuple(replace(f, shape=_drop_dof(f.shape, part[1])) for f in natural)
        else:
            raise ValueError(f"unknown data group kind {group.kind!r}; expected natural, antiresonance, shape or dof")
        if natural or zeros:
            kept.append(replace(cfg, natural=natural, antiresonances=zeros, interlacing=interlacing))
    return kept or None


def wants_diagnosis(status: Status, failed: Sequence[str]) -> bool:
    """True for an answer that reached lambda = 1 (``not_verified``) and failed a check of its
    fit to the data (`MISFIT_CHECKS`): a failed path leaves no answer to start from."""
    return status == Status.NOT_VERIFIED and bool(MISFIT_CHECKS & set(failed))


@dataclass(frozen=True)
class GroupTrial:
    """The fit without one group, polished from the full answer and verified (docs section 7.8).

    Attributes
    ----------
    group : DataGroup
    share : float
        Fraction of the full answer's objective that the group carries there (before refitting).
    objective : float
        Polish objective on the data kept after refitting.
    passed : bool
        Every screened check passed on the data kept.
    failed : tuple of str
        The failed checks.
    mean_error_pct, max_error_pct : float
        Relative frequency errors on the frequencies kept (per cent).
    shape_misses : int
        Measured mode shapes outside their admissible intervals at their best scale: a count.
    xbar : ndarray
    seconds : float
    evaluations : int
        Full-model evaluations of the polish.
    """

    group: DataGroup
    share: float
    objective: float
    passed: bool
    failed: tuple[str, ...]
    mean_error_pct: float
    max_error_pct: float
    shape_misses: int
    xbar: np.ndarray
    seconds: float
    evaluations: int = 0

    def as_dict(self) -> dict:
        out = asdict(self)
        return {**out.pop("group"), **out, "failed": list(self.failed), "xbar": self.xbar.tolist()}


@dataclass(frozen=True)
class Diagnosis:
    """Which data conflict with the model (module docstring).

    Attributes
    ----------
    failed : tuple of str
        The checks of the full answer that failed.
    objective : float
        Polish objective of the full answer on all the data.
    mean_error_pct, max_error_pct : float
        Relative frequency errors of the full answer.
    trials : tuple of GroupTrial
        Refitted groups, ranked (`rank`).
    untried : int
        Groups not refitted (the limits, or a refit that failed).
    groups : int
        Groups of the data in all.
    best : UpdateResult or None
        The update without the top group, with the same options; None when none was screened.
    best_seconds : float
        Wall-clock seconds of that update (its ``seconds`` count the solves only).
    seconds : float
        The whole diagnosis.
    untried_groups : tuple of str
        The labels of the ``untried`` groups, in the order of the one-step screening.
    max_groups, max_seconds : int, float
        The limits it ran with (`diagnose`).
    """

    failed: tuple[str, ...]
    objective: float
    mean_error_pct: float
    max_error_pct: float
    trials: tuple[GroupTrial, ...]
    untried: int
    groups: int
    best: UpdateResult | None
    seconds: float
    best_seconds: float = 0.0
    untried_groups: tuple[str, ...] = ()
    max_groups: int = MAX_GROUPS
    max_seconds: float = MAX_SECONDS

    @property
    def worst(self) -> DataGroup | None:
        """The group whose removal fits best (the top of the ranking)."""
        return self.trials[0].group if self.trials else None

    def message(self) -> str:
        """One line: the top group and the best model without it."""
        if not self.trials:
            return "diagnosis: no group of the data could be screened"
        top = self.trials[0]
        text = (f"diagnosis: the data fit best without the {top.group.label} (objective {self.objective:.3g} -> "
                f"{top.objective:.3g}, frequency error max {self.max_error_pct:.3g} % -> {top.max_error_pct:.3g} %)")
        if self.best is not None:
            text += f"; updated again without it: {self.best.status.value}"
        return text

    def record(self) -> dict:
        """The ``diagnosis`` section of ``results.json`` (``best`` without its matrices)."""
        best = None
        if self.best is not None:
            b, top = self.best, self.worst
            mean, worst = mean_max(b.correlation.errors())
            best = {"without": top.key, "without_label": top.label, "status": b.status.value, "message": b.message,
                    "success": bool(b.success), "values": {p.name: float(v) for p, v in zip(b.parameters, b.values)},
                    "xbar": np.asarray(b.xbar, dtype=float).tolist(), "mean_error_pct": mean, "max_error_pct": worst,
                    "checks": [c.as_dict() for c in b.checks], "seconds": self.best_seconds}
        return {"failed": list(self.failed), "objective": self.objective, "mean_error_pct": self.mean_error_pct,
                "max_error_pct": self.max_error_pct, "groups": self.groups, "untried": self.untried,
                "untried_groups": list(self.untried_groups),
                "trials": [t.as_dict() for t in self.trials], "best": best, "seconds": self.seconds,
                "limits": {"groups": self.max_groups, "seconds": self.max_seconds}}


def rank(trials: Sequence[GroupTrial], exact: dict[str, float]) -> list[GroupTrial]:
    """The trials ranked: those that pass first, then by objective on the data kept, then by
    the largest frequency error. Objectives at or below ``exact[key]`` (`Admissible.exact_fit`
    of the group's data kept) tie, their order being rounding, and among tied trials that pass
    the one that leaves out the fewest data comes first: an assumption (docs section 7.8)."""
    def key(t: GroupTrial):
        tied = t.passed and t.objective <= exact[t.group.key]
        return (not t.passed, not tied, t.group.size if tied else 0, t.objective, t.max_error_pct)

    return sorted(trials, key=key)


def _predicted(configurations, xbar, verification: VerifyOptions) -> tuple[float, float]:
    """The polish's objective of ``configurations`` at ``xbar``, and after one Gauss-Newton
    step from there within the parameter box (`scipy.optimize.lsq_linear` on the residual's
    linearization): what a refit without the left-out group is predicted to reach."""
    r, J = evaluate(configurations, Admissible.of(configurations, verification), xbar)
    lo, hi = configurations[0].model.bounds()
    ok = np.all(np.isfinite(J), axis=1) & np.isfinite(r)
    step = lsq_linear(J[ok], -r[ok], bounds=(np.minimum(lo - xbar, 0.0), np.maximum(hi - xbar, 0.0))).x
    after = r.copy()
    after[ok] += J[ok] @ step   # rows without derivatives keep their value
    return 0.5 * float(r @ r), 0.5 * float(after @ after)


def _screen(kept, group: DataGroup, share: float, xbar, polish: PolishOptions,
            verification: VerifyOptions) -> GroupTrial:
    """Polish the data ``kept`` from ``xbar`` and verify the answer on them."""
    t0 = time.perf_counter()
    nominal = [model_frequencies(c) for c in kept]
    contract = Admissible.of(kept, verification)
    polished = run_polish(kept, xbar, replace(polish, enabled=True), contract=contract)   # as update
    x = polished.xbar
    updated = [model_frequencies(c, x, derivatives=True) for c in kept]
    checks = verify(kept, x, nominal=nominal, updated=updated, lower_bound=None, n_blocks=0, options=verification,
                    contract=contract)
    failed = tuple(c.name for c in checks if c.severity == "error" and not c.passed)
    found = misses(contract, [data_map(c, x, jacobian=False, freqs=f) for c, f in zip(kept, updated)])
    mean, worst = mean_max(np.concatenate(list(declared_errors(kept, updated).values())))
    return GroupTrial(group, share, float(polished.cost), not failed, failed, mean, worst,
                      sum(m.kind == "shape" and m.miss > 0 for m in found), np.asarray(x, dtype=float),
                      time.perf_counter() - t0, polished.evaluations)


def diagnose(configurations: Sequence[Configuration], result: UpdateResult, *,
             formulation: FormulationOptions | None = None, solver: SolverOptions | None = None,
             polish: PolishOptions | None = None, verification: VerifyOptions | None = None,
             progress: Callable[[str], None] | None = None,
             max_groups: int = MAX_GROUPS, max_seconds: float = MAX_SECONDS) -> Diagnosis:
    """Rank the groups of the data by how well the model fits without each, and update again
    without the top one (module docstring).

    Parameters
    ----------
    configurations : sequence of Configuration
        The data of the run.
    result : UpdateResult
        The run's answer (not verified); its ``xbar`` starts every screening polish.
    formulation, solver, polish, verification : options, optional
        Those of the run: the screening polishes and the final update use them.
    progress : callable, optional
        Receives one line per group.
    max_groups, max_seconds : int, float
        Groups refitted at most, and seconds of the refits at most.

    Returns
    -------
    Diagnosis
    """
    if not max_groups >= 1 or not max_seconds > 0:
        raise ValueError(f"the diagnosis needs max_groups >= 1 and max_seconds > 0, got {max_groups!r} and "
                         f"{max_seconds!r}")
    t0 = time.perf_counter()
    say = progress or (lambda message: None)
    polish = polish or PolishOptions()
    verification = verification or VerifyOptions()
    configurations = list(configurations)
    xbar = np.asarray(result.xbar, dtype=float)
    r, _ = evaluate(configurations, Admissible.of(configurations, verification), xbar, jacobian=False)
    full = 0.5 * float(r @ r)   # the polish's objective at the answer
    mean, worst = mean_max(np.concatenate(list(declared_errors(
        configurations, [model_frequencies(c, xbar) for c in configurations]).values())))
    failed = tuple(c.name for c in result.checks if c.severity == "error" and not c.passed)
    candidates = []
    for group in data_groups(configurations):
        try:
            kept = without(configurations, group)
        except ValueError as exc:   # data that are invalid without the group (a check of Configuration)
            say(f"diagnosis: the data without the {group.label} are not a valid problem ({exc}); not screened")
            continue
        if kept is not None:   # the one-step screening orders the refits (module docstring)
            here, predicted = _predicted(kept, xbar, verification)
            candidates.append((predicted, (full - here) / full if full > 0 else 0.0, group, kept))
    candidates.sort(key=lambda c: c[0])
    say(f"diagnosis: the answer failed {', '.join(failed)}; {len(candidates)} groups of the data screened in one "
        f"step, the best {min(len(candidates), max_groups)} left out in turn and refitted (polished from the answer)")
    trials, exact = [], {}
    for k, (_, share, group, kept) in enumerate(candidates[:max_groups], start=1):
        if time.perf_counter() - t0 > max_seconds:
            say(f"diagnosis: stopped after {len(trials)} groups on the limit of {max_seconds:g} s; not screened: "
                + "; ".join(g.label for _, _, g, _ in candidates[k - 1:max_groups]))
            break
        try:
            trial = _screen(kept, group, share, xbar, polish, verification)
        except (ValueError, np.linalg.LinAlgError) as exc:   # one group's refit is not worth the ranking
            say(f"diagnosis {k}: without the {group.label}: the refit failed ({exc}); left out of the ranking")
            continue
        trials.append(trial)
        exact[group.key] = Admissible.of(kept, verification).exact_fit(verification.exact_half_width)
        say(f"diagnosis {k}/{min(len(candidates), max_groups)}: without the {group.label}: objective "
            f"{trial.objective:.3g}, frequency error max {trial.max_error_pct:.3g} %, "
            + ("passes" if trial.passed else f"fails {', '.join(trial.failed)}") + f" ({trial.seconds:.2f} s)")
    trials = rank(trials, exact)
    best, t1 = None, time.perf_counter()
    if trials:
        kept = without(configurations, trials[0].group)
        say(f"diagnosis: updating again without the {trials[0].group.label} (the same options)")
        best = update(kept, formulation=formulation, solver=solver, polish=polish, verification=verification,
                      probe=False)
    screened = {t.group.key for t in trials}
    untried = tuple(g.label for _, _, g, _ in candidates if g.key not in screened)
    diagnosis = Diagnosis(failed, full, mean, worst, tuple(trials), len(untried), len(candidates),
                          best, time.perf_counter() - t0, time.perf_counter() - t1, untried, max_groups, max_seconds)
    say(diagnosis.message() + f" ({diagnosis.seconds:.1f} s)")
    return diagnosis
