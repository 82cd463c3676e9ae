"""Acceptance on known-truth problems (the CI profile of `acceptance.runner`).

The profile ``ci`` of `acceptance.criteria.PROFILES`: the named problems of
`acceptance.generator` (each a known failure class), 28 seeded random problems, one per class
(structure, kind, exact or noisy) that seeds 0-30 draw (`acceptance.criteria.CI_RANDOM`; small
models, at most ~60 DOFs), the `REGRESSION_SEEDS`, and one problem of each further family of
`acceptance.families` (model-form and measurement errors, close modes, cross receptances,
mass-normalized shapes, a 52-DOF instance of the size family), each run through
``vibupdate run`` (in-process) and ``vibupdate.update``. What must hold, on both routes:

* no crash or internal error, and no valid problem refused;
* exit codes that match the status;
* no ``success`` with a datum outside its interval (recomputed independently), and
  ``results.json`` frequencies that are the returned model's;
* every parameter the data determine (consistent range at the truth narrower than 5 %, from the
  judge's own finite-difference Jacobian and linear programs, `acceptance.determinacy`) within
  that range at a ``success``; the truth inside every range ``results.json`` reports;
* per family, the budgets of `acceptance.criteria`: at least 97 % of the runs verified and at
  most 3 % ``not_verified``, each on its own; what the judge excuses (``not_unique``,
  ``undetermined_far``) printed per family.

The generator's own invariants are tested first: the truth satisfies its data, and the case
file and the Python objects are the same model and data.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from acceptance import criteria as C
from acceptance import generator as G
from acceptance import runner as R
from acceptance.adapter import Outcome
from vibupdate.io.case import load_case

#: The random family's regression seeds (`acceptance.criteria.REGRESSION_SEEDS`), from
#: `benchmarks/acceptance.py` (500 problems, 2026-11-25), each showing a failure class the first 31
#: seeds do not: 51 the truth outside the reported ranges (a nearly symmetric frame), 167 exact
#: frequencies missed by 0.16 % at a success, 236 a free-free zero missed by 1.3 % at a success
#: (case file), 266 massless DOFs with the highest mode measured refused, 358 a frequency outside
#: its case-file interval at a success (the 2 % fit check). From the runs of 2026-11-26 on the
#: merged fixes: 142 exact point shapes missed by 1.4x the rounding allowance, 204 a point on a
#: bound missing exact data by 3e-5 where 5 of 12 random starts find the exact fit, 368 a
#: symmetric answer whose coupling spring was reported as a point range without the truth. Held
#: out (seeds 500-999): 574, a success with a shape 0.0048 half-widths outside its intervals at
#: every scaling.
REGRESSION_SEEDS = C.REGRESSION_SEEDS


def _problems():
    """The CI profile (`acceptance.criteria.PROFILES`): the named problems, the random seeds
    of `acceptance.criteria.CI_RANDOM` and the regression seeds, and one problem of each further
    family."""
    return [C.FAMILIES[family].make(seed) for family, seed in C.profile_jobs("ci")]


@pytest.fixture(scope="module")
def verdicts(tmp_path_factory):
    folder = tmp_path_factory.mktemp("acceptance")
    start = time.perf_counter()
    out = [v for p in _problems() for v in R.run_problem(p, workdir=folder)]
    print(f"\nacceptance profile: {len(out)} runs in {time.perf_counter() - start:.1f} s")
    print(C.summary(out))
    return out


def _listing(bad) -> str:
    return "\n".join(f"{v.case_id} [{v.route}] {v.classes} {v.status}: {v.failures} {v.details[:2]}" for v in bad)


# -- the generator's invariants (fast) -------------------------------------------------------------


@pytest.mark.parametrize("seed", range(0, 60, 3))
def test_the_truth_satisfies_its_data(seed):
    problem = G.random_problem(seed)
    values = np.array([problem.truth[p.name] for p in problem.parameters])
    misses = R.misses(problem, values)[0]
    assert not misses, misses
    lo, hi = zip(*[(p.lower, p.upper) for p in problem.parameters])
    assert np.all(values >= lo) and np.all(values <= hi)
    assert not np.allclose(problem.xbar_true, 0.0)


def test_the_ci_seeds_draw_every_class_of_the_first_31():
    """The CI profile's random seeds leave out seeds of 0-30 only where another CI seed draws the
    same structure, problem kind and data (exact or noisy)."""
    def classes(seeds):
        return {(c["structure"], c["kind"], c["data"]) for c in (G.random_problem(s).classes() for s in seeds)}

    ci = [s for f, s in C.profile_jobs("ci") if f == "random"]
    assert classes(range(31)) <= classes(ci)
    assert len(ci) < 31 + len(REGRESSION_SEEDS)


@pytest.mark.parametrize("seed", [1, 4, 13, 14, 19, 25])
def test_case_file_and_python_objects_are_the_same_problem(tmp_path, seed):
    problem = G.random_problem(seed)
    case = load_case(problem.write_case(tmp_path))
    python = problem.configurations()
    assert [c.name for c in case.configurations] == [c.name for c in python]
    x = problem.xbar_true
    for a, b in zip(case.configurations, python):
        assert a.model.dofs == b.model.dofs
        for A, B in zip(a.model.matrices(x), b.model.matrices(x)):
            assert abs(A - B).max() <= 1e-9 * abs(B).max()
        assert [n.omega for n in a.natural] == pytest.approx([n.omega for n in b.natural], rel=1e-14)
        assert [n.mode for n in a.natural] == [n.mode for n in b.natural]
        assert [z.index for z in a.antiresonances] == [z.index for z in b.antiresonances]
        assert [n.shape for n in a.natural] == [n.shape for n in b.natural]


def test_a_wrong_answer_is_caught():
    """The judge can fail: the nominal model as a 'success' misses its data."""
    problem = G.noisy_shapes_beam()
    outcome = Outcome("success", None, 0.0, np.array([p.nominal for p in problem.parameters]))
    verdict = R.judge(problem, "api", outcome, R.reference(problem))
    assert "outside" in verdict.failures


# -- the profile -----------------------------------------------------------------------------------


def test_no_crash_or_internal_error(verdicts):
    bad = [v for v in verdicts if "crash" in v.failures]
    assert not bad, _listing(bad)


def test_valid_problems_are_not_refused(verdicts):
    bad = [v for v in verdicts if "refused" in v.failures or "exit_code" in v.failures]
    assert not bad, _listing(bad)


def test_no_success_with_data_outside_their_intervals(verdicts):
    bad = [v for v in verdicts if "outside" in v.failures]
    assert not bad, _listing(bad)


def test_results_report_the_models_frequencies(verdicts):
    bad = [v for v in verdicts if "report" in v.failures]
    assert not bad, _listing(bad)


def test_determined_parameters_lie_in_their_consistent_ranges(verdicts):
    bad = [v for v in verdicts if "determined_miss" in v.failures or "truth_outside_reported" in v.failures]
    assert not bad, _listing(bad)


def test_budgets_of_each_family(verdicts):
    """Verified share and ``not_verified`` share per family, each on its own budget."""
    findings = [f for f in C.check(verdicts, C.FAMILIES) if not f.criterion.startswith("defect")]
    print("\n" + "\n".join(f.line() for f in findings))
    bad = [f for f in findings if not f.ok]
    assert not bad, "\n".join(f.line() for f in bad) + "\n" + _listing([v for v in verdicts if not v.success])


def test_a_least_squares_answer_outside_its_intervals_is_polished_inside_them():
    """r358: noisy frequencies with 3-sigma intervals; the least-squares optimum (every start
    reaches it) leaves one frequency 1.78 % off against its 1.66 % interval, the truth is inside
    all of them. The polish fits the admissible intervals themselves (distance outside first,
    pull toward the midpoints after), so its answer lies inside every interval and verifies
    with no refit (the model family holds the truth: no model-form tolerance,
    `acceptance.emit.model_form`)."""
    from acceptance.emit import model_form
    from vibupdate import VerifyOptions, update

    problem = G.random_problem(358)
    result = update(problem.configurations(),
                    verification=VerifyOptions(frequency_tolerance=problem.tolerance, **model_form(problem)))
    assert result.success, result.message
    assert not any(r.purpose == "fit" for r in result.restarts)   # the homotopy's start verified
    values = np.asarray(result.values)
    misses = R.misses(problem, values)[0]
    assert not misses, misses


def test_the_ranges_of_a_verified_answer_far_along_a_valley_hold_the_truth():
    """r184: a symmetric chain, noisy frequencies and shapes, no parameter determined; the answer
    (kL 1226.9, kc 814.3) lies far along the valley from the truth (865.5, 1047.8). The Python
    route's ranges are the CLI's (`acceptance.runner.api_ranges`). The linear range's ends,
    bounded by the tangent at the answer, excluded the truth (kc [800.2, 987.9]); followed along
    the valley by relinearized programs they hold it."""
    problem = G.random_problem(184)
    outcome = R.run_api(problem)
    assert outcome.status == "success" and outcome.ranges is not None
    verdict = R.judge(problem, "api", outcome, R.reference(problem))
    assert "truth_outside_reported" not in verdict.failures, verdict.details
