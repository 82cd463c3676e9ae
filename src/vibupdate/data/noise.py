"""Noise variance of FRFs per line (a kernel of `vibupdate.data.extraction`): of a single
record from the modal fit's residual, and the split of any per-line variance estimate (the
residual's, or the repeats' scatter) into a smooth and a proportional component. Frequencies
and FRFs normalized as in `vibupdate.data.modal_fit`.

Each squared residual is divided by ``1 - h_k`` (``h_k`` the leverage of its line: HC2,
MacKinnon and White, J. Econometrics 29, 1985; `leverage`), then ``sigma_k^2 = s_k + beta
|H_k|^2`` by maximum likelihood with the EM iteration for variance components (Dempster, Laird
and Rubin, J. R. Statist. Soc. B 39, 1977; `variance_components`). Why, and the alternatives
``W`` and ``beta_width``: docs/frf-extraction.md, "Noise and intervals", and
docs/notes/frf-intervals.md.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from vibupdate.data.modal_fit import linear_fit, real_stack, qr_triangle, basis, basis_derivatives, smooth

SMOOTH_LINES = 21           # the additive component is locally constant over this many lines
EM_ITERATIONS = 50          # EM iterations (from an even split: within 1 % of 1,000 iterations on the tests)


def pole_columns(derivatives, c):
    """One FRF's pole columns (n_freq, 2 n): the exact derivatives of its modal model ``Phi(theta) c``
    with respect to ``w_n`` (first n) and ``zeta`` (last n), from `basis_derivatives` and its
    coefficients ``c``."""
    n = derivatives[0].shape[1] // 2
    return np.hstack([d[:, 0::2] * c[0:2 * n:2] + d[:, 1::2] * c[1:2 * n:2] for d in derivatives])


def leverage(x, xn, zeta, coef, W=None, window=None):
    """Diagonal of the hat matrix of the modal fit of every FRF, shape (n_pairs, 2, n_freq)
    (real and imaginary row of each line): the residue columns of each FRF plus the pole
    columns shared by all FRFs, projected off the former. ``W`` (n_pairs, n_freq): the
    weights ``1/sigma`` per line of a weighted fit (default 1: unweighted); ``coef`` that
    fit's coefficients.

    The projected pole columns ``D`` (every FRF's block: the poles are shared) have the hat
    diagonal of the row norms of ``D V S^-1`` (``S``, ``V`` of the SVD of ``D``'s triangle,
    built FRF by FRF): two passes over the blocks, none kept beyond its own, not the whole ``D``."""
    Phi = basis(x, xn, zeta, window)
    derivatives = basis_derivatives(x, xn, zeta, window)
    shared = None if W is not None else _orthonormal(np.vstack([Phi.real, Phi.imag]))

    def blocks():  # per FRF: the residue columns' basis and the projected pole columns
        for k, c in enumerate(coef):
            w = np.ones(x.size) if W is None else W[k]
            Q = shared if W is None else _orthonormal(real_stack(Phi, w))
            D = real_stack(pole_columns(derivatives, c), w)
            yield Q, D - Q @ (Q.T @ D)

    R = qr_triangle(np.vstack([qr_triangle(D) for _, D in blocks()]))
    _, sv, Vt = np.linalg.svd(R)
    keep = sv > np.finfo(float).eps * max(R.shape) * sv[0]
    T = Vt[keep].T / sv[keep]
    h = np.array([np.sum(Q**2, axis=1) + np.sum((D @ T) ** 2, axis=1) for Q, D in blocks()])
    return h.reshape(coef.shape[0], 2, x.size)


def _orthonormal(A):
    """An orthonormal basis of the columns of ``A`` (economic QR)."""
    return scipy.linalg.qr(A, mode="economic", check_finite=False)[0]


def variance_components(e, g, groups=None, width: int = SMOOTH_LINES, iterations: int = EM_ITERATIONS,
                         beta_width: int | None = None):
    """Maximum-likelihood ``sigma^2 = s + beta g`` per row from squared residuals ``e``.

    ``e`` (n_rows, n_freq): leverage-corrected squared moduli of complex residuals (each
    ``sigma^2`` times a unit exponential variable); ``g`` (n_rows, n_freq) >= 0 the shape of
    the proportional component (``|H|^2``). ``s`` is locally constant over ``width`` lines
    (a running mean) per row; ``beta >= 0`` is shared by the rows of one group (``groups``,
    (n_rows,) integer labels; default one group per row), one number per group, or locally
    constant over ``beta_width`` lines when given. Returns ``(sigma^2, s, beta)`` with
    ``beta`` (n_rows, n_freq)."""
    groups = np.arange(e.shape[0]) if groups is None else np.asarray(groups)
    labels, member = np.unique(groups, return_inverse=True)
    rows = [np.nonzero(member == k)[0] for k in range(labels.size)]
    # a floor that keeps v^2 representable: noise-free data give residuals of rounding size or 0
    floor = 1e-12 * np.max(smooth(e, width), axis=1, keepdims=True) + 1e-150

    def level(share):  # the proportional level: group sums (of running sums along frequency if local)
        num, den = (share, g) if beta_width is None else (smooth(share, beta_width), smooth(g, beta_width))
        out = np.empty_like(e)
        for r in rows:
            top = np.sum(num[r], axis=0 if beta_width else None)
            out[r] = top / np.maximum(np.sum(den[r], axis=0 if beta_width else None), 1e-300)
        return out

    # start from an even split of each line's squared residual between the components
    s = np.maximum(smooth(e / 2, width), floor)
    beta = level(e / 2)
    for _ in range(iterations):
        b = beta * g
        v = s + b
        # E-step: expected energy of each component given the line's residual; M-step: the
        # smooth component's running mean, the proportional one's group mean
        # (each square formed once: the same operations, so the same bits, as writing it out)
        v2, s2, b2 = v * v, s * s, b * b
        share_s = (s - s2 / v) + s2 * e / v2
        share_b = (b - b2 / v) + b2 * e / v2
        s = np.maximum(smooth(share_s, width), floor)
        beta = level(share_b)
    return s + beta * g, s, beta


def residual_variance(x, F, wn, zeta, groups=None, width: int = SMOOTH_LINES, W=None,
                       beta_width: int | None = None, window=None):
    """Noise variance per line of each FRF from the fit's residual, shape (n_pairs, n_freq):
    squared residuals corrected by the leverage, then split into a smooth and a proportional
    component (module docstring), the latter's level shared by the FRFs of one ``groups``
    label ((n_pairs,), e.g. the excitation; default one per FRF).

    ``W`` (n_pairs, n_freq): weights ``1/sigma`` per line from an earlier noise estimate;
    the residual and the leverage are then those of the weighted fit (feasible weighted
    least squares). Default: unweighted."""
    Phi = basis(x, wn, zeta, window)
    if W is None:  # one least-squares solve for every FRF
        A = np.vstack([Phi.real, Phi.imag])
        coef = scipy.linalg.lstsq(A, np.concatenate([F.real, F.imag], axis=1).T, lapack_driver="gelsy")[0].T
    else:
        coef = np.array([linear_fit(Phi, f, w)[0] for f, w in zip(F, W)])
    fitted = coef @ Phi.T
    r = F - fitted
    h = np.minimum(leverage(x, wn, zeta, coef, W, window), 0.99)
    e = r.real**2 / (1.0 - h[:, 0]) + r.imag**2 / (1.0 - h[:, 1])
    var = variance_components(e, np.abs(fitted) ** 2, groups, width, beta_width=beta_width)[0]
    return np.maximum(var, 1e-12 * np.max(var, axis=1, keepdims=True) + 1e-300)
