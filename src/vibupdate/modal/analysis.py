"""Modal analysis, the front end of the modal kernels: natural frequencies and modes
(`vibupdate.modal.eigen`), receptances (`vibupdate.modal.receptance`), antiresonances
(`vibupdate.modal.zeros`), paper Eqs. 2, 3 and 8, and the modal assurance criterion.

Everything works in rad/s. Receptance ``h_rc`` is the displacement of DOF ``r`` per unit
force at DOF ``c`` (m/N). The kernels' names the rest of the package uses are re-exported
here (``import name as name``).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from vibupdate.modal.eigen import (DENSE_LIMIT as DENSE_LIMIT, MASSLESS_TOL as MASSLESS_TOL, massless_dofs,
                                   ModalAccuracyError as ModalAccuracyError, mode_residuals as mode_residuals, modes)
from vibupdate.modal.receptance import receptance as receptance, receptances as receptances
from vibupdate.modal.zeros import (adjunct as adjunct, antiresonance_vectors as antiresonance_vectors,
                                   antiresonances as antiresonances)


def flexible_modes(M, K, n_modes: int | None = None, **options):
    """The lowest flexible modes, with the rigid-body modes apart.

    These are `modes` without the rigid-body modes (those `modes` returns at exactly 0 rad/s,
    `vibupdate.modal.rigid`).

    Measured natural frequencies are numbered by these (docs/vocabulary.md): mode 1 of a
    free-free test is the first flexible mode, whatever the number of rigid-body modes.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Symmetric mass and stiffness matrices of the model (SI: kg and N/m on translations,
        kg m^2 and N m/rad on rotations).
    n_modes : int, optional
        How many flexible modes; by default every finite one (dense) or 20 (sparse).
    **options
        ``dense``, ``rtol`` of `modes`.

    Returns
    -------
    omega : ndarray, shape (n_modes,)
        rad/s, ascending (fewer when the model has fewer flexible modes).
    Phi : ndarray, shape (n, n_modes)
        Mass-normalized.
    rigid : ndarray, shape (n, n_r)
        The rigid-body modes, mass-normalized.
    """
    n_finite = M.shape[0] - massless_dofs(M).size
    want = None if n_modes is None else min(n_modes, n_finite)
    while True:
        omega, Phi = modes(M, K, want, **options)
        zero = omega == 0
        n_rigid = int(np.count_nonzero(zero))
        if n_modes is None or omega.size - n_rigid >= n_modes or omega.size >= n_finite:
            break
        want = min(n_finite, n_modes + n_rigid + (n_rigid == omega.size) * omega.size)
    flexible = np.flatnonzero(~zero)
    if n_modes is not None:
        flexible = flexible[:n_modes]
    return omega[flexible], Phi[:, flexible], Phi[:, zero]


def mac(A, B) -> np.ndarray:
    """Modal assurance criterion between two sets of shapes.

    Parameters
    ----------
    A : ndarray, shape (n, m_a) or (n,)
        The first set of shapes, one per column (real or complex, any scaling).
    B : ndarray, shape (n, m_b) or (n,)
        The second set, on the same ``n`` coordinates as ``A``.

    Returns
    -------
    ndarray, shape (m_a, m_b)
        ``|a_i^H b_j|^2 / ((a_i^H a_i)(b_j^H b_j))``, between 0 and 1.
    """
    A, B = (np.asarray(X)[:, None] if np.ndim(X) == 1 else np.asarray(X) for X in (A, B))
    if A.shape[0] != B.shape[0]:
        raise ValueError(f"MAC needs shapes of equal length, got {A.shape[0]} and {B.shape[0]}")
    num = np.abs(A.conj().T @ B) ** 2
    den = np.outer(np.sum(np.abs(A) ** 2, axis=0), np.sum(np.abs(B) ** 2, axis=0))
    return num / den


def subspace_mac(shape: np.ndarray, U: np.ndarray) -> float:
    """MAC of a measured ``shape``, shape (n_s,), with the best combination of the columns of
    ``U``, shape (n_s, k): the squared cosine of its angle with their span."""
    shape = np.asarray(shape, dtype=float)
    denom = float(shape @ shape)
    if denom == 0.0:
        return 0.0
    Q = scipy.linalg.orth(np.asarray(U, dtype=float))
    p = Q.T @ shape
    return float(p @ p) / denom
