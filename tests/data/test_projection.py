"""The exact Jacobian of the variable-projection residual (`vibupdate.data.modal_fit.projection`)
against a central difference, plain and through a window of the estimate, and the refinement's
poles and covariance with it."""

import numpy as np
import pytest

from vibupdate.data.modal_fit import basis, projection, refine_poles
from vibupdate.data.window import window_for


def _data(seed=1):
    """Three noisy FRFs of three modes on 700 lines (normalized), uneven weights."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.05, 1.0, 700)
    xn, zeta = np.array([0.2, 0.45, 0.8]), np.array([0.01, 0.02, 0.005])
    Phi = basis(x, xn, zeta)
    F = np.array([Phi @ rng.standard_normal(Phi.shape[1]) for _ in range(3)])
    F = F + 0.05 * (rng.standard_normal(F.shape) + 1j * rng.standard_normal(F.shape))
    return x, xn, zeta, F, rng.uniform(0.5, 2.0, F.shape)


@pytest.mark.parametrize("window", [None, "hann"])
def test_the_projection_jacobian_is_the_derivative_of_the_residual(window):
    x, xn, zeta, F, W = _data()
    win = window_for(window, x, "accelerance")
    theta = np.r_[xn * 1.003, zeta * 1.1]  # off the optimum: the residual's own term matters
    J = projection(theta, x, F, W, win, jacobian=True)[1]
    for k in range(theta.size):
        h = 1e-6 * theta[k]
        up, down = theta.copy(), theta.copy()
        up[k] += h
        down[k] -= h
        fd = (projection(up, x, F, W, win)[0] - projection(down, x, F, W, win)[0]) / (2 * h)
        assert np.linalg.norm(J[:, k] - fd) < 1e-6 * np.linalg.norm(fd)


def test_the_refined_poles_are_a_stationary_point_of_the_projected_cost():
    x, xn, zeta, F, W = _data()
    wn, z, cov = refine_poles(x, F, xn * 1.002, zeta * 1.05, 1.0 / W**2, weighted=True)
    r, J = projection(np.r_[wn, z], x, F, W, jacobian=True)
    scale = np.linalg.norm(J, axis=0) * np.linalg.norm(r)
    assert np.all(np.abs(J.T @ r) < 1e-6 * scale)
    assert np.all(np.abs(wn / xn - 1) < 1e-2) and np.all(np.linalg.eigvalsh(cov) > 0)
