"""The noise variance of a single FRF record from the modal fit's residual
(`vibupdate.data._noise`): the leverage of the fit, the two variance components, and the
estimate at the peak lines of a mode whose bandwidth is about one line (issue 9)."""

import numpy as np

from vibupdate.data._modal_fit import _basis, _projected_residual, _smooth, _split_residual
from vibupdate.data._noise import _leverage, _pole_columns, _residual_variance, _variance_components


def _model(n_pairs=3, seed=0):
    """Two light modes (half-power bandwidth about one line) on 2,000 lines, normalized
    frequencies; FRF coefficients of unit-size residues."""
    x = np.linspace(0.05, 1.0, 2000)
    xn, zeta = np.array([0.3, 0.62]), np.array([2.5e-4, 2.5e-4])   # 2 zeta xn ~ 0.3 / 0.6 lines
    rng = np.random.default_rng(seed)
    coef = np.zeros((n_pairs, 2 * xn.size + 4))
    coef[:, 1:2 * xn.size:2] = -rng.uniform(0.5, 1.5, (n_pairs, xn.size)) * 1e-4
    coef[:, 0:2 * xn.size:2] = rng.uniform(-0.1, 0.1, (n_pairs, xn.size)) * 1e-4
    coef[:, -1] = 0.1
    return x, xn, zeta, coef, coef @ _basis(x, xn, zeta).T


def test_leverage_sums_to_the_number_of_fitted_parameters_and_peaks_at_the_resonances():
    x, xn, zeta, coef, F = _model()
    h = _leverage(x, xn, zeta, coef)
    assert h.shape == (3, 2, x.size)
    assert np.all(h >= -1e-12) and np.all(h <= 1 + 1e-9)
    n_params = coef.size + 2 * xn.size  # residues and residual terms per FRF, poles shared
    assert abs(np.sum(h) - n_params) < 1e-6 * n_params
    line = np.argmin(np.abs(x - xn[0]))
    assert np.mean(h[:, :, line]) > 100 * np.mean(h)  # the peak lines hold the mode's parameters


def test_pole_columns_are_the_exact_derivatives():
    x, xn, zeta, coef, _ = _model()
    D = _pole_columns(x, xn, zeta, coef)
    for k in range(2 * xn.size):
        theta = np.concatenate([xn, zeta])
        step = 1e-7 * theta[k]
        up, down = theta.copy(), theta.copy()
        up[k] += step
        down[k] -= step
        fd = (coef @ _basis(x, up[:2], up[2:]).T - coef @ _basis(x, down[:2], down[2:]).T) / (2 * step)
        assert np.allclose(D[:, :, k], fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())


def test_variance_components_recover_a_smooth_floor_and_a_shared_proportional_level():
    """Known components (a smooth floor, a proportional part peaked over about 10 lines),
    20 draws: the total variance at the peaks and the floor are recovered; the proportional
    level is biased low (measured -13 %: near a peak the locally constant floor takes part
    of it), the running mean alone under-states the peak variance by 20 %."""
    rng = np.random.default_rng(1)
    n = 3000
    f = np.linspace(0, 1, n)
    s_true = np.vstack([1e-3 * (1 + f), 2e-3 * (2 - f)])
    g = np.vstack([1.0 / ((f - 0.3) ** 2 + 1e-5), 1.0 / ((f - 0.7) ** 2 + 1e-5)])
    v_true = s_true + 2e-7 * g
    top = np.argmax(g, axis=1)
    betas, peaks, plain, floors = [], [], [], []
    for _ in range(20):
        e = v_true * rng.exponential(size=v_true.shape)
        v, s, beta = _variance_components(e, g, groups=[0, 0])
        assert beta[0] == beta[1]  # one level per group
        betas.append(beta[0])
        peaks.append(v[[0, 1], top] / v_true[[0, 1], top])
        plain.append(_smooth(e, 21)[[0, 1], top] / v_true[[0, 1], top])
        floors.append(np.median(s / s_true))
    assert abs(np.mean(peaks) - 1) < 0.1
    assert abs(np.mean(floors) - 1) < 0.05
    assert abs(np.mean(betas) / 2e-7 - 1) < 0.2
    assert abs(np.mean(peaks) - 1) < abs(np.mean(plain) - 1)


def test_residual_variance_at_the_peak_lines_of_a_one_line_mode():
    """Noise ``0.2e-3 + 1 % of |H|`` on FRFs of two modes whose half-power bandwidths span
    1 and 2 lines (the frame's first mode spans 0.7), 12 seeds: the estimate at the 6 peak
    lines is closer to the truth than the running mean of the squared residual (measured
    0.71 against 0.42 of the true variance; over all lines both are near 1). At the peak
    lines it is still low: the leverage there nears 1, and the correction cannot restore
    what the residual does not show."""
    x, xn, _, coef, _ = _model()
    zeta = np.array([8e-4, 8e-4])
    F = coef @ _basis(x, xn, zeta).T
    sigma2 = (2e-4 + 0.01 * np.abs(F)) ** 2
    peak = np.argsort(np.abs(F).max(axis=0))[-6:]
    new, old, overall = [], [], []
    for seed in range(12):
        rng = np.random.default_rng(seed)
        noisy = F + np.sqrt(sigma2 / 2) * (rng.standard_normal(F.shape) + 1j * rng.standard_normal(F.shape))
        v = _residual_variance(x, noisy, xn, zeta, groups=[0, 0, 0])
        r = _split_residual(_projected_residual(np.r_[xn, zeta], x, noisy, np.ones_like(F.real)), F.shape)
        new.append(np.mean(v[:, peak] / sigma2[:, peak]))
        old.append(np.mean(_smooth(np.abs(r) ** 2, 21)[:, peak] / sigma2[:, peak]))
        overall.append(np.median(v / sigma2))
    assert np.mean(new) > 0.6 and np.mean(old) < 0.5, (np.mean(new), np.mean(old))
    assert 0.85 < np.mean(overall) < 1.18, overall
