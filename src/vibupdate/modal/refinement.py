"""Accurate low modes of large, finely meshed models: one subspace step with refined solves (the
mechanism and its figures: docs/notes/eigen-solutions.md, "Refined Lanczos vectors").

On a fine bending mesh every solve with ``K`` and every product ``K phi`` loses about
``log10(|K| |phi| / |K phi|)`` digits to cancellation, which the residual check cannot see.
Given Lanczos vectors ``X`` of a block a few modes wider than wanted (`block_size`), one step of
subspace iteration ``Y = (K - sigma M)^-1 M X`` is taken with each solve refined by a residual
formed in extended precision (``numpy.longdouble``, the double-precision LU reused), then a
Rayleigh-Ritz projection (`refine_modes`). No solver makes the matrices mean more: one rounding
unit per entry of ``K`` moves the low modes of a fine mesh by as much (`shape_ratio_floor`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from vibupdate.modal.factor import sparse_lu
from vibupdate.modal.readings import ratio_derivatives
from vibupdate.modal.rigid import unit


#: Refinement sweeps per solve: a second sweep changes the modes by less than a converged
#: reference's own scatter (`benchmarks/RESULTS.md`, "Figures behind src/: accurate low modes").
_SWEEPS = 1


def block_size(n_wanted: int, n_available: int) -> int:
    """Lanczos block for ``n_wanted`` modes: half as many again, at least 4 more (the
    Rayleigh-Ritz step cleans a mode of its neighbours inside the block: `benchmarks/RESULTS.md`,
    "Figures behind src/: accurate low modes")."""
    return int(max(n_wanted, min(n_available, n_wanted + max(4, n_wanted // 2))))


def refine_modes(M, K, solve, sigma: float, X: np.ndarray):
    """One refined subspace step and Rayleigh-Ritz projection (module docstring).

    Parameters
    ----------
    M, K : sparse matrix, shape (n, n)
        Mass (positive semidefinite) and stiffness, SI units.
    solve : callable
        ``solve(B)`` returns ``(K - sigma M)^-1 B`` for ``B`` of shape (n, q), double precision
        (the factorization the Lanczos run used).
    sigma : float
        The shift of ``solve``, (rad/s)^2.
    X : ndarray, shape (n, q)
        Approximate eigenvectors spanning the wanted modes and a few more.

    Returns
    -------
    eigval : ndarray, shape (q,)
        Eigenvalues ``w^2``, (rad/s)^2, ascending.
    Phi : ndarray, shape (n, q)
        Mass-normalized eigenvectors (double precision).
    """
    ext = np.longdouble
    KL, ML = K.astype(ext), M.astype(ext)
    AL = KL - ext(sigma) * ML
    B = ML @ np.asarray(X, dtype=ext)
    Y = solve(np.asarray(B, dtype=float)).astype(ext)
    for _ in range(_SWEEPS):
        Y = Y + solve(np.asarray(B - AL @ Y, dtype=float))
    # The products with K carry the cancellation and are formed in extended precision; the
    # dot products of the projection do not cancel (K Y ~ eigval M Y) and run in double BLAS.
    Yd = np.asarray(Y, dtype=float)
    Kr = Yd.T @ np.asarray(KL @ Y, dtype=float)
    Mr = Yd.T @ np.asarray(ML @ Y, dtype=float)
    # Scale to unit diagonal of Mr so that the small dense problem is well balanced.
    d = 1.0 / np.sqrt(np.diagonal(Mr))
    Kr_d = Kr * np.outer(d, d)
    Mr_d = Mr * np.outer(d, d)
    eigval, Q = sla.eigh(0.5 * (Kr_d + Kr_d.T), 0.5 * (Mr_d + Mr_d.T))
    Phi = Yd @ (d[:, None] * Q)
    PhiL = Phi.astype(ext)
    Phi = Phi / np.sqrt(np.einsum("ij,ij->j", Phi, np.asarray(ML @ PhiL, dtype=float)))
    eigval = np.einsum("ij,ij->j", Phi, np.asarray(KL @ Phi.astype(ext), dtype=float))   # Rayleigh quotients
    order = np.argsort(np.asarray(eigval, dtype=float))
    return np.asarray(eigval, dtype=float)[order], np.asarray(Phi, dtype=float)[:, order]


def shape_ratio_floor(M, K, eigval: float, phi: np.ndarray, entries, reference,
                      seed: int = 0, basis: np.ndarray | None = None,
                      precision: float | None = None) -> tuple[float, float]:
    """How far rounding alone moves the shape ratios ``phi[entries] / phi[reference]`` of one
    mode, to first order: every stored entry of ``K`` and ``M`` moved by one rounding unit (signs
    drawn with ``seed``), or for matrices known to a coarser ``precision`` the larger of that and
    every entry rounded once more to its digits (`export_rounding`; an estimate, why:
    docs/notes/eigen-solutions.md). The accuracy against which point shape data are checked
    (`vibupdate.inverse.verify`); one factorization of ``K - eigval M`` without the row and
    column of the largest ``|phi|`` (Nelson's method).

    Parameters
    ----------
    M, K : sparse matrix or ndarray, shape (n, n)
    eigval : float
        ``w^2`` of the mode, (rad/s)^2.
    phi : ndarray, shape (n,)
        The mode (any scaling).
    entries : sequence of int, or sparse matrix, shape (n_e, n)
        DOF indices of the ratios' numerators, or their measurement map
        (`vibupdate.modal.readings.readings`).
    reference : int or sparse matrix, shape (1, n)
        DOF index (or measurement map) of the denominator, where ``phi`` must not vanish.
    basis : ndarray, shape (n, k), optional
        For a mode of a repeated frequency (`vibupdate.inverse.repeated`): the vectors of its
        eigenspace, ``phi`` a combination of them. The change is then the eigenspace's, out of
        it: the right-hand sides and the solution are cleared of the eigenspace (a turn within
        it is another combination, which the caller's check is free to take), and ``k`` rows
        and columns are removed instead of one. Without it, the change grows as the inverse of
        the gap to the nearest other mode, without bound for an exactly repeated one.
    seed : int
        Seed of the signs.
    precision : float, optional
        Relative precision of the entries of ``K`` and ``M`` (a model's ``matrix_precision``);
        None: double precision.

    Returns
    -------
    rounding : float
        Largest absolute change of the ratios (dimensionless) under rounding.
    own : float
        The computed vector's own error: the largest first-order change of the ratios that
        its residual ``K phi - eigval M phi`` calls for (a second right-hand side of the same
        solve): a dense solver is backward stable only in norm, not entry by entry.
    """
    Ms, Ks = sp.csr_matrix(M), sp.csr_matrix(K)
    phi = np.asarray(phi, dtype=float)
    n = phi.size
    rng = np.random.default_rng(seed)
    eps = unit()
    # one rounding unit per stored entry, the signs within a row aligned (the componentwise
    # backward error of a stable solver), the rows' signs drawn: b_i = +-eps ((|K| + w^2 |M|) |phi|)_i.
    # Independent signs per entry cancel within a row and put the floor a factor
    # sqrt(entries per row) too low (`benchmarks/RESULTS.md`, "Figures behind src/: accurate low modes").
    size = abs(Ks) @ np.abs(phi) + abs(eigval) * (abs(Ms) @ np.abs(phi))
    b = eps * size * rng.choice([-1.0, 1.0], size=n)
    U = phi[:, None] if basis is None else np.asarray(basis, dtype=float)
    MU = Ms @ U
    G = U.T @ MU
    rhs = [b, -(Ks @ phi - eigval * (Ms @ phi))]
    if unit(precision) > eps:   # what the export's digits do to the mode
        rhs.append((export_rounding(Ks, precision) - Ks) @ phi
                   - eigval * ((export_rounding(Ms, precision) - Ms) @ phi))
    rhs = np.column_stack(rhs)
    B = rhs - MU @ np.linalg.solve(G, U.T @ rhs)   # the eigenvalue's own change (and the eigenspace's turn)
    if U.shape[1] == 1:
        removed = [int(np.argmax(np.abs(phi)))]
    else:   # rows where the eigenspace's vectors are most independent (Nelson's method for a repeated root)
        removed = sorted(sla.qr(U.T, mode="r", pivoting=True)[1][:U.shape[1]].tolist())
    keep = np.delete(np.arange(n), removed)
    A = (Ks - eigval * Ms)[keep][:, keep]
    V = np.zeros((n, B.shape[1]))
    if n > 400:
        V[keep] = sparse_lu(A).solve(B[keep])
    else:
        V[keep] = sla.solve(A.toarray(), B[keep], assume_a="sym")
    if U.shape[1] > 1:
        V = V - U @ np.linalg.solve(G, MU.T @ V)
    D = ratio_derivatives(V, phi, entries, reference)
    if not D.size:
        return 0.0, 0.0
    worst = np.max(np.abs(D), axis=0)
    rounding = max(worst[0], worst[2]) if worst.size > 2 else worst[0]
    return float(rounding), float(worst[1])


def export_rounding(A, precision: float):
    """``A`` (sparse) with every entry rounded to the significant digits a relative
    ``precision`` stands for, ``floor(1 - log10(2 precision))`` (10 for 5e-10): the rounding a
    text export of that precision applies, drawn afresh."""
    digits = max(1, int(np.floor(1.0 - np.log10(2.0 * precision) + 1e-9)))
    out = sp.csr_matrix(A, dtype=float, copy=True)
    x = out.data
    nonzero = x != 0
    scale = 10.0 ** (digits - 1 - np.floor(np.log10(np.abs(x[nonzero]))))
    x[nonzero] = np.round(x[nonzero] * scale) / scale
    return out
