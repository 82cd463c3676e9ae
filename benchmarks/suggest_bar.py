"""The free-free bar of `vibupdate.examples.bar` through `extract` and `vibupdate suggest`.

Run:  python benchmarks/suggest_bar.py [SEEDS]

A Timoshenko truth (shear and rotary inertia) modelled as an Euler-Bernoulli beam; one
accelerometer at the tip, nine hammer points, 1 % noise, three hits per point, read
reciprocally. Prints, over SEEDS seeds (default 20), the coverage of the 95 % intervals of
the extracted shape entries (every hammer point, mass-normalized, against the truth's modes),
of the frequencies and of the modal masses at the shapes' reference entries, and the CPU seconds per extraction; then, on seed 0, the ranking of
`suggest` over the six candidates (E, rho, r, ks1, ks2, macc), the natural-frequency errors
of the suggested set's full update and the seconds.
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from vibupdate.data.extraction import extract
from vibupdate.data.frf import write_uff58 as write_uff
from vibupdate.examples import bar

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))   # the truth's shapes
from frf_synthetic import bar_true_shapes  # noqa: E402


def coverage(seeds: int) -> dict:
    """Coverage of the shape and frequency intervals over ``seeds`` seeds."""
    shapes, hz = bar_true_shapes()
    band = tuple(2 * math.pi * np.array(bar.BAND_HZ))
    shape_hits, freq_hits, mass_hits, points, cpu = [], [], [], set(), 0.0
    for seed in range(seeds):
        frfs = bar.measured(seed).reciprocal()
        t0 = time.process_time()
        result = extract(frfs, band=band)
        cpu += time.process_time() - t0
        if len(result.modes) != len(hz):
            print(f"seed {seed}: {len(result.modes)} modes, {len(hz)} true", file=sys.stderr)
            continue
        for m, phi, f, nat in zip(result.modes, shapes, hz, result.to_measured(mass_normalized=True)[0]):
            points |= {len(m.shape_interval)}
            lo, hi = nat.shape.modal_mass_bounds()
            mass_hits.append(lo <= 1 / phi[nat.shape.reference] ** 2 <= hi)
            sign = 1.0 if sum(m.shape[d] * phi[d] for d in m.shape) >= 0 else -1.0
            shape_hits += [m.shape_interval[d][0] <= sign * phi[d] <= m.shape_interval[d][1] for d in phi]
            lo, hi = (v / (2 * math.pi) for v in m.omega_interval)
            freq_hits.append(lo <= f <= hi)
    return {"shape_coverage": float(np.mean(shape_hits)), "shape_entries": len(shape_hits),
            "frequency_coverage": float(np.mean(freq_hits)), "frequencies": len(freq_hits),
            "modal_mass_coverage": float(np.mean(mass_hits)),
            "points_per_shape": sorted(points), "cpu_per_extraction": cpu / seeds}


def suggestion(seed: int = 0):
    """`suggest` on the case of ``seed``; returns the suggestion and its wall-clock seconds."""
    from vibupdate.io.case import load_case
    from vibupdate.study.suggest import suggest_case

    folder = Path(tempfile.mkdtemp(prefix="suggest-bar-"))
    write_uff(folder / "hammer.uff", bar.measured(seed))
    (folder / "case.toml").write_text(bar.case_text())
    t0 = time.perf_counter()
    case = load_case(folder / "case.toml")
    found = suggest_case(case, folder / "out", progress=print)
    return found, time.perf_counter() - t0, folder


def main() -> None:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    c = coverage(seeds)
    print(f"extraction over {seeds} seeds: shape entries at {c['points_per_shape']} points per mode, coverage "
          f"{c['shape_coverage']:.3f} of {c['shape_entries']}; frequencies {c['frequency_coverage']:.3f} of "
          f"{c['frequencies']}; modal masses {c['modal_mass_coverage']:.3f} of {c['frequencies']}; "
          f"{c['cpu_per_extraction']:.2f} s CPU per extraction")
    found, seconds, folder = suggestion()
    from vibupdate.report.suggestion import suggestion_text

    print(suggestion_text(found.record()))
    best = found.best
    if best is not None:
        print(f"suggested set {best.names}: natural frequencies mean {best.update['natural_mean_pct']:.4f} %, max "
              f"{best.update['natural_max_pct']:.4f} %; values {best.update['values']}")
    print(f"suggest (loading and extraction included): {seconds:.1f} s; files in {folder / 'out'}")


if __name__ == "__main__":
    main()
