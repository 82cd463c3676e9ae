"""Receptances of large models by `modal_sum` (modes plus Krylov vectors of the excitations)
against direct sparse solves, line by line: undamped and with classical damping, with massless
DOFs, free-free (singular K)."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from vibupdate.modal.eigen import DENSE_LIMIT
from vibupdate.modal.receptance import modal_sum, receptances


def _beam(n_el: int, free: bool, massless_rotations: bool):
    """A uniform Euler-Bernoulli beam of ``n_el`` elements (EI 1e4 N m^2, 2 kg/m, 0.05 m
    elements), clamped at the left end unless ``free``; lumped translational mass and, unless
    ``massless_rotations``, rotational inertia. Returns sparse (M, K)."""
    L, EI, m = 0.05, 1e4, 2.0
    k = EI / L**3 * np.array([[12, 6 * L, -12, 6 * L], [6 * L, 4 * L**2, -6 * L, 2 * L**2],
                              [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L**2, -6 * L, 4 * L**2]])
    n = 2 * (n_el + 1)
    rows, cols, vals = [], [], []
    for e in range(n_el):
        idx = np.arange(2 * e, 2 * e + 4)
        rows += list(np.repeat(idx, 4))
        cols += list(np.tile(idx, 4))
        vals += list(k.ravel())
    K = sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
    diag = np.zeros(n)
    diag[0::2] = m * L
    diag[[0, -2]] = m * L / 2
    if not massless_rotations:
        diag[1::2] = m * L**3 / 12
    M = sp.diags(diag, format="csc")
    if not free:
        keep = np.arange(2, n)
        K, M = K[keep][:, keep], M[keep][:, keep]
    return sp.csc_matrix(M), sp.csc_matrix(K)


def _direct(M, K, pairs, omega, C=None):
    n = M.shape[0]
    out = np.empty((len(pairs), omega.size), dtype=complex)
    for i, w in enumerate(omega):
        A = K - w**2 * M if C is None else K + 1j * w * C - w**2 * M
        lu = spla.splu(sp.csc_matrix(A, dtype=complex))
        for j, (r, c) in enumerate(pairs):
            e = np.zeros(n, dtype=complex)
            e[c] = 1.0
            out[j, i] = lu.solve(e)[r]
    return out


@pytest.mark.parametrize("free, massless", [(False, False), (False, True), (True, False)])
def test_modal_sum_agrees_with_direct_solves_undamped(free, massless):
    M, K = _beam(260, free, massless)
    n = M.shape[0]
    assert n > DENSE_LIMIT
    pairs = [(n - 2, n - 2), (n // 2, n - 2), (n - 1, 1 if free else 0)]
    # across the lowest few modes; the direct solve at w loses about eps lam_max / w^2 of its
    # digits (2e-7 at 1 rad/s against a dense solve), and of a free-free model the rigid-body
    # modes make all of |h| there: its lines start at 5 rad/s (first flexible mode 9.4 rad/s)
    omega = np.linspace(5.0 if free else 1.0, 2 * np.pi * 400.0, 57)
    h = modal_sum(M, K, pairs, omega)
    exact = _direct(M, K, pairs, omega)
    # relative to each pair's largest |h| over the lines (near a resonance |h| is large)
    err = np.abs(h - exact).max(axis=1) / np.abs(exact).max(axis=1)
    assert err.max() < 1e-6, err
    # receptances() takes this path above DENSE_LIMIT without damping
    assert np.array_equal(receptances(M, K, pairs, omega), h)


def test_modal_sum_with_classical_damping_agrees_with_the_rayleigh_matrix():
    """Rayleigh damping C = a M + b K is classical: its modal ratios a / (2 w) + b w / 2 in the
    modal sum give the receptance of the damping matrix."""
    M, K = _beam(260, False, False)
    n = M.shape[0]
    a, b = 2.0, 1e-5
    pairs = [(n - 2, n - 2), (n // 3, n - 2)]
    omega = np.linspace(1.0, 2 * np.pi * 400.0, 41)
    h = modal_sum(M, K, pairs, omega, damping=lambda w: a / (2 * w) + b * w / 2)
    exact = _direct(M, K, pairs, omega, C=a * M + b * K)
    err = np.abs(h - exact).max(axis=1) / np.abs(exact).max(axis=1)
    assert err.max() < 1e-6, err
