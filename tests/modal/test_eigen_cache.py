"""Re-use of sparse eigen-solutions within a run (`vibupdate.modal.eigen`)."""

import numpy as np
import scipy.sparse as sp

from vibupdate.modal import eigen
from vibupdate.modal.kept import Kept
from solve_log import counting_solves


def _chain(n, k=1000.0):
    main = np.full(n, 2 * k)
    K = sp.diags([main, -k * np.ones(n - 1), -k * np.ones(n - 1)], [0, 1, -1], format="csr")
    M = sp.diags(np.linspace(1.0, 2.0, n), format="csr")
    return M, K


def test_the_same_matrices_are_solved_once_and_fewer_modes_come_from_the_kept_solution():
    M, K = _chain(600)
    with counting_solves(()) as log:
        w20, P20 = eigen.modes(M, K, 20)
        w8, P8 = eigen.modes(M.copy(), K.copy(), 8)       # equal matrices, other objects
        w8b, _ = eigen.modes(M, K * (1 + 1e-12), 8)       # other matrices: solved
    assert len(log) == 2
    np.testing.assert_array_equal(w8, w20[:8])
    np.testing.assert_array_equal(P8, P20[:, :8])
    assert not np.array_equal(w8b, w8)
    P8[0, 0] = 1e9                                        # a copy: the kept solution is intact
    assert eigen.modes(M, K, 8)[1][0, 0] != 1e9


def test_the_kept_solutions_are_bounded_in_bytes(monkeypatch):
    monkeypatch.setattr(eigen, "_SOLVED", Kept(eigen._SOLVED_KEPT, 600 * 10 * 8 * 2))   # two solutions of 10 modes
    M, K = _chain(600)
    for s in (1.0, 1.1, 1.2):
        eigen.modes(M, K * s, 10)
    assert len(eigen._SOLVED) == 2


def test_shape_ratio_solutions_are_factorized_once_per_point_of_a_large_model(monkeypatch):
    """The polish's last evaluation, the sensitivity rows and the linearized ranges ask for the
    same shape-ratio derivatives at the answer: one sparse LU per mode and point, not three."""
    import building
    from vibupdate.modal import sensitivities

    model = building.model(7, 2)                      # 546 DOFs: the sparse path
    assert model.n_dofs > eigen.DENSE_LIMIT
    x = 0.05 * np.cos(np.arange(model.n_parameters))
    omega, Phi = eigen.modes(*model.matrices(x), 3)
    calls = []
    original = sensitivities._factor
    monkeypatch.setattr(sensitivities, "_factor", lambda A: calls.append(A.shape) or original(A))
    a = sensitivities.shape_ratio_derivatives(model, x, omega[2], Phi[:, 2], [0, 5, 9], 20)
    b, V = sensitivities.shape_ratio_derivatives(model, x.copy(), omega[2], Phi[:, 2].copy(), [5, 9], 20,
                                                 vectors=True)
    assert len(calls) == 1
    np.testing.assert_array_equal(a[1:], b)
    sensitivities.shape_ratio_derivatives(model, x + 1e-3, omega[2], Phi[:, 2], [0], 20)   # another point
    assert len(calls) == 2


def test_threads_share_the_kept_solutions_safely(monkeypatch):
    """Several threads solving equal and different matrices at once: every answer is right
    and the bound on kept solutions holds (no error from one thread changing the store while
    another reads it)."""
    from concurrent.futures import ThreadPoolExecutor

    monkeypatch.setattr(eigen, "_SOLVED", Kept(eigen._SOLVED_KEPT, 256 * 2**20))
    M, K = _chain(500)
    scales = [1.0, 1.0, 1.3, 1.3, 1.7, 2.1, 1.0, 2.5] * 3
    reference = {s: eigen.modes(M, K * s, 6, dense=True)[0] for s in set(scales)}
    with ThreadPoolExecutor(4) as pool:
        found = list(pool.map(lambda s: eigen.modes(M, K * s, 6)[0], scales))
    for s, w in zip(scales, found):
        np.testing.assert_allclose(w, reference[s], rtol=1e-9)
    assert len(eigen._SOLVED) <= eigen._SOLVED_KEPT


def test_content_key_names_matrices_by_their_values_alone():
    """Dense or sparse, explicit zeros, unsorted indices: the same values, the same key; the
    input is not touched. Another value, another key."""
    from vibupdate.modal.kept import content_key

    M, K = _chain(5)
    order = np.concatenate([np.arange(a, b)[::-1] for a, b in zip(K.indptr[:-1], K.indptr[1:])])  # each row reversed
    unsorted = sp.csr_matrix((K.data[order], K.indices[order], K.indptr), shape=K.shape)
    unsorted.has_sorted_indices = False
    coo = K.tocoo()
    with_zero = sp.csr_matrix((np.r_[coo.data, 0.0], (np.r_[coo.row, 0], np.r_[coo.col, 4])), shape=K.shape)
    assert with_zero.nnz == K.nnz + 1          # an explicit zero at (0, 4)
    before = unsorted.indices.copy()
    keys = {content_key(M, A) for A in (K, K.toarray(), K.tocsc(), with_zero)}
    assert len(keys) == 1 and content_key(M, unsorted) in keys
    np.testing.assert_array_equal(unsorted.indices, before)
    assert content_key(M, K * (1 + 1e-15)) not in keys and content_key(K, M) not in keys
