"""Physical admissibility of a model: definiteness of ``M`` and ``K``, massless DOFs and
rigid-body modes, at the nominal point and over the parameter box.

A model is admissible when

* ``M`` is positive definite, or positive semidefinite with *massless DOFs* (a zero row and
  column, as in FE models whose rotations carry no inertia) on which ``K`` is positive
  definite, so that they can be condensed statically;
* ``K`` is positive semidefinite. Its null space holds the rigid-body modes, counted as the
  eigenvalues of the pencil ``(K, M)`` below ``RIGID_TOL * lam_ref``, with
  ``lam_ref = max_i K_ii / M_ii`` over the DOFs with mass (a Rayleigh quotient, so at most
  the largest eigenvalue); ``K`` is rejected when an eigenvalue of the pencil lies below
  ``-RIGID_TOL * lam_ref``.

Eigenvalues of the pencil below a threshold ``t`` are counted by Sylvester's law of inertia:
their number is the number of negative eigenvalues of ``K - t M`` (with massless DOFs too,
when ``K`` is positive definite on them: the Schur complement on the massless block is the
condensed pencil). Models up to `DENSE_LIMIT` DOFs use dense symmetric eigenvalues; larger
ones a sparse ``L D L^T`` factorization (SuperLU in symmetric mode, diagonal pivots, fill-
reducing symmetric ordering), whose pivot signs give the inertia; no dense ``n x n`` array is
formed.

Over the parameter box, ``M(xbar)`` and ``K(xbar)`` are affine (Eqs. 12-14), so they are
positive (semi)definite on the whole box when they are at every corner; the corners checked
are listed by `box_corners`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from vibupdate.modal.analysis import DENSE_LIMIT, MASSLESS_TOL, massless_dofs
from vibupdate.modal.eigen import repeatable

__all__ = ["DENSE_LIMIT", "RIGID_TOL", "Definiteness", "definiteness", "box_corners", "count_below"]

#: Relative threshold (to ``lam_ref``) of a zero eigenvalue of the pencil ``(K, M)``.
RIGID_TOL = 1e-10
#: All corners are checked up to this many parameters (2^n corners), else a sample.
EXHAUSTIVE_PARAMETERS = 6
#: Seeded random corners checked besides all-lower and all-upper for larger boxes.
RANDOM_CORNERS = 14


@dataclass(frozen=True)
class Definiteness:
    """What `definiteness` found; ``problem`` is None for an admissible model.

    Attributes
    ----------
    massless : tuple of int
        Indices of DOFs without mass.
    rigid_body_modes : int
        Number of zero eigenvalues of the pencil ``(K, M)``.
    problem : str or None
        Why the model is not admissible, in words.
    """

    massless: tuple[int, ...]
    rigid_body_modes: int
    problem: str | None


def _dense(A) -> np.ndarray:
    return A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)


def count_below(A, B, t: float) -> int:
    """Number of eigenvalues of the symmetric pencil ``(A, B)`` below ``t``.

    Parameters
    ----------
    A, B : sparse or ndarray, shape (n, n)
        Symmetric; ``B`` positive semidefinite and ``A`` positive definite on its null space
        (or ``B`` the identity).
    t : float
        Threshold, in the units of ``A / B``.

    Returns
    -------
    int
        Negative eigenvalues of ``A - t B`` (Sylvester's law of inertia).
    """
    n = A.shape[0]
    if n <= DENSE_LIMIT:
        return int(np.sum(sla.eigvalsh(_dense(A) - t * _dense(B)) < 0))
    if sp.issparse(A) and sp.issparse(B):
        a, b = A.diagonal(), B.diagonal()
        if np.count_nonzero(a) == A.count_nonzero() and np.count_nonzero(b) == B.count_nonzero():
            return int(np.sum(a - t * b < 0))           # diagonal pencil (a lumped mass): its own eigenvalues
    S = sp.csc_matrix(A) - t * sp.csc_matrix(B)
    for nudge in (0.0, 1e-13, -1e-13):
        shifted = S if nudge == 0 else S + nudge * abs(S).max() * sp.eye(n, format="csc")
        try:
            lu = spla.splu(sp.csc_matrix(shifted), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                           options={"SymmetricMode": True})
        except RuntimeError:  # an exactly zero pivot: move off the singular point
            continue
        if np.array_equal(lu.perm_r, lu.perm_c):
            return int(np.sum(lu.U.diagonal() < 0))
    # SuperLU left the symmetric ordering: count with shift-invert eigenvalues near t
    k = min(n - 2, 20)
    vals = spla.eigsh(sp.csc_matrix(A), k=k, M=sp.csc_matrix(B) + 1e-12 * sp.eye(n), sigma=t, which="LM",
                      return_eigenvectors=False, **repeatable(n))
    below = int(np.sum(vals < t))
    if below == k:
        raise ValueError(f"could not count the eigenvalues below {t:g}: at least {k} (the inertia "
                         "factorization did not keep a symmetric ordering)")
    return below


def _lowest(A, B) -> float | None:
    """Lowest eigenvalue of the pencil for small models (for messages), else None."""
    if A.shape[0] > DENSE_LIMIT:
        return None
    return float(sla.eigh(_dense(A), _dense(B), eigvals_only=True, subset_by_index=[0, 0])[0])


def definiteness(M, K) -> Definiteness:
    """Check ``M`` and ``K`` of one model (module docstring).

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Symmetric mass and stiffness matrices (SI units).

    Returns
    -------
    Definiteness
    """
    small = M.shape[0] <= DENSE_LIMIT
    if small:   # dense arrays: small models are checked many times (box corners)
        M, K = _dense(M), _dense(K)
    else:
        M, K = sp.csr_matrix(M), sp.csr_matrix(K)

    def block(A, rows, cols):
        return A[np.ix_(rows, cols)] if small else A[rows][:, cols]

    def eye(n):
        return np.eye(n) if small else sp.identity(n, format="csr")

    d = M.diagonal()
    scale = float(np.max(np.abs(d))) if d.size else 0.0
    if not scale > 0:
        return Definiteness((), 0, "the mass matrix M has no positive diagonal entry (no DOF carries mass)")
    if np.any(d < -MASSLESS_TOL * scale):
        i = int(np.argmin(d))
        return Definiteness((), 0, f"the mass matrix M is not positive semidefinite: negative diagonal entry "
                                   f"{d[i]:.6g} (DOF {i + 1})")
    massless = massless_dofs(M)
    mass = np.setdiff1d(np.arange(M.shape[0]), massless)
    if massless.size:
        rows = block(M, massless, np.arange(M.shape[0]))
        coupling = float(abs(rows).max()) if rows.size else 0.0
        if coupling > MASSLESS_TOL * scale:
            return Definiteness(tuple(massless), 0, "the mass matrix M is not positive semidefinite: a DOF without "
                                                    "mass on the diagonal is coupled to others by M")
    Mm = block(M, mass, mass)
    dm = Mm.diagonal()
    if count_below(Mm / dm.max(), eye(mass.size), MASSLESS_TOL) > 0:
        low = _lowest(Mm, eye(mass.size))
        shown = f" (lowest eigenvalue {low:.6g})" if low is not None else ""
        return Definiteness(tuple(massless), 0,
                            f"the mass matrix M is not positive definite on the DOFs that carry mass{shown}")
    kd = K.diagonal()
    if massless.size:
        Ks = block(K, massless, massless)
        ks = max(float(np.max(np.abs(Ks.diagonal()))), 1e-300)
        if count_below(Ks / ks, eye(massless.size), RIGID_TOL) > 0:
            return Definiteness(tuple(massless), 0,
                                f"the stiffness matrix K is not positive definite on the {massless.size} DOF(s) "
                                "without mass, so they cannot be condensed (a massless DOF must be held by stiffness)")
    lam_ref = float(np.max(np.abs(kd[mass]) / dm))
    if not lam_ref > 0:
        return Definiteness(tuple(massless), 0, "the stiffness matrix K is zero on every DOF that carries mass")
    below = count_below(K, M, RIGID_TOL * lam_ref)      # rigid-body modes and any negative ones
    negative = count_below(K, M, -RIGID_TOL * lam_ref) if below else 0
    if negative:
        low = _lowest(K, M) if not massless.size else None
        shown = (f"; lowest eigenvalue of (K, M) {low:.6g} (rad/s)^2" if low is not None else "")
        return Definiteness(tuple(massless), 0, f"the stiffness matrix K is not positive semidefinite: {negative} "
                                                f"negative eigenvalue(s){shown}")
    return Definiteness(tuple(int(i) for i in massless), below, None)


def box_corners(lower, upper, *, seed: int = 0) -> list[tuple[str, np.ndarray]]:
    """Corners of the box ``[lower, upper]`` (normalized parameters) to check.

    All ``2^n`` corners up to `EXHAUSTIVE_PARAMETERS` parameters; otherwise all-lower,
    all-upper and `RANDOM_CORNERS` corners drawn with ``numpy.random.default_rng(seed)``.
    Fixed parameters (``lower == upper``) stay at their value.

    Returns
    -------
    list of (ndarray of bool, ndarray of float), each shape (n,)
        Which parameters are at their upper bound, and the corner's ``xbar``.
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    n = lower.size
    if n <= EXHAUSTIVE_PARAMETERS:
        picks = [np.array(bits, dtype=bool) for bits in itertools.product((False, True), repeat=n)]
    else:
        rng = np.random.default_rng(seed)
        picks = [np.zeros(n, bool), np.ones(n, bool)] + [rng.random(n) < 0.5 for _ in range(RANDOM_CORNERS)]
    out, seen = [], set()
    for up in picks:
        x = np.where(up, upper, lower)
        key = x.tobytes()
        if key not in seen:
            seen.add(key)
            out.append((up, x))
    return out
