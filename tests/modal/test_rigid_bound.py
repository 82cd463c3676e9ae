"""The bound that lets the rigid-body tests skip their scales (`vibupdate.modal.rigid.ceiling`):
it bounds every vector's rounding scale, and the outcomes are those of the full test on both
sides of it (a chain with a rigid-body mode and one without)."""

import numpy as np
import scipy.linalg as sla

from vibupdate import Assembly, antiresonances, modes
from vibupdate.modal import rigid


def chain(n=6, grounded=True):
    """A spring-mass chain with a consistent-mass-like coupling (M not diagonal); free-free
    (one rigid-body mode) unless ``grounded``."""
    k = np.linspace(1e4, 3e4, n - 1)
    K = np.zeros((n, n))
    for i, ki in enumerate(k):
        K[np.ix_([i, i + 1], [i, i + 1])] += ki * np.array([[1.0, -1.0], [-1.0, 1.0]])
    if grounded:
        K[0, 0] += 5e3
    m = np.linspace(1.0, 2.0, n)
    M = np.diag(m) + 0.1 * (np.diag(m[:-1] ** 0.5, 1) + np.diag(m[:-1] ** 0.5, -1))
    return M, K


def test_the_ceiling_bounds_every_vectors_rounding_scale():
    rng = np.random.default_rng(3)
    for grounded in (True, False):
        M, K = chain(grounded=grounded)
        bound = rigid.ceiling(M, K)
        assert 0 < bound < np.inf
        # the vectors that make the scale largest: those of the pencil (|K|, M), and random ones
        U = np.hstack([sla.eigh(np.abs(K), M)[1], rng.standard_normal((M.shape[0], 200)),
                       modes(M, K)[1]])
        assert np.all(rigid.rounding_scale(M, K, U) <= bound)
        assert rigid.ceiling(M, K, 1e-6) > bound   # a coarser precision, a larger bound


def test_a_model_without_rigid_body_modes_is_told_so_by_the_bound():
    M, K = chain(grounded=True)
    bound = rigid.ceiling(M, K)
    omega, Phi = modes(M, K)
    assert np.all(omega > 0)
    assert rigid.beyond(omega**2, bound)                              # the scales are not needed
    assert not rigid.is_zero(M, K, omega**2, Phi, bound=bound).any()
    assert not rigid.is_zero(M, K, omega**2, Phi).any()              # the full test agrees


def test_a_rigid_body_mode_is_below_the_bound_and_the_full_test_finds_it():
    M, K = chain(grounded=False)
    bound = rigid.ceiling(M, K)
    eigval, V = sla.eigh(K, M)
    assert abs(eigval[0]) < 1e-9 * eigval[1]
    assert not rigid.beyond(eigval, bound)                           # no shortcut: the scales decide
    np.testing.assert_array_equal(rigid.is_zero(M, K, eigval, V, bound=bound), [True] + [False] * (eigval.size - 1))
    omega = modes(M, K)[0]
    assert omega[0] == 0 and np.all(omega[1:] > 0)


def test_a_free_free_beam_keeps_its_rigid_body_modes_and_structural_zeros():
    """Three rigid-body modes of a free-free plane frame line, and two structural zeros of a
    transverse driving point (the axial motion and the rotation about that point), removed."""
    asm = Assembly("frame")
    for i in range(6):
        asm.node(f"n{i}", 0.5 * i)
    for i in range(5):
        asm.frame(f"n{i}", f"n{i + 1}", EA=2e8, EI=4e4, mass_per_length=8.0)
    sysm = asm.system()
    M, K = sysm.M.toarray(), sysm.K.toarray()
    bound = rigid.ceiling(M, K)
    assert bound < np.inf
    omega = modes(M, K)[0]
    assert np.count_nonzero(omega == 0) == 3 and np.all(omega[3:] > 1.0)
    r = sysm.dofs.index("yn2")
    zeros = antiresonances(M, K, r, r)
    assert zeros.size == M.shape[0] - 1 - 2 and np.all(zeros > 1.0)
    np.testing.assert_array_equal(zeros, antiresonances(sysm.M, sysm.K, r, r))   # sparse input: no bound, same zeros


def test_no_bound_for_massless_dofs_or_non_finite_matrices():
    M, K = chain()
    M[1, :] = M[:, 1] = 0.0
    assert rigid.ceiling(M, K) == np.inf
    M, K = chain()
    K[0, 0] = np.nan
    assert rigid.ceiling(M, K) == np.inf
    assert not rigid.beyond(np.array([1.0, np.nan]), 1e-12)
    assert not rigid.beyond(np.zeros(0), 1e-12)
