"""Classical baseline: frequency-residual least squares over the same parameters and bounds.

    min_xbar  sum_k ((w_k(xbar) - w_k,measured) / w_k,measured)^2,   xbar in its box

solved by `scipy.optimize.least_squares` (trust-region reflective) from the nominal model,
with the exact Jacobian (`vibupdate.modal.sensitivities`) and one eigen-solve per evaluation: what a
competent engineer would write. It is the sensitivity-based method the paper compares with,
used as the benchmark peer: local, no mode-shape intervals, no certificate.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vibupdate.data.measured import Configuration

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
    from vibupdate.inverse.polish import fit_least_squares, polish_residuals

    configurations = list(configurations)
    model = configurations[0].model
    start = time.perf_counter()
    sol = fit_least_squares(configurations, np.zeros(model.n_parameters), shape_weight=0.0)
    seconds = time.perf_counter() - start
    r = polish_residuals(configurations, sol.x, shape_weight=0.0, jacobian=False)[0]
    weights = np.concatenate([[f.weight for f in c.natural] + [a.weight for a in c.antiresonances]
                              for c in configurations])
    err = 100 * np.abs(r) / np.sqrt(weights)
    return FrequencyFit(sol.x, model.physical(sol.x), float(err.mean()), bool(sol.success), sol.message,
                        seconds, int(sol.nfev))
