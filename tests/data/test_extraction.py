"""Modal extraction from FRFs on known-truth data (tests/frf_synthetic.py).

The extraction's accuracy targets, on the cantilever with non-proportional damping,
5 repeats, 3 % complex noise plus a -60 dB floor, 0.25 Hz lines from 20 to 300 Hz (three
modes in the band, a fourth at 403 Hz above it): frequencies <= 0.05 %, damping <= 2 %,
antiresonances <= 0.2 % with the exact zero count on every FRF, coverage of the 95 %
intervals between 0.85 and 1. The CI profile checks the accuracy on 6 seeds; the coverage
needs many seeds and runs in the slow profile (50 seeds, ``pytest -m slow``). Measured on
50 seeds (2026-11-21, loaded machine, one BLAS thread): worst errors 0.0077 % / 0.81 % /
0.073 %, coverage 0.89 / 0.93 / 0.90 (frequencies / damping ratios / antiresonances), about
0.3 s CPU per extraction; 0.92 / 0.96 / 0.91 with the two-component noise estimate
(benchmarks/frf_coverage.py). With one record per pair on the Southampton-like frame the
slow profile checks the coverage too (docs/frf-extraction.md, "Honest intervals").
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from helpers import realdata
from frf_synthetic import (CHAIN_PAIRS, FRAME_PAIRS, PAIRS, chain_system, frame_measured, measured, score, true_poles,
                           true_zeros, write_uff)
from vibupdate.cli import main
from vibupdate.data.extraction import extract
from vibupdate.data.frf import FRFSet
from vibupdate.data.measured import Antiresonance, Configuration, NaturalFrequency, ShapeInterval
from vibupdate.io.measured_io import read_frequency_csv, read_shape_csv


def _accuracy(seeds):
    pooled = {"freq_err": [], "damping_err": [], "zero_err": [], "freq_hit": [], "damping_hit": [], "zero_hit": []}
    for seed in seeds:
        frfs, M, K, C, dofs = measured(seed)
        s = score(extract(frfs, joint=False), M, K, C, dofs)   # the 95 % intervals each
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


def test_accuracy_on_a_known_truth_frame_like_the_southampton_one():
    """`frame_measured`: the Southampton situation with a known truth (one record per pair,
    0.03125 Hz lines, about 0.2 % non-proportional damping, two light modes just above the
    band, the measured noise floor of 4e-3 (m/s^2)/N). Measured over 20 seeds
    (benchmarks/soton_zeros.py --synthetic 20): zeros worst 0.18 %, rms 0.034 %, coverage
    0.85; the sign change of the measured real part (the local estimate the reference
    values agree with) rms 0.24 %. Seeds 0-1 here."""
    band = (2 * math.pi * 3, 2 * math.pi * 28)
    for seed in range(2):
        frfs, M, K, C, dofs = frame_measured(seed)
        s = score(extract(frfs, band, n_modes=3), M, K, C, dofs, pairs=FRAME_PAIRS)
        assert s["n_modes_ok"] and all(s["zero_count_ok"]), f"seed {seed}: {s['zero_count_ok']}"
        assert max(s["freq_err"]) <= 5e-4 and max(s["damping_err"]) <= 0.02
        assert max(s["zero_err"]) <= 2e-3


@pytest.mark.slow
def test_interval_coverage_with_one_record_on_the_frame_over_50_seeds():
    """`frame_measured`, one record per pair (the noise from the fit's residual), 50 seeds:
    coverage of the 95 % intervals between 0.85 and 1. Measured (2026-11-21, loaded
    machine; benchmarks/frf_coverage.py frame 1 50): frequencies 1.00, damping ratios 0.63,
    antiresonances 0.86 before the leverage-corrected two-component noise estimate; see
    docs/frf-extraction.md for the figures after."""
    band = (2 * math.pi * 3, 2 * math.pi * 28)
    pooled = {"freq_hit": [], "damping_hit": [], "zero_hit": []}
    for seed in range(50):
        frfs, M, K, C, dofs = frame_measured(seed)
        s = score(extract(frfs, band, n_modes=3, joint=False), M, K, C, dofs, pairs=FRAME_PAIRS)
        assert s["n_modes_ok"] and all(s["zero_count_ok"]), f"seed {seed}: {s['zero_count_ok']}"
        for key in pooled:
            pooled[key] += s[key]
    for key, hits in pooled.items():
        coverage = float(np.mean(hits))
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
    # the noise of the quality figure is model-free (second differences) without repeats:
    # about 1 on a fit within the noise (measured 0.93-1.07 on seeds 0-2 of both cases)
    assert all(0.8 < q.quality < 1.25 for q in result.quality), [q.quality for q in result.quality]


def test_the_noise_is_never_estimated_twice_at_the_same_poles(monkeypatch):
    # one record: the noise comes from the residual, at the stable poles (to test their
    # significance) and again at each refit's start; before, the first refit recomputed the
    # significance test's estimate at the same poles (a quarter of the noise cost)
    from vibupdate.data import extraction

    inner, seen = extraction.residual_variance, []

    def counted(x, F, wn, zeta, *args, **kwargs):
        seen.append(np.r_[wn, zeta].tobytes())
        return inner(x, F, wn, zeta, *args, **kwargs)

    monkeypatch.setattr(extraction, "residual_variance", counted)
    frfs, *_ = measured(3, repeats=1)
    assert extract(frfs).noise == "residual"
    assert len(seen) == 3 and len(set(seen)) == len(seen)


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
    assert result.fitted_poles.shape == (3, 2)  # the third mode (217 Hz) is fitted, not reported
    two = extract(frfs, n_modes=2)
    assert len(two.modes) == 2  # the two strongest of the three modes in the band: modes 1 and 2
    truth = true_poles(*measured(5)[1:4])[0]
    # leaving an in-band mode out of the model biases the others (measured 0.03 % and 0.11 %)
    assert np.allclose([m.omega for m in two.modes], truth[:2], rtol=5e-3)
    with pytest.raises(ValueError, match="n_modes = 7 but only 3"):
        extract(frfs, n_modes=7)


def test_modes_just_above_the_band_are_fitted_as_modes_and_not_reported():
    """A mode 5 % above the band's top (the chain's 50.3 Hz, band 5-48 Hz, data to 100 Hz):
    the default fit band (up to twice the band's top) fits it with its own residues and
    reports only the three modes in the band; fitting the band alone leaves it to the
    residual terms and biases the zeros near the top (measured on seeds 0-1: worst zero
    error 0.084 % / 0.096 % with the default, 0.99 % / 0.69 % with fit_band = band)."""
    band = (2 * math.pi * 5, 2 * math.pi * 48)
    worst_default, worst_narrow = [], []
    for seed in (0, 1):
        frfs, M, K, C, dofs = measured(seed, band_hz=(5.0, 100.0), step_hz=0.1, system=chain_system(),
                                       pairs=CHAIN_PAIRS)
        result = extract(frfs, band=band)
        assert result.fit_band == pytest.approx((band[0], 2 * band[1]), rel=1e-3)
        truth = true_poles(M, K, C)[0]
        assert result.fitted_poles[:, 0] == pytest.approx(truth[:4], rel=5e-4)  # the fourth fitted ...
        s = score(result, M, K, C, dofs, CHAIN_PAIRS)
        assert s["n_modes_ok"] and all(s["zero_count_ok"])                      # ... not reported
        assert max(s["freq_err"]) <= 5e-4 and max(s["zero_err"]) <= 2e-3
        worst_default.append(max(s["zero_err"]))
        narrow = score(extract(frfs, band=band, fit_band=band), M, K, C, dofs, CHAIN_PAIRS)
        worst_narrow.append(max(narrow["zero_err"]))
    assert max(worst_default) < min(worst_narrow) / 3, (worst_default, worst_narrow)
    with pytest.raises(ValueError, match="must contain the band"):
        extract(frfs, band=band, fit_band=(band[0], 0.9 * band[1]))


def test_local_refit_finds_a_zero_moved_by_a_smooth_misfit():
    """Known truth: a smooth real offset (a Gaussian 10 % of the zero wide, 0.3 % of the FRF's
    peak) added to h_y3,y3 moves its second zero by 0.61 %; the modal model cannot follow it.
    The local refit finds the moved zero (measured error 0.043 %); the global fit's zero is
    0.2 % off."""
    import scipy.optimize

    frfs, M, K, C, dofs = measured(0)
    k, r = frfs.pairs.index(("y3", "y3")), dofs.index("y3")
    z0 = true_zeros(M, K, r, r)[1]
    peak = np.abs(frfs.mean()[k]).max()

    def offset(w):
        return 0.003 * peak * np.exp(-((w - z0) / (0.1 * z0)) ** 2)

    H = list(frfs.H)
    H[k] = H[k] + offset(frfs.omega)[None, :]
    moved = FRFSet(frfs.omega, frfs.pairs, tuple(H))
    truth = scipy.optimize.brentq(lambda w: np.linalg.inv(K - w**2 * M)[r, r] + offset(w), 0.97 * z0, 1.03 * z0)
    assert abs(truth / z0 - 1) > 5e-3

    def second_zero(result):
        return [z.omega for z in result.zeros if (z.response, z.excitation) == ("y3", "y3")][1]

    assert abs(second_zero(extract(moved)) / truth - 1) < 1e-3
    assert abs(second_zero(extract(moved, local_zeros=False)) / truth - 1) > 1.5e-3


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


# ----------------------------------------------------------------------------- CLI

REALDATA = realdata("soton3storey")
#: The marker of the tests that read it (skipped, naming the path, when it is not there).
SOTON = pytest.mark.realdata("soton3storey")
SOTON_FILES = ("Experimental.csv", "test_2.csv", "test_3.csv")  # force at floor 1, 2, 3
#: Reference values of an independent analysis, Hz.
SOTON_MODES_HZ = (6.5126, 17.4608, 26.5003)
SOTON_DAMPING = (0.0017, 0.0025, 0.0022)
SOTON_ZEROS_HZ = {("x1", "x1"): (8.80, 23.94), ("x2", "x2"): (14.99, 19.85), ("x3", "x3"): (14.18, 25.24),
                  ("x2", "x1"): (14.39,), ("x1", "x2"): (14.48,), ("x3", "x2"): (19.43,), ("x2", "x3"): (19.45,)}




def test_cli_extract_writes_json_case_files_and_plot(tmp_path, capsys):
    frfs, *_ = measured(8, repeats=3)
    uff = tmp_path / "hits.uff"
    write_uff(uff, frfs)
    out = tmp_path / "ex"
    assert main(["extract", str(uff), "--band", "20", "300", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "[[configuration]]" in printed and "noise from repeats" in printed
    assert "have quality above" not in printed  # within the noise
    # mode 1 (67.7 Hz, 2 zeta f = 0.75 Hz) spans 3 lines of 0.25 Hz, modes 2 and 3 more than 4
    assert "fewer than 4 lines (mode 1: 3.0):" in printed
    doc = json.loads((out / "extraction.json").read_text())
    natural = doc["natural"]
    assert len(natural) == 3 and [n["mode"] for n in natural] == [1, 2, 3]
    assert set(natural[0]) >= {"mode", "freq_hz", "freq_hz_interval", "damping_ratio", "damping_ratio_interval",
                               "shape", "shape_interval"}
    assert set(natural[0]["shape"]) == {"y1", "y2", "y3"}
    lo, hi = natural[0]["freq_hz_interval"]
    assert lo <= natural[0]["freq_hz"] <= hi and 67.0 < natural[0]["freq_hz"] < 68.5
    zero = doc["antiresonances"][0]
    assert set(zero) >= {"response", "excitation", "index", "freq_hz", "freq_hz_interval"}
    assert (out / "fit.png").stat().st_size > 10000
    assert doc["fit_band_hz"] == pytest.approx(doc["band_hz"], rel=1e-6)  # the data end at the band's top
    assert [m["reported"] for m in doc["fitted_modes"]] == [True, True, True]
    # the written CSV files read back through the case-format readers
    natural_rows, zero_rows = read_frequency_csv(out / "frequencies.csv")
    assert [r["hz"] for r in natural_rows] == pytest.approx([n["freq_hz"] for n in natural], rel=1e-7)
    assert natural_rows[0]["damping_ratio"] == pytest.approx(natural[0]["damping_ratio"], rel=1e-5)
    assert len(zero_rows) == len(doc["antiresonances"])
    shapes = read_shape_csv(out / "shapes.csv")
    assert set(shapes) == {1, 2, 3} and set(shapes[1]) == {"y1", "y2", "y3"}
    block = (out / "configuration.toml").read_text()
    # the poles' magnitudes are natural frequencies: stated, so their damping raises no note
    assert "frequencies_csv" in block and 'frequency_type = "natural"' in block
    assert [r["mode"] for r in natural_rows] == [1, 2, 3]
    # --first-mode: the frequencies declare the modes the shapes are numbered by (the two files
    # read together: before, the frequencies had no mode column and counted from 1)
    again = tmp_path / "ex2"
    assert main(["extract", str(uff), "--band", "20", "300", "--first-mode", "2", "--no-plot", "--out",
                 str(again)]) == 0
    natural_rows, _ = read_frequency_csv(again / "frequencies.csv")
    assert [r["mode"] for r in natural_rows] == [2, 3, 4] and set(read_shape_csv(again / "shapes.csv")) == {2, 3, 4}


def test_cli_extract_writes_through_the_manifest_and_keeps_foreign_files(tmp_path, capsys):
    from vibupdate.io.manifests import read_manifest

    frfs, *_ = measured(8, repeats=2)
    uff = tmp_path / "hits.uff"
    write_uff(uff, frfs)
    out = tmp_path / "ex"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    args = ["extract", str(uff), "--band", "20", "300", "--out", str(out), "--no-plot"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "holds files `vibupdate extract` did not write (notes.txt)" in err and "--force" in err
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]  # refused before writing anything
    assert main(args + ["--force"]) == 0
    assert read_manifest(out, "extract") == ["configuration.toml", "damping.csv", "extraction.json", "frequencies.csv",
                                  "shapes.csv"]
    assert (out / "notes.txt").read_text() == "mine"
    (out / "frequencies.csv").unlink()
    (out / "fit.png").write_text("not ours")  # a foreign file where the plot would go
    assert main(args[:-1] + ["--force"]) == 2
    assert "fit.png, which `vibupdate extract` did not write and would overwrite" in capsys.readouterr().err
    assert main(args) == 2  # foreign files again without --force
    (out / "fit.png").unlink()
    (out / "notes.txt").unlink()
    assert main(args) == 0  # only vibupdate's own files: a rerun replaces them without --force
    assert (out / "frequencies.csv").is_file()


def test_cli_extract_bad_input_is_a_clear_error(tmp_path, capsys):
    path = tmp_path / "frf.csv"
    path.write_text("1.0;1+1j\n2.0;x\n")
    assert main(["extract", str(path), "--responses", "x1", "--excitations", "x1", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "row 2, column 1" in err and "Traceback" not in err
    assert main(["extract", str(path), "--out", str(tmp_path)]) == 2
    assert "give the response DOF of each column" in capsys.readouterr().err


def _soton(out, files, excitations):
    args = ["extract", *(str(REALDATA / f) for f in files), "--responses", "x1", "x2", "x3",
            "--excitations", *excitations, "--kind", "accelerance", "--band", "3", "28", "--modes", "3",
            "--out", str(out), "--no-plot"]
    assert main(args) == 0
    return json.loads((out / "extraction.json").read_text())


@pytest.fixture(scope="module")
def soton_all(tmp_path_factory):
    """The three tests through one `vibupdate extract` (all nine FRFs)."""
    return _soton(tmp_path_factory.mktemp("soton"), SOTON_FILES, ["x1", "x2", "x3"])


@SOTON
def test_southampton_modes_within_0p1_percent_and_tests_consistent(tmp_path):
    docs = [_soton(tmp_path / f"t{k + 1}", [f], [f"x{k + 1}"]) for k, f in enumerate(SOTON_FILES)]
    for doc in docs:
        assert [n["mode"] for n in doc["natural"]] == [1, 2, 3]
        for n, ref, xi in zip(doc["natural"], SOTON_MODES_HZ, SOTON_DAMPING):
            assert n["freq_hz"] == pytest.approx(ref, rel=1e-3)
            assert n["damping_ratio"] == pytest.approx(xi, rel=0.2)  # reference printed to 2 digits
    for k in range(3):  # the three tests agree within their intervals (common overlap)
        intervals = [d["natural"][k]["freq_hz_interval"] for d in docs]
        assert max(lo for lo, _ in intervals) <= min(hi for _, hi in intervals), intervals


def _soton_zero_errors(doc):
    errors = {}
    for z in doc["antiresonances"]:
        refs = SOTON_ZEROS_HZ.get((z["response"], z["excitation"]), ())
        if refs:
            ref = min(refs, key=lambda r: abs(r - z["freq_hz"]))
            errors[(z["response"], z["excitation"], ref)] = (abs(z["freq_hz"] / ref - 1), z["freq_hz_interval"])
    return errors


@SOTON
def test_southampton_quality_shows_the_misfit_at_the_peaks(tmp_path, capsys):
    """One record per pair: the modal model misses the measured peak lines by 6-14 % of |H|,
    while between the peaks the residual is at the line-to-line noise, so the quality figure
    is well above 1 (measured 2.7-3.6) and `extract` says so in a note; the residual's own
    noise estimate made it 0.43-0.52, as if the fit were better than the noise."""
    doc = _soton(tmp_path, SOTON_FILES[1:2], ["x2"])
    assert all(q["quality"] > 2.0 for q in doc["quality"]), doc["quality"]
    printed = capsys.readouterr().out
    assert "note: 3 of 3 FRF(s) have quality above 2" in printed
    # 2 zeta f / df: 0.7, 2.7 and 3.8 lines, each under 4
    assert "note: half-power bandwidths of fewer than 4 lines (mode 1: 0.7, mode 2: 2.7, mode 3: 3.8)" in printed


@SOTON
def test_southampton_modes_within_0p05_percent_of_the_reference_and_inside_their_intervals(soton_all):
    """All nine FRFs in one extraction: measured -0.015, -0.0038 and +0.0095 % from the
    reference values, each reference inside its 95 % interval."""
    for n, ref in zip(soton_all["natural"], SOTON_MODES_HZ, strict=True):
        assert n["freq_hz"] == pytest.approx(ref, rel=5e-4)
        lo, hi = n["freq_hz_interval"]
        assert lo <= ref <= hi


@SOTON
def test_southampton_antiresonances_found_and_references_within_intervals(soton_all):
    errors = _soton_zero_errors(soton_all)
    assert set(errors) == {(r, c, ref) for (r, c), refs in SOTON_ZEROS_HZ.items() for ref in refs}
    assert len(soton_all["antiresonances"]) == len(errors)  # no zero beyond the reference list
    for (r, c, ref), (_, (lo, hi)) in errors.items():
        assert lo <= ref <= hi, f"h{r}{c}: reference {ref} Hz outside [{lo:.3f}, {hi:.3f}]"
    for n, ref in zip(soton_all["natural"], SOTON_MODES_HZ):
        assert n["freq_hz"] == pytest.approx(ref, rel=1e-3)


@SOTON
def test_southampton_reciprocal_zeros_agree_within_their_intervals(soton_all):
    """h21 / h12 and h32 / h23 are one physical zero each (symmetric M, K) measured in two
    tests: their intervals overlap (measured 14.416 / 14.487 Hz, 0.49 % apart, and 19.407 /
    19.439 Hz; the reference's own pairs are 0.63 % and 0.10 % apart)."""
    got = {(z["response"], z["excitation"]): z["freq_hz_interval"] for z in soton_all["antiresonances"]
           if (z["response"], z["excitation"]) in {("x2", "x1"), ("x1", "x2"), ("x3", "x2"), ("x2", "x3")}}
    for a, b in ((("x2", "x1"), ("x1", "x2")), (("x3", "x2"), ("x2", "x3"))):
        assert max(got[a][0], got[b][0]) <= min(got[a][1], got[b][1]), (a, got[a], b, got[b])


@pytest.mark.xfail(strict=True, reason="measured errors 0.01-0.27 % (h11 8.80 Hz: 0.27 %, h33 14.18 Hz: 0.23 %, h21 "
                                       "14.39 Hz: 0.19 %, h22 19.85 Hz: 0.16 %, h32 19.43 Hz: 0.12 %), each inside "
                                       "its interval; the reference agrees with the sign change of the measured real "
                                       "part (mean 0.04 %), an estimator 5-7x less accurate on known truth, and the "
                                       "data's reciprocal pair h21/h12 differs by 0.5 %: docs/frf-extraction.md")
@SOTON
def test_southampton_antiresonances_within_0p1_percent(soton_all):
    worst = max(e for e, _ in _soton_zero_errors(soton_all).values())
    assert worst <= 1e-3


def test_docs_example_runs_and_finds_the_truth(capsys):
    import re

    text = (Path(__file__).resolve().parents[2] / "docs" / "frf-extraction.md").read_text()
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    namespace = {}
    exec(compile(code, "docs/frf-extraction.md", "exec"), namespace)
    result = namespace["result"]
    assert [round(m.omega / 2 / math.pi, 2) for m in result.modes] == [9.84, 25.75]
    assert [(z.response, z.excitation) for z in result.zeros] == [("x1", "x1")]
    assert result.zeros[0].omega == pytest.approx(100.0, rel=1e-3)  # sqrt(k2 / m2) rad/s


def test_case_configuration_from_frf_files(tmp_path):
    from frf_synthetic import cantilever_frf_case
    from vibupdate.io.case import load_case

    frfs, *_ = measured(9, repeats=3)
    _, text = cantilever_frf_case(tmp_path)
    (tmp_path / "case.toml").write_text(text)
    case = load_case(tmp_path / "case.toml")
    cfg = case.configurations[0]
    kept = case.frfs["A"]  # the measured FRFs in the band, for the report's overlay
    assert kept.pairs == frfs.pairs and kept.freq_hz[0] >= 20 and kept.freq_hz[-1] <= 300
    assert [n.mode for n in cfg.natural] == [1, 2, 3]
    assert all(n.interval is not None and n.damping_interval is not None and n.shape is not None for n in cfg.natural)
    assert cfg.natural[0].freq_hz == pytest.approx(67.65, rel=1e-3)
    assert [z.index for z in cfg.antiresonances if z.response == "y3"] == [1, 2]
    assert all(z.interval is not None for z in cfg.antiresonances)
    (tmp_path / "case.toml").write_text(text.replace('name = "A"\n', 'name = "A"\nnatural_hz = [70.0]\n'))
    with pytest.raises(ValueError, match="FRF files take the place of typed data; remove natural_hz"):
        load_case(tmp_path / "case.toml")
    (tmp_path / "case.toml").write_text(text.replace('files = ["hits.uff"]', 'files = ["none.uff"]'))
    with pytest.raises(ValueError, match=r"configuration 'A'.frf: UFF file .*none.uff' does not exist"):
        load_case(tmp_path / "case.toml")
    (tmp_path / "case.toml").write_text(text.replace("band_hz = [20, 300]", "band_hz = [20, 300]\nfit_band_hz = [30, 300]"))
    with pytest.raises(ValueError, match=r"configuration 'A'.frf: fit_band 30-300 Hz must contain"):
        load_case(tmp_path / "case.toml")
    (tmp_path / "case.toml").write_text(text.replace("band_hz = [20, 300]", 'band_hz = [20, 300]\nwindow = "hamming"'))
    with pytest.raises(ValueError, match=r"configuration 'A'.frf: window 'hamming' is not known"):
        load_case(tmp_path / "case.toml")
    (tmp_path / "case.toml").write_text(text.replace("band_hz = [20, 300]", 'band_hz = [20, 300]\nwindow = "hann"'))
    windowed = load_case(tmp_path / "case.toml").configurations[0]  # the UFF file's receptances, windowed
    assert [n.mode for n in windowed.natural] == [1, 2, 3]
    assert windowed.natural[0].damping_ratio != cfg.natural[0].damping_ratio


def test_fit_band_from_the_command_line_and_a_bad_one_is_a_clear_error(tmp_path, capsys):
    frfs, *_ = measured(8, repeats=2)
    uff = tmp_path / "hits.uff"
    write_uff(uff, frfs)
    top = float(frfs.freq_hz[-1])
    out = tmp_path / "ex"
    assert main(["extract", str(uff), "--band", "40", "250", "--fit-band", "30", f"{top}", "--out", str(out),
                 "--no-plot"]) == 0
    assert json.loads((out / "extraction.json").read_text())["fit_band_hz"] == pytest.approx([30, top], rel=1e-3)
    assert main(["extract", str(uff), "--band", "20", "300", "--fit-band", "30", "300", "--out",
                 str(tmp_path / "bad"), "--no-plot"]) == 2
    err = capsys.readouterr().err
    assert "fit_band 30-300 Hz must contain" in err and "Traceback" not in err
    assert not (tmp_path / "bad").exists()


def test_measured_frf_overlay_plot(tmp_path):
    from vibupdate.report.plots import plot_measured_frf
    from frf_synthetic import cantilever_system

    frfs, *_ = measured(4, repeats=2)
    M, K, C, dofs = cantilever_system()
    path = plot_measured_frf(tmp_path / "frf_A.png", frfs.band(2 * math.pi * 20, 2 * math.pi * 300), dofs,
                             (M, 1.05 * K, None), (M, K, C), "A", "nominal (undamped)", "updated (damped)")
    assert path.stat().st_size > 10_000
    with pytest.raises(ValueError, match=r"no measured FRF pair .*\('y1', 'y3'\).* has both its response and excitation among the model's DOFs and sensors"):
        plot_measured_frf(tmp_path / "x.png", frfs, ["x1", "x2"], (M, K, None), (M, K, C), "A", "n", "u")


@SOTON
@pytest.mark.slow   # a whole run on the real FRFs, 25-35 s each: in CI's second step (pytest -m slow)
@pytest.mark.parametrize("case_file", ["soton-frame.toml", "soton-frame-masses.toml"])
def test_southampton_case_updates_a_frame_model_from_frfs_in_one_run(tmp_path, case_file):
    """docs/soton-frame.toml (and its variant with the masses of floors 2 and 3 free):
    extraction and updating in one ``vibupdate run``; compared with the classical frequency
    fit (vibupdate.inverse.baseline) on the same model and data."""
    import shutil

    from vibupdate.inverse.baseline import frequency_fit
    from vibupdate.io.case import load_case

    shutil.copy(Path(__file__).resolve().parents[2] / "docs" / case_file, tmp_path / "case.toml")
    for name in SOTON_FILES:
        (tmp_path / name).symlink_to(REALDATA / name)
    code = main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out")])
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    rows = doc["frequencies"]
    assert len(rows) == 13  # 3 natural frequencies and the 10 antiresonances, all from the FRFs
    updated = np.mean([r["error_updated_pct"] for r in rows])
    nominal = np.mean([r["error_nominal_pct"] for r in rows])
    # the classical frequency fit on the same model and the same 13 frequencies (its mean error
    # is over all of them)
    classical = frequency_fit(load_case(tmp_path / "case.toml").configurations).mean_error_pct
    assert updated < nominal / 4 and classical < nominal / 4
    report = (tmp_path / "out" / "report.md").read_text()
    assert "FRFs of configuration frame: measured receptance (m/N" in report  # the overlay (Fig. 11)
    # benchmarks/RESULTS.md, "The Southampton frame under one admissible-data contract": each
    # verdict below was checked by an eigen-solve of the written matrices, independent of the
    # library's checks
    if case_file == "soton-frame-masses.toml":
        # with the masses of floors 2 and 3 free, a model fits all 13 data within their
        # measurement intervals plus the 2 % model-form tolerance (mean 1.44 %)
        assert code == 0 and doc["solver"]["status"] == "success", doc["solver"]
        for r in rows:
            widened = (r["measured_lower_hz"] - 0.02 * r["measured_hz"], r["measured_upper_hz"] + 0.02 * r["measured_hz"])
            assert widened[0] <= r["updated_hz"] <= widened[1], r
        assert (tmp_path / "out" / "K_frame.mtx").is_file()
    else:
        # the shear frame cannot fit every datum; the diagnosis leaves each of its 19 groups out
        # in turn and finds that without mode 1 (6.51 Hz) the rest verify
        assert code == 1
        failed = [c["name"] for c in doc["checks"] if not c.get("passed", True)]
        assert "fit" in failed, failed
        diagnosis = doc["diagnosis"]
        assert diagnosis["groups"] == 19 and "## Which data conflict" in report
        assert diagnosis["trials"][0]["key"] == "frame/natural/1" and diagnosis["trials"][0]["passed"]
        assert diagnosis["best"]["status"] == "success"
        assert (tmp_path / "out" / "without_worst_K_frame.mtx").is_file()
        assert (tmp_path / "out" / "not_verified_K_frame.mtx").is_file()
    assert (tmp_path / "out" / "frf_frame.png").stat().st_size > 20_000


@SOTON
@pytest.mark.slow   # a whole run on the real FRFs, about 35 s: in CI's second step (pytest -m slow)
def test_southampton_frame_element_model_updated_from_frfs_in_one_run(tmp_path):
    """docs/soton-frame-elements.toml: the planar frame-element model (legs as frame elements,
    floors as stiff plates, base rotational spring) updated from the FRFs in one run. It does
    not verify: the fit check fails (docs/frf-extraction.md)."""
    import shutil

    from vibupdate.inverse.baseline import frequency_fit
    from vibupdate.io.case import load_case

    shutil.copy(Path(__file__).resolve().parents[2] / "docs" / "soton-frame-elements.toml", tmp_path / "case.toml")
    for name in SOTON_FILES:
        (tmp_path / name).symlink_to(REALDATA / name)
    # the diagnosis of the same data runs in the shear-frame tests above (here it would add 20 s)
    code = main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out"), "--no-diagnose"])
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    assert len(doc["frequencies"]) == 13
    updated = np.mean([r["error_updated_pct"] for r in doc["frequencies"]])
    nominal = np.mean([r["error_nominal_pct"] for r in doc["frequencies"]])
    classical = frequency_fit(load_case(tmp_path / "case.toml").configurations).mean_error_pct
    # measured: nominal 9.22 %, updated 1.86 %, classical 1.77 %; not verified (fit check)
    assert updated < nominal / 4 and classical < nominal / 4
    # the extraction's notes reach the run's warnings (terminal, report, results.json)
    assert any("configuration 'frame' FRFs: half-power bandwidths of fewer than 4 lines" in w
               for w in doc["warnings"]), doc["warnings"]
    assert "FRFs: 9 of 9 FRF(s) have quality above 2" in (tmp_path / "out" / "report.md").read_text()
    assert updated < 1.2 * classical  # the homotopy answer is as good as the local fit, within 20 %
    if code == 1:
        failed = [c["name"] for c in doc["checks"] if not c.get("passed", True)]
        assert "fit" in failed, failed
    assert (tmp_path / "out" / "frf_frame.png").is_file()


def test_extraction_runs_on_one_blas_thread(monkeypatch):
    """Many small least-squares problems: a multithreaded BLAS only spins (111 s against 1.9 s
    on the Southampton data with OpenBLAS's default threads, see `extract`)."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from vibupdate.data import extraction

    seen = []
    inner = extraction._extract

    def spy(*args):
        seen.extend(pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas")
        return inner(*args)

    monkeypatch.setattr(extraction, "_extract", spy)
    frfs, *_ = measured(3, repeats=2)
    with threadpool_limits(limits=2, user_api="blas"):  # as on a machine without OMP_NUM_THREADS=1
        # scipy's BLAS takes the limit (an old BLAS another package bundles, as opensees does,
        # may keep its one thread)
        assert 2 in {p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"}
        extraction.extract(frfs)
    assert seen and set(seen) == {1}


def test_a_roving_hammer_test_read_reciprocally_gives_shapes_at_every_hammer_point(tmp_path, capsys):
    """One accelerometer at y3, the hammer at y1, y2, y3: as measured, the shapes have the one
    response entry; read reciprocally (`--reciprocal`, h_rc as h_cr) they have all three, and
    equal those of the roving-accelerometer layout of the same structure within their intervals."""
    from vibupdate.data.frf import FRFSet

    roving = [("y3", "y1"), ("y3", "y2"), ("y3", "y3")]
    hammer, *_ = measured(11, repeats=3, pairs=roving)
    as_measured = extract(hammer)
    assert all(set(m.shape_interval) == {"y3"} for m in as_measured.modes)
    swapped = hammer.reciprocal()
    assert set(swapped.pairs) == {("y1", "y3"), ("y2", "y3"), ("y3", "y3")}
    result = extract(swapped)
    accelerometers, *_ = measured(12, repeats=3)          # responses y1, y2, y3, excitation y3
    reference = extract(accelerometers)
    assert len(result.modes) == len(reference.modes) == 3
    for m, ref in zip(result.modes, reference.modes):
        assert set(m.shape_interval) == {"y1", "y2", "y3"}
        for dof, (lo, hi) in m.shape_interval.items():
            rlo, rhi = ref.shape_interval[dof]
            assert lo <= rhi and rlo <= hi, (dof, (lo, hi), (rlo, rhi))   # the intervals overlap
    # the command line and a case file say it the same way
    uff = tmp_path / "hammer.uff"
    write_uff(uff, hammer)
    assert main(["extract", str(uff), "--reciprocal", "--no-plot", "--out", str(tmp_path / "ex")]) == 0
    shapes = read_shape_csv(tmp_path / "ex" / "shapes.csv")
    assert set(shapes[1]) == {"y1", "y2", "y3"}
    both = FRFSet(hammer.omega, (("y3", "y1"), ("y1", "y3")), (hammer.H[0], hammer.H[1])).reciprocal()
    assert both.pairs == (("y1", "y3"), ("y3", "y1")) and both.H[0] is hammer.H[0]


def test_zeros_above_the_highest_fitted_pole_are_left_out_unless_kept(tmp_path):
    """Fitting 20-200 Hz of the cantilever (modes 67.7 and 127 Hz; the next, 229 Hz, outside the
    fitted lines): the zeros above 127 Hz are shaped by the residual terms and left out, said in
    the notes; kept on request; with the default fit band (to twice the band's top) the 229 Hz
    mode is fitted and they are ordinary zeros again."""
    frfs, *_ = measured(5, repeats=5)
    band = (2 * math.pi * 20.0, 2 * math.pi * 200.0)
    narrow = extract(frfs, band=band, fit_band=band)
    assert len(narrow.modes) == 2 and narrow.outer_zeros
    top = narrow.fitted_poles[:, 0].max()
    assert all(z.omega > top for z in narrow.outer_zeros) and all(z.omega <= top for z in narrow.zeros)
    note = next(n for n in narrow.notes() if "outside the fitted poles" in n)
    assert "left out" in note and "keep_outer_zeros" in note
    kept = extract(frfs, band=band, fit_band=band, keep_outer_zeros=True)
    assert not kept.outer_zeros and len(kept.zeros) == len(narrow.zeros) + len(narrow.outer_zeros)
    # each zero keeps its index, counted from the lowest in the band, left out or not
    indices = {(z.response, z.excitation, z.index) for z in kept.zeros}
    assert indices == {(z.response, z.excitation, z.index) for z in narrow.zeros + narrow.outer_zeros}
    wide = extract(frfs, band=band)
    assert not wide.outer_zeros and wide.fitted_poles[:, 0].max() > 2 * math.pi * 200


@SOTON
def test_the_docs_extract_command_names_the_files_of_the_southampton_data_set(tmp_path):
    """docs/frf-extraction.md opens with the Southampton command; it names files the data set
    has, and runs as written."""
    import re
    import shlex

    text = (Path(__file__).resolve().parents[2] / "docs" / "frf-extraction.md").read_text()
    line = re.search(r"^vibupdate extract Experimental\.csv .*?(?<!\\)$", text.replace("\\\n", " "), re.M).group(0)
    args = shlex.split(line)[1:]
    files = [a for a in args if a.endswith(".csv")]
    assert files and all((REALDATA / f).is_file() for f in files), files
    args = [str(REALDATA / a) if a in files else a for a in args]
    args[args.index("--out") + 1] = str(tmp_path / "extraction")
    assert main(args + ["--no-plot"]) == 0


@pytest.mark.parametrize("omega_by, h_by", [(1e-150, 1.0), (1.0, 1e280), (1.0, 1e-300)])
def test_the_extraction_holds_at_any_scale_of_the_frequencies_and_the_frf(omega_by, h_by):
    """Frequencies and FRF values scaled by powers of ten far off their units give the same
    modes, scaled: the shape fit works in units of each mode's largest modal constant (before:
    overflow in its least squares below 1e-150, an FRF above 1e280 read as "not a finite number")."""
    import warnings

    frfs, *_ = measured(8, repeats=1)
    reference = extract(frfs, n_modes=3)
    scaled = FRFSet(frfs.omega * omega_by, frfs.pairs, tuple(h * h_by for h in frfs.H))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        found = extract(scaled, n_modes=3)
    assert len(found.modes) == len(reference.modes) == 3
    for a, b in zip(found.modes, reference.modes):
        assert a.omega == pytest.approx(b.omega * omega_by, rel=1e-9)
        assert a.damping_ratio == pytest.approx(b.damping_ratio, rel=1e-6)
        unit = math.sqrt(h_by) * omega_by   # a modal constant is |H| omega^2: a mass-normalised shape scales by its root
        assert [a.shape[d] for d in b.shape] == pytest.approx([b.shape[d] * unit for d in b.shape], rel=1e-6)


@pytest.mark.parametrize("omega_by", [1e-200, 1e200])
def test_frequencies_whose_modal_constants_leave_floating_point_are_refused_naming_the_frf(omega_by):
    import warnings

    frfs, *_ = measured(8, repeats=1)
    scaled = FRFSet(frfs.omega * omega_by, frfs.pairs, frfs.H)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(ValueError, match=r"h\(y1,y3\): frequencies up to 3e[+-]\d+ Hz and values of about .*: its "
                                             r"modal constants .* are beyond the range of floating point; expected "
                                             r"frequencies in Hz and the FRF in SI units"):
            extract(scaled)


def test_a_zero_on_a_fitted_pole_is_left_out_and_the_case_loads(tmp_path):
    """A shaker test of a 4-mass chain (acceptance family `frf_test`, held-out seed 100021) whose
    transfer FRF h_y4,y2 shows mode 4 as a pole and a zero that cancel: the zero was extracted on
    the pole (its interval holding it, its value equal to 1e-12) and the case was refused ("a zero
    cannot sit on a pole"). Now it is left out, named in the notes, and the case loads. Its
    neighbour below the pole, zero 2 (6.473 Hz, truth 6.481, the pole at 6.521), is located only
    to +-5 % at 95 % each and +-8.5 % at the default level for all the intervals together, which
    then holds the pole: it is left out too."""
    from acceptance import families
    from vibupdate.data.frf import read_frfs
    from vibupdate.io.case import load_case

    problem = families.frf_test(100021)
    frf = problem.frf
    case = load_case(problem.write_case(tmp_path))          # refused before
    names = sorted(p.name for p in tmp_path.glob("frf_*.csv"))
    frfs = read_frfs([tmp_path / n for n in names], frf["responses"], [frf["exciter"]] * len(names))
    result = extract(frfs, band=tuple(2 * np.pi * np.array(frf["band_hz"])))
    poles = result.fitted_poles[:, 0]
    assert [(z.response, z.excitation, z.index) for z in result.cancelled_zeros] == [("y4", "y2", 2), ("y4", "y2", 3)]
    assert any("on a fitted pole left out: h_y4,y2" in n for n in result.notes())
    for z in result.zeros:
        assert not np.any((poles >= z.interval[0]) & (poles <= z.interval[1])), z
    loaded = [(a.receptance, a.index) for a in case.configurations[0].antiresonances]
    assert (("y4", "y2"), 3) not in loaded and (("y4", "y2"), 2) not in loaded and (("y4", "y2"), 1) in loaded
