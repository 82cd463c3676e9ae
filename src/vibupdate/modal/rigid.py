"""What a zero eigenvalue is: rigid-body modes of ``(K, M)`` and the structural zeros of the
adjunct pencils of a free-free model, told apart from flexible modes by the rounding of each
eigenvector's own Rayleigh quotient. rad/s and (rad/s)^2 throughout.

**The tolerance.** A computed eigenvalue ``eigval`` with vector ``u`` is indistinguishable
from zero when

    |eigval| <= RIGID_FACTOR * eps * (|u|^T |K| |u|) / (u^T M u)

(``|K|`` entrywise). The right-hand side is what rounding alone puts into the Rayleigh
quotient ``u^T K u / u^T M u`` of that very vector: the products of ``K`` with ``u`` cancel
down to the true value, and each cancels from ``|K| |u|``. It follows the scale of the mode,
not of the matrix: a relative threshold on the largest ``K_ii / M_ii`` grows with the fourth power of the inverse element length on
bending meshes, and counts flexible modes of a refined mesh as rigid. The ratio ``|eigval|``
over ``eps |u|^T |K| |u| / u^T M u`` stays of order 1 for rigid-body modes and structural
zeros and is orders larger for flexible modes, soft suspension modes included; `RIGID_FACTOR`
sits between the two (the ratios found with vibupdate's own solvers: `benchmarks/RESULTS.md`,
"Figures behind src/: rigid-body modes").

**Adjunct pencils.** The zeros of ``h_rc`` are the eigenvalues of ``(K_rc, M_rc)``, ``K`` and
``M`` without row ``c`` and column ``r`` (paper Eq. 8). A rigid-body mode ``rho`` with
``rho_r = 0`` gives ``K_rc rho' = 0`` (``rho'`` is ``rho`` without entry ``r``): a model with
``k`` rigid-body modes has ``k - 1`` such combinations (``k`` when ``r`` does not move in any),
and each is an eigenvalue 0 of every adjunct pencil. It is no antiresonance: the cofactor and
``det(K - w^2 M)`` share the factor, the receptance keeps its mass line ``-A / w^2`` to 0 Hz.
The same test applies to it, with ``u`` the right vector embedded in the full space (entry
``r`` set to 0): for a structural zero ``u`` is a rigid-body mode, ``u^T K u = 0``.

**Matrices known to fewer digits.** ``eps`` is the rounding unit of matrices exact to double
precision. A model read from a text export carries the rounding of the export instead: every
entry within ``delta |K_ij|`` of the exact one, ``delta`` the export's relative precision (5e-10
for the 10 significant digits of a Nastran large-field DMIG). The bound is the same with
``max(eps, delta)`` in place of ``eps`` (`unit`), and every function here takes that
``precision`` (``vibupdate.model.affine.AffineModel.matrix_precision``). One ``delta`` unit is
the most the export's rounding moves a zero eigenvalue at the nominal point (``u^T E u``); the
factor `RIGID_FACTOR` leaves room for the difference quotients of an imported model, whose
rounding grows away from the nominal point. Counted in ``eps`` units, the rigid-body
eigenvalues of an exported model lie far above the bound (some negative); in ``delta`` units
they stay well under it, and the flexible modes far above (`benchmarks/RESULTS.md`, "Figures
behind src/: rigid-body modes").
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
    top = np.einsum("ij,ij->j", A, np.asarray(_abs(K) @ A))
    mass = np.einsum("ij,ij->j", U, np.asarray(M @ U))
    out = np.full(U.shape[1], np.inf)
    ok = mass > 0
    out[ok] = unit(precision) * top[ok] / mass[ok]
    return out


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
    eigval = np.real(np.asarray(eigval))
    return np.abs(eigval) <= RIGID_FACTOR * rounding_scale(M, K, U, precision)


def embed(V, n: int, r: int) -> np.ndarray:
    """Vectors of an adjunct pencil (column ``r`` removed), shape (n - 1, k), in the full
    space with entry ``r`` zero, shape (n, k)."""
    V = np.asarray(V)
    out = np.zeros((n, V.shape[1]), dtype=V.dtype)
    out[np.delete(np.arange(n), r)] = V
    return out
