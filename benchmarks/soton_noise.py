"""The single-record noise estimate on real FRFs: what it is, what it would be.

Run:  python benchmarks/soton_noise.py [DATA_DIR]

Reads the three tests of the Southampton frame (real data, not in the repository; default
``../shared/realdata/soton3storey`` next to the repository), extracts them as
`benchmarks/soton_zeros.py` does (band 3-28 Hz, three modes, one record per pair: the noise
comes from the fit's residual) and prints:

* per FRF, the median over the lines between the peaks (more than 1 Hz from every fitted
  pole) of the extraction's noise variance over the model-free one (running median of the
  squared second difference, `_noise_from_differences`), and the largest relative misfit
  ``|F - fit| / |F|`` at a peak line; the quality figure;
* the same with the alternative of `vibupdate.data.noise` (``W``: the residual and leverage of
  the weighted fit, fed the previous estimate as a feasible weighted least squares; and a
  local proportional level, ``beta_width`` = 21 lines), and what it does to the antiresonance
  intervals against the reference values and to the modes' intervals.

Figures in ``benchmarks/RESULTS.md`` and ``docs/frf-extraction.md``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import vibupdate.data.extraction as extraction  # noqa: E402
from vibupdate.data.modal_fit import basis, _linear_fit, _noise_from_differences  # noqa: E402
from vibupdate.data.frf import read_frfs  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from soton_zeros import FILES, REFERENCE_HZ, TWO_PI  # noqa: E402

MODES_HZ = (6.5126, 17.4608, 26.5003)  # the reference analysis


def _alternative():
    """`residual_variance` as a feasible weighted least squares with a local proportional
    level: each call weights the fit by the previous call's estimate (the first by the
    model-free one)."""
    original = extraction.residual_variance
    last = {}

    def variance(x, F, wn, zeta, groups=None, **_):
        W = 1.0 / np.sqrt(last.get("var", _noise_from_differences(F)))
        last["var"] = original(x, F, wn, zeta, groups, W=W, beta_width=21)
        return last["var"]
    return variance


def _run(frfs, alternative: bool):
    captured = {}
    stage_two, variance = extraction._stage_two, extraction.residual_variance

    def spy(frfs_, fit, *args):
        captured["fit"] = fit
        return stage_two(frfs_, fit, *args)
    extraction._stage_two = spy
    if alternative:
        extraction.residual_variance = _alternative()
    try:
        result = extraction.extract(frfs, (3 * TWO_PI, 28 * TWO_PI), n_modes=3)
    finally:
        extraction._stage_two, extraction.residual_variance = stage_two, variance
    return result, captured["fit"]


def main(folder: Path) -> None:
    frfs = read_frfs([folder / f for f in FILES], ["x1", "x2", "x3"], ["x1", "x2", "x3"], "accelerance")
    for label, alternative in (("default (unweighted residual, one proportional level)", False),
                               ("alternative (weighted residual, local proportional level)", True)):
        result, fit = _run(frfs, alternative)
        f_hz = fit.x * fit.scale_w / TWO_PI
        poles_hz = fit.wn * fit.scale_w / TWO_PI
        between = np.min(np.abs(f_hz[:, None] - poles_hz[None, :]), axis=1) > 1.0
        peaks = [int(np.argmin(np.abs(f_hz - p))) for p in poles_hz[:3]]
        reference = _noise_from_differences(fit.F)
        Phi = basis(fit.x, fit.wn, fit.zeta)
        print(f"\n{label}")
        print(f"{'FRF':5s} {'var/model-free':>15s} {'peak misfit':>12s} {'quality':>8s}")
        for k, pair in enumerate(result.pairs):
            w = 1.0 / np.sqrt(fit.var[k])
            coef = _linear_fit(Phi, fit.F[k], w)[0]
            miss = np.abs(fit.F[k] - Phi @ coef) / np.abs(fit.F[k])
            ratio = float(np.median(fit.var[k][between] / reference[k][between]))
            print(f"h{pair[0][1]}{pair[1][1]:3s} {ratio:15.1f} {100 * max(miss[peaks]):11.1f}% "
                  f"{result.quality[k].quality:8.2f}")
        inside, cells = 0, []
        for pair, refs in REFERENCE_HZ.items():
            for ref in refs:
                z = min((q for q in result.zeros if (q.response, q.excitation) == pair),
                        key=lambda q: abs(q.omega / TWO_PI - ref))
                lo, hi = (v / TWO_PI for v in z.interval)
                hit = lo <= ref <= hi
                inside += hit
                cells.append(f"h{pair[0][1]}{pair[1][1]} {ref:.2f}: {z.omega / TWO_PI:.3f} "
                             f"+-{100 * (hi - lo) / 2 / ref:.2f}% {'in' if hit else 'OUT'}")
        print(f"antiresonances, reference inside the 95 % interval: {inside} of {len(cells)}")
        for c in cells:
            print(f"  {c}")
        for m, ref in zip(result.modes, MODES_HZ):
            lo, hi = (v / TWO_PI for v in m.omega_interval)
            print(f"  mode {m.omega / TWO_PI:.4f} Hz [{lo:.4f}, {hi:.4f}] (reference {ref} "
                  f"{'in' if lo <= ref <= hi else 'OUT'}), damping {100 * m.damping_ratio:.3f} % "
                  f"[{100 * m.damping_interval[0]:.3f}, {100 * m.damping_interval[1]:.3f}]")


if __name__ == "__main__":
    default = Path(__file__).resolve().parents[1].parent / "shared" / "realdata" / "soton3storey"
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else default)
