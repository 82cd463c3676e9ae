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


def _fit(configurations, shape_weight: float, x0=None, tol=None) -> FrequencyFit:
    from vibupdate.inverse.polish import bounded_least_squares, polish_residuals

    configurations = list(configurations)
    model = configurations[0].model
    lo, hi = model.bounds()
    x0 = np.zeros(model.n_parameters) if x0 is None else np.asarray(x0, dtype=float)
    start = time.perf_counter()
    sol = bounded_least_squares(lambda x: polish_residuals(configurations, x, shape_weight),
                                x0, lo, hi, max_nfev=MAX_EVALUATIONS,
                                **({} if tol is None else {"ftol": tol, "xtol": tol, "gtol": tol}))
    seconds = time.perf_counter() - start
    r = polish_residuals(configurations, sol.x, shape_weight=0.0, jacobian=False)[0]
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
