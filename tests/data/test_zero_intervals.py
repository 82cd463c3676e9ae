"""Intervals that hold their truths: each antiresonance from the refit on the lines around it,
the global fit's zero where that refit's window would reach toward a pole, and one level for
all the intervals together (benchmarks/RESULTS.md, "Antiresonance intervals that hold their
truths"). The data: the acceptance family `frf_test`'s shaker tests (chains and clamped beams
with Rayleigh damping, three records of 0.5 % noise plus a floor, 4,000 lines), whose spans end
just above the band's last mode, so that the fit's residual terms stand for several modes
close above it."""

import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
import scipy.stats

from acceptance import emit, families, structures, truth
from vibupdate.data.extraction import extract, per_interval
from vibupdate.data.frf import read_frfs

TWO_PI = 2 * math.pi


def _shaker(seed):
    """The FRFs of `frf_test` problem ``seed`` as a user reads them, its truth and its band."""
    problem = families.frf_test(seed)
    f = problem.frf
    with tempfile.TemporaryDirectory() as folder:
        names = emit.write_frfs(problem, Path(folder))
        frfs = read_frfs([Path(folder) / n for n in names], list(f["responses"]), [f["exciter"]] * len(names),
                         "receptance")
    M, K, dofs = structures.matrices_at(problem.structure, problem.truth)
    return frfs, M, K, dofs, f["exciter"], tuple(TWO_PI * b for b in f["band_hz"])


def _reported(result, response, true_zero):
    """The reported zero of ``h_response,*`` nearest ``true_zero`` and its miss in half-widths
    (0 inside its interval)."""
    zero = min((z for z in result.zeros if z.response == response), key=lambda z: abs(z.omega - true_zero))
    lo, hi = zero.interval
    return zero, max(lo - true_zero, true_zero - hi, 0.0) / ((hi - lo) / 2)


def test_one_level_for_every_interval_together():
    assert per_interval(0.95, 1, joint=True) == 0.95
    assert per_interval(0.95, 25, joint=False) == 0.95
    assert per_interval(0.95, 25, joint=True) ** 25 == pytest.approx(0.95, rel=1e-12)
    assert per_interval(0.95, 0, joint=True) == 0.95   # nothing reported: the stated level


def test_joint_intervals_widen_each_to_the_level_their_number_asks():
    """By default `confidence` is the level of all the intervals at once: each is at
    ``0.95 ** (1 / n)``, ``n`` the reported frequencies, damping ratios, shape entries and
    zeros, so a half-width above its floor grows by the ratio of the normal quantiles."""
    frfs, *_, band = _shaker(0)
    each = extract(frfs, band=band, joint=False)
    together = extract(frfs, band=band)
    count = 2 * len(each.modes) + sum(len(m.shape) for m in each.modes) + len(each.zeros)
    assert each.level == 0.95 and together.confidence == 0.95
    assert together.level == pytest.approx(0.95 ** (1 / count), rel=1e-12)
    ratio = scipy.stats.norm.ppf(0.5 + together.level / 2) / scipy.stats.norm.ppf(0.975)
    assert [z.omega for z in together.zeros] == [z.omega for z in each.zeros]
    widths = [(b.interval[1] - b.omega) / (a.interval[1] - a.omega) for a, b in zip(each.zeros, together.zeros)]
    assert len(widths) >= 5 and widths == pytest.approx([ratio] * len(widths), rel=1e-9)


def test_a_zero_that_hangs_on_the_residual_terms_says_so(monkeypatch):
    """Problem 3 (a clamped beam of 8 elements, its next modes 1.3x and 1.8x above the fitted
    lines, which the residual terms stand for): the second zero of h_y1,y5 moves by 8 of its
    noise-only standard errors when the pseudo-mode sits just above the lines instead of at 1.5x
    their top. With only the noise in its error, its 95 % interval misses the truth by 1.8
    half-widths beyond its end (40 records of other noise put it 4.7 standard errors off on
    average); with the shift added, it holds the truth."""
    import vibupdate.data.extraction as extraction
    from vibupdate.data.modal_fit import PSEUDO_POLE

    frfs, M, K, dofs, exciter, band = _shaker(3)
    t = truth.zeros(M, K, dofs.index("y1"), dofs.index(exciter))[0][1]
    _, miss = _reported(extract(frfs, band=band, local_zeros=False, joint=False), "y1", t)
    assert miss == 0.0
    monkeypatch.setattr(extraction, "NEAR_PSEUDO_POLE", PSEUDO_POLE)   # no shift: the noise alone
    _, noise_only = _reported(extract(frfs, band=band, local_zeros=False, joint=False), "y1", t)
    assert noise_only > 1.0


def test_a_zero_inside_a_peak_keeps_the_global_fit():
    """Problem 47: the second zero of h_y2,y7 lies 0.4 half-power half-bandwidths from mode 2's
    pole. A third of that distance holds fewer than the local refit's 21 lines, and widened to
    21 the window reaches into the peak, where the misfit is a resonance's, not a line: that
    refit, taken for its smaller error, missed the truth by 11 half-widths beyond its 95 %
    interval. The global fit's zero, whose error there is the pole's and the residue's, holds
    it."""
    frfs, M, K, dofs, exciter, band = _shaker(47)
    t = truth.zeros(M, K, dofs.index("y2"), dofs.index(exciter))[0][1]
    global_zero, _ = _reported(extract(frfs, band=band, local_zeros=False, joint=False), "y2", t)
    zero, miss = _reported(extract(frfs, band=band, joint=False), "y2", t)
    assert zero.omega == global_zero.omega and zero.interval == global_zero.interval
    assert miss == 0.0


@pytest.mark.slow
def test_zero_intervals_hold_their_truths_on_thirty_shaker_tests():
    """Coverage of the 95 % zero intervals (each) on problems 0-29 between 0.85 and 1, and at the
    default level (95 % for all together) every zero interval of an extraction holding its truth
    in at least 70 % of them (zeros of FRFs whose zero count is right). Measured on these 30:
    0.89 each, every zero interval together in 26 of 29 (0.90; 0.70 is 3.5 binomial standard
    deviations below). On 100 problems (`benchmarks/frf_coverage.py shaker 3 100`): 0.90 each
    (0.80 before); every interval of an extraction, of every kind, held in 57 of 73 (16 of 80
    before, at 95 % each)."""
    hits, together = [], []
    for seed in range(30):
        frfs, M, K, dofs, exciter, band = _shaker(seed)
        each, joint = extract(frfs, band=band, joint=False), extract(frfs, band=band)
        for result, out in ((each, hits), (joint, together)):
            held = []
            for response in {z.response for z in result.zeros}:
                true = truth.zeros(M, K, dofs.index(response), dofs.index(exciter))[0]
                true = true[(true > result.band[0]) & (true < result.band[1])]
                got = [z for z in result.zeros if z.response == response]
                if len(got) == true.size:
                    held += [z.interval[0] <= t <= z.interval[1] for z, t in zip(got, true)]
            if result is each:
                out += held
            elif held:
                out.append(all(held))
    assert 0.85 <= np.mean(hits) <= 1.0, np.mean(hits)
    assert np.mean(together) >= 0.7, np.mean(together)


def test_the_command_and_the_case_file_state_the_level_as_asked(tmp_path, capsys):
    """`vibupdate extract` states the level for all the intervals together and writes each one's
    (`level` in extraction.json); `--per-interval` and a case file's ``joint = false`` state it
    for each interval, and their intervals are the narrower ones `extract(joint=False)` gives."""
    import json

    from frf_synthetic import cantilever_frf_case
    from vibupdate.cli import main
    from vibupdate.io.case import load_case

    _, text = cantilever_frf_case(tmp_path)
    docs = {}
    for label, extra in (("together", []), ("each", ["--per-interval"])):
        assert main(["extract", str(tmp_path / "hits.uff"), "--band", "20", "300", "--out", str(tmp_path / label),
                     "--no-plot", *extra]) == 0
        docs[label] = json.loads((tmp_path / label / "extraction.json").read_text())
        assert f"intervals at 95 % {label}" in capsys.readouterr().out
    assert docs["each"]["level"] == 0.95 and 0.95 < docs["together"]["level"] < 1.0
    for a, b in zip(docs["each"]["natural"], docs["together"]["natural"], strict=True):
        (lo_a, hi_a), (lo_b, hi_b) = a["freq_hz_interval"], b["freq_hz_interval"]
        assert lo_b <= lo_a < hi_a <= hi_b and hi_b - lo_b > hi_a - lo_a
    (tmp_path / "each.toml").write_text(text.replace("band_hz = [20, 300]", "band_hz = [20, 300]\njoint = false"))
    case = load_case(tmp_path / "each.toml").configurations[0]
    hz = [v / (2 * math.pi) for n in case.natural for v in n.interval]
    assert hz == pytest.approx([v for n in docs["each"]["natural"] for v in n["freq_hz_interval"]], rel=1e-12)
