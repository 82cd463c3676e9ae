"""Classical baseline: frequency-residual least squares over the same parameters and bounds.

    min_xbar  sum_k ((w_k(xbar) - w_k,measured) / w_k,measured)^2,   xbar in its box

solved by `scipy.optimize.least_squares` (trust-region reflective) from the nominal model,
with the exact Jacobian (`vibupdate.sensitivities`) and one eigen-solve per evaluation: what a
competent engineer would write. It is the sensitivity-based method the paper compares with,
used as the benchmark peer: local, no mode-shape intervals, no certificate.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from vibupdate.measured import Configuration

__all__ = ["FrequencyFit", "frequency_fit"]


@dataclass(frozen=True)
class FrequencyFit:
    """Outcome of the baseline fit: ``xbar`` (n_x,), ``values`` (n_x,), mean absolute error
    in per cent over all measured frequencies, scipy's status and message, and seconds."""

    xbar: np.ndarray
    values: np.ndarray
    mean_error_pct: float
    success: bool
    message: str
    seconds: float
    n_evaluations: int


def frequency_fit(configurations: Sequence[Configuration]) -> FrequencyFit:
    """Fit the shared parameters of ``configurations`` to their measured frequencies."""
    from vibupdate.polish import polish_residuals

    configurations = list(configurations)
    model = configurations[0].model
    lo, hi = model.bounds()
    cache: dict = {}

    def evaluate(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = polish_residuals(configurations, x, shape_weight=0.0)
        return cache[key]

    start = time.perf_counter()
    span = hi - lo  # a start strictly inside the box (parameters with nominal 0 sit on a bound)
    x0 = np.clip(np.zeros(model.n_parameters), lo + 1e-10 * span, hi - 1e-10 * span)
    sol = least_squares(lambda x: evaluate(x)[0], x0,
                        jac=lambda x: evaluate(x)[1], bounds=(lo, hi), x_scale="jac", method="trf")
    seconds = time.perf_counter() - start
    r = polish_residuals(configurations, sol.x, shape_weight=0.0, jacobian=False)[0]
    weights = np.concatenate([[f.weight for f in c.natural] + [a.weight for a in c.antiresonances]
                              for c in configurations])
    err = 100 * np.abs(r) / np.sqrt(weights)
    return FrequencyFit(sol.x, model.physical(sol.x), float(err.mean()), bool(sol.success), sol.message,
                        seconds, int(sol.nfev))
