"""Receptances ``h_rc(j omega)`` (paper Eq. 2, computed without determinants): the displacement
of DOF ``r`` per unit force at DOF ``c``, m/N, at angular frequencies in rad/s.

Undamped small models by superposition of all modes (`vibupdate.modal.eigen`), damped small
models by the modes of the first-order form or by dense complex solves over chunks of
frequencies. Large models, undamped or with classical (modal) damping, by superposition of
their lowest modes plus the residual flexibility of the modes left out (`modal_sum`): one
sparse eigen-solve and one factorization for every line and pair, where a direct solve costs
one sparse LU per line (`benchmarks/RESULTS.md`, "Shrinking data, modal, damping, model and
examples"). Large models with a general damping matrix: one sparse LU per line.
Several pairs of one model share the eigen-solve or the factorizations (`receptances`); memory
is O(n^2) at most on small models, O(n k) on large ones, never O(n_f n^2).

The modes left out: ``h_rc(w)`` needs ``sum_{k>N} phi_rk phi_ck / (lam_k - w^2)`` too, the
residual flexibility, whose expansion in ``w^2 - sigma`` is ``[F (M F)^j]_rc`` less the included
modes' share (``F = (K - sigma M)^-1``, ``sigma`` the shift of `vibupdate.modal.eigen`, 0
unless ``K`` is singular). Adding the vectors ``F e_c, (F M) F e_c, ...`` (`KRYLOV_DEPTH` per
excitation) to the modes and solving the model projected on them (Rayleigh-Ritz) matches
those terms and keeps the included modes exact: the static part of massless DOFs, the modes'
resonances and the residual are all in one small dense solve (the static correction alone
against `KRYLOV_DEPTH` vectors: `benchmarks/RESULTS.md`, "Figures behind src/: receptances");
held against direct solves in `tests/modal/test_receptance.py`."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from vibupdate.modal import eigen
from vibupdate.modal.eigen import as_dense, dense_modes, check_dof_pair, massless_dofs
from vibupdate.modal.factor import sparse_lu


#: Bytes a dense damped receptance may hold in its stack of dynamic stiffness matrices.
_CHUNK_BYTES = 32 * 2**20
#: Fewest modes of a modal sum on a large model (`modal_sum`): the count `CaugheyLaw` took.
MODAL_SUM_MODES = 40
#: A modal sum takes modes up to this multiple of its highest line (`modal_sum`), so that every
#: resonance drawn is an exact mode and the nearest ones left out lie above the plot.
MODAL_SUM_REACH = 1.2
#: Krylov vectors per excitation added to the modes of a modal sum (`modal_sum`; the error
#: against the depth: `benchmarks/RESULTS.md`, "Shrinking data, modal, damping, model and examples").
KRYLOV_DEPTH = 4


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
    eigval, Phi = dense_modes(M, K)
    h = (Phi[rows] * Phi[cols]) @ (1.0 / (eigval[:, None] - omega[None, :] ** 2))
    s = massless_dofs(M)
    both = np.flatnonzero(np.isin(rows, s) & np.isin(cols, s))
    if both.size:
        Kd = as_dense(K)
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
    Md, Kd, Cd = as_dense(M), as_dense(K), as_dense(C)
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
    lines to 1e-7 of the largest |h| of each pair (`benchmarks/RESULTS.md`, "Figures behind
    src/: receptances"); returns None when they disagree (ill-conditioned eigenvectors).
    Shape (n_pairs, n_f)."""
    Md, Kd, Cd = as_dense(M), as_dense(K), as_dense(C)
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


def classical_terms(w, Phi, pairs, omega, damping=None) -> np.ndarray:
    """``sum_k phi_rk phi_ck / (w_k^2 - omega^2 + 2 j zeta_k w_k omega)`` over the given modes,
    shape (n_pairs, n_f), m/N: exact modes of a model with classical damping (``damping(w)``,
    the ratio of each flexible mode; rigid-body modes, ``w = 0``, undamped).

    Parameters
    ----------
    w : ndarray, shape (k,)
        rad/s.
    Phi : ndarray, shape (n, k)
        Mass-normalized modes.
    pairs : sequence of (int, int), length n_pairs
    omega : ndarray, shape (n_f,)
        rad/s.
    damping : callable, optional
        As in `modal_sum`.
    """
    rows, cols = _pair_arrays(Phi.shape[0], pairs)
    xi = np.zeros_like(w)
    if damping is not None:
        xi[w > 0] = damping(w[w > 0])
    den = w[:, None] ** 2 - omega[None, :] ** 2 + 2j * (xi * w)[:, None] * omega[None, :]
    return (Phi[rows] * Phi[cols]) @ (1.0 / den)


def modal_sum(M, K, pairs, omega, damping=None, n_modes: int | None = None) -> np.ndarray:
    """``h_rc(j omega)`` of several pairs of a large model from its lowest modes and the
    Krylov vectors of its excitations (module docstring), with classical damping.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Symmetric mass and stiffness matrices of the model (SI: kg and N/m on translations,
        kg m^2 and N m/rad on rotations).
    pairs : sequence of (int, int), length n_pairs
        Response and excitation DOF indices (0-based).
    omega : array_like, shape (n_f,)
        Angular frequencies, rad/s.
    damping : callable, optional
        Modal damping ratio of each mode, ``damping(w)`` for ``w`` shape (k,) rad/s (all
        positive), returns shape (k,); undamped if omitted.
    n_modes : int, optional
        The modes of the basis; by default those up to `MODAL_SUM_REACH` times the highest
        line, at least `MODAL_SUM_MODES`.

    Returns
    -------
    ndarray of complex, shape (n_pairs, n_f)
        m/N.
    """
    n = M.shape[0]
    rows, cols = _pair_arrays(n, pairs)
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    Ms, Ks = sp.csc_matrix(M), sp.csc_matrix(K)
    n_finite = n - massless_dofs(Ms).size
    k = min(n_finite - 1, n_modes if n_modes is not None else MODAL_SUM_MODES)
    sigma, lu = eigen.shifted_lu(Ks, Ms)
    while True:
        w, Phi = eigen.modes(Ms, Ks, k, dense=False, factor=(sigma, lu))
        if n_modes is not None or k >= n_finite - 1 or w[-1] >= MODAL_SUM_REACH * omega.max():
            break
        k = min(n_finite - 1, 2 * k)
    E, which = _unit_columns(n, cols)
    # The Krylov vectors without their share of the included modes (M-orthogonal, hence also
    # K-orthogonal, to them): the projected pencil splits into the exact modes and a small
    # block of the modes left out, which a nearly singular shift (free-free) no longer swamps
    # with rigid-body modes.
    def deflate(X):
        return X - Phi @ (Phi.T @ np.asarray(Ms @ X))

    blocks, X = [], lu.solve(E)
    for _ in range(KRYLOV_DEPTH):
        X = deflate(X)
        X = X / np.linalg.norm(X, axis=0)
        blocks.append(X)
        X = lu.solve(np.asarray(Ms @ X))
    Q = deflate(sla.qr(np.hstack(blocks), mode="economic")[0])
    # Ritz pairs of the shifted pencil on Q: Mr z = mu Ks_r z, mu = 1 / (lam - sigma) >= 0 (0 on
    # directions without mass), Z.T Ks_r Z = I; then (Ks_r - s Mr)^-1 = Z diag(1 / (1 - s mu)) Z.T.
    mu, Z = sla.eigh(Q.T @ np.asarray(Ms @ Q), Q.T @ np.asarray((Ks - sigma * Ms) @ Q))
    Psi = Q @ Z
    lam = sigma + 1.0 / np.where(mu > 0, mu, np.inf)
    zeta = np.zeros_like(mu)
    if damping is not None:
        zeta[lam > 0] = damping(np.sqrt(lam[lam > 0]))
    rest = (1.0 - (omega[None, :] ** 2 - sigma) * mu[:, None]
            + 2j * (zeta * np.sqrt(np.maximum(lam, 0.0)) * mu)[:, None] * omega[None, :])
    return classical_terms(w, Phi, pairs, omega, damping) + (Psi[rows] * Psi[cols]) @ (1.0 / rest)


def receptances(M, K, pairs, omega, C=None) -> np.ndarray:
    """Receptances ``h_rc(j omega)`` of several ``(r, c)`` pairs of one model, from one
    eigen-solve or one factorization per frequency shared by every pair.

    ``h_rc`` is entry ``r`` of the solution of ``(K + j omega C - omega^2 M) x = e_c``, by the
    path of the module docstring for the model's size and damping (the first-order form of a
    small damped model from 50 lines on, when ``M`` is positive definite).

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Symmetric mass and stiffness matrices of the model (SI: kg and N/m on translations,
        kg m^2 and N m/rad on rotations).
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
    if C is None:
        return modal_sum(M, K, pairs, omega)
    Ms, Ks, Cs = sp.csc_matrix(M), sp.csc_matrix(K), sp.csc_matrix(C)
    E, which = _unit_columns(n, cols)
    out = np.empty((rows.size, omega.size), dtype=complex)
    for i, w in enumerate(omega):
        A = Ks + 1j * w * Cs - w**2 * Ms
        X = sparse_lu(A).solve(E.astype(A.dtype))
        out[:, i] = X[rows, which]
    return out


def receptance(M, K, r: int, c: int, omega, C=None) -> np.ndarray:
    """Receptance ``h_rc(j omega)`` of one pair: `receptances` of ``[(r, c)]``.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Symmetric mass and stiffness matrices of the model (SI: kg and N/m on translations,
        kg m^2 and N m/rad on rotations).
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
