"""Antiresonances of a fitted modal model (kernels of `vibupdate.data.extraction`):
the real zeros of the undamped fitted receptance, their standard errors by the
implicit-function rule with exact derivatives, and the local refit of a zero on the lines
around it. Frequencies normalized as in `vibupdate.data.modal_fit`; the method:
docs/frf-extraction.md, "Method", steps 3 and 4."""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
import scipy.optimize

from vibupdate.data.modal_fit import correlation_inflation, modal_basis, undamped_derivatives

LOCAL_FRACTION = 1 / 3      # local refit: window of this times the distance to the nearest pole ...
LOCAL_LINES = 21            # ... holding at least this many lines
GRID_CHUNK = 65536          # grid points evaluated at once by `zeros_of_all` (bounds its memory)


def zeros_of_all(x, coefs, xn, zeta):
    """Real zeros of the undamped fitted receptance of each FRF in (x[0], x[-1]): a list of
    arrays, one per row of ``coefs`` (n_fun, n_cols).

    Sign changes of the receptance times ``prod (w_r^2 - x^2)`` (which removes the sign
    changes at the poles) on a grid of 20 points per line, refined by Brent's method. The
    FRFs share the poles, so each stretch of the grid is evaluated once for all of them, in
    stretches of `GRID_CHUNK` points (the whole grid would hold 20 lines' worth of basis
    columns per line)."""
    coefs = np.asarray(coefs)
    grid = np.linspace(x[0], x[-1], max(20 * x.size, 4000))

    def g(t, c):  # (n_t, n_fun) for coefficient rows c
        t = np.atleast_1d(t)
        return (modal_basis(t, xn, zeta, False) @ c.T) * np.prod(xn[None, :] ** 2 - t[:, None] ** 2, axis=1)[:, None]

    brackets = []
    for lo in range(0, grid.size - 1, GRID_CHUNK):
        sign = np.sign(g(grid[lo:lo + GRID_CHUNK + 1], coefs))   # one point of overlap: no change missed
        point, fun = np.nonzero(sign[:-1] * sign[1:] < 0)
        brackets.append(np.column_stack([point + lo, fun]))
    brackets = np.vstack(brackets)
    out = []
    for k in range(coefs.shape[0]):
        idx = np.sort(brackets[brackets[:, 1] == k, 0])
        c = coefs[k:k + 1]
        out.append(np.array([scipy.optimize.brentq(lambda t: float(g(t, c)[0, 0]), grid[i], grid[i + 1], xtol=1e-14)
                             for i in idx]))
    return out


def _zero_window(z, x, xn, widen: bool = True) -> np.ndarray:
    """Indices of the lines that locate a zero ``z``: those within `LOCAL_FRACTION` of its
    distance to the nearest fitted pole (``xn``), at least `LOCAL_LINES` of them (widened to the
    nearest `LOCAL_LINES`, or none without ``widen``). Its width follows the structure (where the
    receptance turns from one pole's side to the next), not the line spacing."""
    d = LOCAL_FRACTION * float(np.min(np.abs(xn - z)))
    near = np.nonzero(np.abs(x - z) <= d)[0]
    if near.size < LOCAL_LINES:
        near = np.sort(np.argsort(np.abs(x - z))[:LOCAL_LINES]) if widen else near[:0]
    return near


def zero_snr(z, x, fitted, v, xn) -> float:
    """Signal-to-noise ratio of a zero ``z``: the median of ``|fitted| / sigma`` over the lines
    that locate it (`_zero_window`; ``fitted`` the damped fit (n_freq,), ``v`` its noise
    variance per line, ``xn`` the fitted poles). A zero of the structure has the receptance
    rise well above the noise on either side within that window; a zero made by noise, where
    the receptance lies in the noise floor across it, has the ratio near 1 or below."""
    near = _zero_window(z, x, xn)
    return float(np.median(np.abs(fitted[near]) / np.sqrt(v[near])))


def zero_se(z, coef, cov_coef, xn, zeta, cov_poles, slope_offset: float = 0.0):
    """Standard error of a zero ``z`` (normalized) of ``u(t) = b(t) coef (+ a local line)``.

    Implicit-function rule: ``dz = -(b dcoef + du/dw_n dw_n + du/dzeta dzeta) / u'(z)``, with
    ``cov_coef`` (n_cols, n_cols) and ``cov_poles`` (2 n, 2 n) of ``(w_n, zeta)``; every
    derivative exact (`undamped_derivatives`). ``slope_offset`` is the slope of a line added
    to ``u`` (the local correction of `local_zero`). Returns ``(se, u'(z))``."""
    t = np.array([z])
    b = modal_basis(t, xn, zeta, False)[0]
    d_x, d_wn, d_zeta = undamped_derivatives(t, xn, zeta)
    du_dz = float(d_x[0] @ coef) + slope_offset
    mode_coef = coef[1:2 * xn.size:2]  # each mode's column carries its Im A coefficient
    g_poles = -np.concatenate([d_wn[0] * mode_coef, d_zeta[0] * mode_coef]) / du_dz
    g_coef = -b / du_dz
    var = g_coef @ cov_coef @ g_coef + g_poles @ cov_poles @ g_poles
    return math.sqrt(max(float(var), 0.0)), du_dz


def local_zero(z, x, f, v, Phi, coef, xn, zeta, cov_poles):
    """A zero of the fitted receptance refined on the lines around it; ``None`` when the
    refined zero leaves the window.

    Parameters: ``z`` the global zero; ``x`` (n_freq,) the lines; ``f`` (n_freq,) the FRF and
    ``v`` (n_freq,) its noise variance per line; ``Phi`` (n_freq, n_cols) the damped basis
    and ``coef`` (n_cols,) the FRF's fitted coefficients; ``xn``, ``zeta`` (n,) the poles,
    ``cov_poles`` (2 n, 2 n) their covariance (all normalized).

    On the lines of `_zero_window` (not widened: none when `LOCAL_FRACTION` of the distance to the
    pole holds fewer than `LOCAL_LINES` lines) the real part of the misfit ``f - Phi coef`` is fitted by
    ``c0 + c1 (x - z)`` (weights ``1/sigma``) and added to the undamped fitted receptance (why:
    docs/frf-extraction.md, "Method", step 4). Returns ``(zero, se)``, the standard error from
    ``(c0, c1)``'s covariance (inflated by the reduced chi-square and the residual's
    correlation) and the poles'.
    """
    near = _zero_window(z, x, xn, widen=False)
    if not near.size:
        return None   # widened, the window would reach toward the pole: a resonance's misfit, not a line
    w = 1.0 / np.sqrt(v[near])
    X = np.column_stack([np.ones(near.size), x[near] - z]) * w[:, None]
    r = (f[near] - Phi[near] @ coef).real * w
    c = scipy.linalg.lstsq(X, r)[0]
    res = r - X @ c
    chi2 = 2.0 * float(res @ res) / max(res.size - 2, 1)  # weighted real components have variance 1/2
    cov_c = np.linalg.inv(X.T @ X) * 0.5 * max(1.0, chi2) * correlation_inflation(res + 0j)

    def u(t):
        return float(modal_basis(np.array([t]), xn, zeta, False)[0] @ coef) + c[0] + c[1] * (t - z)

    lo, hi = float(x[near[0]]), float(x[near[-1]])
    if u(lo) * u(hi) >= 0:
        return None
    z_local = scipy.optimize.brentq(u, lo, hi, xtol=1e-14)
    se_poles, du_dz = zero_se(z_local, coef, np.zeros((coef.size, coef.size)), xn, zeta, cov_poles, c[1])
    g = np.array([1.0, z_local - z]) / du_dz
    return z_local, math.sqrt(se_poles**2 + max(float(g @ cov_c @ g), 0.0))
