"""The judge of the acceptance engine: one verdict per run, from what it computed itself.

Everything the judge compares an answer with is computed here from the problem alone: the data
of the returned model by the dense kernels of `acceptance.truth`, and what the data determine
by the finite-difference Jacobian and linear programs of `acceptance.determinacy` (never by the
library's ranges). The answer is read through `acceptance.adapter` only.

Failure codes of one run (`Verdict.failures`):

* ``crash``: an internal error (exit 3, an exception that is not a ValueError);
* ``refused``: exit 2 or a ValueError on a valid problem;
* ``exit_code``: an exit code that does not match the status (0 success, 1 otherwise);
* ``outside``: an answer claiming to fit (``success``, or the tool's ``not_unique``) whose model
  has a datum outside its interval, recomputed from the returned parameters (exact data:
  intervals of relative half-width `acceptance.emit.EXACT_SLACK`); a shape is inside when some
  common scaling puts every measured entry in its interval (`scale_miss`), a mass-normalized
  shape when the model's mass-normalized entries, or their negatives, are;
* ``determined_miss``: such an answer with a parameter the data determine (its consistent
  range at the truth narrower than `determinacy.DETERMINED_PCT`) outside that range (plus
  `determinacy.MARGIN` of its width and `EXACT_SLACK` of its reference value), at the truth and
  at every mirror image of it under the problem's exact symmetries; ``other_solution`` marks a
  miss whose model fits every datum (the data admit another isolated solution);
* ``truth_outside_reported``: the truth (or a mirror image) outside a consistent range the run
  reports, for a problem whose model family holds the truth;
* ``report``: ``results.json`` frequencies that differ from the recomputed ones;
* ``damping_fit``: where damping ratios were measured, an answer claiming to fit whose damping
  fit is missing, or whose identified ratios are not the least squares of the measured ones by
  the reported series' exponents at the answer's reported frequencies (`DAMPING_FIT_TOL`, the
  judge's own solve), or not what the reported coefficients give there;
* ``damping_truth``: such an answer to exact in-family data (frequencies and ratios) whose
  identified ratios miss the measured ones by more than `DAMPING_TRUTH_TOL` of them;
* ``damping_unwarned``: a reported series with negative modal damping somewhere in ``(0, 1.5
  x the highest measured frequency]`` and no warning of it (one that names the Caughey fit: the
  Rayleigh baseline's own warning does not count);
* ``worse_than_nominal``: an answer further from its data than the nominal model by the
  contract's misfit (`misfit`: the sum of squared distances outside the admissible intervals, in
  their half-widths, the measure the library's own guard uses, recomputed here);
* outcomes, not defects: ``not_verified`` and the path statuses (``path_failed``).

What the judge excuses is counted as its own class (`Verdict.excused`), never dropped:

* ``not_unique``: a determined parameter outside its range at the truth, where the run reports
  other answers that fit as well, one of them at the truth, and that parameter differs between
  the answers; every parameter on which the answers agree is still checked, against the
  determined range and against the reported range;
* ``undetermined_far``: an answer claiming to fit with a parameter the data do not determine
  further than `FAR_PCT` of its reference value from the truth (and from every mirror image).

Which failure codes are defects, and how many outcomes of each kind a family may have, is said
by `acceptance.criteria`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linprog

from acceptance import determinacy as D
from acceptance import structures as S
from acceptance import truth as T
from acceptance.adapter import Outcome
from acceptance.emit import EXACT_SLACK, flexible_mode, model_form

__all__ = ["Reference", "Compromise", "Verdict", "reference", "compromise", "judge", "misses", "excess", "misfit",
           "admissible_misses", "scale_miss", "FLOOR", "FAR_PCT", "ADMISSIBLE_FLOOR",
           "EXACT_HALF_WIDTH", "MODEL_FORM_DEFAULTS", "DAMPING_FIT_TOL", "DAMPING_TRUTH_TOL"]

#: Numerical floor of the interval checks, in half-widths: an answer on a bound to 0.1 % of
#: its half-width is inside (the polish ends on the bounds of the intervals it reaches).
FLOOR = 1e-3
#: An undetermined parameter further than this from the truth (% of its reference) is counted
#: as ``undetermined_far``.
FAR_PCT = D.DETERMINED_PCT
TWO_PI = 2.0 * np.pi

# The admissible intervals of docs/polish-and-verification.md (7.3), as that page states them:
# measurement interval + model-form tolerance + numerical floor, an exact datum given a stated
# half-width. The numbers are the documented defaults, written here (not imported) so that the
# judge's measure is its own code; `tests/acceptance/test_judge.py` holds them equal to the
# library's option defaults.
#: Relative numerical floor of every admissible interval (of a shape entry: of its largest entry).
ADMISSIBLE_FLOOR = 1e-8
#: Relative half-width of a datum known exactly (a measurement interval of zero width).
EXACT_HALF_WIDTH = 1e-6
#: Model-form tolerances a case file does not state (`acceptance.emit.model_form` states the rest).
MODEL_FORM_DEFAULTS = {"natural_tolerance": 0.02, "antiresonance_tolerance": 0.02, "shape_tolerance": 0.02,
                       "modal_mass_tolerance": 0.05}
#: Agreement of the identified damping ratios with the judge's least squares at the same
#: frequencies, relative to the largest measured ratio (rounding of two solves of one problem).
DAMPING_FIT_TOL = 1e-6
#: Agreement of the identified damping ratios with exact in-family ratios, relative to each: the
#: answer's frequencies meet exact data to about 1e-6, which moves a ratio by as much.
DAMPING_TRUTH_TOL = 1e-4


@dataclass(frozen=True)
class Reference:
    """What the judge computed from the problem, independently of any answer.

    Attributes
    ----------
    ranges : list of determinacy.Ranges
        Consistent ranges at the truth and at each mirror image of it (empty when the model
        family does not hold the truth).
    truths : list of ndarray
        The truth and its mirror images, physical values in parameter order.
    width_pct : ndarray or None
    determined : tuple of str
    determinacy : {"determined", "partial", "undetermined", "out_of_family"}
    nominal_misfit : float
        `misfit` of the nominal model (what ``worse_than_nominal`` compares with).
    nominal_excess : float
        `excess` of the nominal model (shown beside the misfit, decides nothing).
    compromise : Compromise or None
        The judge's own weighted least-squares compromise, for a problem that asks for it.
    """

    ranges: list
    truths: list
    width_pct: np.ndarray | None
    determined: tuple
    determinacy: str
    nominal_misfit: float
    nominal_excess: float
    compromise: "Compromise | None" = None


@dataclass(frozen=True)
class Compromise:
    """The judge's weighted least-squares compromise (`compromise`): physical ``values``, its
    `misfit`, and the ``seconds`` it took in this process (the time a classical fit takes)."""

    values: np.ndarray
    misfit: float
    seconds: float


@dataclass
class Verdict:
    """The judged outcome of one problem on one route."""

    case_id: str
    route: str
    classes: dict
    status: str
    exit_code: int | None
    seconds: float
    failures: list = field(default_factory=list)
    excused: list = field(default_factory=list)
    details: list = field(default_factory=list)
    diagnosis: tuple = ()
    compromise: dict | None = None

    @property
    def success(self) -> bool:
        """The run ended with an answer that claims to fit every datum."""
        return self.status in ("success", "not_unique")

    def as_dict(self) -> dict:
        return {"case": self.case_id, "route": self.route, **self.classes, "status": self.status,
                "exit_code": self.exit_code, "seconds": round(self.seconds, 3), "failures": self.failures,
                "excused": self.excused, "details": self.details, "diagnosis": list(self.diagnosis[:3]),
                "compromise": self.compromise}


def _mirror(problem, swap) -> dict:
    out = dict(problem.truth)
    for a, b in swap:
        out[a], out[b] = problem.truth[b], problem.truth[a]
    return out


def _vector(problem, values: dict) -> np.ndarray:
    return np.array([values[p.name] for p in problem.parameters])


def reference(problem) -> Reference:
    """Determinacy at the truth and its mirror images (`acceptance.determinacy`), the nominal
    model's misfit and excess, and, for a problem that asks for it, the judge's own compromise."""
    nominal = np.array([p.nominal for p in problem.parameters])
    _, _, distance, admissible = misses(problem, nominal)
    nominal_misfit, nominal_excess = float(np.sum(np.square(admissible))), float(np.sum(distance))
    truths = [problem.truth] + [_mirror(problem, s) for s in problem.symmetries]
    fit = compromise(problem) if problem.compromise else None
    if not problem.in_family:
        return Reference([], [_vector(problem, t) for t in truths], None, (), "out_of_family", nominal_misfit,
                         nominal_excess, fit)
    ranges = [D.at_truth(problem, t) for t in truths]
    widths = ranges[0].width_pct
    names = [p.name for p in problem.parameters]
    determined = tuple(n for n, w in zip(names, widths) if np.isfinite(w) and w <= D.DETERMINED_PCT)
    label = "determined" if len(determined) == len(names) else "undetermined" if not determined else "partial"
    return Reference(ranges, [_vector(problem, t) for t in truths], widths, determined, label, nominal_misfit,
                     nominal_excess, fit)


def compromise(problem) -> Compromise:
    """The weighted least-squares compromise of the problem's data, computed by the judge alone:
    `scipy.optimize.least_squares` (trust region within the parameter box, finite-difference
    Jacobian) on the truth kernels, from the nominal model. Each datum's residual is its distance
    from its interval's midpoint in half-widths (`determinacy.evaluate`; each shape with its free
    scaling as one more unknown), so the weights are the data's own intervals. This is the
    classical fit a user would run; its time is measured here."""
    import time

    from scipy.optimize import least_squares

    start = time.perf_counter()
    data, n_shapes = D.data_map(problem)
    mid = np.array([0.5 * (d.lower + d.upper) for d in data])
    half = np.array([max(0.5 * (d.upper - d.lower), 1e-15) for d in data])
    n = len(problem.parameters)

    def residual(z):
        f = D.evaluate(problem, data, z[:n], z[n:])
        return np.where(np.isfinite(f), (f - mid) / half, 1e6)

    lo = [(p.lower - p.nominal) / p.reference for p in problem.parameters] + [-np.inf] * n_shapes
    hi = [(p.upper - p.nominal) / p.reference for p in problem.parameters] + [np.inf] * n_shapes
    sol = least_squares(residual, np.r_[np.zeros(n), np.ones(n_shapes)], bounds=(lo, hi), method="trf")
    values = np.array([p.nominal + p.reference * x for p, x in zip(problem.parameters, sol.x[:n])])
    seconds = time.perf_counter() - start
    return Compromise(values, misfit(problem, values), seconds)


# -- the data of a model -------------------------------------------------------------------------


def misses(problem, values: np.ndarray) -> tuple[list[str], list[tuple], list[float], list[float]]:
    """Data of the model at physical ``values`` outside their intervals (in words), every
    recomputed frequency ``(configuration, kind, index, hz)``, each datum's distance outside
    its interval in half-widths (a shape counted once, at its best scaling), and each datum's
    distance outside its admissible interval in its half-widths (`admissible_misses`)."""
    tol = problem.tolerance if problem.tolerance > 0 else EXACT_SLACK
    given = dict(zip([p.name for p in problem.parameters], values))
    out, freqs, distance, admissible = [], [], [], []
    form = {**MODEL_FORM_DEFAULTS, **model_form(problem)}
    for cfg in problem.data:
        spec = problem.structure.with_mass(*cfg.extra_mass) if cfg.extra_mass else problem.structure
        M, K, dofs = S.matrices_at(spec, given)
        w, Phi = T.modes(M, K)
        checks = []
        for n in cfg.natural:
            model = w[n.mode - 1] / TWO_PI if n.mode <= w.size else np.nan
            checks.append((f"{cfg.name} mode {n.mode}", n.hz, model, form["natural_tolerance"]))
            freqs.append((cfg.name, "natural", flexible_mode(problem, n), model))
            if n.shape:
                slack = EXACT_SLACK if problem.shape_noise == 0 else 0.0
                names = list(n.shape)
                phi = np.array([Phi[dofs.index(d), n.mode - 1] for d in names]) if n.mode <= w.size else None
                lo, hi = (np.array([n.shape[d][i] for d in names]) + sign * slack for i, sign in ((0, -1), (1, 1)))
                admissible += _admissible_shape(problem, n.shape, names, phi, form)
                if phi is None:
                    miss = np.inf
                elif problem.mass_normalized:   # the entries themselves, up to a common sign
                    miss = min(_entry_miss(phi, lo, hi), _entry_miss(-phi, lo, hi))
                else:
                    miss = scale_miss(phi, lo, hi)
                distance.append(miss)
                if miss > FLOOR:
                    out.append(f"{cfg.name} mode {n.mode}: shape at {', '.join(names)} outside its intervals at "
                               f"every scaling ({miss:.3g} half-widths)")
        zeros: dict = {}
        for z in cfg.zeros:
            if z.receptance not in zeros:
                zeros[z.receptance] = T.zeros(M, K, dofs.index(z.response), dofs.index(z.excitation))[0]
            zz = zeros[z.receptance]
            model = zz[z.index - 1] / TWO_PI if z.index <= zz.size else np.nan
            checks.append((f"{cfg.name} zero {z.index} of h_{z.response},{z.excitation}", z.hz, model,
                           form["antiresonance_tolerance"]))
            freqs.append((cfg.name, f"h_{z.response},{z.excitation}", z.index, model))
        for label, hz, model, form_tol in checks:
            d = abs(model - hz) / (tol * hz) - 1.0 if np.isfinite(model) else np.inf
            distance.append(max(d, 0.0))
            measured = problem.tolerance * hz    # the measurement interval's half-width (0: exact)
            half = (EXACT_HALF_WIDTH * hz if measured == 0 else measured) + (form_tol + ADMISSIBLE_FLOOR) * hz
            admissible.append(max(abs(model - hz) - half, 0.0) / half if np.isfinite(model) else np.inf)
            if d > FLOOR:
                out.append(f"{label}: {model:.7g} Hz vs {hz:.7g} Hz +- {100 * tol:.3g} % "
                           f"({100 * (model - hz) / hz:+.3g} %)")
    return out, freqs, distance, admissible


def excess(problem, values: np.ndarray) -> float:
    """The plain sum of the distances of the data outside their measurement intervals (the
    judge's own, `misses`), in half-widths (0: every datum inside). Shown beside `misfit`; it
    decides nothing. A datum the model does not have counts as infinitely far."""
    return float(np.sum(misses(problem, values)[2]))


def misfit(problem, values: np.ndarray) -> float:
    """The contract's misfit of the model at physical ``values``: the sum of the squared
    distances of the data outside their admissible intervals, each in its interval's half-widths
    (`admissible_misses`; 0: every datum admissible, inf: a datum the model does not have). The
    definition of docs/polish-and-verification.md (7.3, 7.6), computed here from the truth
    kernels: an answer with a larger one than the nominal model is ``worse_than_nominal``."""
    return float(np.sum(np.square(admissible_misses(problem, values))))


def admissible_misses(problem, values: np.ndarray) -> np.ndarray:
    """Each datum's distance outside its admissible interval, in its half-widths, as the
    documentation defines the interval: the measurement interval (a noisy frequency's 3 sigma; an
    exact one `EXACT_HALF_WIDTH` of its value), widened on both sides by the case's model-form
    tolerance (`acceptance.emit.model_form`, else `MODEL_FORM_DEFAULTS`) times the value and by
    `ADMISSIBLE_FLOOR` of it. A shape of two entries or more is one datum: its entries' intervals
    (an entry of zero width given `EXACT_HALF_WIDTH`) widened by the shape tolerance and the floor
    times the magnitude of the entry whose midpoint is largest, at the best common scale
    (`scale_miss`; its scale free; a mass-normalized shape's the mode's own, up to sign, times a
    calibration within ``1 / sqrt(1 -+ t)``, ``t`` the modal-mass tolerance); a mass-normalized shape adds
    its modal mass at that entry, ``1 / phi_p^2``, against ``[1 / hi_p^2, 1 / lo_p^2]`` widened
    by the modal-mass tolerance and the floor times its midpoint."""
    return np.array(misses(problem, values)[3], dtype=float)


def _admissible_shape(problem, shape: dict, names: list, phi, form: dict) -> list[float]:
    """`admissible_misses` of one measured shape (one or two data)."""
    if len(names) < 2:
        return []
    lo = np.array([shape[d][0] for d in names])
    hi = np.array([shape[d][1] for d in names])
    mid = 0.5 * (lo + hi)
    p = int(np.argmax(np.abs(mid)))
    scale = abs(mid[p])
    extra = np.where(hi - lo <= 0, EXACT_HALF_WIDTH * scale, 0.0) + (form["shape_tolerance"] + ADMISSIBLE_FLOOR) * scale
    t = form["modal_mass_tolerance"]
    calibration = (1.0 / np.sqrt(1.0 + t), 1.0 / np.sqrt(1.0 - t)) if problem.mass_normalized else None
    out = [scale_miss(phi, lo - extra, hi + extra, calibration) if phi is not None else np.inf]
    if problem.mass_normalized:
        a, b = sorted((abs(lo[p]), abs(hi[p])))
        mlo, mhi = 1.0 / b**2, 1.0 / a**2
        mmid = 0.5 * (mlo + mhi)
        widen = (EXACT_HALF_WIDTH * mmid if mhi - mlo <= 0 else 0.0) + (form["modal_mass_tolerance"]
                                                                         + ADMISSIBLE_FLOOR) * mmid
        half = 0.5 * (mhi - mlo) + widen
        if phi is None or phi[p] == 0:
            out.append(np.inf)
        else:
            mass = 1.0 / phi[p] ** 2
            out.append(max(mlo - widen - mass, mass - mhi - widen, 0.0) / half)
    return out


def _entry_miss(phi: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """The largest distance of an entry of ``phi`` outside ``[lo, hi]``, in half-widths."""
    half = np.maximum(0.5 * (hi - lo), 1e-12)
    return float(np.max(np.maximum(np.maximum(lo - phi, phi - hi), 0.0) / half))


def scale_miss(phi: np.ndarray, lo: np.ndarray, hi: np.ndarray, scales: tuple | None = None) -> float:
    """How far a model shape ``phi`` (at the measured DOFs) is from its entry intervals
    ``[lo, hi]`` at the best common scaling: ``min over c, max over j`` of the distance of
    ``c phi_j`` outside ``[lo_j, hi_j]`` in half-widths (0 when some scaling fits every entry; the
    normalization of a measured shape is free, `vibupdate.ShapeInterval`). A linear program in
    ``(c, t)``; with ``scales`` ``(a, b)``, ``c`` within ``+-[a, b]`` (a mass-normalized shape:
    the mode itself up to sign, times a calibration)."""
    half = np.maximum(0.5 * (hi - lo), 1e-12)
    # c phi_j - t half_j <= hi_j  and  -c phi_j - t half_j <= -lo_j
    A = np.vstack([np.column_stack([phi, -half]), np.column_stack([-phi, -half])])
    b = np.concatenate([hi, -lo])
    best = np.inf
    for bound in ([(None, None)] if scales is None else [scales, (-scales[1], -scales[0])]):
        sol = linprog([0.0, 1.0], A_ub=A, b_ub=b, bounds=[bound, (0.0, None)], method="highs")
        best = min(best, float(sol.x[1]) if sol.status == 0 else np.inf)
    return best


# -- the verdict -----------------------------------------------------------------------------------


def _margin(problem, lo, hi) -> np.ndarray:
    refs = np.abs([p.reference for p in problem.parameters])
    return D.MARGIN * (hi - lo) + EXACT_SLACK * refs


def _outside(values, lo, hi, margin, mask) -> np.ndarray:
    """Indices (within ``mask``) of ``values`` outside ``[lo - margin, hi + margin]``."""
    bad = ~(np.isfinite(lo) & (lo - margin <= values) & (values <= hi + margin))
    return np.flatnonzero(bad & mask)


def judge(problem, route: str, outcome: Outcome, ref: Reference) -> Verdict:
    """The verdict on one outcome (module docstring)."""
    v = Verdict(problem.case_id, route, {**problem.classes(), "determinacy": ref.determinacy},
                outcome.status, outcome.exit_code, outcome.seconds, diagnosis=outcome.diagnosis)
    names = [p.name for p in problem.parameters]
    if outcome.status == "crash" or outcome.exit_code == 3:
        v.failures.append("crash")
        v.details.append("crash: " + outcome.error)
    elif outcome.status == "refused":
        v.failures.append("refused")
        v.details.append("refused: " + outcome.error)
    elif not v.success:
        v.failures.append("not_verified" if v.status == "not_verified" else "path_failed")
    if route == "cli" and outcome.exit_code not in (2, 3) and outcome.exit_code != (0 if v.success else 1):
        v.failures.append("exit_code")
        v.details.append(f"exit_code: exit {outcome.exit_code} with status {v.status}")
    values = outcome.values
    if values is None:
        return v
    missed, freqs, distance, admissible = misses(problem, values)
    if v.success and missed:
        v.failures.append("outside")
        v.details += ["outside: " + m for m in missed[:4]]
    if not v.success and missed:
        v.details.append(f"{v.failures[-1]}: {len(missed)} data outside their intervals, e.g. {missed[0]}")
    answer_misfit = float(np.sum(np.square(admissible)))   # `misfit` of the answer
    answer_excess = float(np.sum(distance))                # `excess` of the answer
    if answer_misfit > ref.nominal_misfit * (1 + FLOOR) + FLOOR:
        v.failures.append("worse_than_nominal")
        v.details.append(f"worse_than_nominal: misfit {answer_misfit:.4g} (sum of squared distances outside the "
                         f"admissible intervals, in half-widths), the nominal model's {ref.nominal_misfit:.4g}; "
                         f"plain sum of misses {answer_excess:.4g} half-widths, the nominal model's "
                         f"{ref.nominal_excess:.4g}")
    _check_parameters(problem, v, outcome, ref, names, bool(missed))
    if ref.compromise is not None:
        refs = np.abs([p.reference for p in problem.parameters])
        gap = np.abs(values - ref.compromise.values) / refs * 100.0
        v.compromise = {"distance_pct": float(np.max(gap)), "parameter": names[int(np.argmax(gap))],
                        "misfit": answer_misfit, "compromise_misfit": ref.compromise.misfit,
                        "time_ratio": outcome.seconds / ref.compromise.seconds}
        v.details.append(f"compromise: largest distance {np.max(gap):.3g} % ({names[int(np.argmax(gap))]}) from the "
                         f"judge's least-squares compromise (misfit {ref.compromise.misfit:.4g}, the answer's "
                         f"{answer_misfit:.4g}); run time {v.compromise['time_ratio']:.3g}x the compromise's")
    if any(n.damping is not None for c in problem.data for n in c.natural):
        _check_damping(problem, v, outcome)
    lookup = {(c, k, i): hz for c, k, i, hz in freqs}
    for row in outcome.rows:
        key = (row["configuration"], row.get("receptance") or row["kind"], row.get("model_index", row["index"]))
        hz, got = lookup.get(key), row.get("updated_hz")
        if hz is not None and got is not None and np.isfinite(hz) and abs(got - hz) > 1e-6 * hz:
            v.failures.append("report")
            v.details.append(f"report: {row['kind']} {key[2]} of {key[0]} reported at {got:.7g} Hz, recomputed "
                             f"{hz:.7g} Hz")
            break
    return v


def _check_parameters(problem, v: Verdict, outcome: Outcome, ref: Reference, names, missed: bool) -> None:
    """``determined_miss``, ``truth_outside_reported`` and the excused classes (module docstring)."""
    if not ref.ranges:
        return
    values = outcome.values
    n = len(names)
    determined = np.array([name in ref.determined for name in names])
    # parameters that differ between the answer and some other answer the run reports
    differ = np.zeros(n, dtype=bool)
    for alt in outcome.alternatives:
        r = ref.ranges[0]
        differ |= np.abs(alt - values) > _margin(problem, r.lower, r.upper)
    if v.success:
        found = [_outside(values, r.lower, r.upper, _margin(problem, r.lower, r.upper), determined)
                 for r in ref.ranges]
        if all(f.size for f in found):
            best = min(found, key=lambda f: f.size)
            named = any(_outside(alt, r.lower, r.upper, _margin(problem, r.lower, r.upper), determined).size == 0
                        for alt in outcome.alternatives for r in ref.ranges)
            if named and all(differ[best]):
                v.excused.append("not_unique")
                v.details.append("not_unique: the truth is one of the answers the run reports as fitting the data "
                                 "as well; " + ", ".join(names[i] for i in best) + " differ between them")
            else:
                v.failures.append("determined_miss")
                if not missed:   # every datum fits: the data admit another, isolated solution
                    v.failures.append("other_solution")
                r = ref.ranges[0]
                v.details += [f"determined_miss: {names[i]} = {values[i]:.6g} outside its consistent range "
                              f"[{r.lower[i]:.6g}, {r.upper[i]:.6g}] at the truth" for i in found[0][:4]]
        far = np.min([np.abs(values - t) / np.abs([p.reference for p in problem.parameters]) for t in ref.truths],
                     axis=0) * 100.0 > FAR_PCT
        if np.any(far & ~determined):
            v.excused.append("undetermined_far")
            v.details.append("undetermined_far: " + ", ".join(
                f"{names[i]} = {values[i]:.6g} (truth {ref.truths[0][i]:.6g})" for i in np.flatnonzero(far & ~determined)[:4]))
    if outcome.ranges:
        lo = np.array([outcome.ranges[name][0] if outcome.ranges[name][0] is not None else np.nan for name in names],
                      dtype=float)
        hi = np.array([outcome.ranges[name][1] if outcome.ranges[name][1] is not None else np.nan for name in names],
                      dtype=float)
        found = [_outside(t, lo, hi, _margin(problem, lo, hi), ~differ) for t in ref.truths]
        if all(f.size for f in found):
            v.failures.append("truth_outside_reported")
            v.details += [f"truth_outside_reported: true {names[i]} = {ref.truths[0][i]:.6g} outside the reported "
                          f"range [{lo[i]:.6g}, {hi[i]:.6g}]" for i in found[0][:4]]


def _check_damping(problem, v: Verdict, outcome: Outcome) -> None:
    """``damping_fit``, ``damping_truth`` and ``damping_unwarned`` (module docstring)."""
    measured = {(c.name, flexible_mode(problem, n)): (n.damping, TWO_PI * n.hz)
                for c in problem.data for n in c.natural if n.damping is not None}
    if outcome.damping_model is not None:
        Y, beta = (np.asarray(outcome.damping_model[k], dtype=float) for k in ("exponents", "beta"))
        top = 1.5 * max(w for _, w in measured.values())
        grid = np.unique(np.concatenate([np.linspace(top / 4000, top, 4000), np.geomspace(1e-6 * top, top, 4000)]))
        terms = beta * grid[:, None] ** (2.0 * Y)
        negative = np.sum(terms, axis=1) < -1e-9 * np.sum(np.abs(terms), axis=1)
        if negative.any() and not any("Caughey" in w and "negative modal damping" in w for w in outcome.warnings):
            v.failures.append("damping_unwarned")
            w = grid[negative] / TWO_PI
            v.details.append(f"damping_unwarned: the reported series is negative at {w.min():.4g}-{w.max():.4g} Hz "
                             f"(checked to {top / TWO_PI:.4g} Hz) and no warning says so")
    if not v.success:
        return
    if outcome.damping_model is None or len(outcome.damping) != len(measured):
        v.failures.append("damping_fit")
        v.details.append(f"damping_fit: {len(measured)} measured damping ratios, {len(outcome.damping)} identified")
        return
    updated = {(r["configuration"], r["model_index"]): TWO_PI * r["updated_hz"] for r in outcome.rows
               if r["kind"] == "natural" and r.get("updated_hz") is not None}
    keys = [(r["configuration"], int(r["mode"])) for r in outcome.damping]
    if set(keys) != set(measured) or any(k not in updated for k in keys):
        v.failures.append("damping_fit")
        v.details.append(f"damping_fit: ratios identified for {sorted(keys)}, measured for {sorted(measured)}")
        return
    omega = np.array([updated[k] for k in keys])
    zeta = np.array([measured[k][0] for k in keys])
    identified = np.array([r["identified"] for r in outcome.damping], dtype=float)
    A = np.column_stack([T.caughey_ratios(Y, np.eye(Y.size)[j], omega) for j in range(Y.size)])   # ratios per beta_j
    scale = np.linalg.norm(A, axis=0)
    own = A @ (np.linalg.lstsq(A / scale, zeta, rcond=None)[0] / scale)
    tol = DAMPING_FIT_TOL * np.max(np.abs(zeta))
    for what, ratios in (("the least squares of the measured ratios", own),
                         ("the reported coefficients", T.caughey_ratios(Y, beta, omega))):
        gap = np.abs(identified - ratios)
        if gap.max() > tol:
            k = int(np.argmax(gap))
            v.failures.append("damping_fit")
            v.details.append(f"damping_fit: {keys[k][0]} mode {keys[k][1]}: identified ratio {identified[k]:.6g}, "
                             f"{what} give {ratios[k]:.6g} at the answer's {omega[k] / TWO_PI:.6g} Hz")
            return
    if problem.in_family and problem.exact and problem.damping_noise == 0:
        miss = np.abs(identified - zeta) / zeta
        if miss.max() > DAMPING_TRUTH_TOL:
            k = int(np.argmax(miss))
            v.failures.append("damping_truth")
            v.details.append(f"damping_truth: {keys[k][0]} mode {keys[k][1]}: identified {identified[k]:.6g}, "
                             f"exact {zeta[k]:.6g} ({100 * miss[k]:.3g} %)")
