"""Classical baselines: the local least-squares fits a competent engineer would write.

Both start from the nominal model, keep the parameters in their box and are solved by
`scipy.optimize.least_squares` (trust-region reflective) with the exact Jacobian
(`vibupdate.modal.sensitivities`) and one eigen-solve per evaluation (dense up to 400 DOFs,
sparse shift-invert above); they are the benchmark peers of `update`.

`frequency_fit` (sensitivity-based updating on natural frequencies, the method the paper
compares with)::

    min_xbar  sum_k w_k ((w_k(xbar) - w_k,measured) / w_k,measured)^2

`eigenvector_fit` (the modal property difference method: frequencies and mode shapes)::

    min_xbar  sum_k w_k ((w_k(xbar) - w_k,measured) / w_k,measured)^2
            + sum_k sum_j (phi_jk(xbar) / phi_pk(xbar) - phi_jk,measured / phi_pk,measured)^2

where a measured shape is compared through its ratios to its reference entry ``p`` (the entry
of largest measured magnitude, `ShapeInterval.reference`) and the measured value is the
interval midpoint. Local, no use of the interval widths, no certificate.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vibupdate.data.measured import Configuration
from vibupdate.inverse.bounded_lsq import bounded_least_squares
from vibupdate.inverse.data_map import data_map


#: Residual evaluations at most (each one eigen-solve per configuration).
MAX_EVALUATIONS = 200


@dataclass(frozen=True)
class FrequencyFit:
    """Outcome of a baseline fit.

    Attributes
    ----------
    xbar, values : ndarray, shape (n_x,)
        Normalized and physical parameters found.
    mean_error_pct : float
        Mean absolute error over all measured frequencies, per cent.
    success : bool
    message : str
        scipy's status and message.
    seconds : float
    n_evaluations : int
    """

    xbar: np.ndarray
    values: np.ndarray
    mean_error_pct: float
    success: bool
    message: str
    seconds: float
    n_evaluations: int


def classical_residuals(configurations: Sequence[Configuration], xbar, shape_weight: float = 1.0,
                        jacobian: bool = True):
    """Residuals of the classical fit and their exact Jacobian: each declared frequency's
    relative error times ``sqrt(weight)``, then ``shape_weight`` times each shape ratio's and
    each modal mass's signed difference from its interval's midpoint (the mass relative to it):
    the residuals of `frequency_fit` (``shape_weight`` 0) and `eigenvector_fit`, and the data
    the minimum change keeps (`vibupdate.inverse.minimum_change`).

    Returns
    -------
    r : ndarray, shape (n_r,)
        Per configuration, in the order of the data map (`vibupdate.inverse.data_map`).
    J : ndarray, shape (n_r, n_x), or None without ``jacobian``
    """
    res, jac = [], []
    for cfg in configurations:
        d = data_map(cfg, xbar, jacobian=jacobian, shapes=shape_weight > 0)
        measured = (*cfg.natural, *cfg.antiresonances)
        w = np.array([m.omega for m in measured])
        s = np.sqrt([m.weight for m in measured])
        lost = np.isnan(d.frequency_values)   # a zero the model lost: a constant penalty, no direction to follow
        res.append(np.where(lost, s, s * (d.frequency_values - w) / w))
        if jacobian:
            jac.append(np.where(lost[:, None], 0.0, s[:, None] * d.frequency_jacobian / w[:, None]))
        for k, (shape, ratio) in enumerate(zip(d.shapes, d.ratios)):
            res.append(shape_weight * (ratio - shape.midpoint))
            if jacobian:
                jac.append(shape_weight * d.ratio_jacobians[k])
        mid = np.array([0.5 * sum(shape.mass) for shape in d.shapes if shape.mass is not None])
        if mid.size:
            res.append(shape_weight * (d.masses - mid) / mid)
            if jacobian:
                jac.append(shape_weight * d.mass_jacobian / mid[:, None])
    r = np.concatenate(res) if res else np.zeros(0)
    return r, (np.vstack(jac) if jacobian and jac else None)


def _fit(configurations, shape_weight: float, x0=None, tol=None) -> FrequencyFit:
    configurations = list(configurations)
    model = configurations[0].model
    lo, hi = model.bounds()
    x0 = np.zeros(model.n_parameters) if x0 is None else np.asarray(x0, dtype=float)
    start = time.perf_counter()
    sol = bounded_least_squares(lambda x: classical_residuals(configurations, x, shape_weight),
                                x0, lo, hi, max_nfev=MAX_EVALUATIONS,
                                **({} if tol is None else {"ftol": tol, "xtol": tol, "gtol": tol}))
    seconds = time.perf_counter() - start
    r = classical_residuals(configurations, sol.x, shape_weight=0.0, jacobian=False)[0]
    weights = np.concatenate([[f.weight for f in c.natural] + [a.weight for a in c.antiresonances]
                              for c in configurations])
    err = 100 * np.abs(r) / np.sqrt(weights)
    return FrequencyFit(sol.x, model.physical(sol.x), float(err.mean()), bool(sol.success), sol.message,
                        seconds, int(sol.nfev))


def frequency_fit(configurations: Sequence[Configuration], *, tol: float | None = None) -> FrequencyFit:
    """Fit the shared parameters of ``configurations`` to their measured frequencies and
    antiresonances, from the nominal model.

    ``tol`` sets ``ftol``, ``xtol`` and ``gtol`` of `scipy.optimize.least_squares` (its
    defaults, 1e-8, when None: what a user would write; exact-data benchmarks pass the
    polish's 1e-12)."""
    return _fit(configurations, 0.0, tol=tol)


def eigenvector_fit(configurations: Sequence[Configuration], x0=None, *, tol: float | None = None) -> FrequencyFit:
    """Fit the shared parameters to the measured frequencies and the measured mode-shape
    ratios (interval midpoints), from the nominal model or from ``x0`` (shape (n_x,)),
    unit weight on each relative frequency and each shape ratio (module docstring); ``tol``
    as in `frequency_fit`."""
    return _fit(configurations, 1.0, x0, tol=tol)
