"""Modes, receptances, antiresonances (Eqs. 2, 3, 8) and MAC."""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import example, given, settings
from hypothesis import strategies as st

from helpers import random_spd, uniform_cantilever
from vibupdate import antiresonances, mac, modes, receptance
from vibupdate.modal.analysis import adjunct, antiresonance_vectors


def test_modes_are_mass_normalized_and_dense_equals_sparse():
    s = uniform_cantilever(60)
    w_dense, P_dense = modes(s.M, s.K, 5, dense=True)
    w_sparse, P_sparse = modes(s.M, s.K, 5, dense=False)
    # Dense LAPACK resolves eigenvalues to about eps * lambda_max in absolute terms, which for
    # a 60-element beam is 1e-7 of lambda_1; shift-invert is the more accurate of the two.
    w_all, _ = modes(s.M, s.K)
    bound = 50 * np.finfo(float).eps * w_all[-1] ** 2 / w_dense**2
    assert np.all(np.abs(w_sparse**2 / w_dense**2 - 1) < bound)
    np.testing.assert_allclose(P_dense.T @ (s.M @ P_dense), np.eye(5), atol=1e-10)
    np.testing.assert_allclose(np.abs(np.diag(mac(P_dense, P_sparse))), 1.0, atol=1e-10)


def test_receptance_equals_modal_sum_when_undamped():
    rng = np.random.default_rng(3)
    M, K = random_spd(rng, 6, 3.0), random_spd(rng, 6, 50.0)
    omega, Phi = modes(M, K)
    w = np.array([0.3, 2.0, 11.0])
    h = receptance(sp.csr_matrix(M), sp.csr_matrix(K), 1, 4, w)
    modal = np.array([np.sum(Phi[1] * Phi[4] / (omega**2 - x**2)) for x in w])
    np.testing.assert_allclose(h, modal, rtol=1e-9)


def test_receptance_with_damping_is_reciprocal_and_dissipative():
    rng = np.random.default_rng(4)
    M, K, C = random_spd(rng, 5, 2.0), random_spd(rng, 5, 30.0), 0.05 * random_spd(rng, 5, 3.0)
    w = np.linspace(0.5, 6.0, 7)
    h12 = receptance(M, K, 1, 2, w, C)
    h21 = receptance(M, K, 2, 1, w, C)
    np.testing.assert_allclose(h12, h21, rtol=1e-10)
    # A driving-point receptance of a damped system has a negative imaginary part.
    assert np.all(receptance(M, K, 0, 0, w, C).imag < 0)


def _chain(masses, springs):
    n = len(masses)
    K = np.zeros((n, n))
    K[0, 0] += springs[0]
    for i in range(1, n):
        k = springs[i]
        K[np.ix_([i - 1, i], [i - 1, i])] += k * np.array([[1, -1], [-1, 1]])
    return np.diag(masses), K


#: A zero this close to a pole (relative) nearly cancels it: near both, h ~ C (w - z) / (w - p),
#: so at a zero computed to a relative error d, |h(z)| / |h(z +- 2 %)| ~ d / gap, which double
#: precision (d ~ 1e-14) takes above the drop asserted below once the gap is under ~1e-8.
CANCELLING = 1e-7


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(3, 7),
    seed=st.integers(0, 10_000),
    r=st.integers(0, 6),
    c=st.integers(0, 6),
)
@example(n=5, seed=210, r=1, c=1)   # its fourth zero lies 6e-9 (relative) below the fifth pole
def test_antiresonances_are_zeros_of_the_direct_receptance(n, seed, r, c):
    rng = np.random.default_rng(seed)
    r, c = r % n, c % n
    M, K = random_spd(rng, n, 4.0), random_spd(rng, n, 80.0)
    zeros = antiresonances(M, K, r, c)
    poles = modes(M, K)[0]
    for z in zeros:
        if np.min(np.abs(poles / z - 1)) < CANCELLING:   # a pole-zero pair: h is flat around both
            continue
        at = abs(receptance(M, K, r, c, [z])[0])
        around = np.abs(receptance(M, K, r, c, [z * 0.98, z * 1.02]))
        # |h| drops by orders of magnitude at the antiresonance.
        assert at < 1e-6 * around.min()


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 8), seed=st.integers(0, 10_000), r=st.integers(0, 7))
def test_driving_point_zeros_interlace_with_poles(n, seed, r):
    rng = np.random.default_rng(seed)
    r = r % n
    M, K = _chain(rng.uniform(0.5, 2.0, n), rng.uniform(10, 100, n))
    poles, _ = modes(M, K)
    zeros = antiresonances(M, K, r, r)
    assert zeros.size <= n - 1
    for z in zeros:
        k = np.searchsorted(poles, z)
        assert 0 < k < n  # strictly between two poles
    # ... and no two zeros share an interval.
    assert len(set(np.searchsorted(poles, zeros))) == zeros.size


def test_antiresonance_vectors_solve_the_adjunct_problem():
    s = uniform_cantilever(6)
    z, V = antiresonance_vectors(s.M, s.K, 0, 4)
    Mr, Kr = adjunct(s.M, 0, 4).toarray(), adjunct(s.K, 0, 4).toarray()
    for k in range(z.size):
        res = (Kr - z[k] ** 2 * Mr) @ V[:, k]
        assert np.linalg.norm(res) < 1e-8 * np.linalg.norm(Kr @ V[:, k])
        assert np.max(np.abs(V[:, k])) == pytest.approx(1.0)


def test_antiresonances_has_one_return_type_and_the_vectors_their_own_function():
    s = uniform_cantilever(6)
    with pytest.raises(TypeError, match="unexpected keyword argument 'with_vectors'"):
        antiresonances(s.M, s.K, 0, 4, with_vectors=True)     # the pair: antiresonance_vectors
    z = antiresonances(s.M, s.K, 0, 4)
    z_pair, V = antiresonance_vectors(s.M, s.K, 0, 4)
    assert isinstance(z, np.ndarray) and z.ndim == 1 and z.size > 0
    np.testing.assert_array_equal(z, z_pair)
    assert V.shape == (s.M.shape[0] - 1, z.size)


def test_out_of_range_dofs_are_named():
    s = uniform_cantilever(3)
    with pytest.raises(ValueError, match="r=6 is out of range for a model of 6 DOFs"):
        receptance(s.M, s.K, 6, 0, [1.0])
    with pytest.raises(ValueError, match="c=-1 is out of range"):
        antiresonances(s.M, s.K, 0, -1)
    with pytest.raises(ValueError, match="n_modes must be between 1 and 6"):
        modes(s.M, s.K, 7)


def test_mac_properties():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((8, 3))
    np.testing.assert_allclose(np.diag(mac(A, -2.5 * A)), 1.0)
    Q, _ = np.linalg.qr(A)
    np.testing.assert_allclose(mac(Q, Q), np.eye(3), atol=1e-12)
    assert mac(A[:, 0], A[:, 0]).shape == (1, 1)
    with pytest.raises(ValueError, match="equal length"):
        mac(A, A[:5])


def test_a_one_dof_model_has_its_one_mode_and_no_antiresonance():
    """A mass on a spring: one mode; its one receptance is a driving point's, without a zero (both
    paths, with and without vectors); the sparse eigen-solver finds fewer modes than the model has,
    none here, and says so instead of failing inside ARPACK."""
    M, K = np.array([[2.0]]), np.array([[800.0]])
    omega, Phi = modes(M, K)
    np.testing.assert_allclose(omega, [20.0])
    np.testing.assert_allclose(Phi, [[np.sqrt(0.5)]])
    for dense in (True, False):
        assert antiresonances(M, K, 0, 0, dense=dense).shape == (0,)
        z, V = antiresonance_vectors(M, K, 0, 0, dense=dense)
        assert z.shape == (0,) and V.shape == (0, 0)
    with pytest.raises(ValueError, match=r"between 1 and 0, got 1 \(a receptance of a 1-DOF model has at most 0 zeros"):
        antiresonances(M, K, 0, 0, n_zeros=1)
    with pytest.raises(ValueError, match="at most 0 of the 1 finite modes.*dense=True"):
        modes(M, K, dense=False)
    with pytest.raises(ValueError, match="at most 2 of the 3 finite modes.*dense=True"):
        modes(np.eye(3), np.diag([1.0, 2.0, 3.0]), 3, dense=False)
