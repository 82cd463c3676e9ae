"""Benchmark: `vibupdate.data.extraction.extract` vs peak picking on known-truth FRFs, one process.

Run:  python benchmarks/frf_extraction.py [--seeds N]

Data: the cantilever of the paper's test case 2 with non-proportional damping, 5 repeated
hits, 3 % complex noise plus a -60 dB floor, 0.25 Hz lines from 20 to 300 Hz (the generator
of ``tests/frf_synthetic.py``). The peer: peaks of the averaged ``|H|`` summed over the FRFs
(scipy.signal.find_peaks), damping from the half-power bandwidth, antiresonances as local
minima of each ``|H|`` between the first and last peak. Printed per method: worst and mean
relative errors of frequencies, damping ratios and antiresonances, how many FRFs got the
right zero count, CPU seconds per extraction, and the ratios.

Second part: a mode just above the band (``chain_system``: 50.3 Hz, band 5-48 Hz, data to
100 Hz, 0.1 Hz lines, same noise): the default fit band (to twice the band's top, the
out-of-band mode fitted as a mode) against fitting the band alone (``fit_band = band``, the
mode left to the residual terms), same data, same process.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.signal  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from frf_synthetic import CHAIN_PAIRS, PAIRS, chain_system, measured, score, true_poles, true_zeros  # noqa: E402

from vibupdate.data.extraction import extract  # noqa: E402


def peak_picking(frfs):
    """(omega_n, zeta, {pair: zeros}) by peaks, half-power bandwidths and minima of |H|."""
    mean = np.abs(frfs.mean())
    w = frfs.omega
    peaks, _ = scipy.signal.find_peaks(mean.sum(axis=0), prominence=0.05 * mean.sum(axis=0).max())
    wn, zeta = [], []
    for p in peaks:
        k = int(np.argmax(mean[:, p]))
        half = mean[k, p] / np.sqrt(2)
        lo, hi = p, p
        while lo > 0 and mean[k, lo] > half:
            lo -= 1
        while hi < w.size - 1 and mean[k, hi] > half:
            hi += 1
        wn.append(w[p])
        zeta.append((w[hi] - w[lo]) / (2 * w[p]))
    zeros = {}
    for pair, h in zip(frfs.pairs, mean):
        minima, _ = scipy.signal.find_peaks(-np.log(h))
        zeros[pair] = w[minima[(minima > peaks[0]) & (minima < peaks[-1])]] if len(peaks) else np.array([])
    return np.array(wn), np.array(zeta), zeros


def _score(wn, zeta, zeros, truth):
    t_wn, t_zeta, t_zeros = truth
    out = {"f": [], "d": [], "z": [], "count": 0}
    for w, z in zip(wn, zeta):
        k = int(np.argmin(np.abs(t_wn - w)))
        out["f"].append(abs(w / t_wn[k] - 1))
        out["d"].append(abs(z / t_zeta[k] - 1))
    for pair, tz in t_zeros.items():
        got = np.asarray(zeros.get(pair, []))
        out["count"] += int(got.size == tz.size)
        for z in got:
            out["z"].append(float(np.min(np.abs(tz / z - 1))) if tz.size else 1.0)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    args = parser.parse_args()
    totals = {"extract": {"f": [], "d": [], "z": [], "count": 0, "t": 0.0},
              "peaks": {"f": [], "d": [], "z": [], "count": 0, "t": 0.0}}
    for seed in range(args.seeds):
        frfs, M, K, C, dofs = measured(seed)
        lo, hi = frfs.omega[0], frfs.omega[-1]
        t_wn, t_zeta = true_poles(M, K, C)
        inside = (t_wn > lo) & (t_wn < hi)
        t_zeros = {}
        for r, c in PAIRS:
            z = true_zeros(M, K, dofs.index(r), dofs.index(c))
            t_zeros[(r, c)] = z[(z > lo) & (z < hi)]
        truth = (t_wn[inside], t_zeta[inside], t_zeros)
        t0 = time.process_time()
        result = extract(frfs)
        totals["extract"]["t"] += time.process_time() - t0
        s = _score([m.omega for m in result.modes], [m.damping_ratio for m in result.modes],
                   {p: [z.omega for z in result.zeros if (z.response, z.excitation) == p] for p in PAIRS}, truth)
        t0 = time.process_time()
        peer = peak_picking(frfs)
        totals["peaks"]["t"] += time.process_time() - t0
        p = _score(*peer, truth)
        for name, sc in (("extract", s), ("peaks", p)):
            for key in ("f", "d", "z"):
                totals[name][key] += sc[key]
            totals[name]["count"] += sc["count"]
    print(f"{args.seeds} seeds, {len(PAIRS)} FRFs each (CPU times on the machine as it is, possibly loaded)")
    print(f"{'method':8} {'freq worst/mean %':>20} {'damping worst/mean %':>22} {'zeros worst/mean %':>20} "
          f"{'zero count ok':>14} {'s/extraction':>13}")
    for name, t in totals.items():
        cells = [f"{100 * max(t[k]):.4f}/{100 * np.mean(t[k]):.4f}" if t[k] else "-" for k in ("f", "d", "z")]
        print(f"{name:8} {cells[0]:>20} {cells[1]:>22} {cells[2]:>20} "
              f"{t['count']:>6}/{args.seeds * len(PAIRS):<7} {t['t'] / args.seeds:>13.3f}")
    e, p = totals["extract"], totals["peaks"]
    print("error ratio peaks/extract (mean): "
          + ", ".join(f"{k} {np.mean(p[k]) / np.mean(e[k]):.0f}x" for k in ("f", "d", "z") if p[k] and e[k])
          + f"; time ratio extract/peaks {e['t'] / max(p['t'], 1e-9):.0f}x")

    out_of_band(args.seeds)


def out_of_band(seeds: int) -> None:
    """Default fit band vs the band alone on the chain with a mode just above the band."""
    band = (2 * np.pi * 5, 2 * np.pi * 48)
    rows = {"default": ([], [], [], 0.0), "band only": ([], [], [], 0.0)}
    for seed in range(seeds):
        frfs, M, K, C, dofs = measured(seed, band_hz=(5.0, 100.0), step_hz=0.1, system=chain_system(),
                                       pairs=CHAIN_PAIRS)
        for name, fit_band in (("default", None), ("band only", band)):
            t0 = time.process_time()
            result = extract(frfs, band=band, fit_band=fit_band)
            f, z, hits, t = rows[name]
            s = score(result, M, K, C, dofs, CHAIN_PAIRS)
            f += s["freq_err"]
            z += s["zero_err"]
            hits += s["zero_hit"]
            rows[name] = (f, z, hits, t + time.process_time() - t0)
    print(f"\nmode 5 % above the band (chain, {seeds} seeds, {len(CHAIN_PAIRS)} FRFs)")
    print(f"{'fit band':10} {'freq worst/mean %':>20} {'zeros worst/mean %':>20} {'zero coverage':>14} "
          f"{'s/extraction':>13}")
    for name, (f, z, hits, t) in rows.items():
        print(f"{name:10} {100 * max(f):.4f}/{100 * np.mean(f):.4f} {100 * max(z):>11.4f}/{100 * np.mean(z):.4f} "
              f"{np.mean(hits):>14.2f} {t / seeds:>13.3f}")


if __name__ == "__main__":
    main()
