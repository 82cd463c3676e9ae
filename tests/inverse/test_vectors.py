"""The vectors of the answer: the first stage's free unknowns at given parameters
(`vibupdate.inverse.formulation.problem.BilinearProblem.unknowns_at`, `bounded_lstsq`)."""

import numpy as np
import scipy.sparse as sp
from scipy.optimize import lsq_linear

from vibupdate.inverse.formulation.problem import bounded_lstsq


def test_a_large_sparse_block_gives_the_dense_answer_without_a_dense_matrix():
    """Constructed: a banded 800 x 799 block (a mode's rows and free entries above
    `DENSE_LIMIT`) with 10 bounded unknowns (measured entries), 4 of whose bounds cut through
    the unbounded optimum. The elimination of the unbounded unknowns by one sparse LU gives
    the dense bvls answer to 1e-9, the active bounds held exactly; with no bounded unknown it
    is the unbounded least squares."""
    rng = np.random.default_rng(7)
    m, n = 800, 799
    B = sp.diags([rng.uniform(1, 2, n), rng.uniform(-0.5, 0.5, n - 1), rng.uniform(-0.5, 0.5, n)],
                 [0, 1, -1], shape=(m, n), format="csr")
    B = B + sp.csr_matrix((rng.uniform(-0.3, 0.3, n), (np.full(n, m - 1), np.arange(n))), shape=(m, n))
    r = rng.normal(size=m)
    free = lsq_linear(B.toarray(), r, method="bvls").x
    lower, upper = np.full(n, -np.inf), np.full(n, np.inf)
    measured = rng.choice(n, 10, replace=False)
    lower[measured], upper[measured] = free[measured] - 0.1, free[measured] + 0.1
    cut = measured[:4]
    lower[cut], upper[cut] = free[cut] + 0.05, free[cut] + 0.2   # the optimum lies below these
    dense = lsq_linear(B.toarray(), r, bounds=(lower, upper), method="bvls", tol=1e-14).x
    found = bounded_lstsq(B, r, lower, upper)
    assert np.allclose(found, dense, rtol=0, atol=1e-9 * np.abs(dense).max())
    assert np.array_equal(found[cut], lower[cut])
    unbounded = bounded_lstsq(B, r, np.full(n, -np.inf), np.full(n, np.inf))
    assert np.allclose(unbounded, free, rtol=0, atol=1e-9 * np.abs(free).max())


def test_a_dense_block_is_solved_by_bvls_as_it_is():
    """A dense block (below `DENSE_LIMIT`) goes to scipy's bvls unchanged: the same bits."""
    rng = np.random.default_rng(8)
    B, r = rng.normal(size=(30, 20)), rng.normal(size=30)
    lower, upper = np.full(20, -np.inf), np.full(20, np.inf)
    lower[:3], upper[:3] = 0.0, 0.1
    assert np.array_equal(bounded_lstsq(B, r, lower, upper),
                          lsq_linear(B, r, bounds=(lower, upper), method="bvls", tol=1e-14).x)


def test_unbounded_unknowns_the_block_does_not_determine_go_to_bvls_on_the_dense_block():
    """Constructed: the banded block of a large mode with one free entry no row reads (a zero
    column: the augmented system is singular, its LU fails). The answer is scipy's bvls on the
    dense block, the same bits, with the bounded entries held."""
    rng = np.random.default_rng(9)
    m, n = 600, 599
    B = sp.diags([rng.uniform(1, 2, n), rng.uniform(-0.5, 0.5, n - 1)], [0, 1], shape=(m, n), format="lil")
    B[:, 100] = 0.0
    B = sp.csr_matrix(B)
    r = rng.normal(size=m)
    lower, upper = np.full(n, -np.inf), np.full(n, np.inf)
    lower[[3, 300]], upper[[3, 300]] = -0.01, 0.01
    dense = lsq_linear(B.toarray(), r, bounds=(lower, upper), method="bvls", tol=1e-14).x
    assert np.array_equal(bounded_lstsq(B, r, lower, upper), dense)
