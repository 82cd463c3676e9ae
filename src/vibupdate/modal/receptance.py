"""Receptances ``h_rc(j omega)`` (paper Eq. 2, computed without determinants): the displacement
of DOF ``r`` per unit force at DOF ``c``, m/N, at angular frequencies in rad/s.

Undamped small models by superposition of all modes (`vibupdate.modal.eigen`), damped small
models by the modes of the first-order form or by dense complex solves over chunks of
frequencies, large models by one sparse LU per frequency. Several pairs of one model share the
eigen-solve or the factorizations (`receptances`); memory is O(n^2) at most, never O(n_f n^2).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from vibupdate.modal import eigen
from vibupdate.modal.eigen import _dense, _dense_modes, check_dof_pair, massless_dofs

__all__ = ["receptance", "receptances"]

#: Bytes a dense damped receptance may hold in its stack of dynamic stiffness matrices.
_CHUNK_BYTES = 32 * 2**20




def _pair_arrays(n: int, pairs) -> tuple[np.ndarray, np.ndarray]:
    """Checked response and excitation indices of ``pairs``, each shape (n_pairs,)."""
    pairs = list(pairs)
    if not pairs:
        raise ValueError("receptances need at least one (response, excitation) pair, got none")
    for r, c in pairs:
        check_dof_pair(n, r, c)
    return np.array([p[0] for p in pairs], dtype=int), np.array([p[1] for p in pairs], dtype=int)


def _modal_receptances(M, K, rows, cols, omega: np.ndarray) -> np.ndarray:
    """Undamped ``h_rc`` of every pair by superposition of all finite modes (one eigen-solve),
    plus the exact static term of the massless DOFs (``(K_ss^-1)_rc`` when both are massless).
    Shape (n_pairs, n_f)."""
    eigval, Phi = _dense_modes(M, K)
    h = (Phi[rows] * Phi[cols]) @ (1.0 / (eigval[:, None] - omega[None, :] ** 2))
    s = massless_dofs(M)
    both = np.flatnonzero(np.isin(rows, s) & np.isin(cols, s))
    if both.size:
        Kd = _dense(K)
        position = {int(d): k for k, d in enumerate(s)}
        E = np.zeros((s.size, both.size))
        E[[position[int(c)] for c in cols[both]], np.arange(both.size)] = 1.0
        static = sla.cho_solve(sla.cho_factor(Kd[np.ix_(s, s)]), E)
        h[both] += static[[position[int(r)] for r in rows[both]], np.arange(both.size)][:, None]
    return h.astype(complex)


def _unit_columns(n: int, cols: np.ndarray):
    """Distinct excitation DOFs, unit right-hand sides for them (n, n_c) and, per pair, the
    column of its excitation."""
    distinct, which = np.unique(cols, return_inverse=True)
    E = np.zeros((n, distinct.size))
    E[distinct, np.arange(distinct.size)] = 1.0
    return E, which


def _dense_damped_receptances(M, K, C, rows, cols, omega: np.ndarray) -> np.ndarray:
    """``h_rc`` of every pair by complex solves in chunks of frequencies (memory bounded by
    `_CHUNK_BYTES`), one right-hand side per distinct excitation. Shape (n_pairs, n_f)."""
    Md, Kd, Cd = _dense(M), _dense(K), _dense(C)
    n = Md.shape[0]
    E, which = _unit_columns(n, cols)
    chunk = max(1, _CHUNK_BYTES // (16 * n * n))
    out = np.empty((rows.size, omega.size), dtype=complex)
    for start in range(0, omega.size, chunk):
        w = omega[start:start + chunk, None, None]
        A = Kd[None] + 1j * w * Cd[None] - w**2 * Md[None]
        X = np.linalg.solve(A, np.broadcast_to(E.astype(complex), (w.shape[0], n, E.shape[1])))
        out[:, start:start + chunk] = X[:, rows, which].T
    return out


def _state_space_receptances(M, K, C, rows, cols, omega: np.ndarray):
    """Damped ``h_rc`` of every pair from one eigen-decomposition of the first-order form
    ``A = [[0, I], [-M^-1 K, -M^-1 C]]`` (M positive definite): one ``2n`` eigen-solve, then
    ``h(w) = sum_k V_rk (V^-1 b_c)_k / (j w - s_k)``. Checked against direct solves at three
    lines to 1e-7 of the largest |h| of each pair (measured 1.5e-9 on the 305-DOF frame,
    eigenvector matrix condition 7e7); returns None when they disagree (ill-conditioned
    eigenvectors). Shape (n_pairs, n_f)."""
    Md, Kd, Cd = _dense(M), _dense(K), _dense(C)
    n = Md.shape[0]
    try:
        cho = sla.cho_factor(Md)
    except sla.LinAlgError:
        return None
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -sla.cho_solve(cho, Kd)
    A[n:, n:] = -sla.cho_solve(cho, Cd)
    E, which = _unit_columns(n, cols)
    B = np.zeros((2 * n, E.shape[1]))
    B[n:] = sla.cho_solve(cho, E)
    s, V = sla.eig(A)
    try:
        weights = V[rows] * sla.solve(V, B)[:, which].T      # (n_pairs, 2n)
    except sla.LinAlgError:
        return None
    h = weights @ (1.0 / (1j * omega[None, :] - s[:, None]))
    probe = np.unique([0, omega.size // 2, omega.size - 1])
    check = _dense_damped_receptances(Md, Kd, Cd, rows, cols, omega[probe])
    if np.any(np.abs(h[:, probe] - check) > 1e-7 * np.abs(check).max(axis=1, keepdims=True)):
        return None
    return h


def receptances(M, K, pairs, omega, C=None) -> np.ndarray:
    """Receptances ``h_rc(j omega)`` of several ``(r, c)`` pairs of one model, from one
    eigen-solve or one factorization per frequency shared by every pair.

    ``h_rc`` is entry ``r`` of the solution of ``(K + j omega C - omega^2 M) x = e_c``. Small
    undamped models: superposition of all modes (exact, with the static term of massless
    DOFs); small damped models: the modes of the first-order (state-space) form when there are
    more than 50 lines and ``M`` is positive definite (checked against direct solves at
    three lines), else dense complex solves over chunks of frequencies; large models (over
    `DENSE_LIMIT` DOFs): one sparse LU per frequency. Memory is O(n^2) at most, never
    O(n_f n^2).

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
    pairs : sequence of (int, int), length n_pairs
        Response and excitation DOF indices (0-based) of each receptance.
    omega : array_like, shape (n_f,)
        Angular frequencies, rad/s.
    C : sparse or ndarray, shape (n, n), optional
        Viscous damping matrix, N s/m; undamped if omitted.

    Returns
    -------
    ndarray of complex, shape (n_pairs, n_f)
        ``h_rc`` in m/N (Eq. 2, computed without determinants), in the order of ``pairs``.
    """
    n = M.shape[0]
    rows, cols = _pair_arrays(n, pairs)
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    if n <= eigen.DENSE_LIMIT:
        if C is None:
            return _modal_receptances(M, K, rows, cols, omega)
        if omega.size > 50:  # enough lines to pay for one 2n eigen-solve (~8 n^3 vs ~2.7 n^3 a line)
            h = _state_space_receptances(M, K, C, rows, cols, omega)
            if h is not None:
                return h
        return _dense_damped_receptances(M, K, C, rows, cols, omega)
    Ms, Ks = sp.csc_matrix(M), sp.csc_matrix(K)
    Cs = None if C is None else sp.csc_matrix(C)
    E, which = _unit_columns(n, cols)
    out = np.empty((rows.size, omega.size), dtype=complex)
    for i, w in enumerate(omega):
        A = Ks - w**2 * Ms if Cs is None else Ks + 1j * w * Cs - w**2 * Ms
        X = spla.splu(sp.csc_matrix(A)).solve(E.astype(A.dtype))
        out[:, i] = X[rows, which]
    return out


def receptance(M, K, r: int, c: int, omega, C=None) -> np.ndarray:
    """Receptance ``h_rc(j omega)`` of one pair: `receptances` of ``[(r, c)]``.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
    r, c : int
        Response and excitation DOF indices (0-based).
    omega : array_like, shape (n_f,)
        Angular frequencies, rad/s.
    C : sparse or ndarray, shape (n, n), optional
        Viscous damping matrix, N s/m; undamped if omitted.

    Returns
    -------
    ndarray of complex, shape (n_f,)
        ``h_rc`` in m/N.
    """
    return receptances(M, K, [(r, c)], omega, C)[0]
