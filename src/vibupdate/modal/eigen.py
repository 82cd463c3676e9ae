"""Eigen-solves of the pencil ``(K, M)``: natural frequencies and mass-normalized modes (paper
Eq. 3 with C = 0), their residual check, and what a massless DOF is. Everything in rad/s.

Two paths, chosen by size (`DENSE_LIMIT`):

* **dense** (small models): LAPACK on the whole pencil. The eigenvalues come from the
  *reciprocal* pencil ``M phi = mu (K - sigma M) phi``, ``eigval = sigma + 1/mu``, solved by the
  full ``scipy.linalg.eigh`` (no subset driver). Its absolute error in ``mu`` is about
  ``n eps mu_max``, so the relative error of mode ``k`` is about ``n eps eigval_k / eigval_1``:
  machine precision for the lowest modes, which are the measured ones. The direct pencil
  ``K phi = eigval M phi`` has absolute error about ``n eps eigval_max`` instead, i.e. a relative
  error ``n eps eigval_max / eigval_k``, large on refined meshes where ``eigval_max / eigval_1``
  is large (`benchmarks/RESULTS.md`, "Figures behind src/: eigen-solver paths and shifts").
* **sparse** (large models): shift-invert Lanczos / Arnoldi (ARPACK) with a sparse LU of
  ``K - sigma M``, one step of inverse iteration on every returned vector and a residual
  check per mode (`mode_residuals`); a mode whose backward error exceeds the tolerance raises
  `ModalAccuracyError` rather than returning a number nobody can trust.

Massless DOFs (`massless_dofs`; ``K`` positive definite on them) are condensed out exactly on
the dense path (``u_s = -K_ss^-1 K_sm u_m``) and need nothing on the sparse one (shift-invert
factorizes ``K - sigma M`` only); mode vectors are always full length, and a model with ``n_s``
massless DOFs has ``n - n_s`` finite natural frequencies.
"""

from __future__ import annotations

import inspect

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from vibupdate.modal import rigid
from vibupdate.modal.factor import sparse_lu
from vibupdate.modal.kept import Kept, content_key
from vibupdate.modal.refinement import block_size, refine_modes


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
class ModalAccuracyError(ValueError):
    """An eigenpair failed its residual check (the reported frequency cannot be trusted)."""


def as_dense(A) -> np.ndarray:
    """``A`` as a dense array (a sparse matrix converted, an array passed through)."""
    if type(A) is np.ndarray:
        return A
    return A.toarray() if sp.issparse(A) else np.asarray(A)


def _diagonal(A) -> np.ndarray:
    return np.asarray(A.diagonal()).ravel()


def massless_dofs(M) -> np.ndarray:
    """Indices of the massless DOFs: ``|M_ii| <= MASSLESS_TOL * max_j |M_jj|``.

    The one definition of a massless DOF in vibupdate; relative, so that rotations carrying a
    rounding-level mass in an export are massless, not spurious modes far above the rest.

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
    return np.nonzero(d <= MASSLESS_TOL * scale)[0]


# -- dense eigen-solver -------------------------------------------------------------------
def _eigh(A: np.ndarray, B: np.ndarray):
    """``scipy.linalg.eigh(A, B)`` of real dense matrices (``B`` positive definite): the same
    LAPACK driver (``sygvd``) with the same arguments, without the wrapper's per-call dispatch
    (half its time on a small pencil). Whatever that fast call does not solve (an empty or
    non-finite matrix, a nonzero LAPACK ``info``) goes to ``scipy.linalg.eigh`` itself, which
    raises its own errors."""
    if A.size and A.dtype == B.dtype == np.float64 and np.isfinite(A).all() and np.isfinite(B).all():
        eigval, V, info = sla.get_lapack_funcs("sygvd", dtype=np.float64)(A, B)   # eigh's itype 1, "V", "L"
        if info == 0:
            return eigval, V
    return sla.eigh(A, B)


def _reciprocal_eigh(K: np.ndarray, M: np.ndarray, precision: float | None = None):
    """All eigenpairs of ``K phi = eigval M phi`` (M positive definite); ``precision``: the
    relative precision of the entries (`vibupdate.modal.rigid`), None for double precision.

    The reciprocal pencil resolves the low modes, the direct one the high ones (module
    docstring): when the spectrum spans more than six decades both are solved and spliced at
    the geometric mean of the extreme eigenvalues.

    Returns ``eigval`` ascending and ``Phi`` with ``Phi.T M Phi = I``.
    """
    sigma = 0.0
    eigval_direct = V_direct = None
    try:
        mu, V = _eigh(M, K)
    except (sla.LinAlgError, ValueError):
        mu = None
    if mu is not None and mu[-1] > 0 and rigid.is_zero(M, K, 1.0 / mu[-1:], V[:, -1:], precision)[0]:
        # A singular K whose Cholesky factor completed on rounding-level pivots: its largest
        # mu is rounding, and the error n eps mu_max it puts on every mu swamps the flexible
        # modes.
        mu = None
    if mu is None:
        # K is not positive definite: shift below the lowest eigenvalue of the direct pencil,
        # with rigid-body modes by one first flexible eigenvalue (the error n eps mu_max then
        # stays at n eps of the flexible modes), at an unstable point by its own size.
        eigval_direct, V_direct = _direct_eigh(K, M)
        # the direct pencil puts a rigid-body mode at up to n eps |eigval_max|, beyond what
        # `vibupdate.modal.rigid` allows: the shift goes below the first eigenvalue
        # `SINGULAR_SHIFT` rounding units clear of zero, the rigid-body modes told apart later
        # (`modes`; `benchmarks/RESULTS.md`, "Figures behind src/: eigen-solver paths and shifts").
        near = np.abs(eigval_direct) <= SINGULAR_SHIFT * rigid.rounding_scale(M, K, V_direct, precision)
        mu = None
        if near[0] and not near.all():
            sigma = min(eigval_direct[0], 0.0) - eigval_direct[np.argmin(near)]
            try:
                mu, V = _eigh(M, K - sigma * M)
            except (sla.LinAlgError, ValueError):
                mu = None
        if mu is None:
            spread = max(abs(eigval_direct[0]), 1e-6 * abs(eigval_direct[-1]), 1e-300)
            sigma = eigval_direct[0] - spread
            mu, V = _eigh(M, K - sigma * M)
    mu, V = mu[::-1], V[:, ::-1]
    if mu[-1] < 1e-6 * mu[0]:
        if eigval_direct is None:
            eigval_direct, V_direct = _direct_eigh(K, M)
        split = np.sqrt(_lowest_flexible(K, M, sigma, mu, V, eigval_direct[-1], precision) * eigval_direct[-1])
        with np.errstate(divide="ignore"):
            n_low = int(np.sum((mu > 0) & (sigma + 1.0 / mu < split)))
        eigval = np.concatenate([sigma + 1.0 / mu[:n_low], eigval_direct[n_low:]])
        V = np.concatenate([V[:, :n_low], V_direct[:, n_low:]], axis=1)
    else:
        eigval = sigma + 1.0 / mu
    V = V / np.sqrt(np.einsum("ij,ij->j", V, M @ V))
    return eigval, V


def _lowest_flexible(K, M, sigma: float, mu: np.ndarray, V: np.ndarray, top: float,
                     precision: float | None = None) -> float:
    """Lowest eigenvalue of the reciprocal pencil that is not zero within rounding
    (`vibupdate.modal.rigid`), or ``top`` when there is none: the low end of the splice, so that
    a free-free model's flexible modes still come from the reciprocal pencil."""
    positive = mu > 0
    with np.errstate(divide="ignore"):
        eigval = np.where(positive, sigma + 1.0 / np.where(positive, mu, 1.0), np.inf)
    candidates = np.flatnonzero(positive & (eigval > 0))
    if candidates.size:
        zero = rigid.is_zero(M, K, eigval[candidates], V[:, candidates], precision)
        candidates = candidates[~zero]
    return float(eigval[candidates[0]]) if candidates.size else float(top)


def _direct_eigh(K: np.ndarray, M: np.ndarray):
    try:
        return _eigh(K, M)
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


def dense_modes(M, K, precision: float | None = None):
    """All finite eigenpairs of a dense pencil, massless DOFs condensed exactly; ``precision``:
    the relative precision of the entries (`vibupdate.modal.rigid`).

    Returns ``eigval`` (n_f,) ascending and ``Phi`` (n, n_f), mass-normalized, full length.
    """
    Md, Kd = np.asarray(as_dense(M), dtype=float), np.asarray(as_dense(K), dtype=float)
    n = Md.shape[0]
    s = massless_dofs(Md)
    if s.size == 0:
        return _reciprocal_eigh(Kd, Md, precision)
    if s.size == n:
        raise ValueError("the mass matrix is zero: no DOF carries mass")
    m = np.setdiff1d(np.arange(n), s)
    _, G = _condensation(Kd, s, m)
    Kc = Kd[np.ix_(m, m)] - Kd[np.ix_(m, s)] @ G
    eigval, V = _reciprocal_eigh(0.5 * (Kc + Kc.T), Md[np.ix_(m, m)], precision)
    Phi = np.empty((n, V.shape[1]))
    Phi[m] = V
    Phi[s] = -G @ V
    return eigval, Phi


# -- sparse eigen-solver ------------------------------------------------------------------
def _norm1(A) -> float:
    return float(abs(A).sum(axis=0).max()) if A.nnz else 0.0


#: Shift of a singular ``K`` (rigid-body modes, structural zeros of an adjunct pencil), in units
#: of the rounding level of its null vector (`_null_level`): far above rounding, far below the
#: lowest flexible eigenvalue (at least 4.6e4 rounding units in the measurements of
#: `vibupdate.modal.rigid`).
SINGULAR_SHIFT = 1e3


def _null_level(K, M, lu, precision: float | None = None) -> float | None:
    """Rounding level (rad/s)^2 of the null vector of ``K`` when ``K`` is singular within
    rounding, else None: three steps of inverse iteration from a fixed start with the LU of
    ``K``, then ``||K x|| <= RIGID_FACTOR delta || |K| |x| ||`` (symmetric or not), ``delta``
    the rounding unit of the entries (`vibupdate.modal.rigid.unit` of ``precision``)."""
    x = np.random.default_rng(1).standard_normal(K.shape[0])
    for _ in range(3):
        with np.errstate(all="ignore"):
            x = lu.solve(np.asarray(M @ x))
        size = np.linalg.norm(x)
        if not np.isfinite(size) or size == 0:
            break
        x = x / size
    if not np.all(np.isfinite(x)) or not np.any(x):
        return float(abs(_diagonal(K)).max() / max(abs(_diagonal(M)).max(), 1e-300)) * 1e-9
    rounding = rigid.unit(precision) * np.linalg.norm(abs(K) @ np.abs(x))
    if np.linalg.norm(K @ x) > rigid.RIGID_FACTOR * rounding:
        return None
    return float(rounding / max(np.linalg.norm(M @ x), 1e-300))


def shifted_lu(K, M, precision: float | None = None):
    """Sparse LU of ``K - sigma M`` with ``sigma = 0`` when K is nonsingular, else below zero:
    ``-SINGULAR_SHIFT`` rounding levels of its null vector (`_null_level`, entries known to the
    relative ``precision``) when the LU of a singular ``K`` completes on rounding-level pivots,
    a millionth of ``max K_ii / max M_ii`` when it stops on an exactly zero one."""
    K, M = sp.csc_matrix(K), sp.csc_matrix(M)
    try:
        lu = sparse_lu(K)
        level = _null_level(K, M, lu, precision)
        if level is None:
            return 0.0, lu
        sigma = -SINGULAR_SHIFT * level
        return sigma, sparse_lu(K - sigma * M)
    except RuntimeError:
        dm = abs(_diagonal(M)).max()
        sigma = -1e-6 * abs(_diagonal(K)).max() / max(dm, 1e-300)
        try:
            return sigma, sparse_lu(K - sigma * M)
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


#: Sparse eigen-solutions kept for re-use (`vibupdate.modal.kept`): one run asks for the modes of
#: the same updated pencil in several stages (verification, damping checks, FRF plots), each
#: building its own copy of the matrices; a solve of at least as many modes serves them all.
_SOLVED_KEPT = 4
_SOLVED = Kept(_SOLVED_KEPT, 256 * 2**20)


def _sparse_modes(M, K, k: int, rtol: float, factor=None, precision: float | None = None):
    """The ``k`` lowest eigenpairs by shift-invert (module docstring), from `_SOLVED` when the
    same matrices were solved for at least ``k`` modes before; ``factor``: `shifted_lu` of
    ``(K, M)`` when the caller has it."""
    key = content_key(M, K, extra=np.array([rtol, rigid.unit(precision)]).tobytes())
    kept = _SOLVED.get(key)
    if kept is not None and kept[0].size >= k:
        return kept[0][:k].copy(), kept[1][:, :k].copy()
    eigval, V = _solve_sparse_modes(M, K, k, rtol, factor, precision)
    _SOLVED.put(key, (eigval, V), V.nbytes)
    return eigval.copy(), V.copy()


def _solve_sparse_modes(M, K, k: int, rtol: float, factor=None, precision: float | None = None):
    Ms, Ks = sp.csc_matrix(M), sp.csc_matrix(K)
    sigma, lu = shifted_lu(Ks, Ms, precision) if factor is None else factor
    q = block_size(k, Ks.shape[0] - massless_dofs(Ms).size - 1)
    if sigma < 0:   # K singular: rigid-body modes (`flexible_shift`)
        shift = flexible_shift(Ms, Ks, lu, q, precision)
        if shift is not None:
            sigma, lu = shift, sparse_lu(Ks - shift * Ms)
    op = spla.LinearOperator(Ks.shape, matvec=lu.solve, dtype=float)
    try:
        _, V = spla.eigsh(Ks, k=q, M=Ms, sigma=sigma, which="LM", OPinv=op, tol=0, **repeatable(Ks.shape[0]))
    except spla.ArpackError as exc:
        singular = (f"; K counts as singular at the matrices' relative precision {precision:g}, which cannot tell "
                    "its lowest modes from zero: matrices written with more digits are needed"
                    if sigma < 0 and precision is not None and precision > rigid.EPS else "")
        raise ModalAccuracyError(f"shift-invert eigen-solve at shift {sigma:.4g} (rad/s)^2 failed: {exc}"
                                 f"{singular}") from None
    # One refined step of inverse iteration on the block and a Rayleigh-Ritz projection
    # (`vibupdate.modal.refinement`): removes any component along the infinite modes of a
    # singular M and recovers the digits the solves lose on fine meshes.
    eigval, V = refine_modes(Ms, Ks, lu.solve, sigma, V)
    eigval, V = eigval[:k], V[:, :k]
    omega = np.sign(eigval) * np.sqrt(np.abs(eigval))
    require_accuracy(Ms, Ks, omega, V, rtol, "shift-invert eigen-solve: mode")
    return eigval, V


#: Steps of block inverse iteration that estimate the first flexible eigenvalue of a singular
#: ``K`` (`flexible_shift`).
FLEXIBLE_STEPS = 3


def flexible_shift(Ms, Ks, lu, q: int, precision: float | None = None) -> float | None:
    """``-lambda_1``, one first flexible eigenvalue below zero, for the eigen-solve of a model
    whose ``K`` is singular (rigid-body modes), or None when no flexible eigenvalue is found.

    At the shift `shifted_lu` gives a singular ``K``, `SINGULAR_SHIFT` rounding units below
    zero, Lanczos sees the rigid-body modes some 1e12 times the flexible ones and its vectors
    carry errors of eps times that ratio, enough to fail `RESIDUAL_TOL` on full-precision
    free-free frames (`benchmarks/RESULTS.md`, "Shrinking data, modal, damping, model and
    examples"). At ``sigma = -lambda_1`` every mode is at least ``lambda_1`` from the shift.

    `FLEXIBLE_STEPS` steps of block inverse iteration with ``lu`` on ``q`` seeded random
    vectors and a Rayleigh-Ritz projection capture the rigid-body modes at once; the lowest
    Ritz value not zero by the rigid-body test at ``precision`` (`vibupdate.modal.rigid`) is an
    upper bound of ``lambda_1`` (a bound a few times too high only slows Lanczos a little)."""
    X = np.random.default_rng(2).standard_normal((Ks.shape[0], q))
    for _ in range(FLEXIBLE_STEPS):
        X = np.linalg.qr(lu.solve(np.asarray(Ms @ X)))[0]
    Kr, Mr = X.T @ (Ks @ X), X.T @ (Ms @ X)
    try:
        theta, Q = sla.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    except (sla.LinAlgError, ValueError):
        return None
    flexible = theta[~rigid.is_zero(Ms, Ks, theta, X @ Q, precision) & (theta > 0)]
    return -float(flexible[0]) if flexible.size else None


_ARPACK_RNG = "rng" in inspect.signature(spla.eigsh).parameters


def repeatable(n: int) -> dict:
    """Keywords of `scipy.sparse.linalg.eigsh` / ``eigs`` that make an ARPACK run repeatable:
    a fixed start vector and, where scipy takes one, a seeded generator for the random vectors
    ARPACK asks for on a restart, else drawn from the operating system's entropy
    (`benchmarks/RESULTS.md`, "The polish stops on convergence; point data against the pencil's
    rounding floor; repeatable ARPACK")."""
    rng = np.random.default_rng(0)
    out = {"v0": rng.standard_normal(n)}
    if _ARPACK_RNG:
        out["rng"] = rng
    return out


def require_accuracy(M, K, omega, V, rtol: float, what: str) -> None:
    """Raise `ModalAccuracyError` naming the first pair whose backward error
    (`mode_residuals`) exceeds ``rtol``; ``what`` names the pairs, e.g. ``"... mode"``."""
    eta = mode_residuals(M, K, omega, V)
    bad = np.flatnonzero(eta > rtol)
    if bad.size:
        j = bad[0]
        raise ModalAccuracyError(f"{what} {j + 1} ({omega[j]:.6g} rad/s) has a residual (backward error) of "
                                 f"{eta[j]:.2e} > {rtol:.0e}; its frequency cannot be trusted")


def modes(M, K, n_modes: int | None = None, *, dense: bool | None = None, rtol: float = RESIDUAL_TOL,
          factor=None, precision: float | None = None):
    """Natural angular frequencies and mass-normalized mode shapes (Eq. 3 with C = 0).

    By the dense or the sparse path of the module docstring (every sparse pair's backward
    error at most ``rtol``).

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
    factor : (float, SuperLU), optional
        The shift and sparse LU of ``K - sigma M`` (`shifted_lu`) when the caller already
        has them (the sparse path does not factorize again).
    precision : float, optional
        Relative precision of the entries of ``K`` and ``M``, the rounding unit of the
        rigid-body test (`vibupdate.modal.rigid`): a model's ``matrix_precision``; None for
        matrices exact to double precision.

    Returns
    -------
    omega : ndarray, shape (n_modes,)
        Natural frequencies in rad/s, ascending. Rigid-body modes (eigenvalues zero within the
        rounding of their own Rayleigh quotient, `vibupdate.modal.rigid`) are exactly 0;
        negative eigenvalues beyond rounding give ``-sqrt(|.|)``.
    Phi : ndarray, shape (n, n_modes)
        Mass-normalized modes, ``Phi.T @ M @ Phi = I``, full length (massless DOFs included);
        each column's largest-magnitude entry is positive.

    Raises
    ------
    ModalAccuracyError
        A sparse eigenpair failed its residual check.
    """
    n = M.shape[0]
    use_dense = (n <= DENSE_LIMIT or n_modes is None) if dense is None else dense
    if n_modes is not None or not use_dense:   # the number of finite modes bounds a count
        n_finite = n - massless_dofs(M).size
        if n_modes is not None and not 1 <= n_modes <= n_finite:
            raise ValueError(f"n_modes must be between 1 and {n_finite}, got {n_modes}")
    if use_dense:
        if n > max(DENSE_MAX, DENSE_LIMIT):
            raise ValueError(f"a dense eigen-solve of all modes of a {n}-DOF model would need about "
                             f"{5 * 8 * n * n / 2**30:.0f} GB; ask for the lowest n_modes instead (at most "
                             f"{DENSE_MAX} DOFs are solved densely)")
        eigval, Phi = dense_modes(M, K, precision)
        if n_modes is not None:
            eigval, Phi = eigval[:n_modes], Phi[:, :n_modes]
    else:
        k = n_modes if n_modes is not None else min(n_finite - 1, 20)
        if not 1 <= k < n_finite:   # Lanczos (ARPACK) finds fewer pairs than the pencil has
            raise ValueError(f"the sparse eigen-solver finds at most {n_finite - 1} of the {n_finite} finite modes of "
                             f"this model, asked for {k}; solve densely (dense=True) for all of them")
        eigval, Phi = _sparse_modes(M, K, k, rtol, factor, precision)
    # rigid-body modes (zero within the rounding of their own Rayleigh quotient,
    # `vibupdate.modal.rigid`) are exactly 0 rad/s, whatever sign rounding gave them
    eigval = np.where(rigid.is_zero(M, K, eigval, Phi, precision), 0.0, eigval)
    omega = np.sign(eigval) * np.sqrt(np.abs(eigval))
    idx = np.abs(Phi).argmax(axis=0)
    Phi = Phi * np.sign(Phi[idx, np.arange(Phi.shape[1])])
    return omega, Phi


def check_dof_pair(n: int, r: int, c: int) -> None:
    """Raise ValueError unless ``r`` and ``c`` are DOF indices (0-based) of an ``n``-DOF model."""
    for label, v in (("r", r), ("c", c)):
        if not isinstance(v, (int, np.integer)) or not 0 <= v < n:
            raise ValueError(f"receptance index {label}={v!r} is out of range for a model of {n} DOFs")
