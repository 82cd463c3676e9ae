"""Run a known-truth problem through vibupdate, as a user would, and judge the outcome.

Routes: ``"cli"`` writes the case folder and runs ``vibupdate run`` in-process
(`vibupdate.cli.main`, ``SystemExit`` caught), reading ``results.json``; ``"api"`` calls
`vibupdate.update` on the problem's `Configuration` s (with the case file's verification
options: the frequency tolerance of noisy data). Both answers are read through
`acceptance.adapter` and judged by `acceptance.judge` against what the judge computed itself
(`acceptance.judge.reference`, once per problem).
"""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
import time
import warnings
from pathlib import Path

from acceptance.adapter import Outcome, failed_outcome, from_results_json, from_update_result
from acceptance.judge import Reference, Verdict, judge, misses, reference

__all__ = ["Reference", "Verdict", "reference", "run_cli", "run_api", "api_damping", "judge", "misses", "run_problem",
           "DEFECTS"]

#: The failure codes that are defects in every family (not_verified, path_failed and
#: worse_than_nominal are outcomes, each family's budget in `acceptance.criteria`).
DEFECTS = ("crash", "refused", "exit_code", "outside", "determined_miss", "truth_outside_reported", "report",
           "damping_fit", "damping_truth", "damping_unwarned")


# -- the two routes ------------------------------------------------------------------------------


def run_cli(problem, folder: Path) -> Outcome:
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
    last = buf_err.getvalue().strip().splitlines()[-1:]
    return from_results_json(doc, code, seconds, crash or (last[0] if last else ""))


def run_api(problem) -> Outcome:
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
        return failed_outcome("refused", time.perf_counter() - start, str(exc))
    except Exception as exc:   # an internal error is the finding, recorded
        return failed_outcome("crash", time.perf_counter() - start, f"{type(exc).__name__}: {exc}")
    seconds = time.perf_counter() - start
    try:
        ranges = api_ranges(problem, result)
    except Exception as exc:   # the library's ranges failing on a verified answer is a finding too
        return failed_outcome("crash", seconds, f"parameter_ranges: {type(exc).__name__}: {exc}")
    try:
        damping = api_damping(problem, result)
    except Exception as exc:   # so is the damping fit failing on valid ratios
        return failed_outcome("crash", seconds, f"identify_damping: {type(exc).__name__}: {exc}")
    return from_update_result(result, seconds, ranges, damping)


def api_damping(problem, result):
    """The damping a Python user identifies on the answer, as ``vibupdate run`` does with the
    case's ``[damping]`` exponents (docs/python-api.md): `identify_damping` at ``result.xbar``
    with the answer's modal data; None when the problem has no damping."""
    if problem.damping is None:
        return None
    from vibupdate import identify_damping

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return identify_damping(problem.configurations(), result.xbar, problem.damping[0],
                                freqs=list(result.correlation.updated))


def api_ranges(problem, result):
    """The consistent ranges a Python user computes at a verified answer, as ``vibupdate run``
    does (docs/python-api.md, "Which parameters do the data determine?"): `parameter_ranges` at
    ``result.xbar`` with the case's frequency tolerance; None when the answer is not verified
    (the CLI computes none then either)."""
    if not result.success:
        return None
    from vibupdate.ranges.identifiability import parameter_ranges

    configurations = problem.configurations()
    found = parameter_ranges(configurations, result.xbar, frequency_tolerance=problem.tolerance,
                             freqs=list(result.correlation.updated), valley=result.valley)
    return found.as_dict()


def run_problem(problem, routes=("cli", "api"), workdir: Path | None = None) -> list[Verdict]:
    """Run ``problem`` on each route and judge it (FRF data on the case-file route alone:
    `acceptance.problem.Problem.frf`); the reference is computed once."""
    ref = reference(problem)
    out = []
    with tempfile.TemporaryDirectory(prefix="vibupdate-accept-", dir=workdir) as tmp:
        for route in routes if problem.frf is None else [r for r in routes if r == "cli"]:
            outcome = run_cli(problem, Path(tmp) / route) if route == "cli" else run_api(problem)
            out.append(judge(problem, route, outcome, ref))
    return out
