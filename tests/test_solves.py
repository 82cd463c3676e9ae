"""No repeated eigen-solves of the same matrices within a run (Kernels): one whole
``run_case`` on the cantilever (four configurations, one receptance each, damping ratios)
solves each configuration's updated pencil and its adjunct once per stage that needs them at
a point of its own, and never again in the damping stage, the results object or the writers."""

from collections import Counter

import pytest

from solve_log import counting_solves, matrices_key as _key

#: Which stage a solve belongs to: the first source file of these in its call stack.
STAGES = (("polish", "inverse/polish.py"), ("ranges", "ranges/identifiability.py"),
          ("correlation", "inverse/update.py"))


@pytest.fixture(scope="module")
def solves(tmp_path_factory):
    from vibupdate.pipeline import run_example

    # "later": damping, results, report, pipeline
    with counting_solves(STAGES, default="later") as log:
        run = run_example("cantilever", tmp_path_factory.mktemp("solves") / "out")
    return run, [(s.kind, s.key, s.stage) for s in log]


def test_the_updated_matrices_are_solved_once_per_stage_that_needs_them(solves):
    run, log = solves
    assert run.success and set(run.matrices) == {"A", "B", "C", "D"}
    updated = {_key(m.M, m.K): name for name, m in run.matrices.items()}
    at_answer = Counter((kind, updated[key], stage) for kind, key, stage in log if key in updated)
    for name in run.matrices:
        # the modes at the answer: once in the whole run, by the polish's evaluation there; the
        # correlation (rows, verification, sensitivity, and from UpdateResult.correlation the
        # damping, the MAC and the Caughey C) and the ranges read them (twice before)
        assert sum(n for (kind, of, _), n in at_answer.items() if kind == "modes" and of == name) == 1
        for kind in ("modes", "zeros"):   # one receptance per configuration: one adjunct pencil
            # the first stage's correlation: one solve of the adjunct pencil, none of the modes
            assert at_answer[(kind, name, "correlation")] == (kind == "zeros")
            # the polish's last evaluation, at the point it returns, and the parameter ranges'
            # Jacobian at the answer: at most one each
            assert at_answer[(kind, name, "polish")] <= 1
            assert at_answer[(kind, name, "ranges")] <= 1
            # the damping stage, the results object and the writers: never
            assert at_answer[(kind, name, "later")] == 0
