"""The leakage bias of `frame_windowed` (tests/frf_synthetic.py): the expected H1 estimate of
a random test with a Hann window, computed by convolving the exact accelerance with the
window's power kernel on a fine grid, checked against the same expectation computed
independently in the time domain. With a flat-spectrum force and the window ``w`` on each
record of length ``T``, ``E[X F*] / E[|F|^2]`` is the transform of the impulse response times
the window's normalized autocorrelation ``g(t) = integral w(s) w(s + t) ds / integral w^2``
(zero beyond ``T``); with the modal expansion ``A(s) = D + sum_k rho_k lam_k^2 / (s - lam_k)``
of the accelerance (state-space poles ``lam_k`` and residues ``rho_k``, ``D`` the direct
term) that transform is ``D + sum_k rho_k lam_k^2 integral_0^T exp((lam_k - j omega) t) g(t) dt``,
in closed form (`lagged_accelerance`).
"""

import numpy as np
import pytest

from frf_synthetic import (FRAME_PAIRS, frame_system, frame_windowed, lagged_accelerance, true_poles, true_zeros,
                           window_power_kernel, windowed_accelerance)

STEP_HZ = 0.03125


def _exact(M, K, C, dofs, omega):
    H = np.linalg.inv(K[None] - omega[:, None, None] ** 2 * M[None] + 1j * omega[:, None, None] * C[None])
    return np.array([-omega**2 * H[:, dofs.index(r), dofs.index(c)] for r, c in FRAME_PAIRS])


@pytest.fixture(scope="module")
def frame():
    M, K, C, dofs = frame_system()
    omega = 2 * np.pi * np.arange(3.0, 28.0 + STEP_HZ / 2, STEP_HZ)
    return M, K, C, dofs, omega, windowed_accelerance(M, K, C, dofs, FRAME_PAIRS, omega)


def test_kernel_has_unit_integral_and_the_hann_shape():
    u = np.arange(-64 * 32, 64 * 32 + 1) / 32
    k = window_power_kernel(u)
    assert abs(k.sum() / 32 - 1) < 1e-6
    # transform T/2 at 0 and T/4 at +-1 line, zero at the other whole lines; over 3/8:
    assert k[u == 0][0] == pytest.approx(1 / 0.375 * 0.25)
    assert k[u == 1][0] == pytest.approx(0.0625 / 0.375)
    assert np.all(k[np.isin(u, (-3.0, -2.0, 2.0, 3.0))] < 1e-30)
    with pytest.raises(ValueError, match="'flattop'"):
        window_power_kernel(u, "flattop")


def test_grid_converged(frame):
    M, K, C, dofs, omega, A = frame
    finer = windowed_accelerance(M, K, C, dofs, FRAME_PAIRS, omega, points_per_line=64)
    wider = windowed_accelerance(M, K, C, dofs, FRAME_PAIRS, omega, span_lines=128)
    assert np.max(np.abs(finer - A) / np.abs(A)) < 1e-6
    assert np.max(np.abs(wider - A) / np.abs(A)) < 1e-6


def test_matches_the_time_domain_expectation(frame):
    """At the first three modes' peak lines, between the peaks and at h11's first zero."""
    M, K, C, dofs, omega, A = frame
    exact = _exact(M, K, C, dofs, omega)
    for i, pair in ((0, ("x1", "x1")), (5, ("x3", "x2"))):
        peaks = [int(np.argmax(np.abs(exact[i]) * (np.abs(omega - w) < 0.5))) for w in true_poles(M, K, C)[0][:3]]
        zero = int(np.argmin(np.abs(omega - true_zeros(M, K, dofs.index(pair[0]), dofs.index(pair[1]))[0])))
        lines = np.array(peaks + [zero, zero // 2, (peaks[0] + peaks[1]) // 2])
        reference = lagged_accelerance(M, K, C, dofs, [pair], omega[lines], record_s=1 / STEP_HZ)[0]
        np.testing.assert_allclose(A[i, lines], reference, rtol=1e-6)


def test_bias_is_where_it_should_be(frame):
    """Lower at the first mode's peak line by the amount the kernel predicts (about a quarter
    for a half-power bandwidth of 0.84 lines), and the exact FRF within 1e-3 where it varies
    slowly (over 1 Hz from every pole and zero of the FRF)."""
    M, K, C, dofs, omega, A = frame
    exact = _exact(M, K, C, dofs, omega)
    wn = true_poles(M, K, C)[0]
    k = int(np.argmax(np.abs(exact[0]) * (np.abs(omega - wn[0]) < 0.5)))
    predicted = lagged_accelerance(M, K, C, dofs, [("x1", "x1")], omega[k:k + 1], record_s=1 / STEP_HZ)[0, 0]
    ratio = abs(A[0, k]) / abs(exact[0, k])
    assert ratio == pytest.approx(abs(predicted) / abs(exact[0, k]), rel=1e-6)
    assert 0.70 < ratio < 0.80
    for i, (r, c) in enumerate(FRAME_PAIRS):
        features = np.concatenate([wn, true_zeros(M, K, dofs.index(r), dofs.index(c))])
        calm = np.min(np.abs(omega[:, None] - features[None]), axis=1) > 2 * np.pi * 1.0
        assert calm.sum() > 100
        assert np.max(np.abs(A[i, calm] / exact[i, calm] - 1)) < 1e-3


def test_noise_model_is_frame_measured_s(frame):
    M, K, C, dofs, omega, A = frame
    clean, *_ = frame_windowed(0, floor=0.0, noise=0.0, band_hz=(3.0, 28.0))
    np.testing.assert_allclose(clean.H[0][0] * -omega**2, A[0], rtol=1e-12)
    noisy, *_ = frame_windowed(0, repeats=3, band_hz=(3.0, 28.0))
    e = (np.array(noisy.H)[:, :, :] * -omega**2 - A[:, None, :]) / (4e-3 + 0.005 * np.abs(A[:, None, :]))
    assert e.shape == (9, 3, omega.size)
    assert np.mean(np.abs(e) ** 2) == pytest.approx(1.0, abs=0.02)
