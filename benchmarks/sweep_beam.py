"""Sampling sweep of a 50-element clamped beam: interval shapes (+-1 %) and frequencies (+-0.1 %).

Run: ``PYTHONPATH=src python benchmarks/sweep_beam.py [--samples 24] [--workers 1 2]``.

The case (written to a temporary folder as a case file with CSV data, the way a user brings
it): a clamped Euler-Bernoulli beam of 50 elements (100 DOFs, 1 m, steel-like section) whose
bending stiffness and mass per length are parameters in five groups of ten elements (10
parameters, true values drawn within +-8 % of nominal, bounds +-20 %); 6 measured natural
frequencies with relative intervals of +-0.1 % (``frequency_tolerance = 0.001``) and mode
shapes at the deflections of every fifth node (10 points) with intervals of +-1 % of the
mode's largest entry. The measured values are the truth's plus a uniform error of at most half
the interval's half-width, so every interval holds the truth.

Prints, per worker count, the sweep's verified count, wall time of the task phase and
speed-up, and whether every true parameter lies inside its sampled range.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np

N_ELEMENTS = 50
GROUPS = 5
LENGTH = 1.0
EI0 = 2.0e3        # N m^2
MU0 = 4.0          # kg/m
N_MODES = 6
SHAPE_HALF = 0.01  # of the mode's largest entry
FREQ_TOL = 0.001


def _build(values: dict):
    from vibupdate import Assembly

    asm = Assembly("beam")
    for i in range(N_ELEMENTS + 1):
        asm.node(i, LENGTH * i / N_ELEMENTS)
    per = N_ELEMENTS // GROUPS
    for e in range(N_ELEMENTS):
        g = e // per + 1
        asm.beam(e, e + 1, EI=EI0 * values[f"E{g}"], mass_per_length=MU0 * values[f"mu{g}"])
    asm.clamp(0)
    return asm.system()


def write_case(folder: Path, seed: int = 0) -> tuple[Path, dict]:
    """The case file and its data in ``folder``; returns its path and the true parameters."""
    import vibupdate as vu

    rng = np.random.default_rng(seed)
    names = [f"E{g}" for g in range(1, GROUPS + 1)] + [f"mu{g}" for g in range(1, GROUPS + 1)]
    truth = {n: float(v) for n, v in zip(names, rng.uniform(0.92, 1.08, len(names)))}
    M, K = _build(truth).M, _build(truth).K
    dofs = _build(truth).dofs
    omega, Phi = vu.modes(M, K, N_MODES)
    freq_hz = omega / (2 * np.pi)
    measured_hz = freq_hz * (1 + 0.5 * FREQ_TOL * rng.uniform(-1, 1, N_MODES))
    rows = ["kind,hz"] + [f"natural,{f:.12g}" for f in measured_hz]
    (folder / "frequencies.csv").write_text("\n".join(rows) + "\n")
    points = [f"y{i}" for i in range(5, N_ELEMENTS + 1, 5)]
    shape_rows = ["mode,dof,lower,upper"]
    for k in range(N_MODES):
        phi = Phi[:, k] / Phi[np.argmax(np.abs(Phi[:, k])), k]
        for d in points:
            true = phi[dofs.index(d)]
            centre = true + 0.5 * SHAPE_HALF * rng.uniform(-1, 1)
            shape_rows.append(f"{k + 1},{d},{centre - SHAPE_HALF:.12g},{centre + SHAPE_HALF:.12g}")
    (folder / "shapes.csv").write_text("\n".join(shape_rows) + "\n")
    per = N_ELEMENTS // GROUPS
    text = [f'case = "beam50"', f"frequency_tolerance = {FREQ_TOL}", "", "[model]", 'type = "elements"',
            'kind = "beam"', f"line = {{ first = 0, last = {N_ELEMENTS}, start = [0.0], end = [{LENGTH}] }}",
            "clamp = [0]", ""]
    for g in range(1, GROUPS + 1):
        nodes = list(range((g - 1) * per, g * per + 1))
        text += ["[[model.beam]]", f"nodes = {nodes}", f'EI = "{EI0}*E{g}"', f'mass_per_length = "{MU0}*mu{g}"', ""]
    for n in names:
        text += ["[[parameter]]", f'name = "{n}"', "nominal = 1.0", "lower = 0.8", "upper = 1.2", ""]
    text += ["[[configuration]]", 'name = "beam"', 'frequencies_csv = "frequencies.csv"',
             'mode_shapes_csv = "shapes.csv"', ""]
    path = folder / "case.toml"
    path.write_text("\n".join(text))
    return path, truth


def main(argv=None) -> dict:
    from vibupdate.study.sampling import SamplingOptions
    from vibupdate.study.sweep import run_sweep

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=24)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    root = Path(tempfile.mkdtemp(prefix="vibupdate-beam50-"))
    try:
        case, truth = write_case(root, args.seed)
        out = {}
        for workers in args.workers:
            folder = root / f"out{workers}"
            summary = run_sweep(str(case), folder, args.samples, seed=0, workers=workers, plots=False,
                                sampling=SamplingOptions())
            doc = summary.document
            inside = {}
            for name, value in truth.items():
                lo, hi = summary.parameter(name)["min"], summary.parameter(name)["max"]
                inside[name] = None if lo is None else bool(lo <= value <= hi)
            wall = doc["timing"]["task_phase_wall_seconds"]
            out[workers] = {"verified": summary.verified, "samples": args.samples, "failed": summary.failed,
                            "wall_s": wall, "truth_inside": inside}
            print(f"{workers} worker(s): {summary.verified}/{args.samples} verified, task phase {wall:.1f} s; "
                  f"truth inside the sampled range: {sum(bool(v) for v in inside.values())} of {len(inside)}")
        if 1 in out and 2 in out and out[1]["wall_s"] and out[2]["wall_s"]:
            print(f"speed-up 2 workers / 1: {out[1]['wall_s'] / out[2]['wall_s']:.2f}x")
        print(json.dumps(out, indent=1, default=str))
        return out
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
