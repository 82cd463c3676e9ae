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
    top = np.add.reduce(A * np.asarray(_abs(K) @ A), axis=0)     # column dot products; einsum's dispatch
    mass = np.add.reduce(U * np.asarray(M @ U), axis=0)          # costs more on small matrices
    with_mass = mass > 0
    if with_mass.all():    # the usual case: no masking needed
        return unit(precision) * top / mass
    return np.divide(unit(precision) * top, mass, out=np.full(U.shape[1], np.inf), where=with_mass)


def is_zero(M, K, eigval, U, precision: float | None = None) -> np.ndarray:
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

    Returns
    -------
    ndarray of bool, shape (k,)
    """
    eigval = np.asarray(eigval).real
    return np.abs(eigval) <= RIGID_FACTOR * rounding_scale(M, K, U, precision)


def embed(V, n: int, r: int) -> np.ndarray:
    """Vectors of an adjunct pencil (column ``r`` removed), shape (n - 1, k), in the full
    space with entry ``r`` zero, shape (n, k)."""
    V = np.asarray(V)
    out = np.zeros((n, V.shape[1]), dtype=V.dtype)
    out[:r], out[r + 1:] = V[:r], V[r:]
    return out
