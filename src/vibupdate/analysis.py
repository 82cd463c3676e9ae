"""Modal analysis: natural frequencies, receptances, antiresonances (paper Eqs. 2, 3, 8), MAC.

Everything here works in rad/s. Receptance ``h_rc`` is the displacement of DOF ``r`` per unit
force at DOF ``c`` (m/N).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["modes", "receptance", "adjunct", "antiresonances", "mac", "DENSE_LIMIT"]

#: Models up to this many DOFs use dense LAPACK; larger ones sparse shift-invert.
DENSE_LIMIT = 400


def _dense(A) -> np.ndarray:
    return A.toarray() if sp.issparse(A) else np.asarray(A)


def modes(M, K, n_modes: int | None = None, *, dense: bool | None = None):
    """Natural angular frequencies and mass-normalized mode shapes (Eq. 3 with C = 0).

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Symmetric mass (positive definite) and stiffness matrices.
    n_modes : int, optional
        How many of the lowest modes; all of them by default (dense only).
    dense : bool, optional
        Force the dense (``scipy.linalg.eigh``) or sparse (``eigsh`` shift-invert) path;
        by default dense up to `DENSE_LIMIT` DOFs.

    Returns
    -------
    omega : ndarray, shape (n_modes,)
        Natural frequencies in rad/s, ascending (negative eigenvalues give ``-sqrt(|.|)``).
    Phi : ndarray, shape (n, n_modes)
        Mass-normalized modes, ``Phi.T @ M @ Phi = I``; each column's largest-magnitude entry
        is positive.
    """
    n = M.shape[0]
    if n_modes is not None and not 1 <= n_modes <= n:
        raise ValueError(f"n_modes must be between 1 and {n}, got {n_modes}")
    use_dense = (n <= DENSE_LIMIT or n_modes is None) if dense is None else dense
    if use_dense:
        subset = None if n_modes is None else (0, n_modes - 1)
        try:
            lam, Phi = sla.eigh(_dense(K), _dense(M), subset_by_index=subset)
        except sla.LinAlgError as exc:
            raise ValueError(f"eigenproblem failed (is M positive definite?): {exc}") from None
    else:
        k = n_modes if n_modes is not None else min(n - 1, 20)
        # Shift below the first eigenvalue so that rigid-body modes are handled too.
        shift = -1e-6 * abs(K.diagonal()).max() / max(abs(M.diagonal()).max(), 1e-300)
        lam, Phi = spla.eigsh(sp.csc_matrix(K), k=k, M=sp.csc_matrix(M), sigma=shift, which="LM")
        order = np.argsort(lam)
        lam, Phi = lam[order], Phi[:, order]
        Phi = Phi / np.sqrt(np.einsum("ij,ij->j", Phi, M @ Phi))
    omega = np.sign(lam) * np.sqrt(np.abs(lam))
    idx = np.argmax(np.abs(Phi), axis=0)
    Phi = Phi * np.sign(Phi[idx, np.arange(Phi.shape[1])])
    return omega, Phi


def _check_rc(n: int, r: int, c: int) -> None:
    for label, v in (("r", r), ("c", c)):
        if not isinstance(v, (int, np.integer)) or not 0 <= v < n:
            raise ValueError(f"receptance index {label}={v!r} is out of range for a model of {n} DOFs")


def receptance(M, K, r: int, c: int, omega, C=None) -> np.ndarray:
    """Receptance ``h_rc(j omega)`` by a direct solve of ``(K + j omega C - omega^2 M) x = e_c``.

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
        ``h_rc`` in m/N (Eq. 2, computed without determinants).
    """
    n = M.shape[0]
    _check_rc(n, r, c)
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    if n <= DENSE_LIMIT:
        Md, Kd = _dense(M), _dense(K)
        Cd = np.zeros_like(Md) if C is None else _dense(C)
        A = Kd[None] + 1j * omega[:, None, None] * Cd[None] - omega[:, None, None] ** 2 * Md[None]
        rhs = np.zeros((omega.size, n, 1), dtype=complex)
        rhs[:, c, 0] = 1.0
        return np.linalg.solve(A, rhs)[:, r, 0]
    Ms, Ks = sp.csc_matrix(M), sp.csc_matrix(K)
    Cs = sp.csc_matrix((n, n)) if C is None else sp.csc_matrix(C)
    e = np.zeros(n, dtype=complex)
    e[c] = 1.0
    out = np.empty(omega.size, dtype=complex)
    for i, w in enumerate(omega):
        out[i] = spla.spsolve((Ks + 1j * w * Cs - w**2 * Ms).tocsc(), e)[r]
    return out


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


def antiresonances(M, K, r: int, c: int, *, with_vectors: bool = False, rtol: float = 1e-8):
    """Undamped antiresonance frequencies of ``h_rc`` (Eq. 8).

    They are the finite, real, positive eigenvalues ``omega^2`` of the adjunct pencil
    ``(K_rc, M_rc)`` (row ``c`` and column ``r`` removed).

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
    r, c : int
        Response and excitation DOF indices (0-based).
    with_vectors : bool
        Also return the adjunct eigenvectors.
    rtol : float
        Relative size of the imaginary part below which an eigenvalue counts as real.

    Returns
    -------
    omega_z : ndarray, shape (n_z,)
        Antiresonance frequencies, rad/s, ascending.
    V : ndarray, shape (n - 1, n_z)
        Only with ``with_vectors``: the adjunct eigenvectors, each scaled to unit largest
        entry (positive).
    """
    Mr, Kr = _dense(adjunct(M, r, c)), _dense(adjunct(K, r, c))
    if r == c:
        lam, V = sla.eigh(Kr, Mr)
        keep = lam > 0
        lam, V = lam[keep], V[:, keep]
    else:
        ab, V = sla.eig(Kr, Mr, homogeneous_eigvals=True)
        alpha, beta = ab
        scale = np.abs(alpha) + np.abs(beta)
        finite = np.abs(beta) > 1e-10 * scale
        lam = np.full(alpha.shape, np.nan, dtype=complex)
        lam[finite] = alpha[finite] / beta[finite]
        real = finite & (np.abs(lam.imag) <= rtol * np.abs(lam.real))
        keep = real & (lam.real > 0)
        lam, V = lam[keep].real, V[:, keep].real
    order = np.argsort(lam)
    omega_z = np.sqrt(lam[order])
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
