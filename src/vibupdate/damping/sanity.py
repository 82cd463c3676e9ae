"""Sanity of a fitted damping series: where its modal damping turns negative, and whether the
damping matrix of each configuration's updated model has negative eigenvalues (Sylvester's
law of inertia on ``C = (M Phi) diag(d) (M Phi)^T``).
"""

from __future__ import annotations

import numpy as np

from vibupdate.damping.series import DampingFit
from vibupdate.modal.analysis import DENSE_LIMIT, modes


#: Modes whose Caughey damping is checked on models above DENSE_LIMIT DOFs.
LARGE_MODEL_CHECKED_MODES = 50


def negative_bands(exponents, beta, top: float, *, n_grid: int = 4000) -> list[tuple[float, float]]:
    """Bands of ``(0, top]`` where the modal damping of a Caughey series is negative.

    ``xi(w)`` has the sign of ``g(w) = sum_h beta_h w^(2h)`` for ``w > 0``. Its sign changes
    are bracketed on a grid (uniform and geometric, down to ``1e-6 top``) and refined by
    Brent's method; near 0 the sign is that of the term with the lowest exponent.

    Parameters
    ----------
    exponents, beta : array_like, shape (n_h,)
    top : float
        Upper end of the band, rad/s.

    Returns
    -------
    list of (float, float)
        ``(low, high)`` in rad/s; ``low = 0`` when the damping is negative down to 0.
    """
    from scipy.optimize import brentq

    Y = np.asarray(exponents, dtype=float)
    b = np.asarray(beta, dtype=float)
    scale = top

    def g(w):
        return float(np.sum(b * (np.asarray(w) / scale) ** (2.0 * Y) * scale ** (2.0 * Y)))

    grid = np.unique(np.concatenate([np.linspace(top / n_grid, top, n_grid), np.geomspace(1e-6 * top, top, n_grid)]))
    values = np.sum(b * (grid[:, None] / scale) ** (2.0 * Y) * scale ** (2.0 * Y), axis=1)  # g on the grid
    nonzero = b != 0
    low_sign = np.sign(b[nonzero][np.argmin(Y[nonzero])]) if nonzero.any() else 0.0
    bands, start = [], (0.0 if low_sign < 0 else None)
    if start is None and values[0] < 0:
        start = float(grid[0])
    negative = values < 0
    for k in np.flatnonzero(negative[1:] != negative[:-1]) + 1:   # the grid points where the sign changes
        if values[k - 1] * values[k] < 0:
            root = brentq(g, grid[k - 1], grid[k], xtol=1e-12 * top)
        else:   # g is exactly 0 at one end of the bracket: that grid point is the root
            root = grid[k - 1] if values[k - 1] == 0 else grid[k]
        if values[k] < 0:
            start = float(root)
        else:
            bands.append((start, float(root)))
            start = None
    if start is not None:
        bands.append((start, float(top)))
    return bands


def _hz_band(low: float, high: float) -> str:
    return f"{low / (2 * np.pi):.4g}-{high / (2 * np.pi):.4g} Hz"


def checked_frequencies(configurations, xbar, freqs=None) -> list[np.ndarray]:
    """Natural frequencies (rad/s) of each configuration's updated model checked by
    `damping_sanity`: every mode where C is exported (up to DENSE_LIMIT DOFs; the
    ``spectrum`` of ``freqs`` when given); above, C is kept as its law and the modes checked
    are the lowest LARGE_MODEL_CHECKED_MODES."""
    out = []
    for k, cfg in enumerate(configurations):
        spectrum = freqs[k].spectrum if freqs is not None else None
        if spectrum is not None:
            out.append(spectrum[0])
            continue
        M, K = cfg.model.matrices(xbar)
        n = M.shape[0]
        wanted = None if n <= DENSE_LIMIT else min(n - 1, LARGE_MODEL_CHECKED_MODES)
        out.append(modes(M, K, wanted, precision=cfg.model.matrix_precision)[0])
    return out


def damping_sanity(fit: DampingFit, configurations, xbar, name: str, *, frequencies=None) -> tuple[str, ...]:
    """Warnings when a fitted series gives negative damping.

    Checks the modal damping over ``[0, 1.5 x the highest measured natural frequency]``, and
    the damping matrix of each configuration: ``C = (M Phi) diag(d) (M Phi)^T`` with
    ``d_k = sum_h beta_h w_k^(2h)`` over every mode of the updated model, so by Sylvester's law
    of inertia ``C`` has as many negative eigenvalues as there are negative ``d_k``.

    Parameters
    ----------
    fit : DampingFit
    configurations : sequence of Configuration
    xbar : ndarray, shape (n_x,) or None
        Updated normalized parameters (nominal if None).
    name : str
        What the fit is, for the messages (``"Caughey fit"``).
    frequencies : list of ndarray, optional
        The configurations' natural frequencies from `checked_frequencies` (computed when
        None); passed in to check several fits on one set of eigen-solves.

    Returns
    -------
    tuple of str
    """
    measured = [f.omega for c in configurations for f in c.natural]
    top = 1.5 * max(measured)
    out = []
    bands = negative_bands(fit.exponents, fit.beta, top)
    if bands:
        shown = ", ".join(_hz_band(lo, hi) for lo, hi in bands)
        out.append(f"{name}: negative modal damping at {shown} (checked over 0-{top / (2 * np.pi):.4g} Hz, "
                   "1.5 x the highest measured frequency); the damping model is not physical there")
    per_config, highest = [], top
    if frequencies is None:
        frequencies = checked_frequencies(configurations, xbar)
    for cfg, omega in zip(configurations, frequencies):
        highest = max(highest, float(omega[-1]))
        positive = omega > 0
        d = np.zeros_like(omega)
        d[positive] = (omega[positive, None] ** (2.0 * fit.exponents[None, :])) @ fit.beta
        bad = np.flatnonzero(d < 0)
        if bad.size:
            per_config.append(f"{cfg.name} ({bad.size}: modes {bad[0] + 1}-{bad[-1] + 1}, "
                              f"{_hz_band(omega[bad[0]], omega[bad[-1]])})")
    if per_config:
        beyond = [b for b in negative_bands(fit.exponents, fit.beta, highest) if b[1] > top]
        where = ", ".join(_hz_band(max(lo, 0.0), hi) for lo, hi in beyond)
        out.append(f"{name}: C has negative eigenvalues (modes of the updated model with negative damping) in "
                   f"configuration {'; '.join(per_config)}"
                   + (f"; the modal damping is negative at {where}" if where else ""))
    return tuple(out)
