"""Numerical kernels of `vibupdate.data.extraction` (no ``__all__``: the names without an
underscore are the units its tests check and its sibling modules use, not a promised
surface): the modal-model basis, vector fitting, the stabilization check, variable projection
of the poles, noise estimates and pole selection. Frequencies are normalized by the band's
top (``x = omega / omega_max``); FRFs by their RMS. The method: docs/frf-extraction.md,
"Method"; on long records what must see every line is formed one FRF at a time
(`_CompressedProjection`, ``benchmarks/extraction_cost.py``)."""

from __future__ import annotations

import math
from itertools import combinations

import numpy as np
import scipy.linalg
import scipy.optimize

from vibupdate.data.window import windowed_poles

PSEUDO_POLE = (1.5, 0.2)    # pseudo-mode: natural frequency (x band top) and damping ratio
#: The pseudo-mode placed just above the fitted lines instead: where a zero moves when the residual
#: terms stand for modes close above them, its interval counts that (`vibupdate.data.extraction`).
NEAR_PSEUDO_POLE = (1.1, 0.2)
STABLE_FREQUENCY = 2e-3     # a pole recurs when its frequency is within this (relative) ...
STABLE_DAMPING = 0.2        # ... and its damping ratio within this (relative)

# ----------------------------------------------------------------------------- model basis

def _poles(xn, zeta):
    return -zeta * xn + 1j * xn * np.sqrt(1.0 - zeta**2)


def _pole_terms(x, a, window=None, derivative: bool = False):
    """``1/(s - a)`` and ``1/(s - conj a)`` at ``s = j x`` (each (n_freq, n_poles)), through
    ``window`` when given; with ``derivative`` their derivatives with respect to ``a`` and
    ``conj a`` too (both terms are analytic in their pole)."""
    if window is None:
        s = 1j * np.asarray(x)[:, None]
        p, q = 1.0 / (s - a[None, :]), 1.0 / (s - np.conj(a)[None, :])
        return (p, q, p * p, q * q) if derivative else (p, q)
    both = np.concatenate([a, np.conj(a)])
    p, q = np.split(windowed_poles(x, both, window), 2, axis=1)
    if not derivative:
        return p, q
    return (p, q, *np.split(windowed_poles(x, both, window, derivative=True), 2, axis=1))


def basis(x, xn, zeta, window=None, pseudo=None) -> np.ndarray:
    """Columns of the modal model at normalized frequencies ``x``, shape (n_freq, 2 n + 4).

    Per pole (modes, then the pseudo-mode): ``1/(s-a) + 1/(s-conj a)``, ``j/(s-a) - j/(s-conj a)``
    (coefficients Re A, Im A); then ``1/s^2`` and ``1``. With ``window`` (a
    `vibupdate.data.window.Window`) the pole terms are those of the windowed estimate;
    ``pseudo``: the pseudo-mode's ``(frequency, damping)``, default `PSEUDO_POLE`.
    """
    x = np.asarray(x)
    pseudo = pseudo or PSEUDO_POLE
    a = np.append(_poles(np.asarray(xn), np.asarray(zeta)), _poles(np.array([pseudo[0]]), np.array([pseudo[1]])))
    p, q = _pole_terms(x, a, window)
    cols = np.empty((x.size, 2 * p.shape[1] + 2), dtype=complex)
    cols[:, 0:-2:2], cols[:, 1:-2:2] = p + q, 1j * (p - q)
    cols[:, -2], cols[:, -1] = -1.0 / x**2, 1.0      # 1/s^2 = -1/x^2
    return cols


def basis_derivatives(x, xn, zeta, window=None):
    """Exact derivatives of the modes' columns of `basis` with respect to their poles'
    ``w_n`` and ``zeta``: two complex arrays (n_freq, 2 n), column ``2 r`` (``2 r + 1``) the
    derivative of column ``2 r`` (``2 r + 1``) of `basis` with respect to ``w_n`` (``zeta``)
    of mode ``r`` (no other parameter moves those columns)."""
    xn, zeta = np.asarray(xn, dtype=float), np.asarray(zeta, dtype=float)
    a = _poles(xn, zeta)
    _, _, dp, dq = _pole_terms(x, a, window, derivative=True)
    root = np.sqrt(1.0 - zeta**2)
    out = []
    for da in (a / xn, xn * (-1.0 - 1j * zeta / root)):         # da/dw_n, da/dzeta
        plus, minus = dp * da[None, :], dq * np.conj(da)[None, :]
        d = np.empty((plus.shape[0], 2 * xn.size), dtype=complex)
        d[:, 0::2], d[:, 1::2] = plus + minus, 1j * (plus - minus)
        out.append(d)
    return out[0], out[1]


def _undamped_basis(x, xn, zeta, pseudo=None) -> np.ndarray:
    """Real columns of the undamped receptance, same coefficients as `basis`: each mode's
    ``-2 w_d / (w_n^2 - x^2)`` on Im A (its real modal constant ``Re(2 j w_d A)``); the
    pseudo-mode and the residual terms (which stand for modes outside the band, real in it)
    keep the real part of their damped columns. Built in real arithmetic: the zeros are
    searched on twenty points per line (`vibupdate.data.fitted_zeros`)."""
    x = np.asarray(x, dtype=float)
    a = _poles(np.asarray(xn), np.asarray(zeta))
    n = a.size
    cols = np.zeros((x.size, 2 * n + 4))
    cols[:, 1:2 * n:2] = -2.0 * a.imag[None, :] / (np.abs(a)[None, :] ** 2 - x[:, None] ** 2)
    cols[:, 2 * n:] = basis(x, [], [], pseudo=pseudo).real
    return cols


def undamped_derivatives(x, xn, zeta):
    """Exact derivatives of `_undamped_basis` at ``x`` (n_x,): ``d/dx`` of every column,
    shape (n_x, 2 n + 4), and of each mode's column ``-2 w_n s / (w_n^2 - x^2)``
    (``s = sqrt(1 - zeta^2)``) with respect to its ``w_n`` and ``zeta``, each (n_x, n)."""
    x = np.asarray(x, dtype=float)[:, None]
    xn, zeta = np.asarray(xn, dtype=float)[None, :], np.asarray(zeta, dtype=float)[None, :]
    n = xn.shape[1]
    s = np.sqrt(1.0 - zeta**2)
    gap = xn**2 - x**2
    d_x = np.zeros((x.shape[0], 2 * n + 4))
    d_x[:, 1:2 * n:2] = -4.0 * xn * s * x / gap**2
    a = _poles(np.array([PSEUDO_POLE[0]]), np.array([PSEUDO_POLE[1]]))[0]
    p, q = 1.0 / (1j * x[:, 0] - a), 1.0 / (1j * x[:, 0] - np.conj(a))
    d_x[:, 2 * n] = (-1j * (p**2 + q**2)).real
    d_x[:, 2 * n + 1] = (p**2 - q**2).real
    d_x[:, 2 * n + 2] = 2.0 / x[:, 0] ** 3        # d/dx of Re 1/(j x)^2 = -1/x^2
    d_wn = 2.0 * s * (xn**2 + x**2) / gap**2
    d_zeta = 2.0 * xn * zeta / (s * gap)
    return d_x, d_wn, d_zeta


def modal_basis(x, xn, zeta, damped: bool = True, window=None, pseudo=None) -> np.ndarray:
    """Stage-2 columns: `basis` (damped, through ``window`` when given) or `_undamped_basis`
    (the structure's own receptance: never windowed); ``pseudo`` as in `basis`."""
    return basis(x, xn, zeta, window, pseudo) if damped else _undamped_basis(x, xn, zeta, pseudo)


def real_stack(Phi: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``[Re Phi; Im Phi]`` with each line weighted by ``w``, (2 n_freq, n_cols): written in
    place (no temporaries: these are the largest arrays of an extraction)."""
    n = Phi.shape[0]
    out = np.empty((2 * n,) + Phi.shape[1:])
    np.multiply(Phi.real, w[:, None], out=out[:n])
    np.multiply(Phi.imag, w[:, None], out=out[n:])
    return out


def linear_fit(Phi, h, w):
    """Weighted linear LS of h (n_freq,) on Phi; returns coefficients and weighted residual."""
    A = real_stack(Phi, w)
    b = np.concatenate([h.real * w, h.imag * w])
    coef = scipy.linalg.lstsq(A, b, lapack_driver="gelsy")[0]
    return coef, b - A @ coef


# ----------------------------------------------------------------------------- stage 1: poles

def _vector_fit(x, F, n_pairs: int, n_iter: int = 12, W=None) -> np.ndarray:
    """Common poles (upper half plane, normalized) of the rows of F (n_fun, n_freq), the
    lines weighted by W (n_fun, n_freq) when given."""
    step = max(1, x.size // 400)  # the start poles need no more than ~400 lines
    W = np.ones(F.shape) if W is None else W
    x, F, W = x[::step], F[:, ::step], W[:, ::step]
    s = 1j * x
    beta = np.linspace(x[0], x[-1], n_pairs + 2)[1:-1]
    a = -beta / 100.0 + 1j * beta
    for _ in range(n_iter):
        p, q = 1.0 / (s[:, None] - a[None, :]), 1.0 / (s[:, None] - np.conj(a)[None, :])
        Phi = np.empty((s.size, 2 * n_pairs), dtype=complex)
        Phi[:, 0::2], Phi[:, 1::2] = p + q, 1j * (p - q)
        n_lin = 2 * n_pairs + 1
        rows, rhs = [], []
        for f, w in zip(F, W):
            A = np.hstack([Phi, np.ones((s.size, 1)), -f[:, None] * Phi, f[:, None]]) * w[:, None]
            R = scipy.linalg.qr(np.vstack([A.real, A.imag]), mode="r", check_finite=False)[0]
            rows.append(R[n_lin:-1, n_lin:-1])
            rhs.append(R[n_lin:-1, -1])
        c = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
        Amat = np.zeros((2 * n_pairs, 2 * n_pairs))
        bvec = np.zeros(2 * n_pairs)
        for k, ak in enumerate(a):
            Amat[2 * k:2 * k + 2, 2 * k:2 * k + 2] = [[ak.real, ak.imag], [-ak.imag, ak.real]]
            bvec[2 * k] = 2.0
        z = np.linalg.eigvals(Amat - np.outer(bvec, c))
        z = z[z.imag > 1e-9]
        if z.size < n_pairs:  # real poles appeared: restart the missing ones where none are
            grid = np.linspace(x[0], x[-1], 4 * n_pairs + 2)[1:-1]
            far = grid[np.argsort([-np.min(np.abs(np.abs(z) - g), initial=np.inf) for g in grid])]
            z = np.concatenate([z, -far[:n_pairs - z.size] / 100.0 + 1j * far[:n_pairs - z.size]])
        a = np.where(z.real > 0, -z.real + 1j * z.imag, z)
    return np.sort_complex(a)


def stabilization_diagram(x, F, orders, max_damping, W=None):
    """``(order, w_n, zeta)`` per model order: the in-band poles of damping below ``max_damping``."""
    out = []
    for n in orders:
        a = _vector_fit(x, F, n, W=W)
        wn, zeta = np.abs(a), -a.real / np.abs(a)
        keep = (wn >= x[0]) & (wn <= x[-1]) & (zeta > 0) & (zeta < max_damping)
        out.append((n, wn[keep], zeta[keep]))
    return out


def stable_poles(stab, min_stable):
    """Poles that recur in >= min_stable orders, each taken from the highest order that has it."""
    keep, counts = [], []
    for _, wn, zeta in reversed(stab):
        for w, z in zip(wn, zeta):
            count = sum(np.any((np.abs(w2 - w) < STABLE_FREQUENCY * w) & (np.abs(z2 - z) < STABLE_DAMPING * z))
                        for _, w2, z2 in stab)
            if count >= min_stable and not any(abs(k[0] - w) < 5e-3 * w for k in keep):
                keep.append((w, z))
                counts.append(count)
    order = np.argsort([k[0] for k in keep])
    return (np.array([keep[i][0] for i in order]), np.array([keep[i][1] for i in order]),
            [counts[i] for i in order])


def projected_residual(theta, x, F, W, window=None):
    """The variable-projection residual at poles ``theta`` = (w_n, zeta): `projection`'s."""
    return projection(theta, x, F, W, window)[0]


def projection(theta, x, F, W, window=None, jacobian: bool = False):
    """Weighted residual of the variable-projection problem at poles ``theta`` and, with
    ``jacobian``, its exact derivative with respect to ``theta``.

    ``theta`` (2 n,): ``w_n`` then ``zeta`` of the modes; ``F``, ``W`` (n_pairs, n_freq):
    FRFs and weights ``1/sigma`` per line. Per FRF, with ``A`` the weighted real basis
    (`real_stack`), ``b`` the weighted FRF and ``c`` its least-squares coefficients (one
    pivoted QR ``A = Q R``), the residual is ``r = b - A c`` and its derivative (Golub and
    Pereyra, SIAM J. Numer. Anal. 10, 1973)::

        dr/dtheta_k = -(I - Q Q^T) (dA/dtheta_k) c - Q R^-T (dA/dtheta_k)^T r

    with ``dA/dtheta_k`` from `basis_derivatives` (two columns per mode). The second term is
    orthogonal to ``r`` (Kaufman's approximation drops it): the gradient ``J^T r`` is the
    same either way, and keeping it gives the same Jacobian as a finite difference of the
    residual, so the sandwich covariance of `refine_poles` is unchanged.

    Returns ``r`` (n_pairs * 2 n_freq,), stacked [Re f1, Im f1, Re f2, ...] (weighted), and
    ``J`` (n_pairs * 2 n_freq, 2 n) or None.
    """
    blocks = list(_projection_blocks(theta, x, F, W, window, jacobian))
    r = np.concatenate([b[0] for b in blocks])
    return r, (np.vstack([b[1] for b in blocks]) if jacobian else None)


def _projection_blocks(theta, x, F, W, window=None, jacobian: bool = False):
    """`projection` one FRF at a time: yields ``(r_k, J_k)`` ((2 n_freq,), (2 n_freq, 2 n) or
    None), so that a caller may reduce each block before the next is formed."""
    n = theta.size // 2
    xn, zeta = theta[:n], theta[n:]
    Phi = basis(x, xn, zeta, window)
    if jacobian:   # the pole columns' derivatives, (n_freq, 4 n): shared by every FRF
        d_theta = np.hstack(basis_derivatives(x, xn, zeta, window))
    for f, w in zip(F, W):
        A = real_stack(Phi, w)
        b = np.concatenate([f.real * w, f.imag * w])
        # pivoted QR, columns of negligible |R_kk| dropped: the rank rule of LAPACK's least-squares solver
        Q, R, piv = scipy.linalg.qr(A, mode="economic", pivoting=True, check_finite=False)
        diag = np.abs(np.diag(R))
        rank = int(np.sum(diag > np.finfo(float).eps * diag[0])) if diag[0] > 0 else 0
        Q, R, piv = Q[:, :rank], R[:rank, :rank], piv[:rank]
        c = np.zeros(A.shape[1])
        c[piv] = scipy.linalg.solve_triangular(R, Q.T @ b, check_finite=False)
        r = b - A @ c
        yield r, (_projection_jacobian(Q, R, piv, d_theta, c, r, w) if jacobian else None)


class _CompressedProjection:
    """`projection` as ``scipy.optimize.least_squares`` needs it, in ``2 n + 1`` numbers.

    With ``[J r] = Q_t R_t`` (all FRFs, each block reduced by its own QR as it is formed),
    ``R_t[:, -1]`` and ``R_t[:, :-1]`` have the ``J^T J``, ``J^T r`` and ``|r|`` of the full
    residual and Jacobian, all a trust-region step uses; the last point's ``R_t`` is kept (the
    solver asks for the Jacobian where it has just asked for the residual)."""

    def __init__(self, x, F, W, window=None):
        self.args = (x, F, W, window)
        self.theta, self.R = None, None

    def _at(self, theta):
        if self.theta is None or not np.array_equal(theta, self.theta):
            tops = [qr_triangle(np.column_stack([J, r]))
                    for r, J in _projection_blocks(theta, *self.args, jacobian=True)]
            self.theta, self.R = np.array(theta, copy=True), qr_triangle(np.vstack(tops))
        return self.R

    def residual(self, theta):
        return self._at(theta)[:, -1]

    def jacobian(self, theta):
        return self._at(theta)[:, :-1]


def qr_triangle(A):
    """The ``R`` of a QR of ``A`` (m >= n), (n, n)."""
    return scipy.linalg.qr(A, mode="r", overwrite_a=True, check_finite=False)[0][:A.shape[1]]


def _projection_jacobian(Q, R, piv, d_theta, c, r, w):
    """One FRF's block of `projection`'s Jacobian, (2 n_freq, 2 n): ``d_theta`` (n_freq, 4 n)
    the two arrays of `basis_derivatives` side by side (``w_n``, then ``zeta``); ``Q``, ``R``,
    ``piv`` the kept columns' QR (`_projection_blocks`); ``c`` the coefficients, ``r`` the
    weighted residual, ``w`` the weights."""
    n = d_theta.shape[1] // 4
    dA = real_stack(d_theta, w)                                      # dA/dtheta's nonzero columns
    even = np.r_[c[0:2 * n:2], c[0:2 * n:2]]
    odd = np.r_[c[1:2 * n:2], c[1:2 * n:2]]
    dAc = dA[:, 0::2] * even + dA[:, 1::2] * odd                     # (dA/dtheta_k) c, (2 n_freq, 2 n)
    g = dA.T @ r                                                      # (4 n,): the nonzero (dA/dtheta_k)^T r
    E = np.zeros((c.size, 2 * n))                                     # (dA/dtheta_k)^T r, full length
    k = np.arange(2 * n)
    mode = k % n
    E[2 * mode, k], E[2 * mode + 1, k] = g[0::2], g[1::2]
    second = Q @ scipy.linalg.solve_triangular(R, E[piv], trans="T", check_finite=False)
    return -(dAc - Q @ (Q.T @ dAc)) - second


def refine_poles(x, F, wn, zeta, var, weighted: bool, window=None):
    """Variable projection on (w_n, zeta); returns them and their covariance (sandwich).

    Weights 1/sigma per line when ``weighted`` (sigma from repeats), else uniform; the
    Jacobian exact (`projection`)."""
    n = wn.size
    W = 1.0 / np.sqrt(var) if weighted else np.ones_like(F.real)
    theta0 = np.concatenate([wn, zeta])
    lower = np.concatenate([np.full(n, x[0] * 0.5), np.full(n, 1e-6)])
    upper = np.concatenate([np.full(n, x[-1] * 1.5), np.full(n, 0.5)])
    problem = _CompressedProjection(x, F, W, window)
    sol = scipy.optimize.least_squares(problem.residual, theta0, jac=problem.jacobian, bounds=(lower, upper),
                                       x_scale=np.concatenate([wn, zeta]), xtol=1e-10, ftol=1e-10, max_nfev=60,
                                       method="trf")
    # the sandwich from the full residual and Jacobian at the solution, one FRF at a time
    v = var * W**2 / 2.0                                                 # per weighted real component
    JtJ, JtVJ, r = 0.0, 0.0, []
    for k, (r_k, J_k) in enumerate(_projection_blocks(sol.x, x, F, W, window, jacobian=True)):
        v_k = np.concatenate([v[k], v[k]])
        JtJ, JtVJ = JtJ + J_k.T @ J_k, JtVJ + (J_k.T * v_k) @ J_k
        r.append(r_k / np.sqrt(v_k))
    r = np.concatenate(r)                                               # residual over its noise
    JtJ_inv = np.linalg.pinv(JtJ)
    cov = JtJ_inv @ JtVJ @ JtJ_inv
    chi2 = float(np.sum(r**2)) / max(r.size - theta0.size, 1)
    tau = correlation_inflation(split_residual(r, F.shape) / math.sqrt(2.0))  # over sigma per line
    return sol.x[:n], sol.x[n:], cov * max(1.0, chi2) * tau


# ----------------------------------------------------------------------------- noise

def smooth(values: np.ndarray, width: int) -> np.ndarray:
    kernel = np.ones(width) / width
    pad = width // 2
    padded = np.pad(values, [(0, 0), (pad, pad)], mode="edge")
    return np.array([np.convolve(v, kernel, mode="valid") for v in padded])


def noise_from_repeats(blocks) -> np.ndarray | None:
    """Variance of the mean per line, shape (n_pairs, n_freq), unsmoothed (each line's an
    unbiased estimate with ``2 (R - 1)`` real degrees of freedom, ``R`` repeats); None unless
    every pair has >= 2 repeats."""
    if min(h.shape[0] for h in blocks) < 2:
        return None
    return np.array([np.sum(np.abs(h - h.mean(axis=0)) ** 2, axis=0) / (h.shape[0] - 1) / h.shape[0] for h in blocks])


def noise_from_differences(F, width: int = 21) -> np.ndarray:
    """Noise variance per line from the data alone (no repeats, no model), shape (n_pairs, n_freq).

    The second difference ``F[k-1] - 2 F[k] + F[k+1]`` of a smooth FRF is small, of white
    noise of variance ``sigma^2`` it has variance ``6 sigma^2``; the running median of its
    squared modulus over ``width`` lines, divided by ``ln 2`` (median over mean of an
    exponential variable), ignores the few lines of a sharp peak."""
    import scipy.ndimage

    d2 = np.abs(F[:, :-2] - 2.0 * F[:, 1:-1] + F[:, 2:]) ** 2 / 6.0
    d2 = np.pad(d2, [(0, 0), (1, 1)], mode="edge")
    var = scipy.ndimage.median_filter(d2, size=(1, width), mode="nearest") / math.log(2.0)
    return np.maximum(var, 1e-12 * np.mean(np.abs(F) ** 2, axis=1, keepdims=True) + 1e-300)  # noise-free data


def resolvable_poles(x, F, wn, zeta, counts, var, threshold: float = 1e-3, min_bandwidth: float = 0.1,
                     min_lines: int = 5, window=None):
    """Drop poles the data cannot resolve: a half-power bandwidth ``2 zeta w_n`` below
    ``min_bandwidth`` line spacings; a response on the measured lines below ``threshold``
    times the FRF at the pole in every FRF (computational poles of a noise-free fit); or a
    response above twice the noise (``var``, (n_pairs, n_freq)) on fewer than ``min_lines``
    lines in every FRF (a pole fitted to a noise spike). Returns the kept poles and their
    largest sampled response."""
    spacing = float(np.median(np.diff(x)))
    Phi = basis(x, wn, zeta, window)
    coef = np.array([linear_fit(Phi, f, np.ones(x.size))[0] for f in F])
    n = wn.size
    own = np.abs(Phi[:, 0:2 * n:2][None] * coef[:, None, 0:2 * n:2]
                 + Phi[:, 1:2 * n:2][None] * coef[:, None, 1:2 * n:2])                 # (n_pairs, n_freq, n)
    peak = own.max(axis=1)                                                              # (n_pairs, n)
    at_pole = np.abs(F[:, np.clip(np.searchsorted(x, wn), 0, x.size - 1)])              # (n_pairs, n)
    above_noise = np.sum(own > 2.0 * np.sqrt(var)[:, :, None], axis=1)                # (n_pairs, n)
    keep = (np.any(peak > threshold * at_pole, axis=0) & (2 * zeta * wn >= min_bandwidth * spacing)
            & np.any(above_noise >= min_lines, axis=0))
    return wn[keep], zeta[keep], [c for c, k in zip(counts, keep) if k], peak.max(axis=0)[keep]


def correlation_inflation(r: np.ndarray, max_lag: int = 200, stop: float = 0.05) -> float:
    """Variance inflation ``1 + 2 sum_k rho_k`` for residuals correlated along frequency.

    ``r`` (n_pairs, n_freq) complex, normalized by the noise; ``rho_k`` the pooled
    autocorrelation at lag ``k``, summed while above ``stop``. White noise gives about 1;
    a residual dominated by a smooth misfit (model error of real data) gives the number of
    lines over which it is correlated, so that such lines are not counted as independent.
    """
    r = np.atleast_2d(r)
    power = float(np.sum(np.abs(r) ** 2)) or 1.0
    total = 0.0
    for k in range(1, min(max_lag, r.shape[1] - 1)):
        rho = float(np.sum((r[:, k:] * np.conj(r[:, :-k])).real)) / power
        if rho < stop:
            break
        total += rho
    return 1.0 + 2.0 * total


def best_subset(x, F, wn, zeta, peak, n_modes, candidates, fixed, max_subsets: int = 400, window=None):
    """Positions in ``candidates`` (indices into ``wn``) of the ``n_modes`` poles whose modal
    model, with the ``fixed`` poles always in it, fits the FRFs best (unweighted); by peak
    response when there are too many subsets to try."""
    candidates, fixed = np.asarray(candidates, dtype=int), np.asarray(fixed, dtype=int)
    if math.comb(candidates.size, n_modes) > max_subsets:
        return np.sort(np.argsort(peak[candidates])[::-1][:n_modes])
    best, best_cost = None, np.inf
    for subset in combinations(range(candidates.size), n_modes):
        keep = np.r_[candidates[list(subset)], fixed]
        theta = np.concatenate([wn[keep], zeta[keep]])
        cost = float(np.sum(projected_residual(theta, x, F, np.ones_like(F.real), window) ** 2))
        if cost < best_cost:
            best, best_cost = np.array(subset), cost
    return best


def split_residual(r, shape):
    """The stacked projected residual [Re f1, Im f1, Re f2, ...] back to complex (n_pairs, n_freq)."""
    flat = r.ravel().reshape(shape[0], 2, shape[1])
    return flat[:, 0, :] + 1j * flat[:, 1, :]
