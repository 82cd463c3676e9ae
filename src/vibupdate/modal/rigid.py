"""What a zero eigenvalue is: rigid-body modes of ``(K, M)`` and the structural zeros of the
adjunct pencils of a free-free model, told apart from flexible modes by the rounding of each
eigenvector's own Rayleigh quotient. rad/s and (rad/s)^2 throughout.

**The tolerance.** A computed eigenvalue ``eigval`` with vector ``u`` is zero when

    |eigval| <= RIGID_FACTOR * delta * (|u|^T |K| |u|) / (u^T M u)

(``|K|`` entrywise): what rounding alone puts into the Rayleigh quotient of that very vector,
so it follows the scale of the mode, not of the matrix. ``delta`` is the rounding unit of the
entries (`unit`): ``eps`` for matrices exact to double precision, the export's relative
precision for a model read from a text export (``AffineModel.matrix_precision``).

**Adjunct pencils.** The zeros of ``h_rc`` are the eigenvalues of ``(K_rc, M_rc)`` (paper
Eq. 8). A rigid-body mode with no motion at ``r`` gives an eigenvalue 0 of every adjunct pencil
(``k - 1`` of them for ``k`` rigid-body modes), a *structural zero*, no antiresonance; the
same test applies with ``u`` the right vector embedded in the full space (`embed`).

The rule, the rounding units measured and the alternatives: docs/method.md, "Rigid-body
modes", docs/notes/eigen-solutions.md and `benchmarks/RESULTS.md`, "Figures behind src/:
rigid-body modes".
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.linalg.lapack import dsyev


#: An eigenvalue within this many rounding units of its vector's Rayleigh quotient is zero.
RIGID_FACTOR = 50.0

#: Relative rounding unit of double precision, the precision of matrices exact to double.
EPS = float(np.finfo(float).eps)


def unit(precision: float | None = None) -> float:
    """Rounding unit of matrices whose entries are known to the relative ``precision``:
    ``max(eps, precision)``; None is double precision."""
    return EPS if precision is None else max(EPS, float(precision))


def _abs(A):
    return abs(A) if sp.issparse(A) else np.abs(np.asarray(A))


def rounding_scale(M, K, U, precision: float | None = None) -> np.ndarray:
    """``delta (|u|^T |K| |u|) / (u^T M u)`` of each column ``u`` of ``U``, (rad/s)^2, with
    ``delta = unit(precision)``.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
    U : ndarray, shape (n, k)
        Real vectors, any scaling.
    precision : float, optional
        Relative precision of the entries of ``K`` and ``M`` (module docstring); None for
        matrices exact to double precision.

    Returns
    -------
    ndarray, shape (k,)
        ``inf`` for a vector without mass (``u^T M u <= 0``).
    """
    U = np.asarray(U, dtype=float).reshape(M.shape[0], -1)
    A = np.abs(U)
    top = np.einsum("ij,ij->j", A, np.asarray(_abs(K) @ A))
    mass = np.einsum("ij,ij->j", U, np.asarray(M @ U))
    with_mass = mass > 0
    if with_mass.all():    # the usual case: no masking needed
        return unit(precision) * top / mass
    return np.divide(unit(precision) * top, mass, out=np.full(U.shape[1], np.inf), where=with_mass)


def ceiling(M: np.ndarray, K: np.ndarray, precision: float | None = None) -> float:
    """An upper bound of `rounding_scale` over every real vector of the dense ``M``, ``K``
    (nonzero, not so small that its products underflow), inf when none is found.

    ``|u|^T |K| |u| <= ||K||_F ||u||^2`` and ``u^T M u >= lambda ||u||^2`` with ``lambda``
    the least eigenvalue of the symmetric part of ``M`` (LAPACK's, less ``8 n^2 eps ||M||_F``,
    far above its error and the rounding of ``u^T M u``), so the scale is at most
    ``delta ||K||_F / lambda``; the bound is twice that (the rounding of the scale itself), inf
    unless ``lambda > 0`` (massless DOFs). It holds as well for principal submatrices of ``M``,
    ``K`` and for vectors zero at some entries (`embed`).
    """
    S = M + M.T                                  # twice the symmetric part of M
    size_S, size_K = np.sqrt(np.vdot(S, S)), np.sqrt(np.vdot(K, K))   # Frobenius norms
    if not (np.isfinite(size_S) and np.isfinite(size_K)):
        return np.inf
    eigval_S, _, info = dsyev(S, compute_v=0)
    lowest = eigval_S[0] - 8.0 * S.shape[0] ** 2 * EPS * size_S
    return float(4.0 * unit(precision) * size_K / lowest) if info == 0 and lowest > 0 else np.inf


def beyond(eigval: np.ndarray, bound: float) -> bool:
    """Whether every eigenvalue (real) exceeds `RIGID_FACTOR` times ``bound`` in magnitude
    (a `ceiling`): none of them is zero, whatever its vector."""
    size = np.abs(eigval)
    return bool(size.size) and size.min() > RIGID_FACTOR * bound


def is_zero(M, K, eigval, U, precision: float | None = None, bound: float = np.inf) -> np.ndarray:
    """Which eigenvalues are zero within rounding (module docstring).

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
    eigval : ndarray, shape (k,)
        Eigenvalues, (rad/s)^2 (real parts are used).
    U : ndarray, shape (n, k)
        Their vectors in the full space.
    precision : float, optional
        Relative precision of the entries of ``K`` and ``M``; None: double precision.
    bound : float, optional
        The `ceiling` of ``M``, ``K`` (``U``'s columns scaled eigenvectors): when every
        eigenvalue is `beyond` it, none is zero and no scale is computed.

    Returns
    -------
    ndarray of bool, shape (k,)
    """
    eigval = np.asarray(eigval).real
    if bound < np.inf and beyond(eigval, bound):
        return np.zeros(eigval.shape, dtype=bool)
    return np.abs(eigval) <= RIGID_FACTOR * rounding_scale(M, K, U, precision)


def embed(V, n: int, r: int) -> np.ndarray:
    """Vectors of an adjunct pencil (column ``r`` removed), shape (n - 1, k), in the full
    space with entry ``r`` zero, shape (n, k)."""
    V = np.asarray(V)
    out = np.zeros((n, V.shape[1]), dtype=V.dtype)
    out[:r], out[r + 1:] = V[:r], V[r:]
    return out
