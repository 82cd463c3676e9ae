"""Second stage: Caughey-series damping from measured modal damping ratios (Eqs. 20-24).

    C = M sum_h beta_h (M^-1 K)^h,          h in Y (any finite set of real exponents)

For mass-normalized modes ``Phi`` of the updated ``(K, M)``, ``Phi^T C Phi`` is diagonal with
``2 xi_k w_k = sum_h beta_h w_k^(2h)``, so (Eq. 21)

    xi_k = 1/2 sum_h beta_h w_k^(2h - 1).

Stacking every measured ratio of every configuration gives ``Theta beta = xi`` (Eqs. 22-23),
solved in the weighted least-squares sense ``beta = (Theta^T W Theta)^-1 Theta^T W xi``
(Eq. 24). One ``beta`` is shared by all configurations. The frequencies in ``Theta`` are those
of the updated model, so that the identified ``C`` reproduces the fitted ratios exactly.
``C`` itself is built as ``M Phi diag(sum_h beta_h w^(2h)) Phi^T M`` (no matrix powers).
Rayleigh damping is ``Y = [0, 1]``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from vibupdate.modal.analysis import DENSE_LIMIT, modes

#: Modes whose Caughey damping is checked on models above DENSE_LIMIT DOFs.
LARGE_MODEL_CHECKED_MODES = 50

__all__ = ["DampingFit", "fit_caughey", "caughey_matrix", "caughey_damping", "CaugheyLaw", "modal_damping", "DampingWarning", "negative_bands",
           "damping_sanity"]


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
        ratio from the law; exact for these modes (the law is classical damping), truncated
        above them.

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
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        w, Phi = modes(M, K, None if self.n_modes >= M.shape[0] else self.n_modes)
        rows = np.array([p[0] for p in pairs], dtype=int)
        cols = np.array([p[1] for p in pairs], dtype=int)
        xi = np.zeros_like(w)
        xi[w > 0] = modal_damping(self.exponents, self.beta, w[w > 0])
        den = w[:, None] ** 2 - omega[None, :] ** 2 + 2j * xi[:, None] * w[:, None] * omega[None, :]
        return (Phi[rows] * Phi[cols]) @ (1.0 / den)

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


def modal_damping(exponents, beta, omega) -> np.ndarray:
    """``xi(w) = 1/2 sum_h beta_h w^(2h-1)`` for each ``w`` in ``omega`` (rad/s)."""
    return _theta(np.atleast_1d(omega), exponents) @ np.asarray(beta, dtype=float)


def _check_exponents(exponents) -> np.ndarray:
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
    Y = _check_exponents(exponents)
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
        msg = (f"damping fit under-determined: {xi.size} ratios, {Y.size} exponents, rank {rank}; "
               "the minimum-norm solution of the column-scaled system was taken")
        notes.append(msg)
        warnings.warn(msg, DampingWarning, stacklevel=2)
    elif condition > condition_limit:
        msg = (f"damping fit ill-conditioned (condition {condition:.2e} after column scaling): "
               "the exponents give nearly dependent columns over the measured band")
        notes.append(msg)
        warnings.warn(msg, DampingWarning, stacklevel=2)
    labels = tuple(labels) if labels is not None else tuple(("", i + 1) for i in range(xi.size))
    return DampingFit(Y, beta, omega, xi, _theta(omega, Y) @ beta, W, labels, condition, tuple(notes))


def caughey_matrix(M, K, exponents, beta, *, spectrum=None) -> np.ndarray:
    """Damping matrix of a Caughey series (Eq. 20) without matrix powers.

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
    exponents, beta : array_like, shape (n_h,)
    spectrum : (ndarray, ndarray), optional
        Every finite mode of ``(M, K)``, ``(omega, Phi)`` of shapes (n_f,) rad/s and (n, n_f)
        mass-normalized, when already computed (`vibupdate.inverse.correlation.ModelFrequencies`
        ``.spectrum``); solved here otherwise.

    Returns
    -------
    ndarray, shape (n, n)
        ``C = M Phi diag(sum_h beta_h w^(2h)) Phi^T M`` (N s/m), symmetric.
    """
    Y = _check_exponents(exponents)
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
    for k in range(1, grid.size):
        if (values[k - 1] < 0) != (values[k] < 0):
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


def _checked_frequencies(configurations, xbar, freqs=None) -> list[np.ndarray]:
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
        out.append(modes(M, K)[0] if n <= DENSE_LIMIT else modes(M, K, min(n - 1, LARGE_MODEL_CHECKED_MODES))[0])
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
        The configurations' natural frequencies from `_checked_frequencies` (computed when
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
        frequencies = _checked_frequencies(configurations, xbar)
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


@dataclass(frozen=True)
class DampingStage:
    """The second stage over several configurations: the Caughey fit and the Rayleigh
    baseline (``Y = [0, 1]``), both on the updated model's natural frequencies, and the
    warnings of `damping_sanity` for both."""

    caughey: DampingFit
    rayleigh: DampingFit
    warnings: tuple[str, ...] = ()

    def rows(self) -> list[dict]:
        """``damping`` rows of ``results.json``, plus the Rayleigh value of each ratio."""
        return [
            {"configuration": cfg, "mode": mode, "measured": float(m), "identified": float(c),
             "error_pct": float(e), "rayleigh": float(r), "error_rayleigh_pct": float(er)}
            for (cfg, mode), m, c, e, r, er in zip(
                self.caughey.labels, self.caughey.measured, self.caughey.fitted, self.caughey.errors_pct,
                self.rayleigh.fitted, self.rayleigh.errors_pct)
        ]

    def summary(self) -> dict:
        return {"mean_damping_error_pct": self.caughey.mean_error_pct,
                "mean_damping_error_rayleigh_pct": self.rayleigh.mean_error_pct}


def _modal_data(configurations, freqs):
    """``freqs`` as a list in the order of ``configurations`` (a mapping is keyed by name)."""
    if freqs is None:
        return None
    if isinstance(freqs, dict):
        return [freqs[c.name] for c in configurations]
    return list(freqs)


def damping_data(configurations, xbar=None, freqs=None):
    """Measured ratios with the paired updated-model frequencies: (omega, ratios, labels).

    ``freqs``: the `vibupdate.inverse.correlation.ModelFrequencies` of each configuration at
    ``xbar`` (a sequence, or a mapping by configuration name such as ``UpdateResult.modal``)
    when already computed; solved here otherwise."""
    from vibupdate.inverse.correlation import model_frequencies

    freqs = _modal_data(configurations, freqs)
    omega, ratios, labels = [], [], []
    for i, cfg in enumerate(configurations):
        paired = freqs[i] if freqs is not None else None
        for k, f in enumerate(cfg.natural):
            if f.damping_ratio is None:
                continue
            paired = paired or model_frequencies(cfg, xbar, zeros=False)
            omega.append(paired.natural[k])
            ratios.append(f.damping_ratio)
            labels.append((cfg.name, k + 1))
    if not ratios:
        raise ValueError("no measured damping ratio in any configuration: nothing to identify")
    return np.array(omega), np.array(ratios), tuple(labels)


def _expand_weights(weights, labels):
    """Weights given per mode number (mapping) become one weight per data point."""
    if isinstance(weights, dict):
        for key, value in weights.items():
            if not isinstance(key, (int, np.integer)) or key < 1:
                raise ValueError(f"damping weight keys must be mode numbers >= 1, got {key!r}")
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"damping weight of mode {key} must be positive, got {value!r}")
        return np.array([float(weights.get(mode, 1.0)) for _, mode in labels])
    return weights


def identify_damping(configurations: Sequence, xbar=None, exponents=(0.0, 1.0), weights=None, *,
                     freqs=None) -> DampingStage:
    """Second stage on the updated model (``xbar``; nominal if None).

    ``weights``: None, one weight per measured ratio (in configuration and mode order), a full
    matrix ``W``, or a mapping ``{mode number: weight}`` applied in every configuration.
    ``freqs``: the modal data of the configurations at ``xbar`` when already computed
    (``UpdateResult.modal``; `damping_data`): then no eigen-solve is repeated on the dense path.
    """
    freqs = _modal_data(configurations, freqs)
    omega, ratios, labels = damping_data(configurations, xbar, freqs)
    W = _expand_weights(weights, labels)
    caughey = fit_caughey(omega, ratios, exponents, W, labels)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DampingWarning)
        rayleigh = fit_caughey(omega, ratios, [0.0, 1.0], None, labels)
    frequencies = _checked_frequencies(configurations, xbar, freqs)  # one spectrum per configuration for both checks
    checks = (damping_sanity(caughey, configurations, xbar, f"Caughey fit (Y = {caughey.exponents.tolist()})",
                             frequencies=frequencies)
              + damping_sanity(rayleigh, configurations, xbar, "Rayleigh baseline", frequencies=frequencies))
    return DampingStage(caughey, rayleigh, checks)
