"""Benchmark: the cost of `vibupdate.data.extraction.extract` on a long known-truth FRF set.

Run:  python benchmarks/extraction_cost.py [--lines N] [--seed S] [--noise F]

Data: a free-free uniform beam measured as a roving-hammer test would be: one accelerometer
(``p1``) and nine hammer points ``p1``..``p9`` equally spaced along it (nine accelerances,
one of them the driving point), one record per pair, ``N`` lines (default 51,200) of
1000/51,200 = 0.0195 Hz up to 1 kHz. The accelerances are the exact modal sum of the two
rigid-body modes and the first eight bending modes (four in the band: 100, 276, 540 and
893 Hz; damping ratios 0.6, 0.4, 0.3 and 0.25 %, the modes above 0.2 %), plus complex
Gaussian noise of ``F`` (default 1 %) of ``|A|`` and a floor of 1e-4 of the largest
``|A|`` per line. The truth: the four natural frequencies and damping ratios, and the zeros
of each undamped accelerance of the same modal sum in the band (found on a fine grid).

Measured: ``extract(frfs)`` with its defaults, in this process (one BLAS thread): CPU seconds
(``time.process_time``), wall seconds, the process's peak resident set size (``ru_maxrss``:
imports, the data and the extraction), and the accuracy: the worst relative error of the
frequencies, damping ratios and antiresonances against the truth, and how many of the truths
lie in the stated 95 % intervals (coverage).
"""

from __future__ import annotations

import argparse
import os
import resource
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.optimize  # noqa: E402

from vibupdate.data.extraction import extract  # noqa: E402
from vibupdate.data.frf import FRFSet  # noqa: E402

BETA_L = (4.730041, 7.853205, 10.995608, 14.137165, 17.278760, 20.420352, 23.561945, 26.703538)
FIRST_HZ = 100.0                                         # first bending mode
DAMPING = (0.006, 0.004, 0.003, 0.0025, 0.002, 0.002, 0.002, 0.002)
MASS = 2.0                                               # kg; length 1 (positions in [0, 1])
POINTS = np.linspace(0.0, 1.0, 9)                        # hammer points p1..p9; accelerometer at p1
TOP_HZ = 1000.0


def beam_modes():
    """Natural frequencies (rad/s), damping ratios and mass-normalized shapes at `POINTS`
    ((n_modes, 9)) of the free-free beam: the bending modes (closed form) after the two
    rigid-body modes (translation, rotation about the middle; frequency 0)."""
    b = np.array(BETA_L)[:, None]
    u = POINTS[None, :]
    sigma = (np.cosh(b) - np.cos(b)) / (np.sinh(b) - np.sin(b))
    bent = np.cosh(b * u) + np.cos(b * u) - sigma * (np.sinh(b * u) + np.sin(b * u))  # integral of square = 1
    rigid = np.vstack([np.ones(POINTS.size), np.sqrt(12.0) * (POINTS - 0.5)])
    shapes = np.vstack([rigid, bent]) / np.sqrt(MASS)
    wn = np.concatenate([[0.0, 0.0], 2 * np.pi * FIRST_HZ * (np.array(BETA_L) / BETA_L[0]) ** 2])
    return wn, np.concatenate([[0.0, 0.0], DAMPING]), shapes


def accelerances(omega, damped: bool = True):
    """Accelerances ``A_{1,c}`` (c over the nine points), shape (9, n_freq), (m/s^2)/N."""
    wn, zeta, shapes = beam_modes()
    s = 1j * omega[None, :] if damped else 0.0 * omega[None, :]
    denom = wn[:, None] ** 2 - omega[None, :] ** 2 + 2 * zeta[:, None] * wn[:, None] * s   # (n_modes, n_freq)
    modal = shapes[:, :1] * shapes                                                      # (n_modes, 9)
    return -omega[None, :] ** 2 * (modal.T @ (1.0 / denom))


def true_zeros(lo: float, hi: float) -> list:
    """Zeros (rad/s) in (lo, hi) of each undamped accelerance: sign changes of the receptance
    times the product of ``wn^2 - omega^2`` on a grid of 200,000 points, refined by Brent."""
    wn = beam_modes()[0][2:]
    grid = np.linspace(lo, hi, 200_001)

    def g(w):
        w = np.atleast_1d(w)
        return (accelerances(w, damped=False) / -w**2) * np.prod(wn[:, None] ** 2 - w[None, :] ** 2, axis=0)

    values = g(grid)
    out = []
    for row in range(POINTS.size):
        idx = np.nonzero(np.sign(values[row, :-1]) * np.sign(values[row, 1:]) < 0)[0]
        out.append(np.array([scipy.optimize.brentq(lambda w: float(g(w)[row, 0]), grid[i], grid[i + 1]) for i in idx]))
    return out


def measured(lines: int, seed: int, noise: float) -> FRFSet:
    """The nine noisy accelerances as an `FRFSet` of receptances (one record per pair)."""
    step = TOP_HZ / lines
    omega = 2 * np.pi * step * np.arange(1, lines + 1)
    A = accelerances(omega)
    rng = np.random.default_rng(seed)
    sigma = noise * np.abs(A) + 1e-4 * np.abs(A).max()
    e = rng.standard_normal(A.shape) + 1j * rng.standard_normal(A.shape)
    H = (A + sigma * e / np.sqrt(2)) / -omega[None, :] ** 2
    pairs = tuple(("p1", f"p{c + 1}") for c in range(POINTS.size))
    return FRFSet(omega, pairs, tuple(h[None] for h in H), measured="accelerance")


def accuracy(result) -> dict:
    """Worst relative errors and interval hits against the truth."""
    wn, zeta = beam_modes()[0][2:], np.array(DAMPING)
    lo, hi = result.band
    inside = (wn > lo) & (wn < hi)
    wn, zeta = wn[inside], zeta[inside]
    out = {"modes": f"{len(result.modes)} / {wn.size}"}
    if len(result.modes) == wn.size:
        f = [abs(m.omega / w - 1) for m, w in zip(result.modes, wn)]
        d = [abs(m.damping_ratio / z - 1) for m, z in zip(result.modes, zeta)]
        out["freq"] = (max(f), sum(m.omega_interval[0] <= w <= m.omega_interval[1] for m, w in zip(result.modes, wn)))
        out["damping"] = (max(d), sum(m.damping_interval[0] <= z <= m.damping_interval[1]
                                      for m, z in zip(result.modes, zeta)))
    errors, hits, count_ok, total = [], 0, 0, 0
    poles = beam_modes()[0]
    for pair, truth in zip(result.pairs, true_zeros(lo, hi)):
        got = [z for z in result.zeros if (z.response, z.excitation) == pair]
        low, high = result.fitted_poles[0, 0], result.fitted_poles[-1, 0]
        truth = truth[(truth >= low) & (truth <= high)]  # the zeros `extract` reports (outer ones apart)
        # a zero on a pole (a mode with a node at the response or excitation) is no antiresonance of the FRF
        truth = truth[np.min(np.abs(truth[:, None] - poles[None, :]), axis=1) > 1e-9 * truth]
        count_ok += len(got) == truth.size
        if len(got) == truth.size:
            errors += [abs(z.omega / t - 1) for z, t in zip(got, truth)]
            hits += sum(z.interval[0] <= t <= z.interval[1] for z, t in zip(got, truth))
            total += truth.size
    out["zeros"] = (max(errors, default=float("nan")), hits, total, count_ok)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, default=51_200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--noise", type=float, default=0.01)
    args = parser.parse_args()
    frfs = measured(args.lines, args.seed, args.noise)
    cpu, wall = time.process_time(), time.perf_counter()
    result = extract(frfs)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    acc = accuracy(result)
    print(f"{len(frfs.pairs)} FRFs x {frfs.omega.size} lines ({frfs.freq_hz[0]:.4g}-{frfs.freq_hz[-1]:.5g} Hz), "
          f"one record, {100 * args.noise:g} % noise, seed {args.seed} (OMP_NUM_THREADS="
          f"{os.environ.get('OMP_NUM_THREADS')})")
    print(f"extract: CPU {cpu:.2f} s, wall {wall:.2f} s, peak RSS of the process {peak_mb:.0f} MB")
    print(f"modes found: {acc['modes']}")
    if "freq" in acc:
        n = len(result.modes)
        print(f"frequencies: worst error {100 * acc['freq'][0]:.5f} %, {acc['freq'][1]} / {n} in the intervals")
        print(f"damping ratios: worst error {100 * acc['damping'][0]:.3f} %, {acc['damping'][1]} / {n} in the intervals")
    z = acc["zeros"]
    print(f"antiresonances: worst error {100 * z[0]:.4f} %, {z[1]} / {z[2]} in the intervals, zero count right on "
          f"{z[3]} / {len(result.pairs)} FRFs")


if __name__ == "__main__":
    main()
