"""Coverage of the extraction's 95 % intervals on known-truth FRFs, one process.

Run:  python benchmarks/frf_coverage.py CASE RECORDS SEEDS [--true-noise]

CASE is ``frame`` (``tests/frf_synthetic.py``'s ``frame_measured``: the Southampton-like
frame, 0.03125 Hz lines, about 0.2 % damping, band 3-28 Hz, ``n_modes=3``),
``frame-windowed`` (``frame_windowed``: the same frame, band and noise model, but the
noise-free accelerances are the expected H1 estimate of a random test with a Hann window over
each 32 s record, i.e. with the window's leakage bias; the truth is still the system's
poles and undamped zeros, so the bias is part of the error) or ``cantilever``
(``measured``: 3 % noise plus a -60 dB floor, 0.25 Hz lines, 20-300 Hz) or ``shaker`` (the
acceptance family ``frf_test``'s shaker tests of chains and clamped beams, seed by seed: 0.5 %
noise plus a -60 dB floor, 4,000 lines, three records whatever RECORDS says; their spans end
just above the first mode over the band, so the residual terms stand for several modes close
above the fitted lines). RECORDS is the
number of records per pair (1: the noise is estimated from the fit's residual; 3 or 5: from
the repeats' scatter). Per quantity (natural frequency, damping ratio, antiresonance, shape
entry) it prints over all seeds:

* ``coverage``: the fraction of 95 % intervals holding the truth;
* ``rms/SE``: the RMS error over the mean stated standard error (half-width / 1.96), about 1
  for honest intervals; ``bias/rms``: the mean error over the RMS error (a bias that
  the covariance cannot see shows as a value far from 0);
* ``median hw``: the median relative half-width of the intervals (how useful they are).

These are the intervals at 95 % each (``joint=False``). Then ``joint``: the fraction of seeds
whose extraction at the default (95 % for all its intervals together) has every interval
holding its truth, among the seeds whose modes and zero counts are right (the others are
counted apart: a missed mode is no interval's miss).

The truth: ``true_poles`` (damped system), ``true_zeros`` (undamped receptance), and the
mass-normalized undamped modes at the measured DOFs for the shapes (sign of the extracted).
``--true-noise`` (diagnostic, records = 1 only): the extraction is given the true noise
variance per line instead of its estimate from the residual, to separate the noise
estimate's share of a miss from the covariance's. ``--no-floors`` (diagnostic): the
intervals without their stated floors, i.e. the covariance alone.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402
import scipy.stats  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import frf_synthetic as syn  # noqa: E402

import vibupdate.data.extraction as extraction  # noqa: E402

Z95 = float(scipy.stats.norm.ppf(0.975))
TWO_PI = 2 * np.pi


def _case(name, seed, records):
    """(frfs, M, K, C, dofs, pairs, kwargs, true sigma per pair and line (receptance units))."""
    if name == "shaker":
        return _shaker(seed)
    if name in ("frame", "frame-windowed"):
        generator = syn.frame_measured if name == "frame" else syn.frame_windowed
        frfs, M, K, C, dofs = generator(seed, repeats=records)
        omega = frfs.omega
        H = np.array([h.mean(axis=0) for h in frfs.H])
        # sigma of A = 4e-3 + 0.005 |A| (A the generator's noise-free accelerance), then / omega^2
        if name == "frame":
            A_true = _true_receptance(M, K, C, dofs, syn.FRAME_PAIRS, omega) * -omega**2
        else:
            A_true = syn.windowed_accelerance(M, K, C, dofs, syn.FRAME_PAIRS, omega)
        sigma = (4e-3 + 0.005 * np.abs(A_true)) / omega**2
        return frfs, M, K, C, dofs, syn.FRAME_PAIRS, {"band": (TWO_PI * 3, TWO_PI * 28), "n_modes": 3}, sigma, H
    frfs, M, K, C, dofs = syn.measured(seed, repeats=records)
    h = _true_receptance(M, K, C, dofs, syn.PAIRS, frfs.omega)
    sigma = 0.03 * np.abs(h) + 1e-3 * np.abs(h).max(axis=1, keepdims=True)
    return frfs, M, K, C, dofs, syn.PAIRS, {}, sigma, np.array([b.mean(axis=0) for b in frfs.H])


def _shaker(seed):
    """The acceptance family ``frf_test``'s problem ``seed`` written as its table files and read."""
    import tempfile

    from acceptance import emit, families, structures
    from vibupdate.data.frf import read_frfs

    problem = families.frf_test(seed)
    f = problem.frf
    M, K, dofs = structures.matrices_at(problem.structure, problem.truth)
    C = f["rayleigh"][0] * M + f["rayleigh"][1] * K
    with tempfile.TemporaryDirectory() as folder:
        names = emit.write_frfs(problem, Path(folder))
        frfs = read_frfs([Path(folder) / n for n in names], list(f["responses"]), [f["exciter"]] * len(names),
                         "receptance")
    pairs = tuple((r, f["exciter"]) for r in f["responses"])
    h = _true_receptance(M, K, C, dofs, pairs, frfs.omega)
    scale = np.abs(frfs.omega[None] ** 2 * h).max(axis=1, keepdims=True) / frfs.omega[None] ** 2
    sigma = f["noise"] * np.abs(h) + f["floor"] * scale
    return (frfs, M, K, C, dofs, pairs, {"band": tuple(TWO_PI * b for b in f["band_hz"])}, sigma,
            np.array([b.mean(axis=0) for b in frfs.H]))


def _true_receptance(M, K, C, dofs, pairs, omega):
    H = np.linalg.inv(K[None] - omega[:, None, None] ** 2 * M[None] + 1j * omega[:, None, None] * C[None])
    return np.array([H[:, dofs.index(r), dofs.index(c)] for r, c in pairs])


def _true_shapes(M, K, dofs, wn_band):
    """Mass-normalized undamped modes nearest to ``wn_band`` (rad/s), as {dof: value} each."""
    lam, V = scipy.linalg.eigh(K, M)
    w = np.sqrt(lam)
    out = []
    for target in wn_band:
        k = int(np.argmin(np.abs(w - target)))
        out.append({d: V[i, k] for i, d in enumerate(dofs)})
    return out


def _with_true_noise(sigma_raw, H_raw):
    """A stand-in for `residual_variance` that returns the true noise variance (normalized)."""
    def fake(x, F, wn, zeta, *_, **__):
        n = F.shape[1]  # the fit band of both cases starts at the record's first line
        scale = np.abs(H_raw[:, :1] / F[:, :1])
        return (sigma_raw[:, :n] / scale) ** 2
    return fake


def collect(name, records, seeds, true_noise=False, floors=True, window=None):
    rows = {k: [] for k in ("freq", "damping", "zero", "shape")}
    joint = []
    t_cpu = 0.0
    for seed in range(seeds):
        frfs, M, K, C, dofs, pairs, kwargs, sigma, H_raw = _case(name, seed, records)
        original = extraction.residual_variance, extraction.FREQUENCY_FLOOR, extraction.DAMPING_FLOOR, \
            extraction.SHAPE_FLOOR
        if true_noise:
            extraction.residual_variance = _with_true_noise(sigma, H_raw)
        if not floors:
            extraction.FREQUENCY_FLOOR = extraction.DAMPING_FLOOR = extraction.SHAPE_FLOOR = 0.0
        t0 = time.process_time()
        try:
            result = extraction.extract(frfs, window=window, joint=False, **kwargs)
            together = extraction.extract(frfs, window=window, **kwargs)
        finally:
            (extraction.residual_variance, extraction.FREQUENCY_FLOOR, extraction.DAMPING_FLOOR,
             extraction.SHAPE_FLOOR) = original
        t_cpu += time.process_time() - t0
        lo, hi = result.band
        wn, zeta = syn.true_poles(M, K, C)
        inside = (wn > lo) & (wn < hi)
        wn, zeta = wn[inside], zeta[inside]
        if len(result.modes) != wn.size:
            print(f"seed {seed}: {len(result.modes)} modes, {wn.size} true", file=sys.stderr)
            joint.append(None)
            continue
        shapes = _true_shapes(M, K, dofs, wn)
        joint.append(_all_hold(together, wn, zeta, shapes, M, K, dofs, pairs))
        for m, w, z, phi in zip(result.modes, wn, zeta, shapes):
            rows["freq"].append((m.omega / w - 1, (m.omega_interval[1] - m.omega) / w / Z95,
                                 m.omega_interval[0] <= w <= m.omega_interval[1]))
            rows["damping"].append((m.damping_ratio / z - 1, (m.damping_interval[1] - m.damping_ratio) / z / Z95,
                                    m.damping_interval[0] <= z <= m.damping_interval[1]))
            if m.normalization == "mass":
                top = max(abs(v) for v in phi.values())
                sign = 1.0 if sum(m.shape[d] * phi[d] for d in m.shape) >= 0 else -1.0
                for d, v in m.shape.items():
                    t = sign * phi[d]
                    lo_d, hi_d = m.shape_interval[d]
                    rows["shape"].append(((v - t) / top, (hi_d - v) / top / Z95, lo_d <= t <= hi_d))
        for r, c in pairs:
            truth = syn.true_zeros(M, K, dofs.index(r), dofs.index(c))
            truth = truth[(truth > lo) & (truth < hi)]
            got = [z for z in result.zeros if (z.response, z.excitation) == (r, c)]
            if len(got) == truth.size:
                for z, t in zip(got, truth):
                    rows["zero"].append((z.omega / t - 1, (z.interval[1] - z.omega) / t / Z95,
                                         z.interval[0] <= t <= z.interval[1]))
    return rows, t_cpu / seeds, joint


def _all_hold(result, wn, zeta, shapes, M, K, dofs, pairs):
    """Whether every interval of ``result`` holds its truth; None when a mode is missed or a
    zero count is wrong (no interval to judge)."""
    if len(result.modes) != wn.size:
        return None
    held = []
    for m, w, z, phi in zip(result.modes, wn, zeta, shapes):
        held += [m.omega_interval[0] <= w <= m.omega_interval[1], m.damping_interval[0] <= z <= m.damping_interval[1]]
        if m.normalization == "mass":
            sign = 1.0 if sum(m.shape[d] * phi[d] for d in m.shape) >= 0 else -1.0
            held += [m.shape_interval[d][0] <= sign * phi[d] <= m.shape_interval[d][1] for d in m.shape]
    lo, hi = result.band
    for r, c in pairs:
        truth = syn.true_zeros(M, K, dofs.index(r), dofs.index(c))
        truth = truth[(truth > lo) & (truth < hi)]
        got = [z for z in result.zeros if (z.response, z.excitation) == (r, c)]
        if len(got) != truth.size:
            return None
        held += [z.interval[0] <= t <= z.interval[1] for z, t in zip(got, truth)]
    return all(held)


def summarize(rows):
    out = {}
    for key, values in rows.items():
        if not values:
            continue
        err, se, hit = (np.array(v, dtype=float) for v in zip(*values))
        rms = float(np.sqrt(np.mean(err**2)))
        out[key] = {"n": int(err.size), "coverage": float(np.mean(hit)), "rms_over_se": rms / float(np.mean(se)),
                    "bias_over_rms": float(np.mean(err)) / rms if rms else 0.0, "rms": rms,
                    "median_hw": float(np.median(se)) * Z95}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=("frame", "frame-windowed", "cantilever", "shaker"))
    parser.add_argument("records", type=int)
    parser.add_argument("seeds", type=int)
    parser.add_argument("--true-noise", action="store_true")
    parser.add_argument("--no-floors", action="store_true", help="diagnostic: intervals without their floors")
    parser.add_argument("--json", help="append the summary to this file (JSON lines)")
    parser.add_argument("--window", choices=("none", "hann", "rectangular"), default="none",
                        help="the estimate's window that the extraction models (extract's window)")
    args = parser.parse_args()
    rows, cpu, joint = collect(args.case, args.records, args.seeds, args.true_noise, not args.no_floors,
                        None if args.window == "none" else args.window)
    summary = summarize(rows)
    label = f"{args.case}, {args.records} record(s), {args.seeds} seeds" + (", true noise" if args.true_noise else "") \
        + (", no floors" if args.no_floors else "") + (f", window {args.window} modelled" if args.window != "none" else "")
    print(f"{label}; {cpu:.2f} s CPU per extraction (loaded shared machine)")
    print(f"{'quantity':9} {'n':>5} {'coverage':>9} {'rms/SE':>8} {'bias/rms':>9} {'rms err':>10} {'median hw':>10}")
    for key, s in summary.items():
        print(f"{key:9} {s['n']:>5} {s['coverage']:>9.3f} {s['rms_over_se']:>8.2f} {s['bias_over_rms']:>9.2f} "
              f"{s['rms']:>10.2e} {s['median_hw']:>10.2e}")
    judged = [j for j in joint if j is not None]
    print(f"joint: every interval holds its truth in {sum(judged)} of {len(judged)} extractions at 95 % for all "
          f"together ({len(joint) - len(judged)} with a missed mode or a wrong zero count)")
    if args.json:
        with open(args.json, "a") as fh:
            fh.write(json.dumps({"case": args.case, "records": args.records, "seeds": args.seeds,
                                 "true_noise": args.true_noise, "floors": not args.no_floors, "cpu": cpu,
                                 "window": args.window,
                                 "summary": summary, "joint": joint}) + "\n")


if __name__ == "__main__":
    main()
