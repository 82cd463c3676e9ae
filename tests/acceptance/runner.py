"""Run a known-truth problem through vibupdate and judge the outcome as a user would.

Routes: ``"cli"`` writes the case folder and runs ``vibupdate run`` in-process
(`vibupdate.cli.main`, ``SystemExit`` caught), reading ``results.json``; ``"api"`` calls
`vibupdate.update` on the problem's `Configuration` s (with the case file's verification
options: the frequency tolerance of noisy data).

The judge (`judge`), on what the user sees:

* ``crash``: an internal error (exit 3, an exception that is not a ValueError);
* ``refused``: exit 2 or a ValueError on a valid problem;
* ``exit_code``: an exit code that does not match the status (0 success, 1 otherwise);
* ``outside``: a ``success`` whose model has a datum outside its interval, recomputed from
  the returned parameters by the independent dense analysis of `acceptance.truth` (exact data:
  intervals of relative half-width `acceptance.emit.EXACT_SLACK`); a shape is inside when some
  common scaling puts every measured entry in its interval (`_scale_miss`);
* ``determined_miss``: a ``success`` with a parameter that the data determine (its consistent
  range at the truth, `vibupdate.ranges.identifiability.parameter_ranges` on the judge's
  configurations, narrower than `DETERMINED_PCT`) outside that range (plus `MARGIN` of its
  width for the linearization, and `EXACT_SLACK` of its reference value); the mirror image of
  the truth under an exact symmetry counts as the truth; ``other_solution`` marks such a miss
  whose model fits every datum (the data admit another isolated solution: determined locally,
  not globally); none of this counts when the truth is one of the other answers the run
  reports as fitting the data as well (``alternatives`` of the result, "Not unique" in the
  report): the user is told what the data cannot tell apart;
* ``truth_outside_reported``: the truth outside a consistent range that ``results.json``
  reports (same margin);
* ``report``: ``results.json`` frequencies that differ from the recomputed ones;
* not a defect but counted: ``not_verified`` and the path statuses (``path_failed``).
"""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from acceptance import structures as S
from acceptance import truth as T
from acceptance.emit import EXACT_SLACK, flexible_mode

__all__ = ["Reference", "Verdict", "reference", "run_cli", "run_api", "judge", "run_problem", "DEFECTS"]

#: A parameter is determined when its consistent range at the truth is narrower than this (% of its reference).
DETERMINED_PCT = 5.0
#: Allowance beyond a linearized range, as a fraction of its width (second-order terms).
MARGIN = 0.1
#: Numerical floor of the interval checks, in half-widths: an answer on a bound to 0.1 % of
#: its half-width is inside (the polish ends on the bounds of the intervals it reaches).
FLOOR = 1e-3
#: The failure codes that are defects (not_verified and path_failed are outcomes, counted apart).
DEFECTS = ("crash", "refused", "exit_code", "outside", "determined_miss", "truth_outside_reported", "report")
TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class Reference:
    """What the data determine, computed at the truth, independently of any answer.

    Attributes
    ----------
    ranges : list of (lower, upper) arrays, physical units
        Consistent ranges at the truth and at each mirror image of it.
    width_pct : ndarray, shape (n_x,)
    determined : tuple of str
    determinacy : {"determined", "partial", "undetermined"}
    """

    ranges: list
    width_pct: np.ndarray
    determined: tuple
    determinacy: str


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
    details: list = field(default_factory=list)

    @property
    def success(self) -> bool:
        return self.status in ("success", "acceptable")

    @property
    def defects(self) -> list:
        return [f for f in self.failures if f in DEFECTS]

    def as_dict(self) -> dict:
        return {"case": self.case_id, "route": self.route, **self.classes, "status": self.status,
                "exit_code": self.exit_code, "seconds": round(self.seconds, 3), "failures": self.failures,
                "details": self.details}


def _mirror(problem, swap) -> dict:
    out = dict(problem.truth)
    for a, b in swap:
        out[a], out[b] = problem.truth[b], problem.truth[a]
    return out


def reference(problem) -> Reference:
    """Consistent ranges at the truth (and its mirror images) on the judge's configurations."""
    from vibupdate.ranges.identifiability import parameter_ranges

    configs = problem.configurations(judge=True)
    model = configs[0].model
    ranges, widths = [], None
    for values in [problem.truth] + [_mirror(problem, s) for s in problem.symmetries]:
        xbar = model.normalized([values[p.name] for p in model.parameters])
        r = parameter_ranges(configs, xbar, frequency_tolerance=problem.tolerance)
        ranges.append((r.lower, r.upper))
        widths = r.width_pct if widths is None else widths
    determined = tuple(n for n, w in zip(model.parameter_names, widths) if np.isfinite(w) and w <= DETERMINED_PCT)
    n = len(widths)
    label = "determined" if len(determined) == n else "undetermined" if not determined else "partial"
    return Reference(ranges, widths, determined, label)


# -- the two routes ------------------------------------------------------------------------------


def run_cli(problem, folder: Path) -> dict:
    """``vibupdate run`` in-process on the problem's case folder."""
    from vibupdate.cli import main

    case = problem.write_case(folder / "case")
    out = folder / "out"
    buf_out, buf_err = io.StringIO(), io.StringIO()
    start = time.perf_counter()
    crash = None
    with contextlib.redirect_stdout(buf_out), contextlib.redirect_stderr(buf_err), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            code = main(["run", str(case), "--out", str(out)])
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 3
        except Exception as exc:   # an escape from main is itself the finding, recorded
            code, crash = 3, f"{type(exc).__name__}: {exc}"
    seconds = time.perf_counter() - start
    doc = json.loads((out / "results.json").read_text()) if (out / "results.json").is_file() else None
    status = doc["solver"]["status"] if doc else ("refused" if code == 2 else "crash")
    values = np.array([p["updated"] for p in doc["parameters"]]) if doc else None
    ranges = (doc["identifiability"] or {}).get("ranges") if doc else None
    others = ((doc["identifiability"] or {}).get("alternatives") or []) if doc else []
    names = [p["name"] for p in doc["parameters"]] if doc else []
    alternatives = [np.array([a["values"][n] for n in names]) for a in others]
    last = buf_err.getvalue().strip().splitlines()[-1:]
    return {"exit_code": code, "status": status, "values": values, "ranges": ranges, "seconds": seconds,
            "rows": doc["frequencies"] if doc else None, "error": crash or (last[0] if last else ""),
            "alternatives": alternatives}


def run_api(problem) -> dict:
    """`vibupdate.update` on the problem's configurations."""
    from dataclasses import replace as _replace

    from vibupdate import VerifyOptions, update

    from acceptance.emit import model_form

    verification = VerifyOptions(**model_form(problem))
    if problem.tolerance > 0:
        verification = _replace(verification, frequency_tolerance=problem.tolerance,
                                measurement_tolerance=problem.tolerance)
    start = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = update(problem.configurations(), verification=verification)
    except ValueError as exc:
        return {"exit_code": None, "status": "refused", "values": None, "seconds": time.perf_counter() - start,
                "error": str(exc)[:300]}
    except Exception as exc:   # an internal error is the finding, recorded
        return {"exit_code": None, "status": "crash", "values": None, "seconds": time.perf_counter() - start,
                "error": f"{type(exc).__name__}: {exc}"[:300]}
    return {"exit_code": None, "status": result.status.value, "values": np.asarray(result.values),
            "seconds": time.perf_counter() - start, "rows": list(result.frequencies), "error": "",
            "alternatives": [np.array(list(a["values"].values())) for a in result.alternatives]}


# -- judging -------------------------------------------------------------------------------------


def _misses(problem, values: np.ndarray) -> tuple[list[str], list[tuple]]:
    """Data of the model at physical ``values`` outside their intervals, and every recomputed
    frequency ``(configuration, kind, index, hz)``."""
    tol = problem.tolerance if problem.tolerance > 0 else EXACT_SLACK
    given = dict(zip([p.name for p in problem.parameters], values))
    out, freqs = [], []
    for cfg in problem.data:
        spec = problem.structure.with_mass(*cfg.extra_mass) if cfg.extra_mass else problem.structure
        M, K, dofs = S.matrices_at(spec, given)
        w, Phi = T.modes(M, K)
        checks = []
        for n in cfg.natural:
            model = w[n.mode - 1] / TWO_PI if n.mode <= w.size else np.nan
            checks.append((f"{cfg.name} mode {n.mode}", n.hz, model))
            freqs.append((cfg.name, "natural", flexible_mode(problem, n), model))
            if n.shape:
                slack = EXACT_SLACK if problem.shape_noise == 0 else 0.0
                names = list(n.shape)
                phi = np.array([Phi[dofs.index(d), n.mode - 1] for d in names])
                lo, hi = (np.array([n.shape[d][i] for d in names]) + sign * slack for i, sign in ((0, -1), (1, 1)))
                miss = _scale_miss(phi, lo, hi)
                if miss > FLOOR:
                    out.append(f"{cfg.name} mode {n.mode}: shape at {', '.join(names)} outside its intervals at "
                               f"every scaling ({miss:.3g} half-widths)")
        zeros: dict = {}
        for z in cfg.zeros:
            if z.receptance not in zeros:
                zeros[z.receptance] = T.zeros(M, K, dofs.index(z.response), dofs.index(z.excitation))[0]
            zz = zeros[z.receptance]
            model = zz[z.index - 1] / TWO_PI if z.index <= zz.size else np.nan
            checks.append((f"{cfg.name} zero {z.index} of h_{z.response},{z.excitation}", z.hz, model))
            freqs.append((cfg.name, f"h_{z.response},{z.excitation}", z.index, model))
        for label, hz, model in checks:
            if not (np.isfinite(model) and abs(model - hz) <= tol * hz * (1 + FLOOR)):
                out.append(f"{label}: {model:.7g} Hz vs {hz:.7g} Hz +- {100 * tol:.3g} % "
                           f"({100 * (model - hz) / hz:+.3g} %)")
    return out, freqs


def _scale_miss(phi: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """How far a model shape ``phi`` (at the measured DOFs) is from its entry intervals
    ``[lo, hi]`` at the best common scaling: ``min over c, max over j`` of the distance of
    ``c phi_j`` outside ``[lo_j, hi_j]`` in half-widths (0 when some scaling fits every entry; the
    normalization of a measured shape is free, `vibupdate.ShapeInterval`). A linear program in
    ``(c, t)``."""
    from scipy.optimize import linprog

    half = np.maximum(0.5 * (hi - lo), 1e-12)
    # c phi_j - t half_j <= hi_j  and  -c phi_j - t half_j <= -lo_j
    A = np.vstack([np.column_stack([phi, -half]), np.column_stack([-phi, -half])])
    b = np.concatenate([hi, -lo])
    sol = linprog([0.0, 1.0], A_ub=A, b_ub=b, bounds=[(None, None), (0.0, None)], method="highs")
    return float(sol.x[1]) if sol.status == 0 else np.inf


def _outside_ranges(names, values, ranges, references, only=None) -> list[str]:
    lo, hi = ranges
    bad = []
    for i, name in enumerate(names):
        if only is not None and name not in only:
            continue
        m = MARGIN * (hi[i] - lo[i]) + EXACT_SLACK * abs(references[i])
        if not (np.isfinite(lo[i]) and lo[i] - m <= values[i] <= hi[i] + m):
            bad.append((name, values[i], lo[i], hi[i]))
    return bad


def judge(problem, route: str, outcome: dict, ref: Reference) -> Verdict:
    """The verdict on one outcome (module docstring)."""
    v = Verdict(problem.case_id, route, {**problem.classes(), "determinacy": ref.determinacy},
                outcome["status"], outcome["exit_code"], outcome["seconds"])
    names = [p.name for p in problem.parameters]
    refs = [p.reference for p in problem.parameters]
    if outcome["status"] == "crash" or outcome["exit_code"] == 3:
        v.failures.append("crash")
        v.details.append("crash: " + outcome.get("error", ""))
    elif outcome["status"] == "refused":
        v.failures.append("refused")
        v.details.append("refused: " + outcome.get("error", ""))
    elif not v.success:
        v.failures.append("not_verified" if v.status == "not_verified" else "path_failed")
    if route == "cli" and outcome["exit_code"] not in (2, 3) and outcome["exit_code"] != (0 if v.success else 1):
        v.failures.append("exit_code")
        v.details.append(f"exit_code: exit {outcome['exit_code']} with status {v.status}")
    values = outcome.get("values")
    if values is None:
        return v
    misses, freqs = _misses(problem, values)
    if v.success and misses:
        v.failures.append("outside")
        v.details += ["outside: " + m for m in misses[:4]]
    if not v.success and misses:
        v.details.append(f"{v.failures[-1]}: {len(misses)} data outside their intervals, e.g. {misses[0]}")
    # the truth among the other answers the run reports as fitting as well (`alternatives`):
    # the user is told the data admit it, which is all the data can say
    named = [a for a in outcome.get("alternatives") or []
             if not all(_outside_ranges(names, a, r, refs, ref.determined) for r in ref.ranges)]
    if named:
        v.details.append("other_solution_reported: the truth is one of the answers the run reports as fitting "
                         "the data as well")
    if v.success and not named:
        found = [_outside_ranges(names, values, r, refs, ref.determined) for r in ref.ranges]
        if all(found):
            v.failures.append("determined_miss")
            if not misses:   # every datum fits: the data admit another, isolated solution
                v.failures.append("other_solution")
            v.details += [f"determined_miss: {n} = {x:.6g} outside its consistent range [{lo:.6g}, {hi:.6g}] "
                          "at the truth"
                          for n, x, lo, hi in found[0][:4]]
    reported = outcome.get("ranges")
    if reported and not named:
        truths = [problem.truth] + [_mirror(problem, s) for s in problem.symmetries]
        rr = (np.array([reported[n]["lower"] for n in names]), np.array([reported[n]["upper"] for n in names]))
        found = [_outside_ranges(names, np.array([t[n] for n in names]), rr, refs) for t in truths]
        if all(found):
            v.failures.append("truth_outside_reported")
            v.details += [f"truth_outside_reported: true {n} = {x:.6g} outside the reported range [{lo:.6g}, {hi:.6g}]"
                          for n, x, lo, hi in found[0][:4]]
    rows = outcome.get("rows") or []
    lookup = {(c, k, i): hz for c, k, i, hz in freqs}
    for row in rows:
        key = (row["configuration"], row.get("receptance") or row["kind"], row.get("model_index", row["index"]))
        hz, got = lookup.get(key), row.get("updated_hz")
        if hz is not None and got is not None and np.isfinite(hz) and abs(got - hz) > 1e-6 * hz:
            v.failures.append("report")
            v.details.append(f"report: {row['kind']} {key[2]} of {key[0]} reported at {got:.7g} Hz, recomputed "
                             f"{hz:.7g} Hz")
            break
    return v


def run_problem(problem, routes=("cli", "api"), workdir: Path | None = None) -> list[Verdict]:
    """Run ``problem`` on each route and judge it; the reference is computed once."""
    ref = reference(problem)
    out = []
    with tempfile.TemporaryDirectory(prefix="vibupdate-accept-", dir=workdir) as tmp:
        for route in routes:
            outcome = run_cli(problem, Path(tmp) / route) if route == "cli" else run_api(problem)
            out.append(judge(problem, route, outcome, ref))
    return out
