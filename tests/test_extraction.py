"""Modal extraction from FRFs on known-truth data (tests/frf_synthetic.py).

The figures of issue 9's "Must hold" list, on the cantilever with non-proportional damping,
5 repeats, 3 % complex noise plus a -60 dB floor, 0.25 Hz lines from 20 to 300 Hz (three
modes in the band, a fourth at 403 Hz above it): frequencies <= 0.05 %, damping <= 2 %,
antiresonances <= 0.2 % with the exact zero count on every FRF, coverage of the 95 %
intervals between 0.85 and 1. The CI profile checks the accuracy on 6 seeds; the coverage
needs many seeds and runs in the slow profile (50 seeds, ``pytest -m slow``). Measured on
50 seeds (loaded machine): worst errors 0.0087 % / 0.74 % / 0.086 %, coverage 0.89 / 0.91 /
0.90 (frequencies / damping ratios / antiresonances), about 0.3 s CPU per extraction.
"""

import math

import numpy as np
import pytest

from frf_synthetic import PAIRS, measured, score, true_poles
from vibupdate.extraction import extract
from vibupdate.frf import FRFSet
from vibupdate.measured import Antiresonance, Configuration, NaturalFrequency, ShapeInterval


def _accuracy(seeds):
    pooled = {"freq_err": [], "damping_err": [], "zero_err": [], "freq_hit": [], "damping_hit": [], "zero_hit": []}
    for seed in seeds:
        frfs, M, K, C, dofs = measured(seed)
        s = score(extract(frfs), M, K, C, dofs)
        assert s["n_modes_ok"], f"seed {seed}: wrong number of modes"
        assert all(s["zero_count_ok"]), f"seed {seed}: wrong zero count on some FRF ({s['zero_count_ok']})"
        for key in pooled:
            pooled[key] += s[key]
    return pooled


def test_accuracy_on_known_truth():
    s = _accuracy(range(6))
    assert max(s["freq_err"]) <= 5e-4
    assert max(s["damping_err"]) <= 0.02
    assert max(s["zero_err"]) <= 2e-3


@pytest.mark.slow
def test_interval_coverage_over_50_seeds():
    s = _accuracy(range(50))
    assert max(s["freq_err"]) <= 5e-4 and max(s["damping_err"]) <= 0.02 and max(s["zero_err"]) <= 2e-3
    for key in ("freq_hit", "damping_hit", "zero_hit"):
        coverage = float(np.mean(s[key]))
        assert 0.85 <= coverage <= 1.0, f"{key}: coverage {coverage:.3f} of the 95 % intervals"


def test_noise_free_fit_is_exact_and_finds_no_extra_mode():
    frfs, M, K, C, dofs = measured(0, repeats=1, noise=0.0, floor=0.0)
    result = extract(frfs)
    assert result.noise == "residual"
    s = score(result, M, K, C, dofs)
    assert s["n_modes_ok"] and all(s["zero_count_ok"])
    assert max(s["freq_err"]) < 1e-5 and max(s["damping_err"]) < 1e-3 and max(s["zero_err"]) < 5e-4


def test_single_measurement_uses_the_residual_as_noise():
    frfs, M, K, C, dofs = measured(3, repeats=1)
    result = extract(frfs)
    assert result.noise == "residual"
    s = score(result, M, K, C, dofs)
    assert s["n_modes_ok"] and all(s["zero_count_ok"])
    assert max(s["freq_err"]) <= 5e-4 and max(s["zero_err"]) <= 2e-3
    assert all(0.5 < q.quality < 2.0 for q in result.quality)


def test_quality_is_near_one_when_the_fit_is_within_the_noise():
    frfs, *_ = measured(1)
    result = extract(frfs)
    assert [(q.response, q.excitation) for q in result.quality] == list(PAIRS)
    assert all(0.8 < q.quality < 1.25 for q in result.quality), [q.quality for q in result.quality]
    assert all(q.n_repeats == 5 for q in result.quality)


def test_shapes_are_mass_normalized_real_modes_at_the_measured_dofs():
    frfs, M, K, C, dofs = measured(2)
    result = extract(frfs)
    import scipy.linalg

    lam, Phi = scipy.linalg.eigh(K, M)
    idx = [dofs.index(d) for d in ("y1", "y2", "y3")]
    for k, mode in enumerate(result.modes):
        assert mode.normalization == "mass"
        phi = np.array([mode.shape[d] for d in ("y1", "y2", "y3")])
        truth = Phi[idx, k] * np.sign(Phi[idx, k] @ phi)
        assert np.allclose(phi, truth, rtol=0.03, atol=0.02 * np.abs(truth).max())
        mac = (phi @ truth) ** 2 / (phi @ phi) / (truth @ truth)
        assert mac > 0.999
        for d, (lo, hi) in mode.shape_interval.items():
            assert lo <= mode.shape[d] <= hi


def test_stabilization_reports_every_order_and_modes_recur():
    frfs, *_ = measured(4)
    result = extract(frfs, orders=range(2, 9))
    assert [o for o, _, _ in result.stabilization] == list(range(2, 9))
    assert all(m.stable_orders >= 3 for m in result.modes)


def test_band_and_n_modes_select_modes():
    frfs, *_ = measured(5)
    result = extract(frfs, band=(2 * math.pi * 20, 2 * math.pi * 180))
    assert len(result.modes) == 2
    two = extract(frfs, n_modes=2)
    assert len(two.modes) == 2  # the two strongest of the three modes in the band: modes 1 and 2
    truth = true_poles(*measured(5)[1:4])[0]
    # leaving an in-band mode out of the model biases the others (measured 0.03 % and 0.11 %)
    assert np.allclose([m.omega for m in two.modes], truth[:2], rtol=5e-3)
    with pytest.raises(ValueError, match="n_modes = 7 but only 3"):
        extract(frfs, n_modes=7)


def test_to_measured_builds_typed_data_for_a_configuration():
    frfs, *_ = measured(6)
    result = extract(frfs)
    naturals, zeros = result.to_measured(first_mode=1)
    assert all(isinstance(n, NaturalFrequency) for n in naturals)
    assert [n.mode for n in naturals] == [1, 2, 3]
    for n, m in zip(naturals, result.modes):
        assert n.interval == m.omega_interval and n.damping_ratio == m.damping_ratio
        assert isinstance(n.shape, ShapeInterval) and set(n.shape.bounds) == {"y1", "y2", "y3"}
    assert all(isinstance(z, Antiresonance) and z.interval is not None and z.index >= 1 for z in zeros)
    assert [z.index for z in zeros if (z.response, z.excitation) == ("y3", "y3")] == [1, 2]
    unnumbered = result.to_measured()[1]
    assert all(z.index is None for z in unnumbered)
    from vibupdate.examples import cantilever

    model = cantilever.configurations()[0].model
    Configuration("A", model, tuple(naturals), tuple(zeros))


def test_synthesize_reproduces_the_measured_mean():
    frfs, *_ = measured(7)
    result = extract(frfs)
    fitted = result.synthesize(frfs.omega)
    error = np.abs(fitted - frfs.mean()) / np.abs(frfs.mean()).max(axis=1, keepdims=True)
    assert error.max() < 0.02
    undamped = result.synthesize(np.array([z.omega for z in result.zeros[:1]]), damped=False)
    k = frfs.pairs.index((result.zeros[0].response, result.zeros[0].excitation))
    assert abs(undamped[k, 0]) < 1e-6 * np.abs(frfs.mean()[k]).max()


def test_bad_arguments_are_clear_errors():
    frfs, *_ = measured(0, repeats=2)
    with pytest.raises(ValueError, match="confidence must be in"):
        extract(frfs, confidence=1.5)
    with pytest.raises(ValueError, match="band must be 0 < low < high"):
        extract(frfs, band=(100.0, 50.0))
    with pytest.raises(ValueError, match="holds 0 frequency lines"):
        extract(frfs, band=(1.0, 1.1))
    flat = FRFSet(frfs.omega, [("y1", "y3")], [np.ones((2, frfs.omega.size)) + 0j])
    with pytest.raises(ValueError, match="no stable mode"):
        extract(flat)
