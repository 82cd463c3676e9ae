"""Modal data of small dense models, computed independently of vibupdate's modal kernels.

The acceptance engine computes the exact data of its known-truth problems, and judges the
returned models, with these few lines of `scipy.linalg` instead of `vibupdate.modes` and
`vibupdate.antiresonances`, so that an error in the library's kernels cannot hide itself.

* `modes`: ``(K - w^2 M) phi = 0``, mass-normalized, every mode (rigid-body modes first, set
  to exactly 0 rad/s when below the model's rounding floor `rigid_floor`). Massless DOFs (zero
  rows of ``M``) are condensed statically.
* a large model, given as sparse matrices (`acceptance.structures.DENSE_MAX`): its lowest
  `SPARSE_MODES` modes by shift-invert Lanczos at 0 (`scipy.sparse.linalg.eigsh`), then
  mass-normalized. Its stiffness must be nonsingular (no rigid-body mode): a free structure of
  that size is refused by a clear error rather than given a guessed rigid floor.
* `zeros`: the antiresonances of the receptance ``h_rc``: the eigenvalues of the pencil with
  row ``r`` and column ``c`` removed, real and positive (a zero at 0 rad/s of a free structure
  cancels against its rigid-body poles and is not a zero of ``h_rc``); infinite eigenvalues of
  a pencil with massless DOFs are dropped.
* `caughey_ratios`: the modal damping ratios of a Caughey series.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from scipy.sparse.linalg import eigsh

__all__ = ["modes", "zeros", "mac", "caughey_ratios", "rigid_floor", "SPARSE_MODES"]

#: Modes a sparse model's `modes` returns: more than any problem measures.
SPARSE_MODES = 16

#: Safety factor of `rigid_floor` over the rounding of a dense symmetric eigen-solve.
RIGID_FACTOR = 10.0


def rigid_floor(M: np.ndarray, K: np.ndarray) -> float:
    """Eigenvalues (rad^2/s^2) below this are rounding of a rigid-body mode, taken as 0:
    ``RIGID_FACTOR n eps max_i(K_ii / M_ii)`` over the DOFs with mass.

    A dense solve of ``K phi = lam M phi`` resolves an eigenvalue to about ``n eps`` times the
    largest stiffness-to-mass ratio of a DOF (the scale of ``M^-1 K``), so a rigid-body mode
    comes out within that of 0, whatever the lowest flexible mode is. A fraction of the largest
    eigenvalue instead grows with the mesh as ``n^4`` for a beam and, at 40 elements, reaches
    the first flexible mode of a free-free beam (`tests/acceptance/test_judge.py`)."""
    d = np.diag(M)
    mass = d > 1e-14 * np.max(np.abs(d))
    ratio = np.max(np.abs(np.diag(K)[mass]) / d[mass]) if np.any(mass) else 0.0
    return RIGID_FACTOR * M.shape[0] * np.finfo(float).eps * ratio


def _massless(M: np.ndarray) -> np.ndarray:
    scale = np.max(np.abs(np.diag(M)))
    return np.flatnonzero(np.all(np.abs(M) <= 1e-14 * scale, axis=1))


def modes(M: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every natural frequency (rad/s, ascending, shape (n_m,)) and the mass-normalized modes
    (shape (n, n_m)); ``n_m = n`` less the massless DOFs. Sparse ``M``, ``K``: the lowest
    `SPARSE_MODES` alone (`_sparse_modes`)."""
    if sp.issparse(M) or sp.issparse(K):
        return _sparse_modes(sp.csc_matrix(M), sp.csc_matrix(K))
    n = M.shape[0]
    zero = _massless(M)
    keep = np.setdiff1d(np.arange(n), zero)
    if zero.size:
        Kzz, Kzk = K[np.ix_(zero, zero)], K[np.ix_(zero, keep)]
        T = -la.solve(Kzz, Kzk, assume_a="pos")
        Kc = K[np.ix_(keep, keep)] + Kzk.T @ T
        Mc = M[np.ix_(keep, keep)]
        lam, Y = la.eigh(0.5 * (Kc + Kc.T), Mc)
        Phi = np.zeros((n, keep.size))
        Phi[keep], Phi[zero] = Y, T @ Y
        floor = rigid_floor(Mc, Kc)
    else:
        lam, Phi = la.eigh(K, M)
        floor = rigid_floor(M, K)
    lam = np.where(lam < floor, 0.0, lam)
    _refine(M, K, lam, Phi, keep)
    return np.sqrt(lam), Phi


def _sparse_modes(M, K) -> tuple[np.ndarray, np.ndarray]:
    """The lowest `SPARSE_MODES` modes of a large model: shift-invert Lanczos at 0 to full
    precision (``tol=0``), each vector mass-normalized, from a fixed start vector (ARPACK's own is
    random: the data then differed in their last bits from one process to the next). A singular
    ``K`` (rigid-body modes) is refused: the shift at 0 needs its factorization."""
    k = min(SPARSE_MODES, M.shape[0] - 1)
    start = np.random.default_rng(0).standard_normal(M.shape[0])
    try:
        lam, Phi = eigsh(K, k=k, M=M, sigma=0.0, which="LM", tol=0.0, v0=start)
    except RuntimeError as exc:   # splu of a singular K
        raise ValueError(f"the sparse truth kernel needs a nonsingular stiffness (no rigid-body mode): {exc}") from exc
    order = np.argsort(lam)
    lam, Phi = lam[order], Phi[:, order]
    if np.any(lam <= 0):
        raise ValueError(f"the sparse truth kernel found a non-positive eigenvalue {lam.min():.3g}: "
                         "a rigid-body mode, which it does not handle")
    Phi = Phi / np.sqrt(np.einsum("ij,ij->j", Phi, M @ Phi))
    return np.sqrt(lam), Phi


#: Flexible modes refined by inverse iteration (`_refine`): more than any problem measures.
REFINED_MODES = 12


def _refine(M, K, lam, Phi, keep) -> None:
    """Two steps of inverse iteration, in place, on the lowest `REFINED_MODES` flexible modes
    that are well separated from their neighbours (relative gap above 1e-6).

    ``eigh(K, M)`` resolves a low mode only to about ``n eps lam_max / lam_k``: on a free-free
    beam of 10 DOFs its shape ratios were 4e-13 off, above the floor at which vibupdate checks
    point data. Exact data must be exact to rounding; one solve with ``K - lam_k M`` per step
    brings the vector there (a classical refinement, independent of vibupdate's kernels)."""
    n = M.shape[0]
    flexible = np.flatnonzero(lam > 0)[:REFINED_MODES]
    for k in flexible:
        gaps = np.abs(np.delete(lam, k) - lam[k])
        if gaps.size and gaps.min() <= 1e-6 * lam[k]:
            continue
        x = Phi[:, k].copy()
        for _ in range(2):
            try:
                with np.errstate(all="ignore"), warnings.catch_warnings():
                    warnings.simplefilter("ignore", la.LinAlgWarning)   # nearly singular by design
                    y = la.solve(K - lam[k] * M, M @ x, assume_a="sym")
            except la.LinAlgError:   # exactly singular: the vector is already exact
                break
            if not np.all(np.isfinite(y)):
                break
            x = y / np.sqrt(y @ M @ y)
        if np.all(np.isfinite(x)) and abs(x @ M @ Phi[:, k]) > 0.99:
            Phi[:, k] = np.sign(x @ M @ Phi[:, k]) * x
            lam[k] = (x @ K @ x) / (x @ M @ x)


def zeros(M: np.ndarray, K: np.ndarray, r: int, c: int) -> tuple[np.ndarray, int]:
    """Real positive zeros of ``h_rc`` (rad/s, ascending) and the number of complex ones
    (dense models only)."""
    if sp.issparse(M) or sp.issparse(K):
        raise ValueError("the truth kernels compute antiresonances of dense models only "
                         "(at most acceptance.structures.DENSE_MAX DOFs)")
    rows = np.delete(np.arange(M.shape[0]), r)
    cols = np.delete(np.arange(M.shape[0]), c)
    A, B = K[np.ix_(rows, cols)], M[np.ix_(rows, cols)]
    if r == c and not _massless(B).size:
        lam = la.eigh(A, B, eigvals_only=True).astype(complex)
    else:
        alpha, beta = la.eig(A, B, right=False, homogeneous_eigvals=True)
        lam = _finite(alpha, beta)
    lam = lam[np.abs(lam) > rigid_floor(M, K)]   # a zero at 0 of a free structure: rigid-body rounding
    complex_ = (np.abs(lam.imag) > 1e-7 * np.abs(lam)) | (lam.real < 0)
    return np.sort(np.sqrt(lam.real[~complex_])), int(np.count_nonzero(complex_))


def _finite(alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    alpha, beta = np.asarray(alpha), np.asarray(beta)
    ok = np.abs(beta) > 1e-10 * np.abs(alpha)
    return alpha[ok] / beta[ok]


def mac(a: np.ndarray, b: np.ndarray) -> float:
    """Modal assurance criterion of two real vectors; 0 when one is zero (a high mode of a long
    irregular chain localized away from every sensor, its entries there underflowing to 0)."""
    norm = (a @ a) * (b @ b)
    return float((a @ b) ** 2 / norm) if norm > 0 else 0.0


def caughey_ratios(exponents, beta, omega) -> np.ndarray:
    """Modal damping ratios of a Caughey series at ``omega`` (rad/s): ``sum_j beta_j w^(2 Y_j)
    / (2 w)`` (``C = M sum_j beta_j (M^-1 K)^Y_j``, a mode of ``w`` has ``phi^T C phi = sum_j
    beta_j w^(2 Y_j)``)."""
    w = np.asarray(omega, dtype=float)[:, None]
    return np.sum(np.asarray(beta, dtype=float) * w ** (2.0 * np.asarray(exponents, dtype=float)), axis=1) / (
        2.0 * w[:, 0])

