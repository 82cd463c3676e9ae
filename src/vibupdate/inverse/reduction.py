"""Craig-Bampton reduction of an affine model, for large models.

The unknown vectors are written in a basis that keeps the measured DOFs (and those of measured
receptances) as physical coordinates ``b`` and represents the others ``i`` by static constraint
modes and fixed-interface modes of the nominal model (Craig & Bampton, AIAA J. 6 (1968) 1313):

    u = T [u_b; q],   T = [[I, 0], [-K_ii^-1 K_ib, Phi_i]]

``T^T M(xbar) T`` and ``T^T K(xbar) T`` are again affine in ``xbar``; the rule and why:
docs/method.md, "Large models: Craig-Bampton reduction".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from vibupdate.model.affine import AffineModel
from vibupdate.modal.analysis import modes
from vibupdate.modal.factor import sparse_lu
from vibupdate.data.measured import Configuration


def kept_dofs(cfg: Configuration) -> list[str]:
    """The DOFs a reduction must keep physical: measured shape entries (the DOFs a sensor reads)
    and receptance DOFs."""
    keep = []
    sensors = {s.name: s for s in cfg.model.sensors}
    for f in cfg.natural:
        if f.shape is not None:   # a sensor's DOFs, so that it reads the reduced model alike
            keep += [d for name in f.shape.bounds
                     for d in ([d for d, _ in sensors[name].weights] if name in sensors else [name])]
    for a in cfg.antiresonances:
        keep += [a.response, a.excitation]
    return list(dict.fromkeys(keep))


def craig_bampton(model: AffineModel, keep: Sequence[str], n_interior: int) -> tuple[AffineModel, np.ndarray]:
    """Reduce ``model`` to the DOFs ``keep`` plus ``n_interior`` fixed-interface modes.

    Returns
    -------
    reduced : AffineModel
        DOFs: ``keep`` (physical) then ``"cb1"``, ``"cb2"``, ... (generalized).
    T : ndarray, shape (n, len(keep) + n_interior)
        ``u_full = T u_reduced``.
    """
    n = model.n_dofs
    b = np.array([model.dof(d) for d in keep], dtype=int)
    if b.size == 0:
        raise ValueError("a Craig-Bampton reduction needs at least one kept DOF")
    i = np.setdiff1d(np.arange(n), b)
    n_interior = int(min(n_interior, i.size))
    K0 = sp.csc_matrix(model.K0)
    Kii = K0[i][:, i].tocsc()
    Kib = K0[i][:, b].toarray()
    try:
        lu = sparse_lu(Kii)
    except RuntimeError as exc:
        raise ValueError(f"Craig-Bampton reduction: the interior stiffness is singular ({exc})") from None
    T = np.zeros((n, b.size + n_interior))
    T[b, np.arange(b.size)] = 1.0
    T[np.ix_(i, np.arange(b.size))] = -lu.solve(Kib)
    if n_interior:
        _, Phi = modes(sp.csr_matrix(model.M0)[i][:, i], Kii, n_interior, precision=model.matrix_precision)
        T[np.ix_(i, b.size + np.arange(n_interior))] = Phi

    names = tuple(keep) + tuple(f"cb{k + 1}" for k in range(n_interior))
    return _projected(model, T, names), T


def _project(A, T: np.ndarray) -> sp.csr_matrix:
    """``T^T A T`` (symmetrized), touching only the rows of ``T`` where ``A`` has entries: a
    parameter's matrix covers its own elements, often a small part of the model."""
    A = sp.csr_matrix(A)
    rows = np.flatnonzero(np.diff(A.indptr))
    out = T[rows].T @ (A[rows] @ T)
    out = 0.5 * (out + out.T)
    out[np.abs(out) < 1e-14 * max(np.abs(out).max(initial=0.0), 1e-300)] = 0.0
    return sp.csr_matrix(out)


def _projected(model: AffineModel, T: np.ndarray, names) -> AffineModel:
    """The affine model ``T^T M(xbar) T``, ``T^T K(xbar) T`` with DOF names ``names``."""
    return replace(model, dofs=tuple(names), M0=_project(model.M0, T), K0=_project(model.K0, T),
                   M_par=tuple(_project(A, T) for A in model.M_par),
                   K_par=tuple(_project(A, T) for A in model.K_par))


def ritz_reduction(model: AffineModel, keep: Sequence[str], vectors: np.ndarray,
                   rank_tol: float = 1e-12) -> tuple[AffineModel, np.ndarray]:
    """Reduce ``model`` to the DOFs ``keep`` plus the span of ``vectors`` (their other entries).

    ``T = [E_keep, Q]``: unit columns at the kept DOFs (physical coordinates, as in
    `craig_bampton`) and an orthonormal basis ``Q`` of ``vectors`` with their kept entries set
    to zero (rank-revealing QR, columns below ``rank_tol`` of the largest dropped). Every
    column of ``vectors`` lies in the span of ``T``, so a mode or an adjunct vector among them
    is exactly a vector of the reduced model, and by Rayleigh-Ritz its eigenvalue is exactly
    one of the reduced model's at the point where they were computed, with the same first
    derivatives when the vectors' own parameter derivatives are among ``vectors``
    (`vibupdate.inverse.polish`, the reduced rounds). No factorization is needed.

    Parameters
    ----------
    model : AffineModel
    keep : sequence of str
        DOFs kept as physical coordinates (measured entries, receptance DOFs).
    vectors : ndarray, shape (n, n_v)

    Returns
    -------
    reduced : AffineModel
        DOFs: ``keep`` then ``"ritz1"``, ``"ritz2"``, ...
    T : ndarray, shape (n, len(keep) + rank)
    """
    import scipy.linalg as sla

    n = model.n_dofs
    b = np.array([model.dof(d) for d in keep], dtype=int)
    W = np.array(vectors, dtype=float, copy=True).reshape(n, -1)
    W[b] = 0.0
    norms = np.linalg.norm(W, axis=0)
    W = W[:, norms > 0] / norms[norms > 0]
    if W.shape[1]:
        Q, R, _ = sla.qr(W, mode="economic", pivoting=True)
        diag = np.abs(np.diag(R))
        Q = Q[:, :int(np.count_nonzero(diag > rank_tol * diag[0]))]
    else:
        Q = W
    T = np.zeros((n, b.size + Q.shape[1]))
    T[b, np.arange(b.size)] = 1.0
    T[:, b.size:] = Q
    names = tuple(keep) + tuple(f"ritz{k + 1}" for k in range(Q.shape[1]))
    return _projected(model, T, names), T


def derivative_vectors(model: AffineModel, xbar, Phi: np.ndarray) -> np.ndarray:
    """Vectors that carry the modes ``Phi`` (shape (n, n_m), the model's at ``xbar``) through a
    change of each parameter: ``(K + s M)^-1 (K_i - lam_j M_i) phi_j`` for every parameter ``i``
    and mode ``j`` (``lam_j`` the mode's Rayleigh quotient, ``s`` the lowest of them: the
    modes are flexible, so the matrix is definite with rigid-body modes too): the static part of each mode's
    parameter derivative. With the modes themselves they are the basis of a reduced model that
    follows the parameters beyond first order (`vibupdate.inverse.update`, the uniqueness
    search on large models). One factorization; shape (n, n_x * n_m)."""
    Phi = np.asarray(Phi, dtype=float)
    if not Phi.size or not model.n_parameters:
        return np.zeros((model.n_dofs, 0))
    M, K = model.matrices(xbar)
    lam = np.einsum("ij,ij->j", Phi, K @ Phi) / np.einsum("ij,ij->j", Phi, M @ Phi)
    rhs = np.hstack([Ki @ Phi - (Mi @ Phi) * lam for Mi, Ki in zip(model.M_par, model.K_par)])
    return sparse_lu(K + float(lam.min()) * M).solve(rhs)


def wants_reduction(configurations: Sequence[Configuration], options) -> bool:
    """Whether ``options.reduction`` asks for a reduction of these configurations."""
    if options.reduction == "none":
        return False
    has_keep = all(kept_dofs(c) for c in configurations)
    if options.reduction == "craig-bampton":
        if not has_keep:
            raise ValueError("reduction 'craig-bampton' needs measured mode shapes or receptance DOFs in every "
                             "configuration (the DOFs it keeps)")
        return True
    return has_keep and max(c.model.n_dofs for c in configurations) > options.reduction_threshold


def reduce_configurations(configurations: Sequence[Configuration], n_interior: int):
    """Each configuration with its model reduced to its kept DOFs plus ``n_interior`` modes.

    Returns
    -------
    reduced : list of Configuration
    bases : list of ndarray
        The transformation ``T`` of each configuration.
    """
    out, bases = [], []
    for cfg in configurations:
        keep = kept_dofs(cfg)
        if not keep:
            raise ValueError(f"configuration {cfg.name!r}: reduction needs measured shapes or receptance DOFs to keep")
        reduced, T = craig_bampton(cfg.model, keep, n_interior)
        out.append(replace(cfg, model=reduced))
        bases.append(T)
    return out, bases
