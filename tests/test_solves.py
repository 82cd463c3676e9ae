"""No repeated eigen-solves of the same matrices within a run (issue 10, Kernels): one whole
``run_case`` on the cantilever (four configurations, one receptance each, damping ratios)
solves each configuration's updated pencil and its adjunct once per stage that needs them at
a point of its own, and never again in the damping stage, the results object or the writers."""

import hashlib
from collections import Counter

import numpy as np
import pytest
import scipy.sparse as sp

from vibupdate.modal import eigen, receptance, sensitivities, zeros


def _key(M, K) -> str:
    h = hashlib.sha1()
    for A in (M, K):
        A = A.toarray() if sp.issparse(A) else np.asarray(A)
        h.update(np.ascontiguousarray(A, dtype=float).tobytes())
    return h.hexdigest()


#: Which stage a solve belongs to: the first source file of these in its call stack.
STAGES = (("polish", "inverse/polish.py"), ("ranges", "ranges/identifiability.py"),
          ("correlation", "inverse/update.py"))


def _stage(stack) -> str:
    files = [frame.filename.replace("\\", "/") for frame in stack]
    for stage, suffix in STAGES:
        if any(f.endswith(suffix) for f in files):
            return stage
    return "later"   # damping, results, report, pipeline


@pytest.fixture(scope="module")
def solves(tmp_path_factory):
    import traceback

    from vibupdate.pipeline import run_example

    log = []
    patch = pytest.MonkeyPatch()
    # the entry points of the eigen-solves of a pencil (modes, undamped receptances) and of an
    # adjunct pencil (the symmetric adjunct of a driving point goes through _dense_modes inside
    # adjunct_eigenpairs and _dense_zeros: counted once, there)
    for module, name, kind in ((eigen, "_dense_modes", "modes"), (eigen, "_sparse_modes", "modes"),
                               (receptance, "_dense_modes", "modes"),
                               (zeros, "_dense_zeros", "zeros"), (zeros, "_sparse_zeros", "zeros"),
                               (sensitivities, "adjunct_eigenpairs", "zeros")):
        original = getattr(module, name)

        def counted(M, K, *args, _original=original, _kind=kind, **kwargs):
            log.append((_kind, _key(M, K), _stage(traceback.extract_stack())))
            return _original(M, K, *args, **kwargs)

        patch.setattr(module, name, counted)
    try:
        run = run_example("cantilever", tmp_path_factory.mktemp("solves") / "out")
    finally:
        patch.undo()
    return run, log


def test_the_updated_matrices_are_solved_once_per_stage_that_needs_them(solves):
    run, log = solves
    assert run.success and set(run.matrices) == {"A", "B", "C", "D"}
    updated = {_key(m["M"], m["K"]): name for name, m in run.matrices.items()}
    at_answer = Counter((kind, updated[key], stage) for kind, key, stage in log if key in updated)
    for name in run.matrices:
        for kind in ("modes", "zeros"):   # one receptance per configuration: one adjunct pencil
            # the first stage's correlation (rows, verification, sensitivity, and from
            # UpdateResult.modal the damping, the MAC and the Caughey C): one solve
            assert at_answer[(kind, name, "correlation")] == 1
            # the polish's last evaluation, at the point it returns, and the parameter ranges'
            # Jacobian at the answer: at most one each
            assert at_answer[(kind, name, "polish")] <= 1
            assert at_answer[(kind, name, "ranges")] <= 1
            # the damping stage, the results object and the writers: never
            assert at_answer[(kind, name, "later")] == 0
