"""Classical baseline: frequency-residual least squares over the same parameters and bounds.

    min_xbar  sum_k ((w_k(xbar) - w_k,measured) / w_k,measured)^2,   xbar in its box

solved by `scipy.optimize.least_squares` (trust-region reflective) from the nominal model.
It is the sensitivity-based method the paper compares with, used here as a benchmark
baseline: local, no mode-shape intervals, no certificate.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from vibupdate.correlation import model_frequencies
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


def _residuals(configurations, xbar) -> np.ndarray:
    out = []
    for cfg in configurations:
        f = model_frequencies(cfg, xbar)
        measured = np.array([n.omega for n in cfg.natural] + [a.omega for a in cfg.antiresonances])
        model = np.concatenate([f.natural, f.antiresonances])
        out.append((model - measured) / measured)
    return np.concatenate(out)


def frequency_fit(configurations: Sequence[Configuration]) -> FrequencyFit:
    """Fit the shared parameters of ``configurations`` to their measured frequencies."""
    configurations = list(configurations)
    model = configurations[0].model
    lo, hi = model.bounds()
    start = time.perf_counter()
    sol = least_squares(lambda x: _residuals(configurations, x), np.clip(np.zeros(model.n_parameters), lo, hi),
                        bounds=(lo, hi), x_scale="jac", method="trf")
    seconds = time.perf_counter() - start
    err = 100 * np.abs(_residuals(configurations, sol.x))
    return FrequencyFit(sol.x, model.physical(sol.x), float(err.mean()), bool(sol.success), sol.message,
                        seconds, int(sol.nfev))
