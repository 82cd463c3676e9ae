"""Modal analysis, the front end of the modal kernels: natural frequencies and modes
(`vibupdate.modal.eigen`), receptances (`vibupdate.modal.receptance`), antiresonances
(`vibupdate.modal.zeros`), paper Eqs. 2, 3 and 8, and the modal assurance criterion.

Everything works in rad/s. Receptance ``h_rc`` is the displacement of DOF ``r`` per unit
force at DOF ``c`` (m/N). The public names of the three kernel modules are importable from
here.
"""

from __future__ import annotations

import numpy as np

from vibupdate.modal.eigen import (
    DENSE_LIMIT,
    DENSE_MAX,
    MASSLESS_TOL,
    RESIDUAL_TOL,
    ModalAccuracyError,
    massless_dofs,
    mode_residuals,
    modes,
)
from vibupdate.modal.receptance import receptance, receptances
from vibupdate.modal.zeros import adjunct, antiresonances

__all__ = ["modes", "mode_residuals", "receptance", "receptances", "adjunct", "antiresonances", "mac", "massless_dofs",
           "MASSLESS_TOL", "DENSE_LIMIT", "DENSE_MAX", "RESIDUAL_TOL", "ModalAccuracyError"]


def mac(A, B) -> np.ndarray:
    """Modal assurance criterion between two sets of shapes.

    Parameters
    ----------
    A : ndarray, shape (n, m_a)
    B : ndarray, shape (n, m_b)

    Returns
    -------
    ndarray, shape (m_a, m_b)
        ``|a_i^H b_j|^2 / ((a_i^H a_i)(b_j^H b_j))``, between 0 and 1.
    """
    A = np.asarray(A)
    B = np.asarray(B)
    A = A[:, None] if A.ndim == 1 else A
    B = B[:, None] if B.ndim == 1 else B
    if A.shape[0] != B.shape[0]:
        raise ValueError(f"MAC needs shapes of equal length, got {A.shape[0]} and {B.shape[0]}")
    num = np.abs(A.conj().T @ B) ** 2
    den = np.outer(np.sum(np.abs(A) ** 2, axis=0), np.sum(np.abs(B) ** 2, axis=0))
    return num / den
