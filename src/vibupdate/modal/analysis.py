"""Modal analysis: natural frequencies, receptances, antiresonances (paper Eqs. 2, 3, 8), MAC.

Everything here works in rad/s. Receptance ``h_rc`` is the displacement of DOF ``r`` per unit
force at DOF ``c`` (m/N).

Two paths, chosen by size (`DENSE_LIMIT`):

* **dense** (small models): LAPACK on the whole pencil. The eigenvalues come from the
  *reciprocal* pencil ``M phi = mu (K - sigma M) phi``, ``eigval = sigma + 1/mu``, solved by the
  full ``scipy.linalg.eigh`` (no subset driver). Its absolute error in ``mu`` is about
  ``n eps mu_max``, so the relative error of mode ``k`` is about ``n eps eigval_k / eigval_1``:
  machine precision for the lowest modes, which are the measured ones. The direct pencil
  ``K phi = eigval M phi`` has absolute error about ``n eps eigval_max`` instead, i.e. a relative
  error ``n eps eigval_max / eigval_k`` that reaches 1e-9..1e-8 on the refined frames of the
  benchmarks (``eigval_max / eigval_1`` ~ 1e8); the subset driver measured 1.1e-8 at 305 DOFs.
* **sparse** (large models): shift-invert Lanczos / Arnoldi (ARPACK) with a sparse LU of
  ``K - sigma M``, one step of inverse iteration on every returned vector and a residual
  check per mode (`mode_residuals`); a mode whose backward error exceeds the tolerance raises
  `ModalAccuracyError` rather than returning a number nobody can trust.

Positive semidefinite mass matrices (massless DOFs, as exported by FE packages that lump
masses on translations only) are supported when ``K`` is positive definite on the massless
DOFs. A DOF is massless when its diagonal mass entry is at most `MASSLESS_TOL` times the
largest one in magnitude (`massless_dofs`, the one definition used by the eigen-solvers and by
the admissibility check of `vibupdate.model.physical`; for a positive semidefinite ``M`` the
whole row is then zero to that tolerance). The dense path condenses those DOFs out
exactly (static condensation, ``u_s = -K_ss^-1 K_sm u_m``); the sparse path needs nothing
special, since shift-invert only factorizes ``K - sigma M``. Mode vectors are always returned
full length; a model with ``n_s`` massless DOFs has ``n - n_s`` finite natural frequencies.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["modes", "mode_residuals", "receptance", "receptances", "adjunct", "antiresonances", "mac", "massless_dofs",
           "MASSLESS_TOL", "DENSE_LIMIT", "DENSE_MAX", "ModalAccuracyError"]

#: Models up to this many DOFs use dense LAPACK; larger ones sparse shift-invert.
DENSE_LIMIT = 400
#: Largest model whose *every* mode is computed (dense): 6,000 DOFs hold ~0.3 GB per matrix and
#: LAPACK needs several; above this, asking for all modes is an error, not a swap storm.
DENSE_MAX = 6000
#: Largest accepted backward error of a sparse eigenpair,
#: ``||K phi - eigval M phi|| / ((||K|| + |eigval| ||M||) ||phi||)``.
RESIDUAL_TOL = 1e-8
#: A DOF whose diagonal mass entry is at most this fraction of the largest one (in magnitude)
#: carries no mass (`massless_dofs`).
MASSLESS_TOL = 1e-13
#: Bytes a dense damped receptance may hold in its stack of dynamic stiffness matrices.
_CHUNK_BYTES = 32 * 2**20


class ModalAccuracyError(ValueError):
    """An eigenpair failed its residual check (the reported frequency cannot be trusted)."""


def _dense(A) -> np.ndarray:
    return A.toarray() if sp.issparse(A) else np.asarray(A)


def _diagonal(A) -> np.ndarray:
    return np.asarray(A.diagonal()).ravel()


def massless_dofs(M) -> np.ndarray:
    """Indices of the massless DOFs: ``|M_ii| <= MASSLESS_TOL * max_j |M_jj|``.

    The one definition of a massless DOF in vibupdate (eigen-solvers, receptances and the
    admissibility check of `vibupdate.model.physical`). A relative tolerance, so that an
    exported model whose rotations carry a rounding-level mass is treated as the massless
    model it stands for, and not as one with spurious modes at ~1e7 times the highest
    physical frequency.

    Parameters
    ----------
    M : sparse or ndarray, shape (n, n)

    Returns
    -------
    ndarray of int, shape (n_s,)
        Every DOF when no diagonal entry is nonzero.
    """
    d = np.abs(_diagonal(M))
    scale = float(d.max()) if d.size else 0.0
    return np.flatnonzero(d <= MASSLESS_TOL * scale)


# -- dense eigen-solver -------------------------------------------------------------------
def _reciprocal_eigh(K: np.ndarray, M: np.ndarray):
    """All eigenpairs of ``K phi = eigval M phi`` (M positive definite).

    The reciprocal pencil ``M phi = mu (K - sigma M) phi`` resolves the low modes to about
    ``n eps eigval_k / eigval_1``; the direct pencil resolves the high ones to
    ``n eps eigval_max / eigval_k``.
    When the spectrum spans more than six decades both are solved and spliced at the geometric
    mean of the extreme eigenvalues, so every mode keeps the better of the two.

    Returns ``eigval`` ascending and ``Phi`` with ``Phi.T M Phi = I``.
    """
    sigma = 0.0
    eigval_direct = V_direct = None
    try:
        mu, V = sla.eigh(M, K)
    except (sla.LinAlgError, ValueError):
        # K is not positive definite (rigid-body modes or an unstable parameter point): shift
        # below the lowest eigenvalue, estimated by the direct pencil.
        eigval_direct, V_direct = _direct_eigh(K, M)
        spread = max(abs(eigval_direct[0]), 1e-6 * abs(eigval_direct[-1]), 1e-300)
        sigma = eigval_direct[0] - spread
        mu, V = sla.eigh(M, K - sigma * M)
    mu, V = mu[::-1], V[:, ::-1]
    if mu[-1] < 1e-6 * mu[0]:
        if eigval_direct is None:
            eigval_direct, V_direct = _direct_eigh(K, M)
        split = np.sqrt((sigma + 1.0 / mu[0]) * eigval_direct[-1])
        with np.errstate(divide="ignore"):
            n_low = int(np.sum((mu > 0) & (sigma + 1.0 / mu < split)))
        eigval = np.concatenate([sigma + 1.0 / mu[:n_low], eigval_direct[n_low:]])
        V = np.concatenate([V[:, :n_low], V_direct[:, n_low:]], axis=1)
    else:
        eigval = sigma + 1.0 / mu
    V = V / np.sqrt(np.einsum("ij,ij->j", V, M @ V))
    return eigval, V


def _direct_eigh(K: np.ndarray, M: np.ndarray):
    try:
        return sla.eigh(K, M)
    except (sla.LinAlgError, ValueError) as exc:
        raise ValueError(f"eigenproblem failed (is the mass matrix positive definite?): {exc}") from None


def _condensation(K: np.ndarray, s: np.ndarray, m: np.ndarray):
    """Cholesky factor of ``K_ss`` and ``G = K_ss^-1 K_sm`` of the massless DOFs ``s``."""
    try:
        cho = sla.cho_factor(K[np.ix_(s, s)])
    except sla.LinAlgError:
        raise ValueError(f"the stiffness matrix is not positive definite on the {s.size} massless DOFs "
                         f"(indices {s[:8].tolist()}{' ...' if s.size > 8 else ''}); a DOF without mass "
                         "needs stiffness") from None
    return cho, sla.cho_solve(cho, K[np.ix_(s, m)])


def _dense_modes(M, K):
    """All finite eigenpairs of a dense pencil, massless DOFs condensed exactly.

    Returns ``eigval`` (n_f,) ascending and ``Phi`` (n, n_f), mass-normalized, full length.
    """
    Md, Kd = _dense(M).astype(float), _dense(K).astype(float)
    n = Md.shape[0]
    s = massless_dofs(Md)
    if s.size == 0:
        return _reciprocal_eigh(Kd, Md)
    if s.size == n:
        raise ValueError("the mass matrix is zero: no DOF carries mass")
    m = np.setdiff1d(np.arange(n), s)
    _, G = _condensation(Kd, s, m)
    Kc = Kd[np.ix_(m, m)] - Kd[np.ix_(m, s)] @ G
    eigval, V = _reciprocal_eigh(0.5 * (Kc + Kc.T), Md[np.ix_(m, m)])
    Phi = np.empty((n, V.shape[1]))
    Phi[m] = V
    Phi[s] = -G @ V
    return eigval, Phi


# -- sparse eigen-solver ------------------------------------------------------------------
def _norm1(A) -> float:
    return float(abs(A).sum(axis=0).max()) if A.nnz else 0.0


def _shifted_lu(K, M):
    """Sparse LU of ``K - sigma M`` with ``sigma = 0`` when K is nonsingular, else below zero."""
    K, M = sp.csc_matrix(K), sp.csc_matrix(M)
    try:
        return 0.0, spla.splu(K)
    except RuntimeError:
        dm = abs(_diagonal(M)).max()
        sigma = -1e-6 * abs(_diagonal(K)).max() / max(dm, 1e-300)
        try:
            return sigma, spla.splu(sp.csc_matrix(K - sigma * M))
        except RuntimeError as exc:
            raise ValueError(f"shift-invert eigen-solve: K - sigma M is singular at sigma = {sigma:.3g} ({exc})") \
                from None


def mode_residuals(M, K, omega, Phi) -> np.ndarray:
    """Backward error of each eigenpair, ``||K phi - w^2 M phi|| / ((||K|| + w^2 ||M||) ||phi||)``.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
    omega : array_like, shape (k,)
        Natural frequencies, rad/s (negative values stand for negative eigenvalues).
    Phi : ndarray, shape (n, k)

    Returns
    -------
    ndarray, shape (k,)
        Matrix 1-norms, vector 2-norms. About 1e-16 for an exact pair; the eigenvalue's
        relative error is at most this times its condition number.
    """
    Ms, Ks = sp.csr_matrix(M), sp.csr_matrix(K)
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    eigval = np.sign(omega) * omega**2
    Phi = np.asarray(Phi).reshape(Ms.shape[0], -1)
    R = Ks @ Phi - (Ms @ Phi) * eigval
    scale = (_norm1(Ks) + np.abs(eigval) * _norm1(Ms)) * np.linalg.norm(Phi, axis=0)
    return np.linalg.norm(R, axis=0) / np.maximum(scale, 1e-300)


def _sparse_modes(M, K, k: int, rtol: float):
    Ms, Ks = sp.csc_matrix(M), sp.csc_matrix(K)
    sigma, lu = _shifted_lu(Ks, Ms)
    op = spla.LinearOperator(Ks.shape, matvec=lu.solve, dtype=float)
    eigval, V = spla.eigsh(Ks, k=k, M=Ms, sigma=sigma, which="LM", OPinv=op, tol=0)
    order = np.argsort(eigval)
    eigval, V = eigval[order], V[:, order]
    # One step of inverse iteration: removes any component along the infinite modes of a
    # singular M and sharpens the vectors.
    V = lu.solve(np.asarray(Ms @ V)) * (eigval - sigma)
    V = V / np.sqrt(np.einsum("ij,ij->j", V, Ms @ V))
    omega = np.sign(eigval) * np.sqrt(np.abs(eigval))
    eta = mode_residuals(Ms, Ks, omega, V)
    bad = np.flatnonzero(eta > rtol)
    if bad.size:
        j = bad[0]
        raise ModalAccuracyError(f"shift-invert eigen-solve: mode {j + 1} ({omega[j]:.6g} rad/s) has a residual "
                                 f"(backward error) of {eta[j]:.2e} > {rtol:.0e}; its frequency cannot be trusted")
    return eigval, V


def modes(M, K, n_modes: int | None = None, *, dense: bool | None = None, rtol: float = RESIDUAL_TOL):
    """Natural angular frequencies and mass-normalized mode shapes (Eq. 3 with C = 0).

    Accuracy (see the module docstring): the dense path solves the reciprocal pencil with the
    full ``scipy.linalg.eigh``, relative error about ``n eps eigval_k / eigval_1`` for mode ``k``;
    the sparse path is shift-invert ARPACK whose every pair passes a residual check, backward
    error at most ``rtol`` (typically 1e-15).

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Symmetric mass (positive semidefinite: DOFs without diagonal mass, `massless_dofs`, are massless) and
        stiffness matrices (positive definite on the massless DOFs).
    n_modes : int, optional
        How many of the lowest modes; by default all finite ones (dense) or 20 (sparse).
    dense : bool, optional
        Force the dense or the sparse path; by default dense up to `DENSE_LIMIT` DOFs or when
        all modes are asked for.
    rtol : float
        Largest accepted backward error of a sparse eigenpair.

    Returns
    -------
    omega : ndarray, shape (n_modes,)
        Natural frequencies in rad/s, ascending (negative eigenvalues give ``-sqrt(|.|)``).
    Phi : ndarray, shape (n, n_modes)
        Mass-normalized modes, ``Phi.T @ M @ Phi = I``, full length (massless DOFs included);
        each column's largest-magnitude entry is positive.

    Raises
    ------
    ModalAccuracyError
        A sparse eigenpair failed its residual check.
    """
    n = M.shape[0]
    n_finite = n - massless_dofs(M).size
    if n_modes is not None and not 1 <= n_modes <= n_finite:
        raise ValueError(f"n_modes must be between 1 and {n_finite}, got {n_modes}")
    use_dense = (n <= DENSE_LIMIT or n_modes is None) if dense is None else dense
    if use_dense:
        if n > max(DENSE_MAX, DENSE_LIMIT):
            raise ValueError(f"a dense eigen-solve of all modes of a {n}-DOF model would need about "
                             f"{5 * 8 * n * n / 2**30:.0f} GB; ask for the lowest n_modes instead (at most "
                             f"{DENSE_MAX} DOFs are solved densely)")
        eigval, Phi = _dense_modes(M, K)
        if n_modes is not None:
            eigval, Phi = eigval[:n_modes], Phi[:, :n_modes]
    else:
        k = n_modes if n_modes is not None else min(n_finite - 1, 20)
        eigval, Phi = _sparse_modes(M, K, k, rtol)
    omega = np.sign(eigval) * np.sqrt(np.abs(eigval))
    idx = np.argmax(np.abs(Phi), axis=0)
    Phi = Phi * np.sign(Phi[idx, np.arange(Phi.shape[1])])
    return omega, Phi


# -- receptance ---------------------------------------------------------------------------
def _check_rc(n: int, r: int, c: int) -> None:
    for label, v in (("r", r), ("c", c)):
        if not isinstance(v, (int, np.integer)) or not 0 <= v < n:
            raise ValueError(f"receptance index {label}={v!r} is out of range for a model of {n} DOFs")


def _pair_arrays(n: int, pairs) -> tuple[np.ndarray, np.ndarray]:
    """Checked response and excitation indices of ``pairs``, each shape (n_pairs,)."""
    pairs = list(pairs)
    if not pairs:
        raise ValueError("receptances need at least one (response, excitation) pair, got none")
    for r, c in pairs:
        _check_rc(n, r, c)
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
    if n <= DENSE_LIMIT:
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


# -- antiresonances -----------------------------------------------------------------------
def adjunct(A, r: int, c: int):
    """Adjunct matrix of Eq. 2 and 8: ``A`` with row ``c`` and column ``r`` removed.

    Parameters
    ----------
    A : sparse or ndarray, shape (n, n)

    Returns
    -------
    same type as ``A``, shape (n - 1, n - 1)
    """
    n = A.shape[0]
    _check_rc(n, r, c)
    rows = np.delete(np.arange(n), c)
    cols = np.delete(np.arange(n), r)
    if sp.issparse(A):
        return sp.csr_matrix(A)[rows][:, cols]
    return np.asarray(A)[np.ix_(rows, cols)]


def _dense_zeros(M, K, r: int, c: int, rtol: float):
    Mr, Kr = _dense(adjunct(M, r, c)), _dense(adjunct(K, r, c))
    if r == c:
        eigval_z, V = _dense_modes(Mr, Kr)
        keep = eigval_z > 0
        return eigval_z[keep], V[:, keep]
    (num, den), V = sla.eig(Kr, Mr, homogeneous_eigvals=True)
    scale = np.abs(num) + np.abs(den)
    finite = np.abs(den) > 1e-10 * scale
    eigval_z = np.full(num.shape, np.nan, dtype=complex)
    eigval_z[finite] = num[finite] / den[finite]
    real = finite & (np.abs(eigval_z.imag) <= rtol * np.abs(eigval_z.real))
    keep = real & (eigval_z.real > 0)
    return eigval_z[keep].real, _real_vectors(V[:, keep])


def _real_vectors(V: np.ndarray) -> np.ndarray:
    """Real vectors from eigenvectors of real eigenvalues, whatever their complex phase."""
    if not np.iscomplexobj(V):
        return V
    idx = np.argmax(np.abs(V), axis=0)
    phase = V[idx, np.arange(V.shape[1])]
    return (V * (np.abs(phase) / phase)).real


def _sparse_zeros(M, K, r: int, c: int, n_zeros: int, rtol: float):
    """The lowest ``n_zeros`` real positive eigenvalues of the adjunct pencil by shift-invert."""
    Mr, Kr = sp.csc_matrix(adjunct(M, r, c)), sp.csc_matrix(adjunct(K, r, c))
    m = Mr.shape[0]
    sigma, lu = _shifted_lu(Kr, Mr)
    k = min(m - 2, 2 * n_zeros + 8)
    while True:
        if r == c:
            op = spla.LinearOperator(Kr.shape, matvec=lu.solve, dtype=float)
            eigval_z, V = spla.eigsh(Kr, k=k, M=Mr, sigma=sigma, which="LM", OPinv=op, tol=0)
        else:
            op = spla.LinearOperator(Kr.shape, matvec=lambda x: lu.solve(np.asarray(Mr @ x)), dtype=float)
            nu, V = spla.eigs(op, k=k, which="LM", tol=0)
            eigval_z = sigma + 1.0 / nu
        real = (np.abs(eigval_z.imag) <= rtol * np.abs(eigval_z.real) if np.iscomplexobj(eigval_z)
                else np.ones(eigval_z.size, bool))
        keep = real & (eigval_z.real > 0)
        if keep.sum() >= n_zeros or k >= m - 2:
            break
        k = min(m - 2, 2 * k)
    eigval_z, V = eigval_z[keep].real, _real_vectors(V[:, keep])
    order = np.argsort(eigval_z)[:n_zeros]
    eigval_z, V = eigval_z[order], V[:, order]
    V = lu.solve(np.asarray(Mr @ V)) * (eigval_z - sigma)
    eta = mode_residuals(Mr, Kr, np.sqrt(eigval_z), V)
    bad = np.flatnonzero(eta > RESIDUAL_TOL)
    if bad.size:
        j = bad[0]
        raise ModalAccuracyError(f"shift-invert antiresonances of h({r}, {c}): zero {j + 1} "
                                 f"({np.sqrt(eigval_z[j]):.6g} rad/s) has a backward error {eta[j]:.2e}")
    return eigval_z, V


def antiresonances(M, K, r: int, c: int, *, with_vectors: bool = False, rtol: float = 1e-8,
                   n_zeros: int | None = None, dense: bool | None = None):
    """Undamped antiresonance frequencies of ``h_rc`` (Eq. 8).

    They are the finite, real, positive eigenvalues ``omega^2`` of the adjunct pencil
    ``(K_rc, M_rc)`` (row ``c`` and column ``r`` removed). Small models: dense (symmetric
    reciprocal pencil for ``r == c``, QZ otherwise); large models: shift-invert on the sparse
    adjunct pencil (Lanczos for ``r == c``, Arnoldi otherwise) with a residual check per zero.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
    r, c : int
        Response and excitation DOF indices (0-based).
    with_vectors : bool
        Also return the right eigenvectors of the adjunct pencil. The left vectors are the
        right vectors of the ``(c, r)`` pencil.
    rtol : float
        Relative size of the imaginary part below which an eigenvalue counts as real.
    n_zeros : int, optional
        How many of the lowest zeros; all of them (dense) or 20 (sparse) by default.
    dense : bool, optional
        Force a path; by default dense up to `DENSE_LIMIT` DOFs.

    Returns
    -------
    omega_z : ndarray, shape (n_z,)
        Antiresonance frequencies, rad/s, ascending.
    V : ndarray, shape (n - 1, n_z)
        Only with ``with_vectors``: ``(K_rc - omega_z^2 M_rc) v = 0``, each scaled to unit
        largest entry (positive).

    Raises
    ------
    ModalAccuracyError
        A sparse zero failed its residual check.
    """
    n = M.shape[0]
    _check_rc(n, r, c)
    if n_zeros is not None and not (isinstance(n_zeros, (int, np.integer)) and 1 <= n_zeros <= n - 1):
        raise ValueError(f"n_zeros must be between 1 and {n - 1}, got {n_zeros!r}")
    use_dense = n <= DENSE_LIMIT if dense is None else dense
    if use_dense:
        eigval_z, V = _dense_zeros(M, K, r, c, rtol)
        order = np.argsort(eigval_z)[:n_zeros]
    else:
        eigval_z, V = _sparse_zeros(M, K, r, c, 20 if n_zeros is None else int(n_zeros), rtol)
        order = np.arange(eigval_z.size)
    omega_z = np.sqrt(eigval_z[order])
    if not with_vectors:
        return omega_z
    V = V[:, order]
    idx = np.argmax(np.abs(V), axis=0)
    V = V / V[idx, np.arange(V.shape[1])]
    return omega_z, V


def mac(A, B) -> np.ndarray:
    """Modal assurance criterion between two sets of shapes.

    Parameters
    ----------
    A : ndarray, shape (n, m_a)
    B : ndarray, shape (n, m_b)

    Returns
    -------
    ndarray, shape (m_a, m_b)
        ``|a_i^H b_j|^2 / ((a_i^H a_i)(b_j^H b_j))``, between 0 and 1.
    """
    A = np.asarray(A)
    B = np.asarray(B)
    A = A[:, None] if A.ndim == 1 else A
    B = B[:, None] if B.ndim == 1 else B
    if A.shape[0] != B.shape[0]:
        raise ValueError(f"MAC needs shapes of equal length, got {A.shape[0]} and {B.shape[0]}")
    num = np.abs(A.conj().T @ B) ** 2
    den = np.outer(np.sum(np.abs(A) ** 2, axis=0), np.sum(np.abs(B) ** 2, axis=0))
    return num / den
