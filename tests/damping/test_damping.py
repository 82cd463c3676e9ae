"""Second stage: Caughey series (Eqs. 20-24)."""

import warnings

import numpy as np
import pytest

from helpers import random_spd
from vibupdate import modes
from vibupdate.damping.models import caughey_matrix
from vibupdate.damping.series import DampingWarning, fit_caughey, modal_damping
from vibupdate.damping.stage import damping_data, damping_weights, identify_damping
from vibupdate.examples import cantilever
from vibupdate.inverse.update import update


@pytest.mark.parametrize("exponents", [[0.0, 1.0], [-1.5, -0.75, 0.0], [0.0, 0.25, 0.5, 0.75, 1.0], [-0.5, 0.3]])
def test_identified_C_is_modal_and_reproduces_the_fitted_ratios(exponents):
    rng = np.random.default_rng(7)
    M, K = random_spd(rng, 6, 3.0), random_spd(rng, 6, 400.0) * 1e3
    omega, Phi = modes(M, K)
    measured = 0.02 + 0.01 * rng.random(6)
    fit = fit_caughey(omega, measured, exponents)
    C = caughey_matrix(M, K, exponents, fit.beta)
    modal = Phi.T @ C @ Phi
    off = modal - np.diag(np.diag(modal))
    assert np.abs(off).max() <= 1e-9 * np.abs(np.diag(modal)).max()
    np.testing.assert_allclose(np.diag(modal) / (2 * omega), fit.fitted, rtol=1e-9)
    np.testing.assert_allclose(C, C.T)


def test_rayleigh_equals_the_closed_form_two_mode_fit():
    w1, w2, x1, x2 = 120.0, 470.0, 0.02, 0.035
    fit = fit_caughey([w1, w2], [x1, x2], [0.0, 1.0])
    # C = a M + b K gives xi = a / (2 w) + b w / 2 (e.g. Chopra, Dynamics of Structures, Eq. 11.4.3).
    a = 2 * w1 * w2 * (x1 * w2 - x2 * w1) / (w2**2 - w1**2)
    b = 2 * (x2 * w2 - x1 * w1) / (w2**2 - w1**2)
    np.testing.assert_allclose(fit.beta, [a, b], rtol=1e-12)
    np.testing.assert_allclose(fit.fitted, [x1, x2], rtol=1e-12)
    np.testing.assert_allclose(modal_damping([0.0, 1.0], [a, b], [w1, w2]), [x1, x2], rtol=1e-12)


def test_weights_pull_the_fit_toward_the_trusted_ratio():
    omega = np.array([100.0, 300.0, 600.0])
    xi = np.array([0.05, 0.01, 0.012])
    plain = fit_caughey(omega, xi, [0.0, 1.0])
    trusted = fit_caughey(omega, xi, [0.0, 1.0], weights=[100.0, 1.0, 1.0])
    assert trusted.errors_pct[0] < plain.errors_pct[0]
    full = fit_caughey(omega, xi, [0.0, 1.0], weights=np.diag([100.0, 1.0, 1.0]))
    np.testing.assert_allclose(full.beta, trusted.beta)


def test_under_determined_and_ill_conditioned_fits_warn():
    with pytest.warns(DampingWarning, match="under-determined: 2 ratios, 3 exponents"):
        fit = fit_caughey([100.0, 200.0], [0.01, 0.02], [0.0, 0.5, 1.0])
    assert "minimum-norm" in fit.notes[0]
    with pytest.warns(DampingWarning, match="ill-conditioned"):
        fit_caughey([100.0, 100.1, 100.2, 100.3], [0.01, 0.011, 0.012, 0.013], [0.0, 0.001, 0.002], condition_limit=1e6)


def test_damping_weights_follow_the_stated_rule():
    labels = (("A", 1), ("A", 2), ("B", 1))
    ratios = np.array([0.01, 0.02, 0.04])
    plain = damping_weights(labels, ratios, ((1, 2.0),))
    assert plain.weights.tolist() == [2.0, 1.0, 2.0]
    assert plain.rule == "W_ii = w_mode with w_mode = {1: 2.0}"
    relative = damping_weights(labels, ratios, ((1, 2.0),), relative=True)
    np.testing.assert_allclose(relative.weights, [2.0 / 1e-4, 1.0 / 4e-4, 2.0 / 16e-4])
    # intervals win over relative errors, and the rule says so
    half = np.array([0.001, 0.002, 0.004])
    framed = damping_weights(labels, ratios, (), relative=True, half_widths=half)
    np.testing.assert_allclose(framed.weights, 1.0 / half**2)
    assert "superseded by the intervals" in framed.rule and "w_mode = 1" in framed.rule


def test_bad_damping_input_is_named():
    with pytest.raises(ValueError, match="damping ratios must be positive and finite, got -0.01"):
        fit_caughey([100.0, 200.0], [0.01, -0.01], [0.0, 1.0])
    with pytest.raises(ValueError, match="exponents must be distinct"):
        fit_caughey([100.0, 200.0], [0.01, 0.02], [1.0, 1.0])
    with pytest.raises(ValueError, match="must have 2 entries"):
        fit_caughey([100.0, 200.0], [0.01, 0.02], [0.0, 1.0], weights=[1.0])


def test_cantilever_damping_meets_the_paper_figure():
    configurations = cantilever.configurations()
    result = update(configurations)
    _, ratios, labels = damping_data(configurations, result.xbar)
    options = cantilever.DAMPING
    weights = damping_weights(labels, ratios, options.mode_weights, relative=options.relative).weights
    with warnings.catch_warnings():
        warnings.simplefilter("error", DampingWarning)
        stage = identify_damping(configurations, result.xbar, options.exponents, weights)
    assert len(stage.caughey.measured) == 12
    # the paper's Table 7 gives 16.6 %; this implementation's figure is 12.3 % (benchmarks/RESULTS.md,
    # the cantilever example), held here to its printed digit so that a change of the fit shows
    mean = stage.caughey.mean_error_pct
    assert mean == pytest.approx(12.35, abs=0.05), f"{mean:.2f} % (12.3 % expected; paper: 16.6 %)"
    assert stage.rayleigh.mean_error_pct > stage.caughey.mean_error_pct
    rows = stage.rows()
    assert {"configuration", "mode", "measured", "identified", "error_pct"} <= set(rows[0])


# -- damping sanity ---------------------------------------------------------------------------


def test_negative_bands_find_the_roots_of_a_known_series():
    from vibupdate.damping.sanity import negative_bands

    # xi(w) = (b0 + b1 w^2) / (2 w) with b0 = 4, b1 = -1e-4: negative above w = 200 rad/s
    assert negative_bands([0.0, 1.0], [4.0, -1e-4], 1000.0) == [(pytest.approx(200.0), 1000.0)]
    # xi(w) = (-b + c w) / (2 w^2)... with Y = [-0.5, 0]: g(w) = -2 w^-1 + 0.1, negative below w = 20
    bands = negative_bands([-0.5, 0.0], [-2.0, 0.1], 100.0)
    assert bands == [(0.0, pytest.approx(20.0))]
    assert negative_bands([0.0, 1.0], [1.0, 1e-4], 1000.0) == []


def test_negative_band_starts_at_a_root_that_falls_exactly_on_a_grid_point():
    from vibupdate.damping.sanity import negative_bands

    # g(w) = 1 - 2^-20 w^2 is exactly 0 at w = 1024, a point of the uniform grid
    # (1, 2, ..., 4096 rad/s); every operation is exact in binary, so g(1024) == 0.0 and the
    # band must start there, not at the next grid point.
    assert negative_bands([0.0, 1.0], [1.0, -2.0**-20], 4096.0, n_grid=4096) == [(1024.0, 4096.0)]
    # and the mirror image: negative below the root, ending exactly there
    assert negative_bands([0.0, 1.0], [-1.0, 2.0**-20], 4096.0, n_grid=4096) == [(0.0, 1024.0)]


def test_cantilever_caughey_and_rayleigh_fits_are_flagged_where_damping_turns_negative():
    """With the paper's updated parameters (Table 6) the Caughey fit with
    Y = [-1.5, -0.75, 0] is negative at low frequency and the Rayleigh baseline at high
    frequency, so its C has negative eigenvalues; both are warnings of the stage."""
    cfgs = cantilever.configurations()
    model = cfgs[0].model
    xbar = model.normalized([68.1e9, 2383.2, 0.0015, 0.0946, 1.871e5, 15.3e9, 7786.3])
    stage = identify_damping(cfgs, xbar, (-1.5, -0.75, 0.0))
    caughey = [w for w in stage.warnings if w.startswith("Caughey")]
    rayleigh = [w for w in stage.warnings if w.startswith("Rayleigh")]
    assert len(caughey) == 1 and "negative modal damping at 0-48.06 Hz" in caughey[0]
    assert len(rayleigh) == 1 and "C has negative eigenvalues" in rayleigh[0]
    assert "the modal damping is negative at 663.8-" in rayleigh[0]
    # the count of negative eigenvalues is that of the exported matrix (Sylvester's law)
    M, K = cfgs[0].model.matrices(xbar)
    C = caughey_matrix(M, K, [0.0, 1.0], stage.rayleigh.beta)
    negative = int(np.sum(np.linalg.eigvalsh(C) < -1e-12 * np.abs(C).max()))
    assert f"configuration A ({negative}: modes 5-14" in rayleigh[0] and negative == 10
    assert np.all(np.linalg.eigvalsh(caughey_matrix(M, K, stage.caughey.exponents, stage.caughey.beta))
                  > -1e-12 * np.abs(C).max())


def test_frf_plot_draws_the_nominal_model_without_the_updated_damping(tmp_path, monkeypatch):
    """The nominal curve is undamped (labelled so), never the updated C."""
    from vibupdate.report import plots

    calls = []
    real = plots.receptances
    monkeypatch.setattr(plots, "receptances", lambda M, K, pairs, w, C=None: calls.append(C) or real(M, K, pairs, w, C))
    cfg = cantilever.configurations()[0]
    M, K = cfg.model.matrices()
    C = caughey_matrix(M, K, [0.0, 1.0], [1.0, 1e-5])
    plots.plot_receptances(tmp_path / "f.png", [(cfg, (M, K, None), (M, K, C), [(0, 0, "h", [])])])
    assert calls[0] is None and calls[1] is C
