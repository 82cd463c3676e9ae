"""The Caughey series and its weighted least-squares fit, paper Eqs. 20-24 (docs/method.md, section
8): ``xi_k = 1/2 sum_h beta_h w_k^(2h - 1)`` (Eq. 21) stacked as ``Theta beta = xi`` (Eqs. 22-23),
solved as ``beta = (Theta^T W Theta)^-1 Theta^T W xi`` (Eq. 24) on the column-scaled system.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla


class DampingWarning(UserWarning):
    """The damping least squares is ill-conditioned or under-determined."""


@dataclass(frozen=True)
class DampingFit:
    """A fitted Caughey series.

    Attributes
    ----------
    exponents : ndarray, shape (n_h,)
        The set ``Y``.
    beta : ndarray, shape (n_h,)
        Coefficients; ``beta_h`` has units s^(1 - 2h).
    omega : ndarray, shape (n_data,)
        Frequencies (rad/s) of the data points.
    measured, fitted : ndarray, shape (n_data,)
        Damping ratios (-).
    weights : ndarray, shape (n_data, n_data)
        The weight matrix ``W``.
    labels : tuple of (str, int)
        ``(configuration, mode)`` of each data point, mode 1-based.
    condition : float
        Condition number of the column-scaled weighted system.
    notes : tuple of str
        What was done about conditioning or rank, in words.
    """

    exponents: np.ndarray
    beta: np.ndarray
    omega: np.ndarray
    measured: np.ndarray
    fitted: np.ndarray
    weights: np.ndarray
    labels: tuple
    condition: float
    notes: tuple[str, ...]

    @property
    def errors_pct(self) -> np.ndarray:
        """Absolute relative errors in per cent, Eq. 27."""
        return 100.0 * np.abs(self.fitted - self.measured) / np.abs(self.measured)

    @property
    def mean_error_pct(self) -> float:
        return float(np.mean(self.errors_pct))

    def ratios(self, omega) -> np.ndarray:
        """Modal damping ratios of the series at frequencies ``omega`` (rad/s), Eq. 21."""
        return modal_damping(self.exponents, self.beta, omega)


def _theta(omega, exponents) -> np.ndarray:
    omega = np.asarray(omega, dtype=float)
    return 0.5 * omega[:, None] ** (2.0 * np.asarray(exponents)[None, :] - 1.0)


def modal_damping(exponents, beta, omega) -> np.ndarray:
    """``xi(w) = 1/2 sum_h beta_h w^(2h-1)`` for each ``w`` in ``omega`` (rad/s)."""
    return _theta(np.atleast_1d(omega), exponents) @ np.asarray(beta, dtype=float)


def check_exponents(exponents) -> np.ndarray:
    """The Caughey exponents as a float array; a ValueError unless finite, distinct and not empty."""
    Y = np.asarray(exponents, dtype=float).ravel()
    if Y.size == 0 or not np.all(np.isfinite(Y)):
        raise ValueError(f"Caughey exponents must be a non-empty set of finite numbers, got {list(exponents)!r}")
    if np.unique(Y).size != Y.size:
        raise ValueError(f"Caughey exponents must be distinct, got {Y.tolist()}")
    return Y


def _weight_matrix(weights, n: int) -> np.ndarray:
    if weights is None:
        return np.eye(n)
    W = np.asarray(weights, dtype=float)
    if W.ndim == 1:
        if W.shape != (n,):
            raise ValueError(f"damping weights must have {n} entries (one per ratio), got {W.shape[0]}")
        if np.any(W <= 0) or not np.all(np.isfinite(W)):
            raise ValueError(f"damping weights must be positive and finite, got {W.tolist()}")
        return np.diag(W)
    if W.shape != (n, n):
        raise ValueError(f"damping weight matrix must be {n} x {n}, got {W.shape}")
    if not np.allclose(W, W.T) or np.any(np.linalg.eigvalsh(W) <= 0):
        raise ValueError("damping weight matrix must be symmetric positive definite (Eq. 24)")
    return W


def fit_caughey(omega, ratios, exponents, weights=None, labels=None, *,
                condition_limit: float = 1e10) -> DampingFit:
    """Weighted least-squares Caughey fit, Eq. 24.

    Parameters
    ----------
    omega : array_like, shape (n_data,)
        Natural frequencies (rad/s) at which the ratios were measured.
    ratios : array_like, shape (n_data,)
        Measured modal damping ratios, > 0.
    exponents : array_like, shape (n_h,)
        The set ``Y`` (e.g. ``[-1.5, -0.75, 0]``, Rayleigh ``[0, 1]``).
    weights : array_like, shape (n_data,) or (n_data, n_data), optional
        Diagonal weights or the full positive definite ``W``; identity by default.
    labels : sequence, optional
        ``(configuration, mode)`` per data point, carried into the result.
    condition_limit : float
        Above this condition number of the column-scaled system a `DampingWarning` is issued.

    Returns
    -------
    DampingFit
        Under-determined systems (fewer ratios than exponents, or rank deficient) get the
        minimum-norm solution of the column-scaled system, with a warning and a note.
    """
    Y = check_exponents(exponents)
    omega = np.asarray(omega, dtype=float).ravel()
    xi = np.asarray(ratios, dtype=float).ravel()
    if omega.shape != xi.shape or omega.size == 0:
        raise ValueError(f"need one frequency per damping ratio, got {omega.size} and {xi.size}")
    if np.any(~np.isfinite(omega)) or np.any(omega <= 0):
        raise ValueError(f"damping fit needs positive finite frequencies, got {omega.tolist()}")
    if np.any(~np.isfinite(xi)) or np.any(xi <= 0):
        bad = float(xi[~np.isfinite(xi) | (xi <= 0)][0])
        raise ValueError(f"measured damping ratios must be positive and finite, got {bad!r}")
    W = _weight_matrix(weights, xi.size)
    L = sla.cholesky(W, lower=False)              # W = L^T L
    T = L @ _theta(omega, Y)
    scale = np.linalg.norm(T, axis=0)
    scale[scale == 0] = 1.0
    Ts = T / scale
    b = L @ xi
    sol, _, rank, sv = sla.lstsq(Ts, b)
    beta = sol / scale
    condition = float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 else float("inf")
    notes = []
    if xi.size < Y.size or rank < Y.size:
        notes.append(f"damping fit under-determined: {xi.size} ratios, {Y.size} exponents, rank {rank}; "
                     "the minimum-norm solution of the column-scaled system was taken")
    elif condition > condition_limit:
        notes.append(f"damping fit ill-conditioned (condition {condition:.2e} after column scaling): "
                     "the exponents give nearly dependent columns over the measured band")
    for msg in notes:
        warnings.warn(msg, DampingWarning, stacklevel=2)
    labels = tuple(labels) if labels is not None else tuple(("", i + 1) for i in range(xi.size))
    return DampingFit(Y, beta, omega, xi, _theta(omega, Y) @ beta, W, labels, condition, tuple(notes))
