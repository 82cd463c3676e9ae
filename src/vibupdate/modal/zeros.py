"""Antiresonances (the zeros of a receptance ``h_rc``, paper Eq. 8): the finite, real, positive
eigenvalues of the adjunct pencil ``(K_rc, M_rc)``, ``K`` and ``M`` without row ``c`` and column
``r``. Dense up to `vibupdate.modal.eigen.DENSE_LIMIT` DOFs (the symmetric reciprocal pencil for
``r == c``, QZ otherwise), shift-invert on the sparse adjunct pencil above, with a residual
check per zero. rad/s throughout.

A model with rigid-body modes gives every adjunct pencil eigenvalues 0 that are no
antiresonances (`vibupdate.modal.rigid`); they are removed (`structural`) before anything is
counted, so zero ``j`` of ``h_rc`` is the ``j``-th antiresonance above 0 Hz on every path.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from vibupdate.modal import eigen, rigid
from vibupdate.modal.eigen import (
    RESIDUAL_TOL,
    as_dense,
    dense_modes,
    shifted_lu,
    check_dof_pair,
)


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
    check_dof_pair(n, r, c)
    rows, cols = others(n, c), others(n, r)
    if sp.issparse(A):
        return sp.csr_matrix(A)[rows][:, cols]
    return np.asarray(A)[rows[:, None], cols]


@lru_cache(maxsize=256)
def others(n: int, k: int) -> np.ndarray:
    """The indices ``0 .. n - 1`` without ``k``, shape (n - 1,), read-only: built once per
    ``(n, k)`` (every evaluation asks for the same few)."""
    i = np.arange(n - 1)
    i += i >= k
    i.flags.writeable = False
    return i


def structural(M, K, r: int, eigval_z, V, precision: float | None = None) -> np.ndarray:
    """Which eigenvalues of the adjunct pencil of ``h_rc`` are its structural zeros, the
    rigid-body combinations with no motion at ``r`` (`vibupdate.modal.rigid`), no
    antiresonances.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        The full model.
    r : int
        Response DOF (the removed column).
    eigval_z : ndarray, shape (k,)
        Eigenvalues of the adjunct pencil, (rad/s)^2.
    V : ndarray, shape (n - 1, k)
        Their right vectors.
    precision : float, optional
        Relative precision of the entries of ``K`` and ``M`` (`vibupdate.modal.rigid`); None:
        double precision.

    Returns
    -------
    ndarray of bool, shape (k,)
    """
    return rigid.is_zero(M, K, eigval_z, rigid.embed(_real_vectors(V), M.shape[0], r), precision)


def dense_zeros(M, K, r: int, c: int, rtol: float, precision: float | None = None, left: bool = True):
    """The finite, real (imaginary part within ``rtol``), positive eigenvalues of the dense adjunct
    pencil of ``h_rc`` without its structural zeros (`structural`), ascending, with their right
    and left vectors (real, each of unit norm; the same for ``r == c``; None without ``left``
    for ``r != c``): the symmetric reciprocal pencil for ``r == c``, QZ (`qz`) otherwise."""
    Mr, Kr = adjunct(as_dense(M), r, c), adjunct(as_dense(K), r, c)   # dense first: no sparse indexing
    if r == c:
        eigval_z, V = dense_modes(Mr, Kr, precision)
        keep = (eigval_z > 0) & ~structural(M, K, r, eigval_z, V, precision)
        return eigval_z[keep], V[:, keep], V[:, keep]
    (num, den), V_left, V_right = qz(Kr, Mr, left)
    size_den = np.abs(den)
    finite = size_den > 1e-10 * (np.abs(num) + size_den)
    eigval_z = num / np.where(finite, den, 1.0)     # only the finite ones are read
    real = eigval_z.real
    k = (finite & (np.abs(eigval_z.imag) <= rtol * np.abs(real)) & (real > 0)).nonzero()[0]
    k = k[~structural(M, K, r, real[k], V_right[:, k], precision)]
    k = k[real[k].argsort()]
    return real[k], V_right[:, k], None if V_left is None else V_left[:, k]


def qz(A: np.ndarray, B: np.ndarray, left: bool = True):
    """The eigenvalues of the real pencil ``(A, B)`` as ``(alpha, beta)`` (complex ``alpha``)
    with the real parts of the left and right vectors, each of unit norm as a complex vector:
    what ``scipy.linalg.eig(A, B, left=True, right=True, homogeneous_eigvals=True)`` gives,
    taken from LAPACK's ``ggev`` without that function's per-vector normalization loop (most
    of its time on a small pencil). Without ``left`` the left vectors are None and not
    computed (``ggev`` computes the eigenvalues and right vectors the same way either way)."""
    A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float)
    if not (np.isfinite(A).all() and np.isfinite(B).all()):
        raise ValueError("array must not contain infs or NaNs")
    ggev, lwork = _ggev(A.shape[0])
    alphar, alphai, beta, vl, vr, _, info = ggev(A, B, int(left), 1, lwork)
    if info != 0:
        raise sla.LinAlgError(f"generalized eig algorithm (ggev) did not converge (LAPACK info={info})")
    j = None
    if alphai.any():
        first = alphai > 0             # the first column of each complex pair
        first[:-1] |= alphai[1:] < 0
        j = np.flatnonzero(first)
    return (alphar + 1j * alphai, beta), _unit_real(vl, j) if left else None, _unit_real(vr, j)


def _unit_real(V: np.ndarray, j: np.ndarray | None) -> np.ndarray:
    """The real parts of ``ggev``'s vectors ``V``, each of unit norm as a complex vector; ``j``:
    the first columns of the complex pairs (None: none). ``ggev`` stores a pair's vectors as the
    real and imaginary parts in two columns: the real part of both is the first column."""
    norms = _column_norms(V)
    if j is None:                      # real eigenvalues only: each column its own vector
        return V / norms
    norms[j] = norms[j + 1] = np.hypot(norms[j], norms[j + 1])
    real = V.copy()
    real[:, j + 1] = V[:, j]
    return real / norms


def _column_norms(V: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(V, axis=0)`` of a real ``V`` (the same operations) without its dispatch."""
    return np.sqrt(np.add.reduce(V * V, axis=0))


@lru_cache(maxsize=64)
def _ggev(n: int):
    """LAPACK's double-precision ``ggev`` and its optimal workspace for ``n x n`` pencils with
    both vectors (it depends on ``n`` alone): queried once per size."""
    ggev = sla.get_lapack_funcs("ggev", dtype=np.float64)
    eye = np.eye(n)
    return ggev, int(ggev(eye, eye, lwork=-1)[-2][0])


def _real_vectors(V: np.ndarray) -> np.ndarray:
    """Real vectors from eigenvectors of real eigenvalues, whatever their complex phase."""
    if not np.iscomplexobj(V):
        return V
    idx = np.argmax(np.abs(V), axis=0)
    phase = V[idx, np.arange(V.shape[1])]
    return (V * (np.abs(phase) / phase)).real


def _sparse_zeros(M, K, r: int, c: int, n_zeros: int, rtol: float, precision: float | None = None):
    """The lowest ``n_zeros`` real positive eigenvalues of the adjunct pencil by shift-invert."""
    Mr, Kr = sp.csc_matrix(adjunct(M, r, c)), sp.csc_matrix(adjunct(K, r, c))
    m = Mr.shape[0]
    sigma, lu = shifted_lu(Kr, Mr, precision)
    k = min(m - 2, 2 * n_zeros + 8)
    while True:
        if r == c:
            op = spla.LinearOperator(Kr.shape, matvec=lu.solve, dtype=float)
            eigval_z, V = spla.eigsh(Kr, k=k, M=Mr, sigma=sigma, which="LM", OPinv=op, tol=0,
                                  **eigen.repeatable(m))
        else:
            op = spla.LinearOperator(Kr.shape, matvec=lambda x: lu.solve(np.asarray(Mr @ x)), dtype=float)
            nu, V = spla.eigs(op, k=k, which="LM", tol=0, **eigen.repeatable(m))
            eigval_z = sigma + 1.0 / nu
        real = (np.abs(eigval_z.imag) <= rtol * np.abs(eigval_z.real) if np.iscomplexobj(eigval_z)
                else np.ones(eigval_z.size, bool))
        keep = real & (eigval_z.real > 0)
        keep[keep] = ~structural(M, K, r, eigval_z[keep].real, V[:, keep], precision)
        if keep.sum() >= n_zeros or k >= m - 2:
            break
        k = min(m - 2, 2 * k)
    eigval_z, V = eigval_z[keep].real, _real_vectors(V[:, keep])
    order = np.argsort(eigval_z)[:n_zeros]
    eigval_z, V = eigval_z[order], V[:, order]
    V = lu.solve(np.asarray(Mr @ V)) * (eigval_z - sigma)
    eigen.require_accuracy(Mr, Kr, np.sqrt(eigval_z), V, RESIDUAL_TOL,
                           f"shift-invert antiresonances of h({r}, {c}): zero")
    return eigval_z, V


def antiresonances(M, K, r: int, c: int, *, rtol: float = 1e-8, n_zeros: int | None = None,
                   dense: bool | None = None, precision: float | None = None) -> np.ndarray:
    """Undamped antiresonance frequencies of ``h_rc`` (Eq. 8).

    Dense, or by shift-invert (Lanczos for ``r == c``, Arnoldi otherwise) as the module
    docstring says; `antiresonance_vectors` also gives the adjunct pencil's vectors.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Symmetric mass and stiffness matrices of the model (SI: kg and N/m on translations,
        kg m^2 and N m/rad on rotations).
    r, c : int
        Response and excitation DOF indices (0-based).
    rtol : float
        Relative size of the imaginary part below which an eigenvalue counts as real.
    n_zeros : int, optional
        How many of the lowest zeros; all of them (dense) or 20 (sparse) by default.
    dense : bool, optional
        Force a path; by default dense up to `DENSE_LIMIT` DOFs.
    precision : float, optional
        Relative precision of the entries of ``K`` and ``M``, the rounding unit that tells the
        structural zeros apart (`vibupdate.modal.rigid`): a model's ``matrix_precision``.

    Returns
    -------
    omega_z : ndarray, shape (n_z,)
        Antiresonance frequencies, rad/s, ascending.

    Raises
    ------
    ModalAccuracyError
        A sparse zero failed its residual check.
    """
    eigval_z, _, order = _zeros(M, K, r, c, rtol, n_zeros, dense, precision)
    return np.sqrt(eigval_z[order])


def antiresonance_vectors(M, K, r: int, c: int, *, rtol: float = 1e-8, n_zeros: int | None = None,
                          dense: bool | None = None, precision: float | None = None
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Undamped antiresonance frequencies of ``h_rc`` (Eq. 8) with the right eigenvectors of
    the adjunct pencil; the left vectors are the right vectors of the ``(c, r)`` pencil.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Symmetric mass and stiffness matrices of the model, as in `antiresonances`.
    r, c : int
        Response and excitation DOF indices (0-based).
    rtol, n_zeros, dense, precision
        As in `antiresonances`.

    Returns
    -------
    omega_z : ndarray, shape (n_z,)
        Antiresonance frequencies, rad/s, ascending.
    V : ndarray, shape (n - 1, n_z)
        ``(K_rc - omega_z^2 M_rc) v = 0``, each scaled to unit largest entry (positive).

    Raises
    ------
    ModalAccuracyError
        A sparse zero failed its residual check.
    """
    eigval_z, V, order = _zeros(M, K, r, c, rtol, n_zeros, dense, precision)
    if not V.size:   # a 1-DOF model: nothing to scale
        return np.sqrt(eigval_z[order]), V[:, order]
    V = V[:, order]
    idx = np.argmax(np.abs(V), axis=0)
    return np.sqrt(eigval_z[order]), V / V[idx, np.arange(V.shape[1])]


def _zeros(M, K, r: int, c: int, rtol: float, n_zeros: int | None, dense: bool | None, precision: float | None):
    """The squared zeros of `antiresonance_vectors`, their right vectors and the order that
    sorts and keeps them."""
    n = M.shape[0]
    check_dof_pair(n, r, c)
    if n_zeros is not None and not (isinstance(n_zeros, (int, np.integer)) and 1 <= n_zeros <= n - 1):
        raise ValueError(f"n_zeros must be between 1 and {n - 1}, got {n_zeros!r} (a receptance of a {n}-DOF model "
                         f"has at most {n - 1} zeros)")
    if n == 1:   # the one receptance is a driving point's, 1 / (k - omega^2 m): no zero
        return np.empty(0), np.empty((0, 0)), np.arange(0)
    use_dense = n <= eigen.DENSE_LIMIT if dense is None else dense
    if use_dense:
        eigval_z, V = dense_zeros(M, K, r, c, rtol, precision, left=False)[:2]
        return eigval_z, V, np.argsort(eigval_z)[:n_zeros]
    eigval_z, V = _sparse_zeros(M, K, r, c, 20 if n_zeros is None else int(n_zeros), rtol, precision)
    return eigval_z, V, np.arange(eigval_z.size)
