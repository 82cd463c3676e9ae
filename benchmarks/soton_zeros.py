"""What separates the extracted Southampton antiresonances from the reference values.

Run:  python benchmarks/soton_zeros.py [DATA_DIR]
      python benchmarks/soton_zeros.py --synthetic [SEEDS] [RECORDS]

Reads the three tests of the Southampton frame (real data, not in the repository; default
``../shared/realdata/soton3storey`` next to the repository) and prints, at each of the ten
listed antiresonances, several quantities that one might call "the antiresonance":

* ``zero``: the extraction's value (real zero of the undamped fitted receptance, after the
  local refit), and ``global`` without the local refit;
* ``min|H|fit`` / ``min|A|fit``: the minimum of ``|H|`` of the *damped* fitted receptance /
  accelerance (``A = -omega^2 H``);
* ``min|H|`` / ``min|A|``: the minimum of the measured receptance / accelerance magnitude,
  interpolated by a parabola in ``log|.|`` through the lowest line and its neighbours;
* ``Re=0``: where the real part of the measured receptance changes sign (a straight line
  fitted to the real part over the 10 lines around the sign change; ``Re=0 20``: 20
  lines), the middle of the phase jump; a local estimate of the undamped zero from the data
  alone (for light damping the real part of the damped receptance vanishes within
  ``O(zeta^2)`` of the undamped zero);
* the zero of the undamped fitted receptance with other fit bands (the sensitivity to the
  free choices).

All in Hz, and each against the reference as a relative error; ``SE`` is the standard error
of the extraction's zero (its 95 % interval over 1.96) and of the ``Re=0`` line's crossing
(from the line's residual, white noise assumed).

``--synthetic``: the extraction's zeros and the estimators from the measured data alone
(``min|A|``, ``Re=0``, ``Re=0 20``) against the truth on known-truth FRFs like the
Southampton ones (``tests/frf_synthetic.py``'s ``frame_measured``: one record per pair by
default, 0.03125 Hz lines, about 0.2 % non-proportional damping, two light modes just above
the band, the measured noise floor). The tables of ``docs/frf-extraction.md`` ("What
separates the zeros from the reference") come from this script.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.optimize  # noqa: E402

from vibupdate.data.extraction import extract  # noqa: E402
from vibupdate.data.frf import read_frfs  # noqa: E402

FILES = ("Experimental.csv", "test_2.csv", "test_3.csv")  # force at floor 1, 2, 3
REFERENCE_HZ = {("x1", "x1"): (8.80, 23.94), ("x2", "x2"): (14.99, 19.85), ("x3", "x3"): (14.18, 25.24),
                ("x2", "x1"): (14.39,), ("x1", "x2"): (14.48,), ("x3", "x2"): (19.43,), ("x2", "x3"): (19.45,)}
TWO_PI = 2 * np.pi


def _parabola_min(f_hz, mag, k):
    """Vertex of the parabola in log(mag) through lines k-1, k, k+1 (Hz)."""
    y = np.log(mag[k - 1:k + 2])
    denom = y[0] - 2 * y[1] + y[2]
    return float(f_hz[k] + 0.5 * (y[0] - y[2]) / denom * (f_hz[1] - f_hz[0])) if denom > 0 else float(f_hz[k])


def _measured_min(f_hz, mag, ref, width_hz=0.4):
    near = np.nonzero(np.abs(f_hz - ref) <= width_hz)[0]
    k = int(near[np.argmin(mag[near])])
    return _parabola_min(f_hz, mag, k)


def _real_crossing(f_hz, h, ref, width_hz=0.4, half=5, se=False):
    """Sign change of Re h nearest ``ref``, located by a straight line through the 2 half
    lines around it; with ``se`` also its standard error from the line's residual (Hz)."""
    near = np.nonzero(np.abs(f_hz - ref) <= width_hz)[0]
    re = h.real[near]
    idx = np.nonzero(np.sign(re[:-1]) * np.sign(re[1:]) < 0)[0]
    if idx.size == 0:
        return (float("nan"), float("nan")) if se else float("nan")
    i = near[idx[np.argmin(np.abs(f_hz[near[idx]] - ref))]]
    lines = np.arange(i - half + 1, i + half + 1)
    x = f_hz[lines] - f_hz[i]
    (slope, icpt), cov = np.polyfit(x, h.real[lines], 1, cov="unscaled")
    z = float(f_hz[i] - icpt / slope)
    if not se:
        return z
    res = h.real[lines] - (slope * x + icpt)
    s2 = float(res @ res) / (lines.size - 2)
    g = np.array([icpt / slope**2, -1.0 / slope])  # d z / d (slope, icpt)
    return z, float(np.sqrt(s2 * g @ cov @ g))


def _fitted_min(result, k, ref, accel):
    def mag(f):
        w = np.atleast_1d(f) * TWO_PI
        h = result.synthesize(w)[k]
        return float(np.abs(h * w**2 if accel else h)[0])
    grid = np.linspace(ref - 0.4, ref + 0.4, 801)
    f0 = grid[int(np.argmin([mag(f) for f in grid]))]
    return float(scipy.optimize.minimize_scalar(mag, bracket=(f0 - 1e-3, f0, f0 + 1e-3), tol=1e-12).x)


def _zero_near(result, pair, ref):
    got = [z.omega / TWO_PI for z in result.zeros if (z.response, z.excitation) == pair]
    return min(got, key=lambda z: abs(z - ref)) if got else float("nan")


def main(folder: Path) -> None:
    frfs = read_frfs([folder / f for f in FILES], ["x1", "x2", "x3"], ["x1", "x2", "x3"], "accelerance")
    band = (3 * TWO_PI, 28 * TWO_PI)
    base = extract(frfs, band, n_modes=3)
    variants = {
        "global": extract(frfs, band, n_modes=3, local_zeros=False),
        "fit 3-28": extract(frfs, band, n_modes=3, fit_band=band),
        "fit 3-40": extract(frfs, band, n_modes=3, fit_band=(3 * TWO_PI, 40 * TWO_PI)),
        "fit 3-64": extract(frfs, band, n_modes=3, fit_band=(3 * TWO_PI, 64 * TWO_PI), orders=range(2, 13)),
    }
    f_hz = frfs.freq_hz
    cols = ["zero", *variants, "min|H|fit", "min|A|fit", "min|H|", "min|A|", "Re=0", "Re=0 20"]
    print(f"{'FRF':6s} {'ref':>6s} {'SE zero / Re=0':>23s} " + " ".join(f"{c:>16s}" for c in cols))
    errors = {c: [] for c in cols}
    for pair, refs in REFERENCE_HZ.items():
        k = frfs.pairs.index(pair)
        h = frfs.H[k].mean(axis=0)
        accel = np.abs(h * (TWO_PI * f_hz) ** 2)
        for ref in refs:
            values = {"zero": _zero_near(base, pair, ref)}
            values.update({name: _zero_near(res, pair, ref) for name, res in variants.items()})
            values["min|H|fit"] = _fitted_min(base, k, ref, accel=False)
            values["min|A|fit"] = _fitted_min(base, k, ref, accel=True)
            values["min|H|"] = _measured_min(f_hz, np.abs(h), ref)
            values["min|A|"] = _measured_min(f_hz, accel, ref)
            values["Re=0"], se_re = _real_crossing(f_hz, h, ref, se=True)
            values["Re=0 20"] = _real_crossing(f_hz, h, ref, half=10)
            z = min((q for q in base.zeros if (q.response, q.excitation) == pair),
                    key=lambda q: abs(q.omega / TWO_PI - ref))
            se_zero = (z.interval[1] - z.interval[0]) / 2 / 1.959964 / z.omega
            cells = [f"SE {100 * se_zero:.3f}% / {100 * se_re / values['Re=0']:.3f}%"]
            for c in cols:
                e = values[c] / ref - 1
                errors[c].append(abs(e))
                cells.append(f"{values[c]:8.3f} {100 * e:+6.2f}%")
            print(f"h{pair[0][1]}{pair[1][1]:5s} {ref:6.2f} " + " ".join(cells))
    print(f"{'worst':37s} " + " ".join(f"{100 * max(errors[c]):15.2f}%" for c in cols))
    print(f"{'mean':37s} " + " ".join(f"{100 * np.mean(errors[c]):15.2f}%" for c in cols))


def synthetic(seeds: int, repeats: int = 1) -> None:
    """The same estimators on known-truth FRFs like the Southampton ones (`frame_measured`)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from frf_synthetic import FRAME_PAIRS, frame_measured, true_zeros

    band = (3 * TWO_PI, 28 * TWO_PI)
    cols = ["zero", "global", "min|A|", "Re=0", "Re=0 20"]
    errors = {c: [] for c in cols}
    hits = {c: [] for c in ("zero", "global")}
    count_ok, cpu = 0, 0.0
    for seed in range(seeds):
        frfs, M, K, C, dofs = frame_measured(seed, repeats=repeats)
        t0 = time.process_time()
        res = {"zero": extract(frfs, band, n_modes=3)}
        cpu += time.process_time() - t0
        res["global"] = extract(frfs, band, n_modes=3, local_zeros=False)
        f_hz = frfs.freq_hz
        for k, pair in enumerate(FRAME_PAIRS):
            truth = true_zeros(M, K, dofs.index(pair[0]), dofs.index(pair[1])) / TWO_PI
            truth = truth[(truth > 3) & (truth < 28)]
            got = {c: [z for z in r.zeros if (z.response, z.excitation) == pair] for c, r in res.items()}
            count_ok += len(got["zero"]) == truth.size
            h = frfs.H[k].mean(axis=0)
            for t in truth:
                for c, zs in got.items():
                    z = min(zs, key=lambda q: abs(q.omega / TWO_PI - t))
                    errors[c].append(abs(z.omega / TWO_PI / t - 1))
                    hits[c].append(z.interval[0] <= t * TWO_PI <= z.interval[1])
                errors["min|A|"].append(abs(_measured_min(f_hz, np.abs(h) * (TWO_PI * f_hz) ** 2, t) / t - 1))
                errors["Re=0"].append(abs(_real_crossing(f_hz, h, t) / t - 1))
                errors["Re=0 20"].append(abs(_real_crossing(f_hz, h, t, half=10) / t - 1))
    n = len(errors["zero"])
    print(f"known truth (frame_measured, {seeds} seeds, {repeats} record(s) per pair, {n} zeros; "
          f"zero count right on {count_ok} of {seeds * len(FRAME_PAIRS)} FRFs; {cpu / seeds:.2f} s CPU per extraction)")
    for c in cols:
        e = np.array(errors[c])
        cover = f"  coverage {np.mean(hits[c]):.2f}" if c in hits else ""
        print(f"{c:8s} worst {100 * np.nanmax(e):.3f} %  mean {100 * np.nanmean(e):.3f} %  "
              f"rms {100 * np.sqrt(np.nanmean(e**2)):.3f} %  above 0.1 %: {np.sum(e > 1e-3)} of {n}{cover}")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--synthetic":
        synthetic(int(sys.argv[2]) if len(sys.argv) > 2 else 10, int(sys.argv[3]) if len(sys.argv) > 3 else 1)
    else:
        default = Path(__file__).resolve().parents[1].parent / "shared" / "realdata" / "soton3storey"
        main(Path(sys.argv[1]) if len(sys.argv) > 1 else default)
