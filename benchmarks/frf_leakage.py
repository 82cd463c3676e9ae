"""Does the leakage bias of a windowed H1 estimate explain the Southampton misfit?

Run:  python benchmarks/frf_leakage.py [DATA_DIR] [SEED]

Fits, with ``vibupdate.data.extraction.extract`` (band 3-28 Hz, ``n_modes=3``), the three
Southampton tests (real data, not in the repository; default ``../shared/realdata/soton3storey``
next to the repository; skipped with a message where absent) and known-truth FRFs of the
Southampton-like frame of ``tests/frf_synthetic.py`` (one record per pair, seed SEED, default 0):

* ``exact``: ``frame_measured`` (exact FRFs plus noise);
* ``random, hann``: ``frame_windowed``, the expected H1 estimate of a random test with a Hann
  window over each 32 s record (the exact FRF smoothed by the window's power kernel);
* the same frame under other estimates (``lagged_accelerance``, ``LAG_WINDOWS``): a random
  test without a window (``random, boxcar``), one impact per record without a window (the
  response cut at 32 s) or with an exponential window ending at 1 %;
  each also with the frame's damping matrix times 0.5 and 2 (``C x0.5``), to see the misfit
  against the half-power bandwidth in lines. Same noise model and seed.

For each mode it prints the fitted frequency (Hz) and damping ratio, the half-power bandwidth
``2 zeta f / df`` in lines (of the fit), and the relative misfit ``|F - fitted| / |F|`` at the
peak line of each of the nine FRFs (the line of largest ``|F|`` within 3 lines of the fitted
frequency), in %, with their median; and ``wide``, the median over the FRFs of the number of
lines within 6 of the peak line where the misfit exceeds 2 % of ``|F|`` at the peak line (the
residual's width: a 32 s Hann window's kernel has a main lobe of +-2 lines).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import frf_synthetic as syn  # noqa: E402

from vibupdate.data.extraction import extract  # noqa: E402
from vibupdate.data.frf import read_frfs  # noqa: E402

FILES = ("Experimental.csv", "test_2.csv", "test_3.csv")  # force at floor 1, 2, 3
TWO_PI = 2 * np.pi
BAND = (3 * TWO_PI, 28 * TWO_PI)


def peak_misfit(frfs):
    """Per fitted mode: (freq_hz, zeta, bandwidth in lines, misfit at each FRF's peak line,
    median number of lines near the peak with a misfit over 2 % of the peak)."""
    result = extract(frfs, BAND, n_modes=3)
    F = np.array([h.mean(axis=0) for h in frfs.H])
    fitted = result.synthesize(frfs.omega)
    step = frfs.omega[1] - frfs.omega[0]
    out = []
    for mode in result.modes:
        k0 = int(np.argmin(np.abs(frfs.omega - mode.omega)))
        lines = np.arange(k0 - 3, k0 + 4)
        peaks = lines[np.argmax(np.abs(F[:, lines]), axis=1)]
        rows = np.arange(F.shape[0])
        misfit = np.abs(F[rows, peaks] - fitted[rows, peaks]) / np.abs(F[rows, peaks])
        near = peaks[:, None] + np.arange(-6, 7)[None, :]
        wide = np.sum(np.abs(np.take_along_axis(F - fitted, near, axis=1))
                      > 0.02 * np.abs(F[rows, peaks])[:, None], axis=1)
        out.append((mode.omega / TWO_PI, mode.damping_ratio, 2 * mode.damping_ratio * mode.omega / step, misfit,
                    float(np.median(wide))))
    return out


def _lagged(lag, scale, seed):
    M, K, C, dofs = syn.frame_system()
    omega = TWO_PI * np.arange(3.0, 56.0 + 0.015625, 0.03125)  # the lines of frame_measured
    A = syn.lagged_accelerance(M, K, scale * C, dofs, syn.FRAME_PAIRS, omega, lag)
    return syn._noisy_frame_records(A, omega, seed, 1, 4e-3, 0.005)


def main() -> None:
    args = sys.argv[1:]
    folder = Path(args[0]) if args else Path(__file__).resolve().parents[2] / "shared" / "realdata" / "soton3storey"
    seed = int(args[1]) if len(args) > 1 else 0
    cases = {}
    if all((folder / f).exists() for f in FILES):
        cases["Southampton"] = read_frfs([folder / f for f in FILES], ["x1", "x2", "x3"], ["x1", "x2", "x3"],
                                         "accelerance")
    else:
        print(f"Southampton data not found in {folder}: the real-data rows are skipped")
    cases["exact"] = syn.frame_measured(seed)[0]
    cases["random, hann"] = syn.frame_windowed(seed)[0]
    M, K, C, dofs = syn.frame_system()
    omega = cases["exact"].omega
    gap = np.max(np.abs(syn.lagged_accelerance(M, K, C, dofs, syn.FRAME_PAIRS, omega)
                        / syn.windowed_accelerance(M, K, C, dofs, syn.FRAME_PAIRS, omega) - 1))
    print(f"frame_windowed against the time-domain closed form: {gap:.1e} relative at most")
    for lag in syn.LAG_WINDOWS:
        for scale in (0.5, 1.0, 2.0):
            if (lag, scale) != ("random, hann", 1.0):
                cases[lag + ("" if scale == 1.0 else f", C x{scale:g}")] = _lagged(lag, scale, seed)
    print("misfit |F - fitted| / |F| at the peak line of each FRF, % (pairs h11 h21 h31 h12 h22 h32 h13 h23 h33)")
    print(f"{'case':32} {'f (Hz)':>8} {'zeta %':>7} {'bw lines':>8} {'wide':>4}  {'median':>6}  per FRF")
    for name, frfs in cases.items():
        for freq_hz, zeta, bandwidth, misfit, wide in peak_misfit(frfs):
            per = " ".join(f"{100 * m:4.1f}" for m in misfit)
            print(f"{name:32} {freq_hz:8.4f} {100 * zeta:7.3f} {bandwidth:8.2f} {wide:4.0f}  {100 * np.median(misfit):6.1f}  {per}")


if __name__ == "__main__":
    main()
