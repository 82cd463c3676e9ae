"""Damping models of a fitted Caughey series for receptances and export: the damping matrix
``C = M Phi diag(sum_h beta_h w^(2h)) Phi^T M`` (Eq. 20 without matrix powers, dense n x n) on
models up to `vibupdate.modal.eigen.DENSE_LIMIT` DOFs, and above that the series kept as its
modal law (`CaugheyLaw`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vibupdate.damping.series import check_exponents, modal_damping
from vibupdate.modal.analysis import DENSE_LIMIT, modes
from vibupdate.modal.eigen import massless_dofs


@dataclass(frozen=True)
class CaugheyLaw:
    """A Caughey series kept as its modal law instead of a matrix, for models where the
    (dense, n x n) ``C`` of `caughey_matrix` is too large to build.

    Attributes
    ----------
    exponents, beta : tuple of float
        The series (Eq. 20).
    n_modes : int
        Modes of the modal superposition used for receptances.
    """

    exponents: tuple[float, ...]
    beta: tuple[float, ...]
    n_modes: int

    def receptances(self, M, K, pairs, omega) -> np.ndarray:
        """``h_rc(j omega)`` (m/N) of every ``(r, c)`` in ``pairs`` by modal superposition of the
        lowest ``n_modes`` modes (one eigen-solve for all pairs), each with its modal damping
        ratio from the law, plus the residual flexibility of the modes above them
        (`vibupdate.modal.receptance.modal_sum`); all modes when ``n_modes`` reaches them.

        Parameters
        ----------
        M, K : sparse or ndarray, shape (n, n)
        pairs : sequence of (int, int), length n_pairs
            Response and excitation DOF indices (0-based).
        omega : array_like, shape (n_f,)
            Angular frequencies, rad/s.

        Returns
        -------
        ndarray of complex, shape (n_pairs, n_f)
        """
        from vibupdate.modal.receptance import classical_terms, modal_sum

        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        law = lambda w: modal_damping(self.exponents, self.beta, w)   # noqa: E731
        if self.n_modes < M.shape[0] - massless_dofs(M).size - 1:
            return modal_sum(M, K, pairs, omega, law, n_modes=self.n_modes)
        return classical_terms(*modes(M, K), pairs, omega, law)

    def receptance(self, M, K, r: int, c: int, omega) -> np.ndarray:
        """``h_rc(j omega)`` of one pair (`receptances`), shape (n_f,), m/N."""
        return self.receptances(M, K, [(r, c)], omega)[0]


def caughey_damping(M, K, exponents, beta, top_mode: int, *, spectrum=None):
    """The damping model of a Caughey series for receptances and export: the matrix
    `caughey_matrix` (N s/m, dense n x n) up to `DENSE_LIMIT` DOFs, above that its modal law
    (`CaugheyLaw`) over ``max(40, 2 top_mode + 10)`` modes, where ``top_mode`` is the highest
    measured mode: plots reach 1.25 times the highest measured frequency, which about twice as
    many modes cover with a margin on the sparse models this path is for. ``spectrum``: every
    finite mode of ``(M, K)`` when already computed (`caughey_matrix`)."""
    if M.shape[0] <= DENSE_LIMIT:
        return caughey_matrix(M, K, exponents, beta, spectrum=spectrum)
    return CaugheyLaw(tuple(float(y) for y in exponents), tuple(float(b) for b in beta), max(40, 2 * top_mode + 10))


def caughey_matrix(M, K, exponents, beta, *, spectrum=None) -> np.ndarray:
    """Damping matrix of a Caughey series (Eq. 20) without matrix powers.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Mass and stiffness matrices of the model (SI units).
    exponents, beta : array_like, shape (n_h,)
        The series: the exponents ``Y`` and their coefficients, ``beta_h`` in s^(1 - 2h).
        Negative exponents need a model without rigid-body modes.
    spectrum : (ndarray, ndarray), optional
        Every finite mode of ``(M, K)``, ``(omega, Phi)`` of shapes (n_f,) rad/s and (n, n_f)
        mass-normalized, when already computed (`vibupdate.inverse.correlation.ModelFrequencies`
        ``.spectrum``); solved here otherwise.

    Returns
    -------
    ndarray, shape (n, n)
        ``C = M Phi diag(sum_h beta_h w^(2h)) Phi^T M`` (N s/m), symmetric.
    """
    Y = check_exponents(exponents)
    omega, Phi = modes(M, K) if spectrum is None else spectrum
    if np.any(omega <= 0) and np.any(Y < 0):
        raise ValueError("a Caughey series with negative exponents needs a model without rigid-body modes")
    d = np.zeros_like(omega)
    positive = omega > 0
    d[positive] = (omega[positive, None] ** (2.0 * Y[None, :])) @ np.asarray(beta, dtype=float)
    Md = M.toarray() if hasattr(M, "toarray") else np.asarray(M)
    MP = Md @ Phi
    C = (MP * d) @ MP.T
    return 0.5 * (C + C.T)
